// Speed of the segmentation steps on the simulated knee of the segmentation tests (144 x 144 x 65
// voxels of 0.8 x 0.8 x 1 mm, knee group only) and, when ../shared/data is there, on the real
// abdominal CT (512 x 512 x 134 voxels of 1.07 x 1.07 x 3 mm): threshold + growth + separation +
// marrow filling from a seed, the CT iso-surface around the grown femur, 40 live-wire contours
// from a simulated user's anchors, their shape-based interpolation into a mask, and the metrics.
//
//   bench_segmentation [--benchmark_filter=Grow]

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include "mesh_test_support.hpp"
#include "simulated_knee.hpp"
#include "test_support.hpp"

#include <benchmark/benchmark.h>

namespace {

using namespace echoreg;

const simulation::Bone& femur() {
  return test::simulatedKnee().knee.bone(simulation::BoneId::Femur);
}

// The femur's seed: 15 mm below the group's top, the inside point nearest its section's centroid.
Eigen::Vector3d femurSeed() {
  static const Eigen::Vector3d seed =
      *test::insidePointNearCentroid(femur().mesh, test::simulatedKnee().kneeZMaxMm - 15.0);
  return seed;
}

const segmentation::GrowResult& grownFemur() {
  static const segmentation::GrowResult g =
      segmentation::growBone(test::simulatedKnee().ct, femurSeed());
  return g;
}

std::vector<segmentation::AnchorSet> userAnchors() {
  const auto& sim = test::simulatedKnee();
  segmentation::AnchorProposalOptions o;
  o.zMinMm = sim.kneeZMinMm;
  o.zMaxMm = sim.kneeZMaxMm;
  return segmentation::proposeAnchors(femur().mesh, segmentation::SlicePlane::Sagittal, 40, o);
}

void BM_GrowFemur(benchmark::State& state) {
  const auto& ct = test::simulatedKnee().ct;
  for (auto _ : state)
    benchmark::DoNotOptimize(segmentation::growBone(ct, femurSeed()));
  state.counters["voxels"] = static_cast<double>(ct.voxelCount());
}
BENCHMARK(BM_GrowFemur)->Unit(benchmark::kMillisecond);

void BM_FemurSurface(benchmark::State& state) {
  const auto& g = grownFemur();
  std::size_t triangles = 0;
  for (auto _ : state) {
    const auto s = segmentation::boneSurface(test::simulatedKnee().ct, g.mask, &g.others);
    triangles = s.mesh.triangles.size();
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}
BENCHMARK(BM_FemurSurface)->Unit(benchmark::kMillisecond);

void BM_LiveWire40Contours(benchmark::State& state) {
  const auto sets = userAnchors();
  for (auto _ : state) {
    for (const auto& s : sets)
      benchmark::DoNotOptimize(segmentation::liveWireContour(test::simulatedKnee().ct, s));
  }
  state.counters["contours"] = static_cast<double>(sets.size());
}
BENCHMARK(BM_LiveWire40Contours)->Unit(benchmark::kMillisecond);

void BM_ContoursToMask(benchmark::State& state) {
  std::vector<segmentation::SliceContour> contours;
  for (const auto& s : userAnchors())
    contours.push_back(segmentation::liveWireContour(test::simulatedKnee().ct, s));
  for (auto _ : state)
    benchmark::DoNotOptimize(segmentation::contoursToMask(contours, test::simulatedKnee().ct));
}
BENCHMARK(BM_ContoursToMask)->Unit(benchmark::kMillisecond);

void BM_CompareSurfaces(benchmark::State& state) {
  const auto& g = grownFemur();
  const auto s = segmentation::boneSurface(test::simulatedKnee().ct, g.mask, &g.others);
  segmentation::SurfaceComparisonOptions o;
  o.zMinMm = test::simulatedKnee().kneeZMinMm + 2.0;
  o.zMaxMm = test::simulatedKnee().kneeZMaxMm - 2.0;
  for (auto _ : state)
    benchmark::DoNotOptimize(segmentation::compareSurfaces(s.mesh, femur().mesh, o));
}
BENCHMARK(BM_CompareSurfaces)->Unit(benchmark::kMillisecond);

void BM_RealCtReadAndGrowPelvis(benchmark::State& state) {
  const std::string folder =
      test::sharedDataDir().empty() ? "" : test::sharedDataDir() + "/ct-abdomen";
  if (folder.empty() || test::sharedDataFile("ct-abdomen/1-001.dcm").empty()) {
    state.SkipWithError("../shared/data/ct-abdomen is absent");
    return;
  }
  segmentation::GrowOptions o;
  o.separationRadiusMm = 6.0;
  double volume = 0.0;
  for (auto _ : state) {
    const auto ct = segmentation::readDicomSeries(folder);
    volume = segmentation::growBone(ct, {-65.5, 133.4, 91.91}, o).volumeMm3;
  }
  state.counters["volume_cm3"] = volume / 1000.0;
}
BENCHMARK(BM_RealCtReadAndGrowPelvis)->Unit(benchmark::kMillisecond)->Iterations(2);

// The four bones of the simulated knee against each other, one seed each.
void BM_CompetingKneeBones(benchmark::State& state) {
  const auto& sim = test::simulatedKnee();
  std::vector<segmentation::BoneSeed> seeds;
  for (const auto& bone : sim.knee.bones) {
    const auto box = core::bounds(bone.mesh);
    const double z = bone.id == simulation::BoneId::Femur || bone.id == simulation::BoneId::Patella
                         ? std::min(sim.kneeZMaxMm, box[1].z()) - 8.0
                         : std::max(sim.kneeZMinMm, box[0].z()) + 8.0;
    seeds.push_back(
        {std::string(simulation::boneName(bone.id)), *test::insidePointNearCentroid(bone.mesh, z)});
  }
  for (auto _ : state)
    benchmark::DoNotOptimize(segmentation::segmentCompetingBones(sim.ct, seeds));
  state.counters["voxels"] = static_cast<double>(sim.ct.voxelCount());
}
BENCHMARK(BM_CompetingKneeBones)->Unit(benchmark::kMillisecond);

// A leg-sized CT of 512 x 512 x N voxels of 0.5 mm (N = the argument; the size is 1000):
// a femur (cylinder of 4 mm cortex around marrow, radius 15 mm) standing 1 mm above a tibia, a
// fibula touching the tibia and a patella (sphere) touching the femur, in 40 HU tissue with
// noise. Four seeds.
core::CtImage legCt(int slices, bool stem = false) {
  core::CtImage ct;
  ct.dimensions = {512, 512, slices};
  ct.pixelSpacingMm = {0.5, 0.5};
  for (int k = 0; k < slices; ++k)
    ct.slicePositionsMm.push_back(0.5 * k);
  ct.groups = {{0, slices, 0.5}};
  ct.hu.resize(ct.voxelCount());
  const double joint = 0.25 * slices;  // mm
  std::uint64_t state = 12345;
  auto noise = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>((state >> 33) % 41) - 20.0;
  };
  for (int k = 0; k < slices; ++k) {
    const double z = 0.5 * k;
    for (int j = 0; j < 512; ++j) {
      for (int i = 0; i < 512; ++i) {
        const double x = 0.5 * i - 128.0, y = 0.5 * j - 128.0;
        double hu = 40.0;
        auto tube = [&](double cx, double cy, double r, double cortex) {
          const double d = std::hypot(x - cx, y - cy);
          if (d <= r)
            hu = d > r - cortex ? 1500.0 : -60.0;
        };
        if (z > joint + 0.5)
          tube(0.0, 0.0, 15.0, 4.0);  // femur
        else if (z < joint - 0.5)
          tube(0.0, 0.0, 15.0, 4.0);  // tibia
        if (z < joint - 0.5)
          tube(21.5, 0.0, 6.5, 2.0);  // fibula, touching the tibia
        const double dp =
            std::sqrt(x * x + (y + 27.0) * (y + 27.0) + (z - joint - 20.0) * (z - joint - 20.0));
        if (dp <= 12.0)
          hu = dp > 10.0 ? 1500.0 : 300.0;  // patella, touching the femur
        // A hip stem in the femur's canal (3000 HU, radius 5 mm, from 20 mm above the joint).
        if (stem && z > joint + 20.0 && std::hypot(x, y) <= 5.0)
          hu = 3000.0;
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>(hu + noise());
      }
    }
  }
  return ct;
}

void BM_CompetingLegBones(benchmark::State& state) {
  const int slices = static_cast<int>(state.range(0));
  const core::CtImage ct = legCt(slices);
  const double joint = 0.25 * slices;
  const std::vector<segmentation::BoneSeed> seeds = {
      {"femur", {128.0, 128.0, joint + 40.0}},
      {"tibia", {128.0, 128.0, joint - 40.0}},
      {"fibula", {128.0 + 21.5, 128.0, joint - 40.0}},
      {"patella", {128.0, 128.0 - 27.0, joint + 20.0}}};
  for (auto _ : state)
    benchmark::DoNotOptimize(segmentation::segmentCompetingBones(ct, seeds));
  state.counters["voxels"] = static_cast<double>(ct.voxelCount());
}
BENCHMARK(BM_CompetingLegBones)->Arg(200)->Arg(1000)->Unit(benchmark::kMillisecond)->Iterations(1);

// The same leg with a metal stem in the femur (the streaks looked for on its every slice).
void BM_CompetingLegBonesWithStem(benchmark::State& state) {
  const int slices = static_cast<int>(state.range(0));
  const core::CtImage ct = legCt(slices, true);
  const double joint = 0.25 * slices;
  const std::vector<segmentation::BoneSeed> seeds = {
      {"femur", {128.0, 128.0 + 10.0, joint + 40.0}},
      {"tibia", {128.0, 128.0, joint - 40.0}},
      {"fibula", {128.0 + 21.5, 128.0, joint - 40.0}},
      {"patella", {128.0, 128.0 - 27.0, joint + 20.0}}};
  std::size_t streakVoxels = 0;
  int streakSlices = 0;
  for (auto _ : state) {
    const auto r = segmentation::segmentCompetingBones(ct, seeds);
    for (const auto& m : r.metal) {
      streakVoxels += m.brightStreakVoxels + m.darkStreakVoxels;
      streakSlices += m.streakSlices;
    }
  }
  state.counters["voxels"] = static_cast<double>(ct.voxelCount());
  state.counters["streak_voxels"] = static_cast<double>(streakVoxels);
  state.counters["streak_slices"] = streakSlices;
}
BENCHMARK(BM_CompetingLegBonesWithStem)
    ->Arg(200)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
