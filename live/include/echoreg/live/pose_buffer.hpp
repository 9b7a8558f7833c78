// Tracker poses as they arrive, looked up at an A-line's timestamp as PLUS does
// (vtkPlusBuffer::GetInterpolatedStreamBufferItemFromTime): between the two poses nearest in time
// the translation is interpolated linearly and the rotation by SLERP; a pose INVALID on either
// side refuses the frame; a pose too far in time refuses it as stale. Each refusal says why.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <string>

namespace echoreg::live {

struct PoseSample {
  double timestampS = 0.0;
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  std::string status = "OK";  ///< PLUS's status word; only "OK" is valid
};

/// A pose at a time, or why there is none.
struct PoseLookup {
  std::optional<Eigen::Matrix4d> matrix;
  std::string refusal;  ///< "" when matrix is set
};

class PoseBuffer {
 public:
  /// `toleranceS` (> 0): the farthest a pose may be from the A-line's time when it is held (no
  /// pose on the other side yet), and the widest gap between two poses interpolated across.
  /// `capacity`: poses kept per transform (the oldest dropped).
  explicit PoseBuffer(double toleranceS, std::size_t capacity = 4096);

  /// Adds a pose; poses arriving out of time order are inserted in order.
  void add(const std::string& name, const PoseSample& pose);

  /// `name` at `timestampS`. Exact match: that pose. Between two: interpolated (both must be OK
  /// and at most `toleranceS` x 2 apart). After the newest (the tracker lags): the newest when
  /// within `toleranceS`, else refused as stale. Before the oldest: the oldest within `toleranceS`.
  PoseLookup at(const std::string& name, double timestampS) const;

  double toleranceS() const { return toleranceS_; }

 private:
  double toleranceS_;
  std::size_t capacity_;
  std::map<std::string, std::deque<PoseSample>> poses_;
};

/// Linear translation and SLERP rotation between `a` (fraction 0) and `b` (fraction 1).
Eigen::Matrix4d interpolatePose(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                                double fraction);

}  // namespace echoreg::live
