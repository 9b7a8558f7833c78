#include "echoreg/live/incremental_registration.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace echoreg::live {

IncrementalRegistration::IncrementalRegistration(const core::SurfaceRegistration& model,
                                                 core::SurfaceRegistrationOptions options,
                                                 std::vector<core::LandmarkPair> landmarks,
                                                 std::size_t minPoints, double maxRateHz)
    : model_(model),
      options_(std::move(options)),
      landmarks_(std::move(landmarks)),
      minPoints_(minPoints),
      minInterval_(maxRateHz > 0.0 ? 1.0 / maxRateHz : 0.0) {
  if (minPoints < 3)
    throw std::invalid_argument("a registration needs at least 3 points to start");
  if (!(maxRateHz > 0.0))
    throw std::invalid_argument("the registration rate must be > 0 Hz");
  worker_ = std::thread([this] { work(); });
}

IncrementalRegistration::~IncrementalRegistration() {
  stopWorker();
}

void IncrementalRegistration::stopWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable())
    worker_.join();
}

std::optional<RegistrationUpdate> IncrementalRegistration::finish() {
  stopWorker();
  std::vector<core::SurfacePoint> points;
  std::size_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (points_.size() >= minPoints_ && revision_ != usedRevision_) {
      points = points_;
      revision = revision_;
    }
  }
  if (!points.empty())
    runOnce(points, revision, std::chrono::steady_clock::now());
  return take();
}

void IncrementalRegistration::addPoint(const core::SurfacePoint& point) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    points_.push_back(point);
    ++revision_;
  }
  wake_.notify_all();
}

void IncrementalRegistration::replacePoints(std::vector<core::SurfacePoint> points) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    points_ = std::move(points);
    ++revision_;
  }
  wake_.notify_all();
}

std::optional<RegistrationUpdate> IncrementalRegistration::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<RegistrationUpdate> update = std::move(latest_);
  latest_.reset();
  return update;
}

std::string IncrementalRegistration::problem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return problem_;
}

void IncrementalRegistration::runOnce(const std::vector<core::SurfacePoint>& points,
                                      std::size_t revision,
                                      std::chrono::steady_clock::time_point started) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  RegistrationUpdate update;
  update.started = started;
  std::string problem;
  try {
    update.result = model_.registerPoints(points, landmarks_, options_);
    update.points = points.size();
    update.run = runs_.load() + 1;
    update.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  } catch (const std::exception& e) {
    problem = e.what();
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::lock_guard<std::mutex> lock(mutex_);
  usedRevision_ = revision;
  longestFitS_ = std::max(longestFitS_, seconds);
  if (!problem.empty()) {
    problem_ = problem;
    return;
  }
  ++runs_;
  latest_ = std::move(update);
}

void IncrementalRegistration::work() {
  using Clock = std::chrono::steady_clock;
  Clock::time_point lastStart = Clock::now() - std::chrono::hours(1);
  const auto interval = std::chrono::duration_cast<Clock::duration>(minInterval_);
  const auto fresh = [&] { return points_.size() >= minPoints_ && revision_ != usedRevision_; };
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    // Sleep until there are new points (addPoint wakes us), then until the rate allows the next
    // run: exactly then, not at the next tick of a poll (polling every 20 ms stretched an interval
    // of 25 ms to 40 ms). A fit that takes longer than the interval is followed at once by the
    // next one (back to back) while points keep coming.
    wake_.wait(lock, [&] { return stop_ || fresh(); });
    if (stop_)
      return;
    const Clock::time_point due = lastStart + interval;
    if (Clock::now() < due) {
      wake_.wait_until(lock, due, [&] { return stop_; });
      if (stop_)
        return;
    }
    const std::vector<core::SurfacePoint> points = points_;
    const std::size_t revision = revision_;
    lastStart = Clock::now();
    if (workerRuns_ == 0)
      firstWorkerStart_ = lastStart;
    lastWorkerStart_ = lastStart;
    ++workerRuns_;
    lock.unlock();
    runOnce(points, revision, lastStart);
    lock.lock();
  }
}

WorkerRate IncrementalRegistration::workerRate() const {
  std::lock_guard<std::mutex> lock(mutex_);
  WorkerRate rate;
  rate.runs = workerRuns_;
  rate.firstToLastS = std::chrono::duration<double>(lastWorkerStart_ - firstWorkerStart_).count();
  rate.longestFitS = longestFitS_;
  if (workerRuns_ >= 2 && rate.firstToLastS > 0.0)
    rate.hz = static_cast<double>(workerRuns_ - 1) / rate.firstToLastS;
  return rate;
}

}  // namespace echoreg::live
