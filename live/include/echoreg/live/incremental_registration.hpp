// The surface registration refined while points arrive: a worker thread runs the core's
// SurfaceRegistration::registerPoints (the solver of `echoreg register`) on a copy of the points
// once `minPoints` have come, from the session's start (an initial pose, or landmarks: the
// options as `register` builds them), then again whenever new points have come, at most
// `maxRateHz` times a second, each run started from the last converged pose (no restarts, no
// search about a landmark axis: those were done by the first run).
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
  std::size_t points = 0;  ///< points the run used
  int run = 0;             ///< 1 for the first run
  double seconds = 0.0;    ///< the run's duration
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
  /// The newest result not yet taken, if any.
  std::optional<RegistrationUpdate> take();
  /// Runs done so far.
  int runs() const { return runs_.load(); }
  /// The problem of the last run that threw ("" when none), e.g. too few points.
  std::string problem() const;

 private:
  void work();

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
  bool stop_ = false;
  std::atomic<int> runs_{0};
  std::thread worker_;
};

}  // namespace echoreg::live
