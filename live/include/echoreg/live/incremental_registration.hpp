// The surface registration refined while points arrive: a worker thread runs the core's
// SurfaceRegistration::registerPoints (the solver of `echoreg register`) on a copy of the points
// once `minPoints` have come, then again whenever new points have come, at most `maxRateHz` times
// a second: a run starts when new points are there and 1/maxRateHz has passed since the previous
// run's start (back to back when a fit takes longer than that). Every run starts from the session's
// start (an initial pose, or the landmarks, with the options as `register` builds them), not from
// the previous result: a first fit on a small patch of bone can slide to a wrong pose, and starting
// from it would keep the error (measured on the simulated femur sweep: a first fit on the sweep's
// first points ended 24 mm off at the knee and the refinements from it did not recover; every run
// from the landmarks, the last on all 100 points, matches register). The last run on all points is
// register's fit on the same points.
#pragma once

#include "echoreg/core/surface_registration.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace echoreg::live {

struct RegistrationUpdate {
  core::SurfaceRegistrationResult result;
  std::size_t points = 0;                         ///< points the run used
  int run = 0;                                    ///< 1 for the first run
  double seconds = 0.0;                           ///< the run's duration
  std::chrono::steady_clock::time_point started;  ///< when the run started
};

/// How often the worker ran: its runs (finish()'s last one not counted) and their rate, timed from
/// the first run's start to the last's: (runs - 1) / firstToLastS, 0 with fewer than 2 runs.
struct WorkerRate {
  int runs = 0;
  double firstToLastS = 0.0;
  double hz = 0.0;
  double longestFitS = 0.0;  ///< the longest run (the worker's or finish()'s), seconds
};

class IncrementalRegistration {
 public:
  /// `model` must outlive this object. Throws std::invalid_argument for minPoints < 3 or a rate
  /// <= 0.
  IncrementalRegistration(const core::SurfaceRegistration& model,
                          core::SurfaceRegistrationOptions options,
                          std::vector<core::LandmarkPair> landmarks, std::size_t minPoints,
                          double maxRateHz);
  /// Stops the worker (a run in progress finishes first).
  ~IncrementalRegistration();
  IncrementalRegistration(const IncrementalRegistration&) = delete;
  IncrementalRegistration& operator=(const IncrementalRegistration&) = delete;

  void addPoint(const core::SurfacePoint& point);
  /// Replaces every point so far (the detection judged the frames again: live::ShadowRuleSwitch);
  /// the next run uses these. A run in progress finishes on the points it started with.
  void replacePoints(std::vector<core::SurfacePoint> points);
  /// Stops the worker and, when points came after its last run (and enough are there), runs once
  /// more on all of them, here. Returns the newest result not yet taken, if any.
  std::optional<RegistrationUpdate> finish();
  /// The newest result not yet taken, if any.
  std::optional<RegistrationUpdate> take();
  /// Runs done so far.
  int runs() const { return runs_.load(); }
  /// The worker's runs so far and their rate (each run started, whether or not its fit threw).
  WorkerRate workerRate() const;
  /// The problem of the last run that threw ("" when none), e.g. too few points.
  std::string problem() const;

 private:
  void work();
  void stopWorker();
  // One run on `points`, revision `revision` of the points (the worker's, then finish()'s),
  // started at `started`: the time the worker's schedule counts the interval from, so that the
  // reported starts are exactly as far apart as the schedule keeps them (taking the time again
  // after the lock was released put them up to a preemption closer: 9.84 ms for 10 under load).
  void runOnce(const std::vector<core::SurfacePoint>& points, std::size_t revision,
               std::chrono::steady_clock::time_point started);

  const core::SurfaceRegistration& model_;
  core::SurfaceRegistrationOptions options_;
  std::vector<core::LandmarkPair> landmarks_;
  std::size_t minPoints_;
  std::chrono::duration<double> minInterval_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<core::SurfacePoint> points_;
  std::optional<RegistrationUpdate> latest_;
  std::string problem_;
  // Each addPoint or replacePoints makes a new revision of points_; a run is due when the
  // newest has not been run.
  std::size_t revision_ = 0;
  std::size_t usedRevision_ = 0;
  bool stop_ = false;
  int workerRuns_ = 0;
  double longestFitS_ = 0.0;
  std::chrono::steady_clock::time_point firstWorkerStart_, lastWorkerStart_;
  std::atomic<int> runs_{0};
  std::thread worker_;
};

}  // namespace echoreg::live
