// Bones that touch, segmented against each other from one seed each (segmentCompetingBones):
// the simulated knee as it is, with the joint narrowed to 1 mm and to 0 mm, the patella on the
// femur and faint cancellous bone (150 HU); a bone alone with its neighbours found
// automatically; and the refusals (two bones' seeds in one bone, a seed in soft tissue, outside
// the scan, an implausible bone). Targets (issue 13): MSD <= 0.3 mm, Dice >= 0.97 per bone.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include "simulated_knee.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <iostream>

namespace {

using namespace echoreg;
using simulation::BoneId;

// The inside point of `bone` at height z nearest the centroid of its points 3 mm or more deep.
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

// One seed per bone, on a section well inside the scanned slab.
std::vector<segmentation::BoneSeed> seedsOf(const test::SimulatedKnee& sim,
                                            const std::vector<BoneId>& ids) {
  std::vector<segmentation::BoneSeed> seeds;
  for (BoneId id : ids) {
    const simulation::Bone& bone = sim.knee.bone(id);
    const auto box = core::bounds(bone.mesh);
    const double lo = std::max(sim.kneeZMinMm + 6.0, box[0].z() + 6.0);
    const double hi = std::min(sim.kneeZMaxMm - 6.0, box[1].z() - 6.0);
    std::optional<Eigen::Vector3d> p;
    // Femur and patella seeded high, tibia and fibula low: away from the joints.
    const bool high = id == BoneId::Femur || id == BoneId::Patella;
    for (double t = 0.0; t <= 1.0 && !p; t += 0.1)
      p = insidePoint(bone, high ? hi - t * (hi - lo) : lo + t * (hi - lo));
    EXPECT_TRUE(p.has_value()) << simulation::boneName(id) << ": no seed in the scan";
    seeds.push_back({std::string(simulation::boneName(id)), p.value_or(Eigen::Vector3d::Zero())});
  }
  return seeds;
}

struct Accuracy {
  std::string bone;
  segmentation::SurfaceComparison c;
};

// Segments `ids` against each other, and compares each model with the truth inside the slab.
std::vector<Accuracy> segmentAndCompare(const test::SimulatedKnee& sim,
                                        const std::vector<BoneId>& seeded,
                                        const std::vector<BoneId>& compared,
                                        const std::string& what) {
  const auto seeds = seedsOf(sim, seeded);
  const auto t0 = std::chrono::steady_clock::now();
  const auto result = segmentation::segmentCompetingBones(sim.ct, seeds);
  const double tSegment =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "[ measured ] " << what << ": threshold " << result.thresholdUsed.strongHu << " / "
            << result.thresholdUsed.weakHu << " HU from the histogram (soft tissue "
            << result.estimate.softTissueHu << ", noise " << result.estimate.noiseHu << ", cortex "
            << result.estimate.cortexHu << ")\n";
  std::vector<Accuracy> out;
  for (BoneId id : compared) {
    const std::string name(simulation::boneName(id));
    const auto it = std::find_if(result.bones.begin(), result.bones.end(),
                                 [&](const auto& b) { return b.bone == name; });
    if (it == result.bones.end()) {
      ADD_FAILURE() << "no " << name;
      continue;
    }
    // Everything else is another bone.
    segmentation::VoxelMask others = result.unnamed;
    for (const auto& b : result.bones) {
      if (&b != &*it)
        others = segmentation::unite(others, b.mask);
    }
    const auto surface = segmentation::boneSurface(sim.ct, it->mask, &others);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    const auto c = segmentation::compareSurfaces(surface.mesh, sim.knee.bone(id).mesh, co);
    std::cout << "[ measured ] " << what << " " << name << ": MSD " << c.meanMm << " mm (p95 "
              << c.p95Mm << ", max " << c.maxMm << "), Dice " << c.dice << ", volume "
              << c.volumeEstimateMm3 << " / " << c.volumeTruthMm3 << " mm^3; iso " << surface.isoHu
              << "; " << result.automaticNeighbours
              << " neighbours found automatically; segmented in " << tSegment << " s\n";
    out.push_back({name, c});
  }
  return out;
}

void expectTargets(const std::vector<Accuracy>& results) {
  for (const auto& r : results) {
    EXPECT_LE(r.c.meanMm, 0.3) << r.bone;
    EXPECT_GE(r.c.dice, 0.97) << r.bone;
  }
}

const std::vector<BoneId> kAll = {BoneId::Femur, BoneId::Tibia, BoneId::Fibula, BoneId::Patella};

TEST(CompetingBones, FourBonesOfTheKneeFromOneSeedEach) {
  expectTargets(segmentAndCompare(test::simulatedKnee(), kAll, kAll, "knee"));
}

TEST(CompetingBones, ABoneAloneIsSeparatedFromItsNeighbours) {
  const auto& sim = test::simulatedKnee();
  for (BoneId id : {BoneId::Femur, BoneId::Tibia})
    expectTargets(segmentAndCompare(sim, {id}, {id}, "alone"));
}

TEST(CompetingBones, JointNarrowedToOneMillimetrePatellaOnTheFemurFaintBone) {
  test::KneeVariant v;
  v.tibiofemoralGapMm = 1.0;
  v.patellofemoralGapMm = 0.0;
  v.cancellousHu = 150.0;
  v.halfRangeMm = 45.0;
  expectTargets(segmentAndCompare(test::simulatedKnee(v), kAll, kAll, "1 mm joint, 150 HU"));
}

TEST(CompetingBones, JointClosedToZero) {
  test::KneeVariant v;
  v.tibiofemoralGapMm = 0.0;
  v.patellofemoralGapMm = 0.0;
  v.halfRangeMm = 45.0;
  expectTargets(segmentAndCompare(test::simulatedKnee(v), kAll, kAll, "0 mm joint"));
}

// A metal plate (3000 HU, 40 x 8 x 3 mm) screwed onto the femur's lateral side: reported as
// lying on the femur, left out of it, and the femur's model stays on the bone.
TEST(CompetingBones, MetalIsLeftOutAndReported) {
  test::SimulatedKnee sim = test::simulatedKnee();
  const auto seeds = seedsOf(sim, kAll);
  const simulation::Bone& femur = sim.knee.bone(BoneId::Femur);
  const core::MeshLocator locator(femur.mesh);
  // The femur's lateral surface on the line through its seed (+x is medial).
  const Eigen::Vector3d seed = seeds[0].pointLps;
  double surfaceX = seed.x();
  while (locator.inside({surfaceX, seed.y(), seed.z()}))
    surfaceX -= 0.1;
  int plate = 0;
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    for (int j = 0; j < sim.ct.dimensions[1]; ++j) {
      for (int i = 0; i < sim.ct.dimensions[0]; ++i) {
        const Eigen::Vector3d p = sim.ct.voxelToLps(Eigen::Vector3d(i, j, k));
        if (p.x() <= surfaceX && p.x() > surfaceX - 3.0 && std::abs(p.y() - seed.y()) <= 4.0 &&
            std::abs(p.z() - seed.z()) <= 20.0) {
          sim.ct.hu[sim.ct.index(i, j, k)] = 3000;
          ++plate;
        }
      }
    }
  }
  ASSERT_GT(plate, 100);
  const auto result = segmentation::segmentCompetingBones(sim.ct, seeds);
  ASSERT_EQ(result.metal.size(), 1u);
  EXPECT_EQ(result.metal[0].touches, "femur");
  EXPECT_NEAR(result.metal[0].volumeMm3, plate * sim.ct.spacingMm().prod(), 1.0);
  EXPECT_NEAR(result.metal[0].centreLps.y(), seed.y(), 1.0);
  segmentation::VoxelMask others = segmentation::unite(result.unnamed, result.metalMask);
  for (std::size_t b = 1; b < result.bones.size(); ++b)
    others = segmentation::unite(others, result.bones[b].mask);
  const auto surface = segmentation::boneSurface(sim.ct, result.bones[0].mask, &others);
  segmentation::SurfaceComparisonOptions co;
  co.zMinMm = sim.kneeZMinMm + 2.0;
  co.zMaxMm = sim.kneeZMaxMm - 2.0;
  const auto c = segmentation::compareSurfaces(surface.mesh, femur.mesh, co);
  std::cout << "[ measured ] femur with a plate: MSD " << c.meanMm << " mm (max " << c.maxMm
            << "), Dice " << c.dice << "\n";
  EXPECT_LE(c.meanMm, 0.3);
  EXPECT_GE(c.dice, 0.97);
}

