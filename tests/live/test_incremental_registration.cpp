// The live registration's scheduling: a run starts as soon as new points are there and the
// interval 1/maxRateHz since the previous run's start has passed, not at the next tick of a poll
// (the worker used to wake every 20 ms, so no two runs could start less than 20 ms apart and an
// interval of 10 ms became 20 ms or more); a fit slower than the interval is followed at once by
// the next; the rate is never above maxRateHz.
#include "echoreg/live/incremental_registration.hpp"

#include "mesh_test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <iomanip>
#include <thread>
#include <vector>

namespace echoreg::live {
namespace {

using Clock = std::chrono::steady_clock;

core::TriangleMesh ellipsoidMesh() {
  core::TriangleMesh mesh = test::icosphere(1.0, 3);
  for (Eigen::Vector3d& v : mesh.vertices)
    v = Eigen::Vector3d(30.0 * v.x(), 20.0 * v.y(), 45.0 * v.z());
  return mesh;
}

// An ellipsoid (1280 triangles, 642 vertices); the bone frame is the model's.
const core::SurfaceRegistration& ellipsoid() {
  static const core::SurfaceRegistration model(ellipsoidMesh());
  return model;
}

// Point i: a vertex of the model (exactly on its surface), stepping over the whole of it.
core::SurfacePoint surfacePoint(int i) {
  static const core::TriangleMesh mesh = ellipsoidMesh();
  core::SurfacePoint p;
  p.point = mesh.vertices[static_cast<std::size_t>(i * 101) % mesh.vertices.size()];
  return p;
}

struct TakenRun {
  int run = 0;
  Clock::time_point started;
  double seconds = 0.0;
};

// Feeds a point every millisecond (so new points are always waiting) and collects every update
// taken, polling every 0.5 ms: for `seconds`, and on until `consecutive` pairs of updates of
// consecutive runs have been taken (a loaded machine or a sanitizer build fits fewer in the
// time), at most 60 s in all.
std::vector<TakenRun> feed(IncrementalRegistration& registration, double seconds,
                           std::size_t consecutive) {
  const Clock::time_point start = Clock::now();
  const auto after = [&](double s) {
    return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  std::atomic<bool> stop{false};
  std::atomic<bool> done{false};
  std::thread feeder([&] {
    for (int i = 0; !stop && Clock::now() < after(60.0); ++i) {
      registration.addPoint(surfacePoint(i));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    done = true;
  });
  std::vector<TakenRun> runs;
  std::size_t pairs = 0;
  while (!done) {
    if (std::optional<RegistrationUpdate> u = registration.take()) {
      if (!runs.empty() && u->run == runs.back().run + 1)
        ++pairs;
      runs.push_back({u->run, u->started, u->seconds});
    }
    if (pairs >= consecutive && Clock::now() >= after(seconds))
      stop = true;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  feeder.join();
  return runs;
}

double ms(Clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

TEST(IncrementalRegistration, RunsWhenTheIntervalIsDueNotAtAPollsTick) {
  core::SurfaceRegistrationOptions options;
  IncrementalRegistration registration(ellipsoid(), options, {}, 30, 100.0);  // every 10 ms
  const std::vector<TakenRun> runs = feed(registration, 1.5, 20);
  std::vector<double> intervals, fits;
  for (std::size_t i = 1; i < runs.size(); ++i) {
    if (runs[i].run != runs[i - 1].run + 1)
      continue;  // a run taken by neither poll
    intervals.push_back(ms(runs[i].started - runs[i - 1].started));
    fits.push_back(runs[i - 1].seconds * 1e3);
  }
  ASSERT_GE(intervals.size(), 20u) << runs.size() << " updates taken";
  // Never faster than the cap (the steady clock, start to start), however long the fits take.
  EXPECT_GE(*std::min_element(intervals.begin(), intervals.end()), 9.9);
  const WorkerRate rate = registration.workerRate();
  EXPECT_GE(rate.runs, static_cast<int>(runs.size()));
  EXPECT_LE(rate.hz, 100.0 + 1e-9);
  // The fits here take about 3 ms, so runs start at the interval: 10 ms (measured: median 10.15
  // ms at load average 16 on 2 cores; the worker that polled every 20 ms: 23.8 ms, 37 Hz). Where
  // the fits themselves take most of the interval (13.3 ms under ASan), runs follow each other at
  // the fits' pace and the timing says nothing about the scheduling: skipped, with the speed.
  const double fitMs = median(fits);
  if (!(fitMs < 8.0)) {
    GTEST_SKIP() << std::fixed << std::setprecision(1) << "the fits take " << fitMs
                 << " ms here (median of " << fits.size()
                 << "), not under the 8 ms this test's 10 ms interval needs (about 3 ms in a "
                 << "release build): whether runs start at the interval cannot be seen; the cap "
                 << "was checked (shortest interval "
                 << *std::min_element(intervals.begin(), intervals.end()) << " ms, " << rate.hz
                 << " Hz)";
  }
  EXPECT_LT(median(intervals), 15.0);
  EXPECT_GT(rate.hz, 50.0);
}

TEST(IncrementalRegistration, AFitSlowerThanTheIntervalIsFollowedAtOnce) {
  core::SurfaceRegistrationOptions options;
  // An interval of 0.1 ms: every fit is longer, so the next starts as soon as it ends.
  IncrementalRegistration registration(ellipsoid(), options, {}, 30, 10000.0);
  const std::vector<TakenRun> runs = feed(registration, 1.0, 20);
  std::vector<double> gaps;  // from a run's end to the next run's start
  for (std::size_t i = 1; i < runs.size(); ++i) {
    if (runs[i].run == runs[i - 1].run + 1)
      gaps.push_back(ms(runs[i].started - runs[i - 1].started) - runs[i - 1].seconds * 1e3);
  }
  ASSERT_GE(gaps.size(), 20u) << runs.size() << " updates taken";
  // Measured: median 0.64 ms at load average 16 on 2 cores; the worker that polled every 20 ms:
  // 20.1 ms.
  EXPECT_LT(median(gaps), 2.0);
}

TEST(IncrementalRegistration, WaitsForMinPointsAndRefusesBadSettings) {
  core::SurfaceRegistrationOptions options;
  IncrementalRegistration registration(ellipsoid(), options, {}, 30, 1000.0);
  for (int i = 0; i < 29; ++i)
    registration.addPoint(surfacePoint(i));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(registration.workerRate().runs, 0);
  EXPECT_FALSE(registration.take());
  registration.addPoint(surfacePoint(29));
  const std::optional<RegistrationUpdate> last = registration.finish();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->points, 30u);
  EXPECT_LT(last->result.rmsMm, 1e-3);
  EXPECT_THROW(IncrementalRegistration(ellipsoid(), options, {}, 2, 10.0), std::invalid_argument);
  EXPECT_THROW(IncrementalRegistration(ellipsoid(), options, {}, 30, 0.0), std::invalid_argument);
}

// The detection may judge the frames so far again (a new shadow rule) and replace every point:
// the next run is on the new points, even when they are as many as the old ones (the worker used
// to tell new points by their count).
TEST(IncrementalRegistration, ReplacedPointsAreRunEvenWhenAsMany) {
  core::SurfaceRegistrationOptions options;
  IncrementalRegistration registration(ellipsoid(), options, {}, 30, 1000.0);
  for (int i = 0; i < 40; ++i)
    registration.addPoint(surfacePoint(i));
  std::optional<RegistrationUpdate> onSurface;
  for (int wait = 0; wait < 2000 && !(onSurface && onSurface->points == 40u); ++wait) {
    if (std::optional<RegistrationUpdate> u = registration.take())
      onSurface = std::move(u);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(onSurface && onSurface->points == 40u);
  EXPECT_LT(onSurface->result.rmsMm, 1e-3);
  // 40 other points, 2 mm outside the model along its x axis: the fit must move.
  std::vector<core::SurfacePoint> replaced;
  for (int i = 0; i < 40; ++i) {
    core::SurfacePoint p = surfacePoint(i + 40);
    p.point.x() += 2.0;
    replaced.push_back(p);
  }
  registration.replacePoints(replaced);
  const std::optional<RegistrationUpdate> last = registration.finish();
  ASSERT_TRUE(last) << "no run on the replaced points";
  EXPECT_EQ(last->points, 40u);
  EXPECT_NEAR(last->result.transform.translation().x(), -2.0, 0.1);
}

}  // namespace
}  // namespace echoreg::live
