// Scan-aware refinement (issue 13): on 3 mm and the dissertation's 5 mm slices a band of 2 mm and
// an interior erosion of 1.5 mm are less than a voxel along z, so the CT's iso-surface could not
// move the model off the mask's own surface there. BoneSurfaceOptions' bandVoxels and
// interiorVoxels make them at least that many voxels per axis. The simulated knee (seed 3, 0.8 mm
// pixels) scanned at 3 and 5 mm over +-45 mm; four bones from one seed each, each model compared
// with the truth inside the slab: the mask's own surface (--no-refine), the refinement in mm only
// (before), with one level for the whole bone (before the local level) and with the defaults,
// and the table of the candidates the defaults were chosen from; then where the error lies, and
// the z ends' share of bone from the sections (zEndShares, on at 4 mm and more) on knees not used
// to choose it.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/end_shares.hpp"
#include "echoreg/segmentation/joint_slabs.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include "simulated_knee.hpp"
#include "test_support.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <iostream>
#include <map>
#include <memory>

namespace {

using namespace echoreg;
using simulation::BoneId;

const std::vector<BoneId> kAll = {BoneId::Femur, BoneId::Tibia, BoneId::Fibula, BoneId::Patella};

std::vector<segmentation::BoneSeed> seedsOf(const test::SimulatedKnee& sim) {
  std::vector<segmentation::BoneSeed> seeds;
  for (BoneId id : kAll) {
    const std::optional<Eigen::Vector3d> p = test::seedPoint(sim, id);
    EXPECT_TRUE(p.has_value()) << simulation::boneName(id) << ": no seed in the scan";
    seeds.push_back({std::string(simulation::boneName(id)), p.value_or(Eigen::Vector3d::Zero())});
  }
  return seeds;
}

// Every voxel the watershed gave to anything but bone b (the other bones, unnamed bone, metal):
// what boneSurface keeps out of b's surface.
segmentation::VoxelMask othersOf(const segmentation::CompetingResult& result, std::size_t b) {
  segmentation::VoxelMask others = segmentation::unite(result.unnamed, result.metalMask);
  for (std::size_t o = 0; o < result.bones.size(); ++o) {
    if (o != b)
      others = segmentation::unite(others, result.bones[o].mask);
  }
  return others;
}

// The comparison's slab: 2 mm inside the knee group's first and last slice centres.
segmentation::SurfaceComparisonOptions slabOf(const test::SimulatedKnee& sim) {
  segmentation::SurfaceComparisonOptions co;
  co.zMinMm = sim.kneeZMinMm + 2.0;
  co.zMaxMm = sim.kneeZMaxMm - 2.0;
  return co;
}

// The simulated knee of `seed` scanned at the hip's 5 mm over +-45 mm.
const test::SimulatedKnee& kneeAtFiveMillimetres(int seed) {
  test::KneeVariant v;
  v.sliceMm = 5.0;
  v.halfRangeMm = 45.0;
  v.seed = seed;
  return test::simulatedKnee(v);
}

// An empty grid of 1 mm pixels and 5 mm slices (HU not allocated).
core::CtImage fiveMillimetreGrid(int columns, int rows, int slices) {
  core::CtImage g;
  g.dimensions = {columns, rows, slices};
  g.pixelSpacingMm = {1.0, 1.0};
  for (int k = 0; k < slices; ++k)
    g.slicePositionsMm.push_back(5.0 * k);
  g.groups = {{0, slices, 5.0}};
  return g;
}
struct Row {
  double msd = 0.0, p95 = 0.0, dice = 0.0;
};

// Per bone: the mask's surface, and boneSurface with each (band, interior) voxel pair.
std::map<std::string, std::map<std::string, Row>> measure(
    double sliceMm, const std::vector<std::pair<double, double>>& candidates) {
  test::KneeVariant v;
  v.sliceMm = sliceMm;
  v.halfRangeMm = 45.0;
  const auto& sim = test::simulatedKnee(v);
  const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
  std::map<std::string, std::map<std::string, Row>> out;
  const segmentation::SurfaceComparisonOptions co = slabOf(sim);
  for (std::size_t b = 0; b < result.bones.size(); ++b) {
    const auto& bone = result.bones[b];
    const segmentation::VoxelMask others = othersOf(result, b);
    const auto& truth = sim.knee.bone(kAll[b]).mesh;
    auto record = [&](const std::string& what, const core::TriangleMesh& mesh) {
      const auto c = segmentation::compareSurfaces(mesh, truth, co);
      out[bone.bone][what] = {c.meanMm, c.p95Mm, c.dice};
      std::cout << "[ measured ] " << sliceMm << " mm slices, " << bone.bone << ", " << what
                << ": MSD " << c.meanMm << " mm (p95 " << c.p95Mm << "), Dice " << c.dice << "\n";
    };
    record("no-refine", segmentation::maskSurface(bone.mask).mesh);
    for (const auto& [band, interior] : candidates) {
      segmentation::BoneSurfaceOptions so;
      so.bandVoxels = band;
      so.interiorVoxels = interior;
      record(fmt::format("band {} vx, interior {} vx", band, interior),
             segmentation::boneSurface(sim.ct, bone.mask, &others, so).mesh);
    }
    segmentation::BoneSurfaceOptions oneLevel;
    oneLevel.localLevel = false;
    record("one level", segmentation::boneSurface(sim.ct, bone.mask, &others, oneLevel).mesh);
    segmentation::BoneSurfaceOptions hu;
    hu.endSharesMinSliceMm = 0.0;
    record("ends from HU", segmentation::boneSurface(sim.ct, bone.mask, &others, hu).mesh);
    record("defaults", segmentation::boneSurface(sim.ct, bone.mask, &others).mesh);
  }
  return out;
}

// Where a model's error lies: the truth's triangles inside the slab (by area), each one's
// signed distance to the model at its centroid (positive: the truth inside the model, i.e. the
// model too large there),
// in classes of the truth's surface: facing along z (|n_z| >= 0.7: the bones' ends, the
// plateau), oblique, facing in plane (|n_z| < 0.3: the shafts), and at a joint (within 3 mm of
// another bone's truth, whatever its facing).
struct ErrorClass {
  double areaMm2 = 0.0, absSum = 0.0, signedSum = 0.0;
};

std::map<std::string, ErrorClass> whereTheErrorIs(const core::TriangleMesh& model,
                                                  const test::SimulatedKnee& sim, BoneId id,
                                                  double zMin, double zMax) {
  const core::MeshLocator modelLocator(model);
  std::vector<std::unique_ptr<core::MeshLocator>> others;
  for (BoneId o : kAll) {
    if (o != id)
      others.push_back(std::make_unique<core::MeshLocator>(sim.knee.bone(o).mesh));
  }
  const auto& truth = sim.knee.bone(id).mesh;
  std::map<std::string, ErrorClass> out;
  for (std::size_t t = 0; t < truth.triangles.size(); ++t) {
    const auto& tri = truth.triangles[t];
    const Eigen::Vector3d c = (truth.vertices[static_cast<std::size_t>(tri[0])] +
                               truth.vertices[static_cast<std::size_t>(tri[1])] +
                               truth.vertices[static_cast<std::size_t>(tri[2])]) /
                              3.0;
    if (c.z() < zMin || c.z() > zMax)
      continue;
    const Eigen::Vector3d e1 = truth.vertices[static_cast<std::size_t>(tri[1])] -
                               truth.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d e2 = truth.vertices[static_cast<std::size_t>(tri[2])] -
                               truth.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d n = e1.cross(e2);
    const double area = 0.5 * n.norm();
    if (!(area > 0.0))
      continue;
    const double nz = std::abs(n.z()) / n.norm();
    bool joint = false;
    for (const auto& o : others)
      joint = joint || o->closest(c, 3.0).triangle >= 0;
    const std::string what = joint       ? "joint"
                             : nz >= 0.7 ? "facing z"
                             : nz >= 0.3 ? "oblique"
                                         : "facing in plane";
    const double d = -modelLocator.signedDistance(c);
    ErrorClass& e = out[what];
    e.areaMm2 += area;
    e.absSum += area * std::abs(d);
    e.signedSum += area * d;
  }
  return out;
}

// With the local level (BoneSurfaceOptions::localLevel) the surfaces seen in plane (the shafts,
// the condyles' sides) are within 0.1 mm on average at 3 mm, 0.16 mm at 5 mm; what remains at 5 mm
// lies on the surfaces facing along z (the bones' ends at the joint, where a 5 mm slab holds
// femur, joint space and tibia at once and the watershed gives the slab to one of them).
TEST(ThickSlices, WhereTheErrorIs) {
  for (double sliceMm : {3.0, 5.0}) {
    test::KneeVariant v;
    v.sliceMm = sliceMm;
    v.halfRangeMm = 45.0;
    const auto& sim = test::simulatedKnee(v);
    const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
    for (std::size_t b = 0; b < result.bones.size(); ++b) {
      const segmentation::VoxelMask others = othersOf(result, b);
      const auto model = segmentation::boneSurface(sim.ct, result.bones[b].mask, &others).mesh;
      const auto classes =
          whereTheErrorIs(model, sim, kAll[b], sim.kneeZMinMm + 2.0, sim.kneeZMaxMm - 2.0);
      double total = 0.0;
      for (const auto& [what, e] : classes)
        total += e.areaMm2;
      const ErrorClass& inPlane = classes.at("facing in plane");
      // One level for the whole bone gave 0.16-0.20 mm at 3 mm, 0.17-0.24 mm at 5 mm.
      EXPECT_LE(inPlane.absSum / inPlane.areaMm2, sliceMm == 3.0 ? 0.1 : 0.16)
          << sliceMm << " mm " << result.bones[b].bone;
      if (sliceMm == 5.0) {
        const ErrorClass& alongZ = classes.at("facing z");
        EXPECT_GT(alongZ.absSum / alongZ.areaMm2, 2.0 * inPlane.absSum / inPlane.areaMm2)
            << result.bones[b].bone;
      }
      for (const auto& [what, e] : classes) {
        std::cout << "[ measured ] " << sliceMm << " mm, " << result.bones[b].bone << ", " << what
                  << ": " << fmt::format("{:.0f}", 100.0 * e.areaMm2 / total)
                  << " % of the area, mean |d| " << fmt::format("{:.3f}", e.absSum / e.areaMm2)
                  << " mm, mean d " << fmt::format("{:+.3f}", e.signedSum / e.areaMm2)
                  << " mm (+: the model outside the truth)\n";
      }
    }
  }
}

TEST(ThickSlices, MorphologyRadiiAreAtLeastTheVoxels) {
  const Eigen::Vector3d r =
      segmentation::morphologyRadiiMm(Eigen::Vector3d(0.8, 0.8, 3.0), 2.0, 1.5);
  EXPECT_DOUBLE_EQ(r.x(), 2.0);
  EXPECT_DOUBLE_EQ(r.y(), 2.0);
  EXPECT_DOUBLE_EQ(r.z(), 4.5);
  // The ellipsoid's dilation of one voxel: 2 mm in plane (2 voxels of 0.8 mm, 2.5 rounded
  // down), 4.5 mm along z (1 voxel of 3 mm).
  core::CtImage g;
  g.dimensions = {21, 21, 11};
  g.pixelSpacingMm = {0.8, 0.8};
  for (int k = 0; k < 11; ++k)
    g.slicePositionsMm.push_back(3.0 * k);
  g.groups = {{0, 11, 3.0}};
  segmentation::VoxelMask m = segmentation::emptyMask(g);
  m.voxels[g.index(10, 10, 5)] = 1;
  const auto d = segmentation::dilateOrErode(m, 2.0, 1.5, true);
  EXPECT_TRUE(d.at(12, 10, 5));
  EXPECT_FALSE(d.at(13, 10, 5));
  EXPECT_TRUE(d.at(10, 10, 6));
  EXPECT_FALSE(d.at(10, 10, 7));
  EXPECT_FALSE(d.at(12, 10, 6));  // outside the ellipsoid: (1.6/2)^2 + (3/4.5)^2 > 1
  // Erosion by it gives back the voxel of a dilated block's core; mm-only is the plain ball.
  const auto e = segmentation::dilateOrErode(d, 2.0, 1.5, false);
  EXPECT_EQ(e.count(), 1u);
  EXPECT_EQ(segmentation::dilateOrErode(m, 2.0, 0.0, true).voxels,
            segmentation::dilate(m, 2.0).voxels);
}

// (band, interior) in voxels; (0, 0) is the mm-only refinement of before.
const std::vector<std::pair<double, double>> kCandidates = {
    {0.0, 0.0}, {1.0, 1.0}, {1.5, 1.5}, {2.0, 1.0}};

double meanMsd(const std::map<std::string, std::map<std::string, Row>>& rows,
               const std::string& what) {
  double sum = 0.0;
  for (const auto& [bone, r] : rows)
    sum += r.at(what).msd;
  return sum / static_cast<double>(rows.size());
}

// At 3 mm the defaults beat the mask's surface, the mm-only refinement and the one level of
// before on every bone, and the targets of the 1 mm knee hold (MSD <= 0.3 mm, Dice >= 0.97).
TEST(ThickSlices, RefinementWorksAtThreeMillimetreSlices) {
  const auto rows = measure(3.0, kCandidates);
  ASSERT_EQ(rows.size(), 4u);
  for (const auto& [bone, r] : rows) {
    EXPECT_LT(r.at("defaults").msd, r.at("no-refine").msd - 0.1) << bone;
    EXPECT_LT(r.at("defaults").msd, r.at("band 0 vx, interior 0 vx").msd - 0.01) << bone;
    EXPECT_LT(r.at("defaults").msd, r.at("one level").msd - 0.05) << bone;
    EXPECT_LE(r.at("defaults").msd, 0.22) << bone;
    EXPECT_GE(r.at("defaults").dice, 0.98) << bone;
  }
}

// At the hip's 5 mm the defaults beat the mask's surface, the one level of before and the ends'
// HU (before the ends' shares from the sections) on every bone; the targets (MSD <= 0.3 mm,
// Dice >= 0.97) hold for every bone: femur / tibia 0.277 / 0.292 mm with the joint's slabs
// (joint_slabs.hpp; 0.322 / 0.299 without them, 0.43 / 0.55 from the ends' HU; see
// WhereTheErrorIs and docs/segmentation.md). The (0, 0) candidate has the ends' shares too, so
// it is no longer the refinement of before.
TEST(ThickSlices, RefinementWorksAtTheHipsFiveMillimetreSlices) {
  const auto rows = measure(5.0, kCandidates);
  ASSERT_EQ(rows.size(), 4u);
  for (const auto& [bone, r] : rows) {
    EXPECT_LT(r.at("defaults").msd, r.at("no-refine").msd - 0.1) << bone;
    EXPECT_LT(r.at("defaults").msd, r.at("one level").msd - 0.02) << bone;
    EXPECT_LT(r.at("defaults").msd, r.at("ends from HU").msd - 0.02) << bone;
    EXPECT_LE(r.at("defaults").msd, 0.35) << bone;
    EXPECT_GE(r.at("defaults").dice, 0.97) << bone;
  }
  for (const auto& [bone, r] : rows)
    EXPECT_LE(r.at("defaults").msd, 0.3) << bone;
  EXPECT_LT(meanMsd(rows, "defaults"), meanMsd(rows, "ends from HU") - 0.08);
}

// The ends' shares from the sections (EndShareOptions and the flat rule chosen on seed 3) on
// knees not used to choose them: seeds 5 and 7 at 5 mm. From the ends' HU MSD femur / tibia /
// fibula / patella were 0.420 / 0.542 / 0.272 / 0.213 and 0.443 / 0.526 / 0.287 / 0.230 mm; from
// the sections 0.296 / 0.297 / 0.231 / 0.183 and 0.322 / 0.339 / 0.230 / 0.197, with the
// field that ends the bone where the share says (zEndFieldValue) 0.294 / 0.273 / 0.212 / 0.186
// and 0.323 / 0.313 / 0.211 / 0.204, and with the joint's slabs (joint_slabs.hpp) 0.260 / 0.283 /
// 0.213 / 0.186 and 0.288 / 0.290 / 0.212 / 0.204: issue 13's 0.3 mm for every bone.
TEST(ThickSlices, EndSharesOnKneesNotUsedToChooseThem) {
  for (int seed : {5, 7}) {
    const auto& sim = kneeAtFiveMillimetres(seed);
    const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
    ASSERT_EQ(result.bones.size(), 4u);
    const segmentation::SurfaceComparisonOptions co = slabOf(sim);
    double sumHu = 0.0, sumSections = 0.0;
    for (std::size_t b = 0; b < result.bones.size(); ++b) {
      const segmentation::VoxelMask others = othersOf(result, b);
      const auto& truth = sim.knee.bone(kAll[b]).mesh;
      segmentation::BoneSurfaceOptions hu;
      hu.endSharesMinSliceMm = 0.0;
      const auto before = segmentation::compareSurfaces(
          segmentation::boneSurface(sim.ct, result.bones[b].mask, &others, hu).mesh, truth, co);
      const auto after = segmentation::compareSurfaces(
          segmentation::boneSurface(sim.ct, result.bones[b].mask, &others).mesh, truth, co);
      const std::string& bone = result.bones[b].bone;
      std::cout << "[ measured ] seed " << seed << ", 5 mm, " << bone << ": ends from HU MSD "
                << before.meanMm << " mm, Dice " << before.dice << "; from the sections MSD "
                << after.meanMm << " mm, Dice " << after.dice << "\n";
      EXPECT_LT(after.meanMm, before.meanMm - 0.02) << "seed " << seed << " " << bone;
      EXPECT_GE(after.dice, 0.975) << "seed " << seed << " " << bone;
      EXPECT_LE(after.meanMm, bone == "femur" || bone == "tibia" ? 0.3 : 0.24)
          << "seed " << seed << " " << bone;
      sumHu += before.meanMm;
      sumSections += after.meanMm;
    }
    EXPECT_LT(sumSections / 4.0, sumHu / 4.0 - 0.08) << "seed " << seed;
  }
}

// A real femur's shape (../shared/data/meshes/femur.stl, placed by the simulator at the knee with
// its healthy joint, on a field of view wide enough for its patella) instead of the simulator's:
// the methods were chosen on the simulator's condyles. At the knee's 1 mm slices and at 3 mm, four
// bones from one seed each meet issue 13's targets (MSD <= 0.3 mm, Dice >= 0.97): today 0.04-0.06
// mm / 0.996-0.997 at 1 mm and 0.13-0.23 mm / 0.983-0.992 at 3 mm on seeds 3, 5 and 7. (At 5 mm
// the watershed does not separate this femur from the tibia: docs/segmentation.md, stop 31.)
TEST(ThickSlices, ARealFemursShapeAtOneAndThreeMillimetres) {
  ECHOREG_REQUIRE_SHARED_FILE(femurPath, "meshes/femur.stl");
  for (double sliceMm : {1.0, 3.0}) {
    for (int seed : {3, 7}) {
      test::KneeVariant v;
      v.sliceMm = sliceMm;
      v.halfRangeMm = 45.0;
      v.seed = seed;
      v.femurMesh = femurPath;
      v.columns = 176;
      const auto& sim = test::simulatedKnee(v);
      const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
      ASSERT_EQ(result.bones.size(), 4u);
      const segmentation::SurfaceComparisonOptions co = slabOf(sim);
      for (std::size_t b = 0; b < result.bones.size(); ++b) {
        const segmentation::VoxelMask others = othersOf(result, b);
        const auto c = segmentation::compareSurfaces(
            segmentation::boneSurface(sim.ct, result.bones[b].mask, &others).mesh,
            sim.knee.bone(kAll[b]).mesh, co);
        const std::string& bone = result.bones[b].bone;
        std::cout << "[ measured ] real femur's knee, seed " << seed << ", " << sliceMm
                  << " mm slices, " << bone << ": MSD " << c.meanMm << " mm (p95 " << c.p95Mm
                  << "), Dice " << c.dice << "\n";
        EXPECT_LE(c.meanMm, sliceMm < 2.0 ? 0.1 : 0.3) << bone << ", seed " << seed;
        EXPECT_GE(c.dice, sliceMm < 2.0 ? 0.99 : 0.97) << bone << ", seed " << seed;
      }
    }
  }
}

// The same knees at the dissertation's 5 mm: the joint under this femur's flatter condyles lies
// inside one slab across the plateau, and the watershed cut through the tibia (seed 3: the femur's
// region took 26,880 of the tibia's voxels, tibia Dice 0.23) or the femur (seed 5), with no word.
// Their boundary is 25-27 % joint-like (a joint line, or cortex against cortex), where the
// separations of the simulator's knees at 5 mm are 50-53 % and at 1-3 mm 88-100 %: refused,
// naming both bones and what to do (seed 7's boundary runs through cancellous bone: one bone).
TEST(ThickSlices, ARealFemursKneeAtFiveMillimetresIsRefusedNotMislabelled) {
  ECHOREG_REQUIRE_SHARED_FILE(femurPath, "meshes/femur.stl");
  for (int seed : {3, 5, 7}) {
    test::KneeVariant v;
    v.sliceMm = 5.0;
    v.halfRangeMm = 45.0;
    v.seed = seed;
    v.femurMesh = femurPath;
    v.columns = 176;
    const auto& sim = test::simulatedKnee(v);
    try {
      segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
      ADD_FAILURE() << "seed " << seed << ": labels returned where the joint does not show";
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      std::cout << "[ measured ] real femur's knee, seed " << seed << ", 5 mm: " << message << "\n";
      const bool named = message.find("the femur and the tibia") != std::string::npos ||
                         message.find("the tibia and the femur") != std::string::npos;
      EXPECT_TRUE(named) << message;
      if (seed != 7) {
        EXPECT_NE(message.find("is not a joint"), std::string::npos) << message;
        EXPECT_NE(message.find("at 5.0 mm slices the joint does not show"), std::string::npos)
            << message;
      }
    }
  }
}

// The field of a z end's voxel, interpolated linearly along z between its neighbours (1 on the
// bone's side, 0 beyond), crosses 0.5 where its share ends the bone (s - 1/2 slabs from the
// voxel's centre): found by walking the interpolated field in steps of 1e-4 slabs. The share
// itself as the field misses by up to a twelfth of a slab (0.75: a third of a slab out).
TEST(ThickSlices, EndFieldPutsTheCrossingWhereTheShareEndsTheBone) {
  auto crossing = [](double field) {
    // Centres at -1 (1), 0 (field), +1 (0); the first z where the field falls to 0.5.
    for (double z = -1.0; z <= 1.0; z += 1e-4) {
      const double value = z < 0.0 ? (1.0 + z) * field - z : (1.0 - z) * field;
      if (value < 0.5)
        return z;
    }
    return 1.0;
  };
  for (int n = 0; n <= 20; ++n) {
    const double share = n / 20.0;
    const double f = segmentation::zEndFieldValue(share);
    EXPECT_GE(f, 0.0);
    EXPECT_LE(f, 1.0);
    EXPECT_NEAR(crossing(f), share - 0.5, 2e-4) << share;
  }
  // A share of 0.75 as the field itself: a third of a slab out, not a quarter.
  EXPECT_NEAR(crossing(0.75), 1.0 / 3.0, 2e-4);
  EXPECT_DOUBLE_EQ(segmentation::zEndFieldValue(-0.2), 0.0);
  EXPECT_DOUBLE_EQ(segmentation::zEndFieldValue(1.3), 1.0);
}

// A flat-ended block of 9 x 9 pixels of 1 mm over slices 2-6 of 5 mm: its ends are flat (the
// sections do not shrink towards them), and with the sections 0.4 slices inside their slices'
// centres and the --anchors closing the centre column fills its end slab (the section's depth
// is 4.5 mm, closed within 4.5 mm beyond it) and a column 2 pixels from the edge (depth 1.5 mm)
// fills 0.4 of it; nothing lies in the slab beyond. Ends on the scan's last slice or at a gap of
// one slice are not ends, and a voxel beyond marked as another bone's gets no share.
TEST(ThickSlices, EndSharesOfABlock) {
  const core::CtImage g = fiveMillimetreGrid(19, 19, 9);
  segmentation::VoxelMask block = segmentation::emptyMask(g);
  for (int k = 2; k <= 6; ++k) {
    for (int j = 5; j <= 13; ++j) {
      for (int i = 5; i <= 13; ++i)
        block.voxels[g.index(i, j, k)] = 1;
    }
  }
  auto shares = [&](const segmentation::VoxelMask& region, const segmentation::VoxelMask* exclude) {
    std::map<std::size_t, segmentation::VoxelShare> byVoxel;
    for (const auto& s : segmentation::zEndShares(region, exclude))
      byVoxel[s.voxel] = s;
    return byVoxel;
  };
  const auto ends = shares(block, nullptr);
  // 7 x 7 columns face z at each end, each with its end voxel and the voxel beyond it.
  EXPECT_EQ(ends.size(), 4u * 49u);
  for (int k : {6, 2}) {
    ASSERT_EQ(ends.count(g.index(9, 9, k)), 1u);
    EXPECT_NEAR(ends.at(g.index(9, 9, k)).share, 1.0, 1e-9) << k;
    EXPECT_NEAR(ends.at(g.index(6, 9, k)).share, 0.4, 0.03) << k;
    EXPECT_TRUE(ends.at(g.index(9, 9, k)).flatEnd) << k;
  }
  EXPECT_NEAR(ends.at(g.index(9, 9, 7)).share, 0.0, 1e-9);
  EXPECT_NEAR(ends.at(g.index(9, 9, 1)).share, 0.0, 1e-9);
  EXPECT_EQ(ends.count(g.index(5, 9, 6)), 0u);  // on the block's side: faces in plane
  // Cut by the scan's last slice: only the lower end is an end.
  segmentation::VoxelMask cut = block;
  for (int j = 5; j <= 13; ++j) {
    for (int i = 5; i <= 13; ++i) {
      cut.voxels[g.index(i, j, 7)] = 1;
      cut.voxels[g.index(i, j, 8)] = 1;
    }
  }
  EXPECT_EQ(shares(cut, nullptr).size(), 2u * 49u);
  // A gap of one slice inside the block is not an end: only the outer ends count.
  segmentation::VoxelMask gap = block;
  for (int j = 5; j <= 13; ++j) {
    for (int i = 5; i <= 13; ++i)
      gap.voxels[g.index(i, j, 4)] = 0;
  }
  EXPECT_EQ(shares(gap, nullptr).size(), 4u * 49u);
  // Another bone's voxels beyond the upper end.
  segmentation::VoxelMask other = segmentation::emptyMask(g);
  for (int j = 0; j < 19; ++j) {
    for (int i = 0; i < 19; ++i)
      other.voxels[g.index(i, j, 7)] = 1;
  }
  const auto beside = shares(block, &other);
  EXPECT_EQ(beside.size(), 3u * 49u);
  EXPECT_EQ(beside.count(g.index(9, 9, 7)), 0u);
  // Masks on other grids are refused.
  segmentation::VoxelMask small = segmentation::emptyMask(g);
  small.voxels.resize(10);
  EXPECT_THROW(segmentation::zEndShares(block, &small), std::invalid_argument);
  segmentation::VoxelMask twoGroups = block;
  twoGroups.geometry.groups = {{0, 4, 5.0}, {4, 5, 5.0}};
  EXPECT_THROW(segmentation::zEndShares(twoGroups, nullptr), std::invalid_argument);
}

// A ball pressed into its socket on 5 mm slices (1 mm pixels): bone on both sides of the joint,
// so each bone's voxels end where the other's begin and the surface over the joint followed
// that boundary, a staircase of slabs. With the sphere as a bound over the cap (SphereCut) each
// bone's surface there is the sphere; nothing changes beyond the cap.
TEST(ThickSlices, ASphereBoundsABallPressedIntoItsSocket) {
  const core::CtImage grid = fiveMillimetreGrid(60, 60, 16);
  core::CtImage ct = grid;
  const Eigen::Vector3d centre(29.5, 29.5, 37.0);
  const double radius = 15.0;
  const auto bone = [&](const Eigen::Vector3d& q) {
    const bool inBox =
        q.x() > 8 && q.x() < 51 && q.y() > 8 && q.y() < 51 && q.z() > 5 && q.z() < 70;
    return (q - centre).norm() < radius || (inBox && q.z() >= centre.z());
  };
  ct.hu.assign(ct.voxelCount(), 0);
  segmentation::VoxelMask ball = segmentation::emptyMask(ct), socket = ball;
  for (int k = 0; k < 16; ++k) {
    for (int j = 0; j < 60; ++j) {
      for (int i = 0; i < 60; ++i) {
        int inside = 0;
        for (int c = 0; c < 3 * 3 * 9; ++c) {
          const Eigen::Vector3d q((i - 1.0 / 3.0) + (c % 3) / 3.0,
                                  (j - 1.0 / 3.0) + (c / 3 % 3) / 3.0,
                                  5.0 * k - 20.0 / 9.0 + (c / 9) * 5.0 / 9.0);
          inside += bone(q) ? 1 : 0;
        }
        const std::size_t v = ct.index(i, j, k);
        ct.hu[v] = static_cast<std::int16_t>(std::lround(1000.0 * inside / 81.0));
        if (ct.hu[v] < 500)
          continue;
        const bool inBall = (ct.voxelToLps(Eigen::Vector3d(i, j, k)) - centre).norm() < radius;
        (inBall ? ball : socket).voxels[v] = 1;
      }
    }
  }
  segmentation::SphereCut cut;
  cut.centreLps = centre;
  cut.radiusMm = radius;
  cut.axisLps = Eigen::Vector3d::UnitZ();
  cut.capDegrees = 90.0;
  // The mean distance from the sphere of the surface's vertices over the cap (10 degrees in from
  // its rim), within 4 mm of it.
  const auto offSphere = [&](const core::TriangleMesh& mesh) {
    double sum = 0.0;
    int count = 0;
    for (const Eigen::Vector3d& v : mesh.vertices) {
      const Eigen::Vector3d u = v - centre;
      if (std::fabs(u.norm() - radius) > 4.0 || u.z() < std::sin(10.0 * M_PI / 180.0) * u.norm())
        continue;
      sum += std::fabs(u.norm() - radius);
      ++count;
    }
    EXPECT_GT(count, 100);
    return sum / std::max(count, 1);
  };
  for (const bool keepInside : {true, false}) {
    const segmentation::VoxelMask& region = keepInside ? ball : socket;
    const segmentation::VoxelMask& other = keepInside ? socket : ball;
    segmentation::BoneSurfaceOptions options;
    const double before = offSphere(segmentation::boneSurface(ct, region, &other, options).mesh);
    cut.keepInside = keepInside;
    options.sphereCut = cut;
    const auto bounded = segmentation::boneSurface(ct, region, &other, options);
    const double after = offSphere(bounded.mesh);
    std::cout << "[ measured ] a " << (keepInside ? "ball" : "socket")
              << " on 5 mm slices, its surface over the joint from the sphere: " << before
              << " mm from the voxels, " << after << " mm bounded by the sphere\n";
    EXPECT_LE(after, 0.2) << (keepInside ? "ball" : "socket");
    EXPECT_GE(before, 2.0 * after) << (keepInside ? "ball" : "socket");
    EXPECT_TRUE(core::checkMesh(bounded.mesh).closed());
  }
  // The ball's lower half (outside the cap) is the CT's: the same with and without the bound.
  segmentation::BoneSurfaceOptions options;
  const auto free = segmentation::boneSurface(ct, ball, &socket, options).mesh;
  cut.keepInside = true;
  options.sphereCut = cut;
  const auto bounded = segmentation::boneSurface(ct, ball, &socket, options).mesh;
  const core::MeshLocator freeSurface(free);
  double worst = 0.0;
  for (const Eigen::Vector3d& v : bounded.vertices) {
    if (v.z() < centre.z() - 8.0)
      worst = std::max(worst, freeSurface.closest(v).distance);
  }
  EXPECT_LE(worst, 0.05);
}

// The joint's slab (joint_slabs.hpp) on a hand-made pair of bones along z (1 mm pixels, 5 mm
// slices): the upper bone (1000 HU) was given its slab next to the lower one though it reads 200
// HU (0.2 of its inward voxel above the soft tissue at 0 HU: the joint space); it goes to the
// lower bone. The lower bone's contact slab reads 300 HU against 800 inward (0.375: dark too),
// but the column's darker one moved first and two voxels of a column never swap. Then the upper
// bone's sections keep the slab it gave away; at share 0 nothing moves.
TEST(ThickSlices, JointSlabGoesToTheBoneItHolds) {
  core::CtImage g = fiveMillimetreGrid(9, 9, 8);
  const int hu[8] = {800, 800, 800, 300, 200, 1000, 1000, 1000};
  g.hu.resize(g.voxelCount());
  segmentation::VoxelMask upper = segmentation::emptyMask(g), lower = upper;
  for (int k = 0; k < 8; ++k) {
    for (int j = 0; j < 9; ++j) {
      for (int i = 0; i < 9; ++i) {
        g.hu[g.index(i, j, k)] = static_cast<std::int16_t>(hu[k]);
        (k >= 4 ? upper : lower).voxels[g.index(i, j, k)] = 1;
      }
    }
  }
  EXPECT_TRUE(segmentation::readsAsJointSlab(g, 4, 4, 4, 5, 0.0, 0.6));
  EXPECT_FALSE(segmentation::readsAsJointSlab(g, 4, 4, 4, 5, 0.0, 0.15));
  EXPECT_DOUBLE_EQ(segmentation::slabMeanHu(g, 0, 0, 3), 300.0);
  segmentation::VoxelMask a = upper, b = lower;
  EXPECT_EQ(segmentation::giveJointSlabs(g, {&a, &b}, 0.0, 0.0), 0u);
  EXPECT_EQ(a.count(), upper.count());
  EXPECT_EQ(segmentation::giveJointSlabs(g, {&a, &b}, 0.0, 0.6), 81u);
  for (int j = 0; j < 9; ++j) {
    for (int i = 0; i < 9; ++i) {
      EXPECT_FALSE(a.at(i, j, 4)) << i << " " << j;
      EXPECT_TRUE(b.at(i, j, 4)) << i << " " << j;
      EXPECT_TRUE(b.at(i, j, 3)) << i << " " << j;  // no swap
    }
  }
  EXPECT_EQ(a.count() + b.count(), upper.count() + lower.count());
  // The upper bone's sections: its region and the slab it gave away (dark against its voxel
  // inward), not the lower bone's slab 3 (not next to it).
  const segmentation::VoxelMask sections = segmentation::jointSlabSections(g, a, &b, 0.0, 0.6);
  EXPECT_EQ(sections.count(), a.count() + 81u);
  EXPECT_TRUE(sections.at(4, 4, 4));
  EXPECT_FALSE(sections.at(4, 4, 3));
  EXPECT_EQ(segmentation::jointSlabSections(g, a, &b, 0.0, 0.0).count(), a.count());
  EXPECT_EQ(segmentation::jointSlabSections(g, a, nullptr, 0.0, 0.6).count(), a.count());
  segmentation::VoxelMask small = segmentation::emptyMask(g);
  small.voxels.resize(10);
  EXPECT_THROW(segmentation::giveJointSlabs(g, {&a, &small}, 0.0, 0.6), std::invalid_argument);
  EXPECT_THROW(segmentation::jointSlabSections(g, a, &small, 0.0, 0.6), std::invalid_argument);
}

// The joint's slab on simulated knees at 5 mm that had no say in the rule's share (chosen on
// seeds 3, 5 and 7): issue 13's targets (MSD <= 0.3 mm, Dice >= 0.97) for every bone. Without the
// rule the femur's MSD was 0.291 / 0.298 / 0.299 mm and the tibia's 0.302 / 0.292 / 0.295 (seeds 9
// / 11 / 13); with it 0.262 / 0.280 / 0.273 and 0.298 / 0.285 / 0.286 (docs/segmentation.md).
TEST(ThickSlices, JointSlabsOnKneesNotUsedToChooseThem) {
  for (int seed : {9, 11, 13}) {
    const auto& sim = kneeAtFiveMillimetres(seed);
    const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
    segmentation::CompetingOptions off;
    off.jointSlabMinSliceMm = 0.0;
    const auto before = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim), off);
    ASSERT_EQ(result.bones.size(), 4u);
    ASSERT_EQ(before.bones.size(), 4u);
    EXPECT_GT(result.jointSlabVoxels, 100u) << "seed " << seed;
    EXPECT_EQ(before.jointSlabVoxels, 0u) << "seed " << seed;
    const segmentation::SurfaceComparisonOptions co = slabOf(sim);
    for (std::size_t b = 0; b < result.bones.size(); ++b) {
      const std::string& bone = result.bones[b].bone;
      const segmentation::VoxelMask others = othersOf(result, b);
      const auto after = segmentation::compareSurfaces(
          segmentation::boneSurface(sim.ct, result.bones[b].mask, &others).mesh,
          sim.knee.bone(kAll[b]).mesh, co);
      segmentation::BoneSurfaceOptions noSections;
      noSections.jointSlabShare = 0.0;
      const segmentation::VoxelMask othersBefore = othersOf(before, b);
      const auto without = segmentation::compareSurfaces(
          segmentation::boneSurface(sim.ct, before.bones[b].mask, &othersBefore, noSections).mesh,
          sim.knee.bone(kAll[b]).mesh, co);
      std::cout << "[ measured ] seed " << seed << ", 5 mm, " << bone << ": without the joint "
                << "slabs MSD " << without.meanMm << " mm, Dice " << without.dice << "; with them "
                << after.meanMm << " mm, Dice " << after.dice << "\n";
      EXPECT_LE(after.meanMm, 0.3) << "seed " << seed << " " << bone;
      EXPECT_GE(after.dice, 0.97) << "seed " << seed << " " << bone;
      if (bone == "femur") {
        EXPECT_LT(after.meanMm, without.meanMm - 0.01) << "seed " << seed;
      }
    }
  }
}

