// Live-Wire where the automatic method gives up (issue 13): sliceUncertainty marks the slices
// where a bone's automatic boundary touches another bone (the watershed's boundary at a joint)
// or has little contrast. On the simulated knee with the joint narrowed to 1 mm and the patella
// on the femur, the femur's uncertain axial slices must be those where the true femur comes
// within 2 mm of another true bone (the tibiofemoral and patellofemoral joints), and few.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include "simulated_knee.hpp"

#include <gtest/gtest.h>

#include <iostream>

namespace {

using namespace echoreg;
using simulation::BoneId;

const std::vector<BoneId> kAll = {BoneId::Femur, BoneId::Tibia, BoneId::Fibula, BoneId::Patella};

TEST(UncertainSlices, TheFemursUncertainAxialSlicesAreAtItsJoints) {
  test::KneeVariant v;
  v.tibiofemoralGapMm = 1.0;
  v.patellofemoralGapMm = 0.0;
  v.cancellousHu = 150.0;
  v.halfRangeMm = 45.0;
  const auto& sim = test::simulatedKnee(v);
  std::vector<segmentation::BoneSeed> seeds;
  for (BoneId id : kAll) {
    const std::optional<Eigen::Vector3d> p = test::seedPoint(sim, id);
    ASSERT_TRUE(p.has_value());
    seeds.push_back({std::string(simulation::boneName(id)), *p});
  }
  const auto result = segmentation::segmentCompetingBones(sim.ct, seeds);
  ASSERT_EQ(result.bones.size(), 4u);
  std::vector<std::pair<std::string, const segmentation::VoxelMask*>> neighbours;
  for (std::size_t b = 1; b < result.bones.size(); ++b)
    neighbours.emplace_back(result.bones[b].bone, &result.bones[b].mask);
  neighbours.emplace_back("", &result.unnamed);
  std::vector<double> z;
  for (double p = sim.kneeZMinMm + 1.5; p <= sim.kneeZMaxMm - 1.5; p += 3.0)
    z.push_back(p);
  const auto u = segmentation::sliceUncertainty(sim.ct, result.bones[0].mask, neighbours,
                                                segmentation::SlicePlane::Axial, z);
  ASSERT_EQ(u.size(), z.size());

  // The truth: heights where the femur comes within 2 mm of another bone.
  std::vector<core::MeshLocator> others;
  for (BoneId id : {BoneId::Tibia, BoneId::Fibula, BoneId::Patella})
    others.emplace_back(sim.knee.bone(id).mesh);
  auto nearest = [&](double zc) {
    double best = 1e9;
    for (const auto& vtx : sim.knee.bone(BoneId::Femur).mesh.vertices) {
      if (std::abs(vtx.z() - zc) > 1.5)
        continue;
      for (const auto& l : others)
        best = std::min(best, std::abs(l.signedDistance(vtx)));
    }
    return best;
  };
  int uncertain = 0, inContact = 0;
  for (std::size_t s = 0; s < u.size(); ++s) {
    const double gap = nearest(z[s]);
    inContact += gap <= 2.0 ? 1 : 0;
    std::string names;
    for (const auto& n : u[s].neighbours)
      names += (names.empty() ? "" : ",") + (n.empty() ? std::string("auto") : n);
    std::cout << "[ measured ] z " << z[s] << ": share " << u[s].share << " (contact "
              << u[s].contactVoxels << ", low contrast " << u[s].lowContrastVoxels << " of "
              << u[s].boundaryVoxels << ") " << names << "; truth's nearest other bone " << gap
              << " mm" << (u[s].uncertain ? "  UNCERTAIN" : "") << "\n";
    if (!u[s].uncertain)
      continue;
    ++uncertain;
    // Each uncertain slice is at a joint: the truth is within 2 mm of a neighbour there or on
    // the next slice (the slab is +-1.5 mm; a voxel of partial volume).
    const double around = std::min(
        {gap, s > 0 ? nearest(z[s - 1]) : 1e9, s + 1 < u.size() ? nearest(z[s + 1]) : 1e9});
    EXPECT_LE(around, 2.0) << "slice z " << z[s] << " is uncertain away from the joints";
    EXPECT_FALSE(u[s].neighbours.empty()) << "z " << z[s];
  }
  std::cout << "[ measured ] " << uncertain << " of " << u.size() << " axial slices uncertain; "
            << inContact << " at a joint by the truth\n";
  EXPECT_GE(uncertain, 2);
  EXPECT_LE(uncertain, static_cast<int>(u.size()) / 2) << "a few slices, not all";
  // The slices where the femur touches the tibia most closely are uncertain and name it.
  bool tibia = false;
  for (const auto& s : u)
    tibia = tibia || (s.uncertain && !s.neighbours.empty() && s.neighbours.front() == "tibia");
  EXPECT_TRUE(tibia);
}

// The user corrects only the uncertain slices: on the knee with the patella on the femur, a
// femur whose automatic region took the patella's voxels within 4 mm of it (its boundary put
// on the wrong side of the patellofemoral joint) is corrected by the truth's axial sections (a
// simulated user's contours) on every second of the slices sliceUncertainty marks at the
// patella; it comes back to the targets, and the slices away from them are not touched.
TEST(UncertainSlices, CorrectingTheUncertainSlicesFixesTheJoint) {
  test::KneeVariant v;
  v.tibiofemoralGapMm = 1.0;
  v.patellofemoralGapMm = 0.0;
  v.cancellousHu = 150.0;
  v.halfRangeMm = 45.0;
  const auto& sim = test::simulatedKnee(v);
  std::vector<segmentation::BoneSeed> seeds;
  for (BoneId id : kAll) {
    const std::optional<Eigen::Vector3d> p = test::seedPoint(sim, id);
    ASSERT_TRUE(p.has_value());
    seeds.push_back({std::string(simulation::boneName(id)), *p});
  }
  const auto result = segmentation::segmentCompetingBones(sim.ct, seeds);
  const auto& femur = result.bones[0].mask;
  const auto& patella = result.bones[3].mask;
  const auto& dims = sim.ct.dimensions;
  const segmentation::VoxelMask near = segmentation::dilate(femur, 4.0);
  segmentation::VoxelMask wrong = femur, patellaLeft = patella;
  std::size_t taken = 0;
  for (std::size_t i = 0; i < wrong.voxels.size(); ++i) {
    if (patella.voxels[i] && near.voxels[i]) {
      wrong.voxels[i] = 1;
      patellaLeft.voxels[i] = 0;
      ++taken;
    }
  }
  ASSERT_GT(taken, 300u);
  segmentation::VoxelMask others = segmentation::unite(result.unnamed, result.bones[1].mask);
  others = segmentation::unite(others, result.bones[2].mask);
  others = segmentation::unite(others, patella);
  auto accuracy = [&](const segmentation::VoxelMask& region) {
    segmentation::VoxelMask ex = others;
    for (std::size_t i = 0; i < ex.voxels.size(); ++i)
      ex.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    return segmentation::compareSurfaces(segmentation::boneSurface(sim.ct, region, &ex).mesh,
                                         sim.knee.bone(BoneId::Femur).mesh, co);
  };
  std::vector<double> z;
  for (double p = sim.kneeZMinMm + 1.5; p <= sim.kneeZMaxMm - 1.5; p += 3.0)
    z.push_back(p);  // the 30 planes a user would be offered, 3 mm apart
  const auto u = segmentation::sliceUncertainty(
      sim.ct, wrong, {{"tibia", &result.bones[1].mask}, {"patella", &patellaLeft}},
      segmentation::SlicePlane::Axial, z);
  std::vector<segmentation::SliceContour> contours;
  int atPatella = 0, uncertain = 0;
  for (const auto& s : u) {
    uncertain += s.uncertain ? 1 : 0;
    if (!s.uncertain || s.neighbours.empty() || s.neighbours.front() != "patella")
      continue;
    if (atPatella++ % 2 != 0)
      continue;  // every second one
    for (const auto& loop : segmentation::planeSections(
             sim.knee.bone(BoneId::Femur).mesh, segmentation::SlicePlane::Axial, s.positionMm)) {
      segmentation::SliceContour c;
      c.plane = segmentation::SlicePlane::Axial;
      c.positionMm = s.positionMm;
      c.pointsLps = loop;
      contours.push_back(c);
    }
  }
  ASSERT_FALSE(contours.empty());
  const auto fixed = segmentation::correctOnSlices(wrong, contours, 3.0);
  const auto before = accuracy(wrong), after = accuracy(fixed.region), automatic = accuracy(femur);
  std::cout << "[ measured ] femur with the patella's voxels within 4 mm (" << taken << "): MSD "
            << before.meanMm << " mm (p95 " << before.p95Mm << "), Dice " << before.dice << "; "
            << uncertain << " of " << u.size() << " slices uncertain, " << atPatella
            << " at the patella, corrected on " << fixed.slices << " (" << fixed.removed
            << " voxels out, " << fixed.added << " in): MSD " << after.meanMm << " mm (p95 "
            << after.p95Mm << "), Dice " << after.dice << "; the automatic femur: MSD "
            << automatic.meanMm << " mm (p95 " << automatic.p95Mm << ")\n";
  // The damage (MSD above the automatic femur's) is at least halved by 2-3 corrected slices.
  EXPECT_GT(before.meanMm, automatic.meanMm + 0.03);
  EXPECT_LT(after.meanMm - automatic.meanMm, 0.5 * (before.meanMm - automatic.meanMm));
  EXPECT_LE(after.meanMm, 0.3);
  EXPECT_GE(after.dice, 0.97);
  EXPECT_LE(fixed.slices, 6) << "a few slices";
  // Layers farther than the falloff from every corrected one are not touched.
  for (int k = 0; k < dims[2]; ++k) {
    const double zk = sim.ct.voxelToLps(Eigen::Vector3d(0, 0, k)).z();
    bool nearCorrected = false;
    for (const auto& c : contours)
      nearCorrected = nearCorrected || std::abs(zk - c.positionMm) <= 3.6;
    if (nearCorrected)
      continue;
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
        ASSERT_EQ(fixed.region.at(i, j, k), wrong.at(i, j, k)) << "z " << zk;
  }
}

TEST(UncertainSlices, CorrectionsRefuseWhatTheyCannotUse) {
  core::CtImage g;
  g.dimensions = {8, 8, 8};
  g.pixelSpacingMm = {1.0, 1.0};
  g.slicePositionsMm = {0, 1, 2, 3, 4, 5, 6, 7};
  g.groups = {{0, 8, 1.0}};
  const segmentation::VoxelMask m = segmentation::emptyMask(g);
  EXPECT_THROW(segmentation::correctOnSlices(m, {}), std::invalid_argument);
  segmentation::SliceContour c;
  c.plane = segmentation::SlicePlane::Axial;
  c.positionMm = 30.0;
  c.pointsLps = {{1, 1, 30}, {5, 1, 30}, {5, 5, 30}};
  try {
    segmentation::correctOnSlices(m, {c});
    ADD_FAILURE() << "a contour above the CT was used";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("outside the CT's slices"), std::string::npos);
  }
  segmentation::SliceContour s = c;
  s.plane = segmentation::SlicePlane::Sagittal;
  c.positionMm = 3.0;
  for (auto& p : c.pointsLps)
    p.z() = 3.0;
  EXPECT_THROW(segmentation::correctOnSlices(m, {c, s}), std::invalid_argument);
  // A triangle on slice 3 fills its voxels there (the falloff 0: that slice only).
  const auto r = segmentation::correctOnSlices(m, {c}, 0.0);
  EXPECT_EQ(r.slices, 1);
  EXPECT_TRUE(r.region.at(4, 2, 3));
  EXPECT_FALSE(r.region.at(2, 4, 3));  // beyond the hypotenuse
  EXPECT_FALSE(r.region.at(4, 2, 2));
  EXPECT_EQ(r.removed, 0u);
  EXPECT_EQ(r.added, r.region.count());
}

