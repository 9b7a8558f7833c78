// Speed of the segmentation steps on the simulated knee of the segmentation tests (144 x 144 x 65
// voxels of 0.8 x 0.8 x 1 mm, knee group only) and, when ../shared/data is there, on the real
// abdominal CT (512 x 512 x 134 voxels of 1.07 x 1.07 x 3 mm): threshold + growth + separation +
// marrow filling from a seed, the CT iso-surface around the grown femur, 40 live-wire contours
// from a simulated user's anchors, their shape-based interpolation into a mask, and the metrics.
//
//   bench_segmentation [--benchmark_filter=Grow]

#include "echoreg/core/mesh_locator.hpp"
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

}  // namespace

BENCHMARK_MAIN();
