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

// One seed per bone, on a section well inside the scanned slab.
std::vector<segmentation::BoneSeed> seedsOf(const test::SimulatedKnee& sim,
                                            const std::vector<BoneId>& ids) {
  std::vector<segmentation::BoneSeed> seeds;
  for (BoneId id : ids) {
    const std::optional<Eigen::Vector3d> p = test::seedPoint(sim, id);
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

// Marginal osteophytes of 4 mm (simulation::KneeOptions::osteophyteMm) on the femur and the
// tibia, on a joint narrowed to 1 mm: at each margin the spurs bridge the joint to within
// kOsteophyteClearanceMm (less than a pixel), so the bone mask is one solid across the margins
// as well as at the contact. The truth's spurs are checked first (they are there, they bridge,
// the bones do not overlap), then the four bones from one seed each.
TEST(CompetingBones, OsteophytesBridgingTheJointMargins) {
  test::KneeVariant v;
  v.tibiofemoralGapMm = 1.0;
  v.patellofemoralGapMm = 0.0;
  v.osteophyteMm = 4.0;
  v.halfRangeMm = 45.0;
  const auto& sim = test::simulatedKnee(v);
  const auto& femur = sim.knee.bone(BoneId::Femur).mesh;
  const auto& tibia = sim.knee.bone(BoneId::Tibia).mesh;
  const core::MeshLocator femurLocator(femur);
  // Per margin (medial +x, lateral -x, beyond 25 mm from the knee's centre line): the nearest
  // the tibia comes to the femur there, and that no tibia vertex lies inside the femur.
  for (double side : {1.0, -1.0}) {
    double nearest = 1e9;
    for (const auto& p : tibia.vertices) {
      if (side * (p.x() - sim.knee.kneeCentre.x()) < 25.0 || p.z() < sim.knee.kneeCentre.z() - 15.0)
        continue;
      const double d = femurLocator.signedDistance(p);
      EXPECT_GT(d, 0.0) << "a tibia vertex inside the femur at " << p.transpose();
      nearest = std::min(nearest, d);
    }
    std::cout << "[ measured ] osteophytes, " << (side > 0 ? "medial" : "lateral")
              << " margin: tibia to femur " << nearest << " mm\n";
    EXPECT_LT(nearest, simulation::kOsteophyteClearanceMm + 0.3) << side;
  }
  const auto results = segmentAndCompare(sim, kAll, kAll, "osteophytes 4 mm, 1 mm joint");
  expectTargets(results);
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

// An implant with streaks: the plate of the test above plus, on each of its slices, 12 lines
// through its centre every 15 degrees, 1 pixel wide, out to 55 mm, alternately +800 and -800 HU
// on top of the anatomy (beam hardening's bright and photon starvation's dark streaks). The
// streaks are found where they were drawn, the femur is segmented around them to the targets,
// and with refuseMetal the segmentation is refused naming the metal.
TEST(CompetingBones, MetalStreaksAreFoundAndTheBoneSegmentedAroundThem) {
  test::SimulatedKnee sim = test::simulatedKnee();
  const auto seeds = seedsOf(sim, kAll);
  const simulation::Bone& femur = sim.knee.bone(BoneId::Femur);
  const core::MeshLocator locator(femur.mesh);
  const Eigen::Vector3d seed = seeds[0].pointLps;
  double surfaceX = seed.x();
  while (locator.inside({surfaceX, seed.y(), seed.z()}))
    surfaceX -= 0.1;
  auto inPlate = [&](const Eigen::Vector3d& p) {
    return p.x() <= surfaceX && p.x() > surfaceX - 3.0 && std::abs(p.y() - seed.y()) <= 4.0 &&
           std::abs(p.z() - seed.z()) <= 20.0;
  };
  const core::CtImage plain = sim.ct;
  const Eigen::Vector2d centre(surfaceX - 1.5, seed.y());
  std::vector<std::uint8_t> drawn(sim.ct.hu.size(), 0);  // streak pixels drawn in soft tissue
  std::vector<core::MeshLocator> bones;
  for (const auto& bone : sim.knee.bones)
    bones.emplace_back(bone.mesh);
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    const double z = sim.ct.voxelToLps(Eigen::Vector3d(0, 0, k)).z();
    if (std::abs(z - seed.z()) > 20.0)
      continue;
    for (int line = 0; line < 12; ++line) {
      const double t = line * 15.0 * 3.14159265358979 / 180.0;
      const int add = line % 2 == 0 ? 800 : -800;
      std::vector<std::size_t> done;
      for (double r = -55.0; r <= 55.0; r += 0.2) {
        const Eigen::Vector3d p(centre.x() + r * std::cos(t), centre.y() + r * std::sin(t), z);
        const Eigen::Vector3d v = sim.ct.lpsToVoxel(p);
        const int i = static_cast<int>(std::lround(v.x())),
                  j = static_cast<int>(std::lround(v.y()));
        if (i < 0 || j < 0 || i >= sim.ct.dimensions[0] || j >= sim.ct.dimensions[1])
          continue;
        const std::size_t idx = sim.ct.index(i, j, k);
        if (std::find(done.begin(), done.end(), idx) != done.end())
          continue;
        done.push_back(idx);
        const Eigen::Vector3d c = sim.ct.voxelToLps(Eigen::Vector3d(i, j, k));
        if (inPlate(c))
          continue;
        sim.ct.hu[idx] = static_cast<std::int16_t>(std::clamp(sim.ct.hu[idx] + add, -1024, 3000));
        bool soft = std::abs(r) > 6.0;
        for (const auto& l : bones)
          soft = soft && std::abs(l.signedDistance(c)) > 2.0 && !l.inside(c);
        drawn[idx] = soft ? 1 : 0;
      }
    }
  }
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    for (int j = 0; j < sim.ct.dimensions[1]; ++j) {
      for (int i = 0; i < sim.ct.dimensions[0]; ++i) {
        if (inPlate(sim.ct.voxelToLps(Eigen::Vector3d(i, j, k))))
          sim.ct.hu[sim.ct.index(i, j, k)] = 3000;
      }
    }
  }
  core::CtImage plateOnly = plain;
  for (std::size_t v = 0; v < plateOnly.hu.size(); ++v) {
    if (sim.ct.hu[v] == 3000)
      plateOnly.hu[v] = 3000;
  }
  const auto result = segmentation::segmentCompetingBones(sim.ct, seeds);
  ASSERT_EQ(result.metal.size(), 1u);
  const auto& m = result.metal[0];
  EXPECT_EQ(m.touches, "femur");
  // The streaks are looked for on the bones' box (the threshold's and the metal's, + 2 voxels),
  // inside the leg (not the air beyond the skin, where a streak does not show).
  Eigen::Vector3i lo(1 << 30, 1 << 30, 1 << 30), hi(-1, -1, -1);
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    for (int j = 0; j < sim.ct.dimensions[1]; ++j) {
      for (int i = 0; i < sim.ct.dimensions[0]; ++i) {
        const std::size_t v = sim.ct.index(i, j, k);
        if (result.threshold.voxels[v] || result.metalMask.voxels[v]) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
        }
      }
    }
  }
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    for (int j = 0; j < sim.ct.dimensions[1]; ++j) {
      for (int i = 0; i < sim.ct.dimensions[0]; ++i) {
        const std::size_t v = sim.ct.index(i, j, k);
        const bool inBox = i >= lo.x() - 2 && i <= hi.x() + 2 && j >= lo.y() - 2 &&
                           j <= hi.y() + 2 && k >= lo.z() - 2 && k <= hi.z() + 2;
        if (!inBox || plain.hu[v] < -500)
          drawn[v] = 0;
      }
    }
  }
  int plateSlices = 0;
  for (int k = 0; k < sim.ct.dimensions[2]; ++k) {
    const double z = sim.ct.voxelToLps(Eigen::Vector3d(0, 0, k)).z();
    plateSlices += std::abs(z - seed.z()) <= 20.0 ? 1 : 0;
  }
  std::size_t found = 0, drawnCount = 0, far = 0;
  for (std::size_t v = 0; v < drawn.size(); ++v) {
    drawnCount += drawn[v];
    found += drawn[v] && result.streakMask.voxels[v] ? 1u : 0u;
    if (result.streakMask.voxels[v]) {
      int i = static_cast<int>(v % sim.ct.dimensions[0]);
      int j = static_cast<int>((v / sim.ct.dimensions[0]) % sim.ct.dimensions[1]);
      int k = static_cast<int>(v / (sim.ct.dimensions[0] * sim.ct.dimensions[1]));
      const Eigen::Vector3d p = sim.ct.voxelToLps(Eigen::Vector3d(i, j, k));
      far += std::abs(p.z() - seed.z()) > 20.5 ? 1u : 0u;
    }
  }
  std::cout << "[ measured ] streaks: " << m.streakSlices << " slices, " << m.brightStreakVoxels
            << " bright and " << m.darkStreakVoxels << " dark voxels, up to " << m.streakReachMm
            << " mm; " << found << " of the " << drawnCount << " drawn in soft tissue found\n";
  EXPECT_GE(m.streakSlices, plateSlices - 1);
  EXPECT_GT(m.brightStreakVoxels, 500u);
  EXPECT_GT(m.darkStreakVoxels, 500u);
  EXPECT_GE(m.streakReachMm, 40.0);
  EXPECT_GE(static_cast<double>(found), 0.5 * static_cast<double>(drawnCount));
  EXPECT_EQ(far, 0u) << "streak voxels off the plate's slices";
  // The femur around them, and without looking for streaks (metal alone left out).
  auto femurAccuracy = [&](const segmentation::CompetingResult& r) {
    segmentation::VoxelMask others = segmentation::unite(r.unnamed, r.metalMask);
    others = segmentation::unite(others, r.streakMask);
    for (std::size_t b = 1; b < r.bones.size(); ++b)
      others = segmentation::unite(others, r.bones[b].mask);
    const auto surface = segmentation::boneSurface(sim.ct, r.bones[0].mask, &others);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    return segmentation::compareSurfaces(surface.mesh, femur.mesh, co);
  };
  const auto c = femurAccuracy(result);
  segmentation::CompetingOptions blind;
  blind.detectStreaks = false;
  const auto cBlind = femurAccuracy(segmentation::segmentCompetingBones(sim.ct, seeds, blind));
  std::cout << "[ measured ] femur with a streaking plate: MSD " << c.meanMm << " mm (p95 "
            << c.p95Mm << ", max " << c.maxMm << "), Dice " << c.dice
            << "; without the streaks found: MSD " << cBlind.meanMm << " mm (p95 " << cBlind.p95Mm
            << ", max " << cBlind.maxMm << "), Dice " << cBlind.dice << "\n";
  // Streaks also cross the cortex (they stay in the CT the surface is taken from): the
  // targets of a clean knee (0.3 mm) are not reached, the streaks' spikes are gone.
  EXPECT_LE(c.meanMm, 0.4);
  EXPECT_LE(c.p95Mm, 0.5 * cBlind.p95Mm);
  EXPECT_LT(c.meanMm, cBlind.meanMm - 0.2);
  EXPECT_GE(c.dice, 0.98);
  // The plate without streaks: few false streaks (bone edges seen from the plate).
  const auto clean = segmentation::segmentCompetingBones(plateOnly, seeds);
  ASSERT_EQ(clean.metal.size(), 1u);
  std::cout << "[ measured ] the plate without streaks: " << clean.metal[0].brightStreakVoxels
            << " bright, " << clean.metal[0].darkStreakVoxels << " dark streak voxels\n";
  EXPECT_LT(clean.metal[0].brightStreakVoxels + clean.metal[0].darkStreakVoxels,
            (m.brightStreakVoxels + m.darkStreakVoxels) / 10);
  // Refused when asked, naming it.
  segmentation::CompetingOptions refuse;
  refuse.refuseMetal = true;
  std::string message;
  try {
    segmentation::segmentCompetingBones(sim.ct, seeds, refuse);
  } catch (const std::invalid_argument& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("metal (an implant?)"), std::string::npos) << message;
  EXPECT_NE(message.find("with streaks over"), std::string::npos) << message;
  EXPECT_NE(message.find("refused"), std::string::npos) << message;
}

