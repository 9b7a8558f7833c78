// The simulator's inner loops: what one CT voxel (tissueAt), one beam (traceBeam) and one A-line
// (simulateALine) cost, on the default cadaver specimen. A small study makes ~6 M tissueAt calls
// per CT and ~2000 beams; docs/simulation.md gives whole-study times.
#include "echoreg/core/random.hpp"
#include "echoreg/simulation/anatomy.hpp"
#include "echoreg/simulation/pulse_echo.hpp"
#include "echoreg/simulation/specimen.hpp"

#include <benchmark/benchmark.h>

#include <memory>

namespace {

using namespace echoreg;
using namespace echoreg::simulation;

const Specimen& specimen() {
  static const std::unique_ptr<Specimen> instance = [] {
    KneeOptions options;
    options.meshResolutionMm = 1.2;
    options.seed = 7;
    return std::make_unique<Specimen>(buildKnee(options), SpecimenKind::Cadaver,
                                      SoftTissueOptions{});
  }();
  return *instance;
}

// Points spread over the knee's CT box (most far from bone, some in the band near it).
void BM_TissueAt(benchmark::State& state) {
  const Specimen& s = specimen();
  core::Rng rng(1);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 4096; ++i) {
    points.push_back(s.knee().kneeCentre + Eigen::Vector3d(rng.uniform(-100, 100),
                                                           rng.uniform(-100, 100),
                                                           rng.uniform(-40, 40)));
  }
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.tissueAt(points[i++ & 4095]));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TissueAt);

// Beams from the skin of the anteromedial tibia, as a sweep shoots them.
void BM_TraceBeam(benchmark::State& state) {
  const Specimen& s = specimen();
  core::Rng rng(2);
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> beams;
  while (beams.size() < 256) {
    const auto surface =
        s.surfacePoint(Segment::Shank, rng.uniform(45, 130), rng.uniform(-1.3, -0.35));
    if (!surface)
      continue;
    beams.push_back({surface->point + 10.0 * surface->normal, -surface->normal});
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& [origin, direction] = beams[i++ & 255];
    benchmark::DoNotOptimize(s.traceBeam(origin, direction, Tissue::Water, 70.0));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TraceBeam)->Unit(benchmark::kMicrosecond);

void BM_SimulateALine(benchmark::State& state) {
  BeamPath path;
  path.layers = {{Tissue::Water, 10.0, 0.0},
                 {Tissue::Skin, 2.0, 0.0},
                 {Tissue::Fat, 4.0, 0.0},
                 {Tissue::Muscle, 6.0, 5.0},
                 {Tissue::CorticalBone, 1e6, 0.0}};
  core::Rng rng(3);
  for (auto _ : state) {
    benchmark::DoNotOptimize(simulateALine(path, Transducer{}, Receiver{}, rng));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SimulateALine)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