// Areas where the bone is absent: a square over half of a block's layer takes that half away on
// the layer only (falloff 0); one around the whole section empties the layer, and with a falloff
// the block tapers toward it (the layers next to it lose their rim, not their core) and is left
// alone beyond the falloff.
TEST(UncertainSlices, AbsentAreasTakeTheBoneAway) {
  core::CtImage g;
  g.dimensions = {20, 20, 12};
  g.pixelSpacingMm = {1.0, 1.0};
  for (int k = 0; k < 12; ++k)
    g.slicePositionsMm.push_back(k);
  g.groups = {{0, 12, 1.0}};
  segmentation::VoxelMask block = segmentation::emptyMask(g);
  for (int k = 0; k < 12; ++k)
    for (int j = 4; j < 16; ++j)
      for (int i = 4; i < 16; ++i)
        block.voxels[g.index(i, j, k)] = 1;
  auto area = [](double x0, double x1, double y0, double y1, double z) {
    segmentation::SliceContour c;
    c.plane = segmentation::SlicePlane::Axial;
    c.positionMm = z;
    c.pointsLps = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    return c;
  };
  const auto half = segmentation::correctOnSlices(block, {}, 0.0, {area(9.5, 20, -1, 20, 6)});
  EXPECT_EQ(half.slices, 1);
  EXPECT_TRUE(half.region.at(8, 10, 6));
  EXPECT_FALSE(half.region.at(11, 10, 6));
  EXPECT_TRUE(half.region.at(11, 10, 5));
  EXPECT_EQ(half.added, 0u);
  EXPECT_EQ(half.removed, 6u * 12u);
  const auto gone = segmentation::correctOnSlices(block, {}, 3.0, {area(-1, 20, -1, 20, 6)});
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 20; ++i)
      ASSERT_FALSE(gone.region.at(i, j, 6)) << i << " " << j;
  EXPECT_TRUE(gone.region.at(10, 10, 5));  // the core next to the absent layer stays
  EXPECT_FALSE(gone.region.at(4, 10, 5));  // its rim goes
  EXPECT_TRUE(gone.region.at(4, 10, 9));   // at the falloff's end the block is whole
  EXPECT_TRUE(gone.region.at(4, 10, 2));
  EXPECT_EQ(gone.added, 0u);
}

TEST(UncertainSlices, RefusesMasksOfAnotherGrid) {
  core::CtImage g;
  g.dimensions = {4, 4, 4};
  g.slicePositionsMm = {0, 1, 2, 3};
  g.groups = {{0, 4, 1.0}};
  g.hu.assign(64, 0);
  segmentation::VoxelMask m = segmentation::emptyMask(g);
  segmentation::VoxelMask small = m;
  small.voxels.resize(8);
  EXPECT_THROW(
      segmentation::sliceUncertainty(g, m, {{"x", &small}}, segmentation::SlicePlane::Axial, {1.0}),
      std::invalid_argument);
  EXPECT_THROW(segmentation::sliceUncertainty(g, small, {}, segmentation::SlicePlane::Axial, {1.0}),
               std::invalid_argument);
}

}  // namespace
