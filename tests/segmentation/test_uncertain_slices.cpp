// Live-Wire where the automatic method gives up (issue 13): sliceUncertainty marks the slices
// where a bone's automatic boundary touches another bone (the watershed's boundary at a joint)
// or has little contrast. On the simulated knee with the joint narrowed to 1 mm and the patella
// on the femur, the femur's uncertain axial slices must be those where the true femur comes
// within 2 mm of another true bone (the tibiofemoral and patellofemoral joints), and few.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"

#include "simulated_knee.hpp"

#include <gtest/gtest.h>

#include <iostream>

namespace {

using namespace echoreg;
using simulation::BoneId;

std::optional<Eigen::Vector3d> insidePoint(const simulation::Bone& bone, double z) {
  const core::MeshLocator locator(bone.mesh);
  const auto b = core::bounds(bone.mesh);
  std::vector<Eigen::Vector3d> inside;
  for (double y = b[0].y(); y <= b[1].y(); y += 1.0) {
    for (double x = b[0].x(); x <= b[1].x(); x += 1.0) {
      if (locator.signedDistance({x, y, z}) < -3.0)
        inside.emplace_back(x, y, z);
    }
  }
  if (inside.empty())
    return std::nullopt;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : inside)
    c += p;
  c /= static_cast<double>(inside.size());
  return *std::min_element(inside.begin(), inside.end(), [&](const auto& a, const auto& b2) {
    return (a - c).norm() < (b2 - c).norm();
  });
}

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
    const auto box = core::bounds(sim.knee.bone(id).mesh);
    const double lo = std::max(sim.kneeZMinMm + 6.0, box[0].z() + 6.0);
    const double hi = std::min(sim.kneeZMaxMm - 6.0, box[1].z() - 6.0);
    const bool high = id == BoneId::Femur || id == BoneId::Patella;
    std::optional<Eigen::Vector3d> p;
    for (double t = 0.0; t <= 1.0 && !p; t += 0.1)
      p = insidePoint(sim.knee.bone(id), high ? hi - t * (hi - lo) : lo + t * (hi - lo));
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

TEST(UncertainSlices, RefusesMasksOfAnotherGrid) {
  segmentation::CtImage g;
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