// Faint cancellous bone (150 HU) at 5 mm: the condyles' slabs hold too little bone to make the
// femur one hill with its shaft, the joint does not show, and the tibia's basin takes the
// condyles; without a check both models were written wrong without a word (femur Dice 0.47, MSD
// 5.5 mm; the tibia's slice area falls from 5,035 to 1,624 voxels at the joint and rises again to
// 4,852 within three slices). The waist along the slices refuses it, naming where; the same knee
// at 3 mm is segmented (femur / tibia 0.21 / 0.20 mm in the measurement, docs/segmentation.md).
TEST(ThickSlices, FaintBoneAtFiveMillimetresIsRefusedNotMislabelled) {
  test::KneeVariant v;
  v.sliceMm = 5.0;
  v.halfRangeMm = 45.0;
  v.cancellousHu = 150.0;
  const auto& sim = test::simulatedKnee(v);
  std::string message;
  try {
    segmentation::segmentCompetingBones(sim.ct, seedsOf(sim));
  } catch (const std::invalid_argument& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("the tibia grown from the seed"), std::string::npos) << message;
  EXPECT_NE(message.find("narrows along the slices"), std::string::npos) << message;
  EXPECT_NE(message.find("at z = -475.0 mm"), std::string::npos) << message;
  EXPECT_NE(message.find("--anchors"), std::string::npos) << message;
  // What the check stops: the femur's model, cut at its metaphysis.
  segmentation::CompetingOptions unchecked;
  unchecked.waistMinSliceMm = 0.0;
  const auto result = segmentation::segmentCompetingBones(sim.ct, seedsOf(sim), unchecked);
  ASSERT_EQ(result.bones.size(), 4u);
  const segmentation::VoxelMask others = othersOf(result, 0);
  const auto femur = segmentation::compareSurfaces(
      segmentation::boneSurface(sim.ct, result.bones[0].mask, &others).mesh,
      sim.knee.bone(BoneId::Femur).mesh, slabOf(sim));
  std::cout << "[ measured ] faint bone at 5 mm without the waist check: femur MSD " << femur.meanMm
            << " mm, Dice " << femur.dice << "\n";
  EXPECT_LT(femur.dice, 0.8);
}

}  // namespace