// Faint bone (issue 13: thresholds of this patient): the healthy knee's contrast above the soft
// tissue scaled by 0.25 (cortex 1500 -> ~400 HU, cancellous 300 -> ~100 HU), as in an
// osteoporotic knee. The fixed 600 / 200 HU find no cortex; the histogram around the seeds gives
// this CT's levels and the four bones meet the targets. (At 0.35, cortex ~550 HU, the fixed
// levels still work: the hysteresis finds 600 HU in the cortex's texture.)
TEST(CompetingBones, FaintBoneGetsItsThresholdFromTheHistogram) {
  test::SimulatedKnee sim = test::simulatedKnee();
  for (auto& hu : sim.ct.hu) {
    if (hu > 40)
      hu = static_cast<std::int16_t>(std::lround(40.0 + 0.25 * (hu - 40.0)));
  }
  const auto seeds = seedsOf(sim, kAll);
  // The worst bone's MSD and Dice of a segmentation (the surface's cortex level from its
  // threshold, as echoreg segment does); a refusal counts as a failure.
  auto worst = [&](const segmentation::CompetingOptions& options, const std::string& what) {
    std::pair<double, double> w{0.0, 1.0};
    segmentation::CompetingResult result;
    try {
      result = segmentation::segmentCompetingBones(sim.ct, seeds, options);
    } catch (const std::invalid_argument& e) {
      std::cout << "[ measured ] faint bone, " << what << ": refused: " << e.what() << "\n";
      return std::pair<double, double>{1e9, 0.0};
    }
    std::cout << "[ measured ] faint bone, " << what << ": threshold "
              << result.thresholdUsed.strongHu << " / " << result.thresholdUsed.weakHu
              << " HU (soft tissue " << result.estimate.softTissueHu << ", noise "
              << result.estimate.noiseHu << ", cortex " << result.estimate.cortexHu << ")\n";
    for (const BoneId id : kAll) {
      const std::string name(simulation::boneName(id));
      const auto it = std::find_if(result.bones.begin(), result.bones.end(),
                                   [&](const auto& b) { return b.bone == name; });
      if (it == result.bones.end())
        return std::pair<double, double>{1e9, 0.0};
      segmentation::VoxelMask others = result.unnamed;
      for (const auto& o : result.bones) {
        if (&o != &*it)
          others = segmentation::unite(others, o.mask);
      }
      segmentation::BoneSurfaceOptions so;
      so.cortexMinHu = result.estimate.surfaceCortexMinHu;  // as echoreg segment does
      const auto surface = segmentation::boneSurface(sim.ct, it->mask, &others, so);
      segmentation::SurfaceComparisonOptions co;
      co.zMinMm = sim.kneeZMinMm + 2.0;
      co.zMaxMm = sim.kneeZMaxMm - 2.0;
      const auto c = segmentation::compareSurfaces(surface.mesh, sim.knee.bone(id).mesh, co);
      std::cout << "[ measured ] faint bone, " << what << ", " << name << ": MSD " << c.meanMm
                << " mm (p95 " << c.p95Mm << "), Dice " << c.dice << ", " << it->volumeMm3 / 1000.0
                << " cm^3; iso " << surface.isoHu << "\n";
      w.first = std::max(w.first, c.meanMm);
      w.second = std::min(w.second, c.dice);
    }
    return w;
  };
  {
    std::vector<Eigen::Vector3i> voxels;
    for (const auto& seed : seeds)
      voxels.push_back(sim.ct.lpsToVoxel(seed.pointLps).array().round().cast<int>());
    const auto e = segmentation::estimateBoneThreshold(sim.ct, voxels);
    std::cout << "[ measured ] faint bone's estimate: " << e.threshold.strongHu << " / "
              << e.threshold.weakHu << " HU (soft tissue " << e.softTissueHu << ", noise "
              << e.noiseHu << ", cortex " << e.cortexHu << ", surface cortex "
              << e.surfaceCortexMinHu << ")\n";
  }
  segmentation::CompetingOptions fixed;
  fixed.thresholdFromHistogram = false;
  const auto before = worst(fixed, "fixed 600 / 200 HU");
  EXPECT_TRUE(before.first > 0.3 || before.second < 0.97) << "the fixed levels should fail here";
  const auto after = worst({}, "from the histogram");
  EXPECT_LE(after.first, 0.3);
  EXPECT_GE(after.second, 0.97);
}

