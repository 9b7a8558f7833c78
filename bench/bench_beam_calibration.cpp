// Speed of the beam calibration (echoreg::core::calibrateBeam) on simulated shots at a sphere
// (tests/support/beam_shots.hpp) with realistic noise: tracking ~0.25 mm RMS at the beam point,
// 0.1 mm of depth noise, the beam up to half the radius off the sphere's centre, depths
// 15-70 mm, water at 1480 m/s. One timed iteration is one whole calibration (every robust round,
// the condition number and the standard deviations). Target: 500 shots in translation mode
// within 20 ms.
//
//   bench_beam_calibration [--benchmark_filter=Translation]
//
// Counters: offset_err_mm (|t - t_true|), rms_mm, rounds, iterations, condition.

#include "beam_shots.hpp"

#include "echoreg/core/beam_calibration.hpp"

#include <benchmark/benchmark.h>

#include <cstddef>
#include <vector>

namespace {

using echoreg::core::BeamCalibrationMode;
using echoreg::core::BeamCalibrationOptions;
using echoreg::core::BeamCalibrationResult;

echoreg::test::BeamShotsSpec spec(std::size_t shots, bool speed) {
  echoreg::test::BeamShotsSpec s;
  s.shots = shots;
  s.beamToProbe.translation() = Eigen::Vector3d(28.10, 1.72, 201.47);
  s.trackingRotationSigmaDeg = 0.04;
  s.trackingTranslationSigmaMm = 0.05;
  s.depthSigmaMm = 0.1;
  s.minDepthMm = 15.0;
  s.maxDepthMm = 70.0;
  // Without the speed fitted, the assumed speed is the true one.
  s.trueSpeedOfSoundMps = speed ? 1480.0 : 1450.0;
  s.seed = 2008;
  return s;
}

void run(benchmark::State& state, BeamCalibrationMode mode, bool speed) {
  const auto shotCount = static_cast<std::size_t>(state.range(0));
  const echoreg::test::BeamShotsSpec s = spec(shotCount, speed);
  const auto shots = echoreg::test::makeBeamShots(s);
  Eigen::Isometry3d guess = s.beamToProbe;
  guess.translation() += Eigen::Vector3d(-2.0, 1.5, -3.0);
  BeamCalibrationOptions options = echoreg::test::beamOptionsFor(s, guess);
  options.mode = mode;
  options.fitSpeedOfSound = speed;
  BeamCalibrationResult result;
  for (auto _ : state) {
    result = echoreg::core::calibrateBeam(shots, options);
    benchmark::DoNotOptimize(result.parameters.data());
  }
  state.counters["offset_err_mm"] =
      (result.beamToProbe.translation() - s.beamToProbe.translation()).norm();
  state.counters["rms_mm"] = result.rmsMm;
  state.counters["rounds"] = result.rounds;
  state.counters["iterations"] = result.iterations;
  state.counters["condition"] = result.conditionNumber;
  if (speed)
    state.counters["speed_err_mps"] = result.speedOfSoundMps - s.trueSpeedOfSoundMps;
}

void BM_Translation(benchmark::State& state) {
  run(state, BeamCalibrationMode::Translation, false);
}
void BM_TranslationSpeed(benchmark::State& state) {
  run(state, BeamCalibrationMode::Translation, true);
}
void BM_BeamSpeed(benchmark::State& state) {
  run(state, BeamCalibrationMode::Beam, true);
}

}  // namespace

BENCHMARK(BM_Translation)->Arg(100)->Arg(500)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TranslationSpeed)->Arg(500)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BeamSpeed)->Arg(100)->Arg(500)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
