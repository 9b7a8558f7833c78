#include "echoreg/live/pose_buffer.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <stdexcept>

namespace echoreg::live {

PoseBuffer::PoseBuffer(double toleranceS, std::size_t capacity)
    : toleranceS_(toleranceS), capacity_(capacity) {
  if (!(toleranceS > 0.0))
    throw std::invalid_argument("the pose tolerance must be > 0 s");
  if (capacity < 2)
    throw std::invalid_argument("the pose buffer must hold at least 2 poses");
}

void PoseBuffer::add(const std::string& name, const PoseSample& pose) {
  std::deque<PoseSample>& list = poses_[name];
  const auto later =
      std::upper_bound(list.begin(), list.end(), pose.timestampS,
                       [](double t, const PoseSample& sample) { return t < sample.timestampS; });
  list.insert(later, pose);
  while (list.size() > capacity_)
    list.pop_front();
}

Eigen::Matrix4d interpolatePose(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                                double fraction) {
  const Eigen::Quaterniond qa(Eigen::Matrix3d(a.topLeftCorner<3, 3>()));
  const Eigen::Quaterniond qb(Eigen::Matrix3d(b.topLeftCorner<3, 3>()));
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = qa.slerp(fraction, qb).toRotationMatrix();
  m.topRightCorner<3, 1>() =
      (1.0 - fraction) * a.topRightCorner<3, 1>() + fraction * b.topRightCorner<3, 1>();
  return m;
}

PoseLookup PoseBuffer::at(const std::string& name, double timestampS) const {
  PoseLookup result;
  const auto found = poses_.find(name);
  if (found == poses_.end() || found->second.empty()) {
    result.refusal = fmt::format("no {} received yet", name);
    return result;
  }
  const std::deque<PoseSample>& list = found->second;
  const auto after =
      std::lower_bound(list.begin(), list.end(), timestampS,
                       [](const PoseSample& sample, double t) { return sample.timestampS < t; });
  const auto invalid = [&](const PoseSample& pose) {
    return fmt::format("{} is {} at {:.4f} s", name, pose.status, pose.timestampS);
  };
  if (after != list.end() && after->timestampS == timestampS) {
    if (after->status != "OK")
      result.refusal = invalid(*after);
    else
      result.matrix = after->matrix;
    return result;
  }
  if (after == list.end()) {
    const PoseSample& newest = list.back();
    const double age = timestampS - newest.timestampS;
    if (age > toleranceS_) {
      result.refusal = fmt::format(
          "stale pose: the newest {} is {:.3f} s older than the A-line (tolerance {:.3f} s)", name,
          age, toleranceS_);
    } else if (newest.status != "OK") {
      result.refusal = invalid(newest);
    } else {
      result.matrix = newest.matrix;
    }
    return result;
  }
  if (after == list.begin()) {
    const double ahead = after->timestampS - timestampS;
    if (ahead > toleranceS_) {
      result.refusal = fmt::format(
          "no {} within {:.3f} s before the A-line (the oldest kept is {:.3f} s after it)", name,
          toleranceS_, ahead);
    } else if (after->status != "OK") {
      result.refusal = invalid(*after);
    } else {
      result.matrix = after->matrix;
    }
    return result;
  }
  const PoseSample& before = *(after - 1);
  if (before.status != "OK") {
    result.refusal = invalid(before);
    return result;
  }
  if (after->status != "OK") {
    result.refusal = invalid(*after);
    return result;
  }
  const double gap = after->timestampS - before.timestampS;
  if (gap > 2.0 * toleranceS_) {
    result.refusal = fmt::format(
        "stale pose: the {} poses around the A-line are {:.3f} s apart (at most {:.3f} s "
        "interpolated across)",
        name, gap, 2.0 * toleranceS_);
    return result;
  }
  result.matrix =
      interpolatePose(before.matrix, after->matrix, (timestampS - before.timestampS) / gap);
  return result;
}

}  // namespace echoreg::live