// estimateBoneThreshold on a synthetic CT: soft tissue of 50 HU with +-10 HU noise (uniform,
// sigma 5.8), a block of 1000 HU cortex around 250 HU cancellous bone: S, C and the levels as
// the formulas say; a box without bone gets the floors; no seed is refused.
TEST(CompetingBones, ThresholdEstimateFollowsTheHistogram) {
  core::CtImage ct;
  ct.dimensions = {60, 60, 60};
  ct.pixelSpacingMm = {1.0, 1.0};
  for (int k = 0; k < 60; ++k)
    ct.slicePositionsMm.push_back(k);
  ct.groups = {{0, 60, 1.0}};
  ct.hu.resize(ct.voxelCount());
  std::uint64_t state = 7;
  for (int k = 0; k < 60; ++k) {
    for (int j = 0; j < 60; ++j) {
      for (int i = 0; i < 60; ++i) {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        const int noise = static_cast<int>((state >> 33) % 21) - 10;
        const bool block = i >= 20 && i < 40 && j >= 20 && j < 40 && k >= 10 && k < 50;
        const bool inner = i >= 23 && i < 37 && j >= 23 && j < 37 && k >= 13 && k < 47;
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>((inner   ? 250
                                                              : block ? 1000
                                                                      : 50) +
                                                             noise);
      }
    }
  }
  const auto e = segmentation::estimateBoneThreshold(ct, {{30, 30, 30}});
  EXPECT_NEAR(e.softTissueHu, 55.0, 10.0);  // the 10 HU bin 50-60
  EXPECT_NEAR(e.cortexHu, 1000.0, 10.0);
  EXPECT_NEAR(e.noiseHu, 6.0, 2.0);
  ASSERT_EQ(e.marrowHu.size(), 1u);
  EXPECT_NEAR(e.marrowHu[0], 250.0, 10.0);
  const double strong = e.softTissueHu + 0.41 * (e.cortexHu - e.softTissueHu);
  EXPECT_NEAR(e.threshold.strongHu, strong, 1.0);
  EXPECT_NEAR(e.threshold.weakHu,
              std::max(e.softTissueHu + 0.29 * (strong - e.softTissueHu), e.softTissueHu + 80.0),
              1.0);
  // Away from the block (a box of soft tissue only): the floors, not the noise's tail.
  const auto soft = segmentation::estimateBoneThreshold(ct, {{5, 5, 5}}, 4.0);
  EXPECT_NEAR(soft.threshold.strongHu, soft.softTissueHu + 200.0, 1.0);
  EXPECT_NEAR(soft.threshold.weakHu, soft.softTissueHu + 80.0, 1.0);
  // Capped at the ceiling.
  segmentation::BoneThreshold low;
  low.strongHu = 300.0;
  low.weakHu = 100.0;
  const auto capped = segmentation::estimateBoneThreshold(ct, {{30, 30, 30}}, 30.0, 2500.0, low);
  EXPECT_EQ(capped.threshold.strongHu, 300.0);
  EXPECT_EQ(capped.threshold.weakHu, 100.0);
  EXPECT_THROW(segmentation::estimateBoneThreshold(ct, {}), std::invalid_argument);
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
  const auto a = test::insidePoint(femur, sim.kneeZMaxMm - 4.0);
  const auto b = test::insidePoint(femur, sim.kneeZMaxMm - 24.0);
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

// Where two named bones meet along k: each face one pixel (0.5 x 0.8 mm), z between the slices,
// pairs that do not meet left out, largest first; a mask on another grid is refused.
TEST(CompetingBones, ContactsAlongTheSlicesAreMeasured) {
  core::CtImage ct =
      core::axialCtImage(6, 5, 0.5, {0.0, 0.0}, {{"stack", {0.0, 5.0, 10.0, 15.0}, 5.0}});
  ct.hu.assign(ct.voxelCount(), 0);
  std::vector<segmentation::SegmentedBone> bones(3);
  bones[0].bone = "femur";
  bones[1].bone = "tibia";
  bones[2].bone = "patella";
  for (auto& b : bones)
    b.mask = segmentation::emptyMask(ct);
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 6; ++i) {
      bones[0].mask.voxels[ct.index(i, j, 2)] = 1;  // the femur over the tibia where i < 4
      bones[0].mask.voxels[ct.index(i, j, 3)] = 1;
      if (i < 4)
        bones[1].mask.voxels[ct.index(i, j, 1)] = 1;
    }
  }
  bones[2].mask.voxels[ct.index(5, 0, 0)] = 1;  // touches nothing along k
  const auto contacts = segmentation::contactsAlongSlices(ct, bones);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].first, "femur");
  EXPECT_EQ(contacts[0].second, "tibia");
  const Eigen::Vector3d s = ct.spacingMm();
  EXPECT_NEAR(contacts[0].areaMm2, 20 * s.x() * s.y(), 1e-9);
  const double zFace = 0.5 * (ct.voxelToLps(Eigen::Vector3d(0, 0, 1)).z() +
                              ct.voxelToLps(Eigen::Vector3d(0, 0, 2)).z());
  EXPECT_NEAR(contacts[0].zMinMm, zFace, 1e-9);
  EXPECT_NEAR(contacts[0].zMaxMm, zFace, 1e-9);
  EXPECT_NEAR(contacts[0].centreLps.z(), zFace, 1e-9);
  EXPECT_NEAR(contacts[0].centreLps.x(),
              0.5 * (ct.voxelToLps(Eigen::Vector3d(0, 0, 1)).x() +
                     ct.voxelToLps(Eigen::Vector3d(3, 0, 1)).x()),
              1e-9);
  bones[1].mask.voxels.pop_back();
  EXPECT_THROW(segmentation::contactsAlongSlices(ct, bones), std::invalid_argument);
}

}  // namespace