std::string thrownMessage(const test::SimulatedKnee& sim,
                          const std::vector<segmentation::BoneSeed>& seeds) {
  try {
    segmentation::segmentCompetingBones(sim.ct, seeds);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

TEST(CompetingBones, RefusesSeedsItCannotUse) {
  const auto& sim = test::simulatedKnee();
  const auto seeds = seedsOf(sim, {BoneId::Femur, BoneId::Tibia});
  // Two bones' seeds in the femur (its shaft, 20 mm apart).
  const simulation::Bone& femur = sim.knee.bone(BoneId::Femur);
  const auto a = insidePoint(femur, sim.kneeZMaxMm - 4.0);
  const auto b = insidePoint(femur, sim.kneeZMaxMm - 24.0);
  ASSERT_TRUE(a && b);
  std::string m = thrownMessage(sim, {{"femur", *a}, {"tibia", *b}});
  EXPECT_NE(m.find("lie in one bone"), std::string::npos) << m;
  EXPECT_NE(m.find("femur"), std::string::npos) << m;
  // Soft tissue: 42 mm lateral of the femur's seed, outside every bone.
  const Eigen::Vector3d soft = seeds[0].pointLps + Eigen::Vector3d(-42.0, 0.0, 0.0);
  for (const auto& bone : sim.knee.bones)
    ASSERT_FALSE(core::MeshLocator(bone.mesh).inside(soft)) << simulation::boneName(bone.id);
  m = thrownMessage(sim, {seeds[1], {"femur", soft}});
  EXPECT_NE(m.find("not in bone"), std::string::npos) << m;
  EXPECT_NE(m.find("HU there"), std::string::npos) << m;
  // Outside the scan: 10 mm above its last slice.
  m = thrownMessage(
      sim,
      {seeds[1], {"femur", {seeds[0].pointLps.x(), seeds[0].pointLps.y(), sim.kneeZMaxMm + 10.0}}});
  EXPECT_NE(m.find("outside the CT volume"), std::string::npos) << m;
  EXPECT_NE(m.find("femur"), std::string::npos) << m;
}

// A seed in a patch above the weak threshold that holds no cortex (a 205-330 HU blob in the
// soft tissue: a calcification, contrast) is refused with that reason, not its HU alone.
TEST(CompetingBones, ASeedInAPatchWithoutCortexSaysSo) {
  test::SimulatedKnee sim = test::simulatedKnee();
  const auto seeds = seedsOf(sim, kAll);
  // A point of the femur seed's slice 12 mm or more from every bone and from the field's edge.
  std::vector<core::MeshLocator> bones;
  for (const auto& bone : sim.knee.bones)
    bones.emplace_back(bone.mesh);
  std::optional<Eigen::Vector3d> found;
  const Eigen::Vector3d lo = sim.ct.voxelToLps(Eigen::Vector3d(0, 0, 0));
  const Eigen::Vector3d hi =
      sim.ct.voxelToLps(Eigen::Vector3d(sim.ct.dimensions[0] - 1, sim.ct.dimensions[1] - 1, 0));
  for (double y = lo.y() + 12.0; y <= hi.y() - 12.0 && !found; y += 2.0) {
    for (double x = lo.x() + 12.0; x <= hi.x() - 12.0 && !found; x += 2.0) {
      const Eigen::Vector3d p(x, y, seeds[0].pointLps.z());
      bool far = true;
      for (const auto& l : bones)
        far = far && !l.inside(p) && std::abs(l.signedDistance(p)) >= 12.0;
      if (far)
        found = p;
    }
  }
  ASSERT_TRUE(found.has_value());
  const Eigen::Vector3d soft = *found;
  const Eigen::Vector3d c = sim.ct.lpsToVoxel(soft);
  int blob = 0;
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    for (int j = 0; j < sim.ct.dimensions[1]; ++j) {
      for (int i = 0; i < sim.ct.dimensions[0]; ++i) {
        if ((Eigen::Vector3d(i, j, k) - c).cwiseProduct(sim.ct.spacingMm()).norm() <= 3.0) {
          sim.ct.hu[sim.ct.index(i, j, k)] = static_cast<std::int16_t>(i % 2 ? 330 : 205);
          ++blob;
        }
      }
    }
  }
  ASSERT_GT(blob, 50);
  const std::string m = thrownMessage(sim, {seeds[1], {"femur", soft}});
  std::cout << "[ measured ] " << m << "\n";
  EXPECT_NE(m.find("not in bone"), std::string::npos) << m;
  EXPECT_NE(m.find("is brightest at 330 HU"), std::string::npos) << m;
  EXPECT_NE(m.find("reaches no cortex"), std::string::npos) << m;
}

// The leak guard on a whole segmentation: the femur's seed given as a "patella" grows the femur,
// which no patella can be: refused, saying what it is, what a patella may be and what to do.
TEST(CompetingBones, AnImplausibleBoneIsRefused) {
  const auto& sim = test::simulatedKnee();
  auto seeds = seedsOf(sim, {BoneId::Femur, BoneId::Tibia});
  seeds[0].bone = "patella";
  const std::string m = thrownMessage(sim, seeds);
  EXPECT_NE(m.find("is not a patella"), std::string::npos) << m;
  EXPECT_NE(m.find("cm^3 (a patella is at most 60)"), std::string::npos) << m;
  EXPECT_NE(m.find("mm wide (x) (at most 70)"), std::string::npos) << m;
  EXPECT_NE(m.find("add a seed in each neighbouring bone"), std::string::npos) << m;
}

TEST(CompetingBones, ImplausibleBonesAreNamed) {
  EXPECT_EQ(segmentation::implausibleBone("femur", 300e3, {80, 70, 300}), "");
  const std::string why = segmentation::implausibleBone("femur", 722e3, {330, 200, 300});
  EXPECT_EQ(why.find("cm^3"), std::string::npos) << why;  // a whole femur can have 722
  EXPECT_NE(why.find("330 mm wide"), std::string::npos) << why;
  EXPECT_NE(segmentation::implausibleBone("patella", 90e3, {50, 30, 50}), "");
  EXPECT_EQ(segmentation::implausibleBone("my bone", 9e9, {900, 900, 900}), "");  // unknown
}

}  // namespace
