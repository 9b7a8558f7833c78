// Speed of the calibration fits, with their recovery errors against the generators' truth as
// counters: the sphere fit on 500 points of a hemisphere (radius 25.4 mm, 0.2 mm Gaussian noise
// per coordinate), free or known radius, clean or with 10 % stray points (5-20 mm off the
// surface); pivot calibration on 1000 stylus poses (30 deg cone, +-60 deg spin, 0.2 mm noise per
// coordinate on the translations), clean or with 10 % stray poses (5-20 mm off). Every timed
// iteration is one whole fit (all robust rounds).
//
//   bench_fits [--benchmark_filter=Pivot]

#include "echoreg/core/fits.hpp"
#include "echoreg/core/random.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

namespace {

using echoreg::core::Rng;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kNoiseMm = 0.2;
const Eigen::Vector3d kCentre(112.5, -43.25, 1287.0);
constexpr double kRadiusMm = 25.4;
const Eigen::Vector3d kTipInMarker(3.1, -1.7, -152.4);
const Eigen::Vector3d kDivotInTracker(212.5, -48.0, 1634.0);

Eigen::Vector3d gaussian(Rng& rng) {
  return {rng.normal(), rng.normal(), rng.normal()};
}

std::vector<Eigen::Vector3d> hemisphere(int count, double strayShare) {
  Rng rng = Rng::derive(2008, "bench-fits-sphere");
  const Eigen::Quaterniond toAxis = Eigen::Quaterniond::FromTwoVectors(
      Eigen::Vector3d::UnitZ(), Eigen::Vector3d(-0.3, -0.9, 0.2).normalized());
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double cosTheta = rng.uniform(0.0, 1.0);
    const double sinTheta = std::sqrt(1.0 - cosTheta * cosTheta);
    const double phi = rng.uniform(0.0, 2.0 * kPi);
    const Eigen::Vector3d u =
        toAxis * Eigen::Vector3d(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
    Eigen::Vector3d p = kCentre + kRadiusMm * u + kNoiseMm * gaussian(rng);
    if (rng.chance(strayShare))
      p += (rng.chance(0.5) ? 1.0 : -1.0) * rng.uniform(5.0, 20.0) * u;
    points.push_back(p);
  }
  return points;
}

std::vector<Eigen::Isometry3d> pivotPoses(int count, double strayShare) {
  Rng rng = Rng::derive(2008, "bench-fits-pivot");
  const Eigen::Matrix3d base =
      Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.2, -0.7, 0.4).normalized()).toRotationMatrix();
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < count; ++i) {
    const double azimuth = rng.uniform(0.0, 2.0 * kPi);
    const double tilt = 30.0 * kDeg * std::sqrt(rng.uniform());
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() =
        base * Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0)) *
        Eigen::AngleAxisd(rng.uniform(-60.0, 60.0) * kDeg, Eigen::Vector3d::UnitZ());
    pose.translation() = kDivotInTracker - pose.linear() * kTipInMarker + kNoiseMm * gaussian(rng);
    if (rng.chance(strayShare))
      pose.translation() += rng.uniform(5.0, 20.0) * gaussian(rng).normalized();
    poses.push_back(pose);
  }
  return poses;
}

// Args: {known radius (0/1), stray share in %}.
void BM_FitSphere500(benchmark::State& state) {
  const std::vector<Eigen::Vector3d> points =
      hemisphere(500, static_cast<double>(state.range(1)) / 100.0);
  echoreg::core::SphereFitOptions options;
  if (state.range(0) != 0)
    options.radiusMm = kRadiusMm;
  echoreg::core::SphereFit fit;
  for (auto _ : state) {
    fit = echoreg::core::fitSphere(points, options);
    benchmark::DoNotOptimize(fit.centre.data());
  }
  state.counters["centre_err_mm"] = (fit.centre - kCentre).norm();
  state.counters["radius_err_mm"] = std::abs(fit.radiusMm - kRadiusMm);
  state.counters["rms_mm"] = fit.rmsMm;
  state.counters["inliers"] = fit.inliers;
  state.counters["condition"] = fit.conditionNumber;
}
BENCHMARK(BM_FitSphere500)
    ->ArgNames({"known_radius", "stray_pct"})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({0, 10})
    ->Args({1, 10})
    ->Unit(benchmark::kMicrosecond);

// Args: {stray share in %}.
void BM_Pivot1000(benchmark::State& state) {
  const std::vector<Eigen::Isometry3d> poses =
      pivotPoses(1000, static_cast<double>(state.range(0)) / 100.0);
  echoreg::core::PivotResult result;
  for (auto _ : state) {
    result = echoreg::core::pivotCalibration(poses);
    benchmark::DoNotOptimize(result.pointInMarker.data());
  }
  state.counters["tip_err_mm"] = (result.pointInMarker - kTipInMarker).norm();
  state.counters["pivot_err_mm"] = (result.pointInTracker - kDivotInTracker).norm();
  state.counters["rms_mm"] = result.rmsMm;
  state.counters["inliers"] = result.inliers;
  state.counters["spread2_deg"] = result.rotationSpreadDeg[1];
}
BENCHMARK(BM_Pivot1000)->ArgNames({"stray_pct"})->Arg(0)->Arg(10)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
