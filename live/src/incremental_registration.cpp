#include "echoreg/live/incremental_registration.hpp"

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
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (points_.size() >= minPoints_ && points_.size() != usedPoints_)
      points = points_;
  }
  if (!points.empty())
    runOnce(points);
  return take();
}

void IncrementalRegistration::addPoint(const core::SurfacePoint& point) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    points_.push_back(point);
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

void IncrementalRegistration::runOnce(const std::vector<core::SurfacePoint>& points) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  RegistrationUpdate update;
  std::string problem;
  try {
    update.result = model_.registerPoints(points, landmarks_, options_);
    update.points = points.size();
    update.run = runs_.load() + 1;
    update.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  } catch (const std::exception& e) {
    problem = e.what();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  usedPoints_ = points.size();
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
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait_for(lock, std::chrono::milliseconds(20), [&] { return stop_; });
    if (stop_)
      return;
    if (points_.size() < minPoints_ || points_.size() == usedPoints_ ||
        Clock::now() - lastStart < minInterval_) {
      continue;
    }
    const std::vector<core::SurfacePoint> points = points_;
    lock.unlock();
    lastStart = Clock::now();
    runOnce(points);
    lock.lock();
  }
}

}  // namespace echoreg::live
