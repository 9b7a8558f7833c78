// Speed of the landmark registration steps: paired-point registration of 4 and 8 pairs, dwell
// detection on a 100 Hz stylus track of 60 s (8 rests of 2 s, 0.3 mm jitter per axis, every 50th
// frame INVALID), and the in-order matching of 12 dwells to 8 landmarks (495 choices).
//
//   bench_landmarks [--benchmark_filter=Dwell]
//
// (Results pass through benchmark::DoNotOptimize(const&) only: with GCC 12 and Debian's
// benchmark 1.7.1 the read-write DoNotOptimize(double&) once returned a wrong FRE here.)

#include "echoreg/core/dwell.hpp"
#include "echoreg/core/paired_point.hpp"
#include "echoreg/core/random.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

namespace {

using echoreg::core::Rng;

std::vector<Eigen::Vector3d> landmarks(int n) {
  Rng rng = Rng::derive(2008, "bench-landmarks");
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i)
    out.emplace_back(rng.uniform(-80, 80), rng.uniform(-80, 80), rng.uniform(-400, 0));
  return out;
}

Eigen::Isometry3d pose() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() =
      Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.2, 0.5, -0.8).normalized()).toRotationMatrix();
  t.translation() = Eigen::Vector3d(310.0, -45.0, 1250.0);
  return t;
}

void BM_PairedPoint(benchmark::State& state) {
  const auto from = landmarks(static_cast<int>(state.range(0)));
  Rng rng(7);
  const Eigen::Isometry3d truth = pose();
  std::vector<Eigen::Vector3d> to;
  for (const auto& p : from) {
    const Eigen::Vector3d noise(rng.normal(), rng.normal(), rng.normal());  // 1 mm per axis
    to.push_back(truth * p + noise);
  }
  double fre = 0.0;
  for (auto _ : state) {
    const auto r = echoreg::core::registerPairedPoints(from, to);
    benchmark::DoNotOptimize(r.transform);
    fre = r.freMm;
  }
  state.counters["fre_mm"] = fre;
}
BENCHMARK(BM_PairedPoint)->Arg(4)->Arg(8);

void BM_DetectDwells(benchmark::State& state) {
  const auto spots = landmarks(8);
  Rng rng(11);
  std::vector<Eigen::Vector3d> p;
  std::vector<double> t;
  std::vector<bool> v;
  Eigen::Vector3d here(0, 0, 200);
  for (const auto& spot : spots) {
    for (int i = 0; i < 550; ++i) {  // 5.5 s of travel, then 2 s at rest
      const double s = static_cast<double>(i) / 550.0;
      const Eigen::Vector3d noise(rng.normal(), rng.normal(), rng.normal());
      p.push_back(here + (spot - here) * s + 0.3 * noise);
    }
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d noise(rng.normal(), rng.normal(), rng.normal());
      p.push_back(spot + 0.3 * noise);
    }
    here = spot;
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    t.push_back(0.01 * static_cast<double>(i));
    v.push_back(i % 50 != 49);
  }
  std::size_t found = 0;
  for (auto _ : state) {
    const auto dwells = echoreg::core::detectDwells(p, t, v, echoreg::core::DwellOptions{});
    benchmark::DoNotOptimize(dwells.data());
    found = dwells.size();
  }
  state.counters["frames"] = static_cast<double>(p.size());
  state.counters["dwells"] = static_cast<double>(found);
}
BENCHMARK(BM_DetectDwells)->Unit(benchmark::kMillisecond);

void BM_MatchDwells(benchmark::State& state) {
  const auto lm = landmarks(8);
  std::vector<echoreg::core::Dwell> dwells;
  const Eigen::Isometry3d truth = pose();
  Rng rng(5);
  for (std::size_t i = 0; i < lm.size(); ++i) {
    if (i % 2 == 0) {  // a rest away from the landmarks before every other one
      echoreg::core::Dwell away;
      away.meanMm =
          Eigen::Vector3d(rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(500, 900));
      dwells.push_back(away);
    }
    echoreg::core::Dwell d;
    d.meanMm = truth * lm[i];
    dwells.push_back(d);
  }
  long long candidates = 0;
  for (auto _ : state) {
    const auto m = echoreg::core::matchDwellsInOrder(dwells, lm);
    benchmark::DoNotOptimize(m.dwellIndex.data());
    candidates = m.candidates;
  }
  state.counters["choices"] = static_cast<double>(candidates);
}
BENCHMARK(BM_MatchDwells)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
