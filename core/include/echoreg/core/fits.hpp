// Geometric fits of calibration: the centre of a sphere from points on it (stylus tips on the
// calibration sphere), and pivot calibration, the fixed point of a set of marker poses (a stylus
// tip pivoting in a divot, or the hip centre while the femur is rotated). Both robust to stray
// points, both refuse data that cannot determine them, saying what is missing.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

namespace echoreg::core {

struct SphereFitOptions {
  /// Known radius (mm); nullopt fits the radius too.
  std::optional<double> radiusMm;
  /// Points whose |residual| exceeds max(outlierSigmas * robust sigma, minOutlierMm) are dropped
  /// and the fit repeated (robust sigma = 1.4826 * median absolute residual). With maxRounds > 1
  /// and 8 or more points, the first round fits the points that agree with the least-median
  /// sphere of 128 four-point samples (deterministic), so that stray points cannot drag the
  /// start; maxRounds = 1 fits all points.
  double outlierSigmas = 3.0;
  double minOutlierMm = 0.5;
  int maxRounds = 5;
  /// Refuse a fit whose Jacobian condition number (see SphereFit) exceeds this: the points cover
  /// too small a part of the sphere. With a free radius, points spread evenly over the whole
  /// sphere give about 1.7, a hemisphere 4.5, a cap of 45 deg (half-angle) 20, 30 deg 48, 20 deg
  /// 110, 10 deg 460; with a known radius a 10 deg cap still gives 12. A cap of 20 deg with 100
  /// points and 0.2 mm noise leaves the centre uncertain by about 1 mm along the cap's axis.
  double maxConditionNumber = 100.0;
};

struct SphereFit {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radiusMm = 0.0;
  double rmsMm = 0.0;               ///< over the inliers
  std::vector<double> residualsMm;  ///< per input point: |p - c| - r (signed)
  std::vector<bool> inlier;         ///< per input point
  int inliers = 0;
  /// Largest over smallest singular value of the fit's Jacobian at the solution.
  double conditionNumber = 0.0;
};

/// Least-squares sphere (algebraic start, then geometric refinement with Ceres). Throws
/// std::invalid_argument when there are too few points (4 free, 3 known radius), a point is not
/// finite, a radius <= 0, a bad option, or the points are too poorly spread, saying which:
/// points in one plane (with a known radius the centre could lie on either side of that plane,
/// so three points never suffice in practice) or a cap too small for the condition number.
/// Residuals and inliers are reported for every input point; rms and the condition number over
/// the inliers, at the solution.
SphereFit fitSphere(const std::vector<Eigen::Vector3d>& points,
                    const SphereFitOptions& options = {});

struct PivotOptions {
  /// Poses whose residual exceeds max(outlierSigmas * robust sigma, minOutlierMm) are dropped.
  double outlierSigmas = 3.0;
  double minOutlierMm = 0.5;
  int maxRounds = 5;
  /// Refuse unless the marker's rotations span at least this much about two independent axes.
  double minRotationSpreadDeg = 15.0;
};

struct PivotResult {
  Eigen::Vector3d pointInMarker = Eigen::Vector3d::Zero();   ///< e.g. the tip in Stylus
  Eigen::Vector3d pointInTracker = Eigen::Vector3d::Zero();  ///< the fixed point in Tracker
  double rmsMm = 0.0;               ///< |R p_marker + t - p_fixed| over the inliers
  std::vector<double> residualsMm;  ///< per pose
  std::vector<bool> inlier;
  int inliers = 0;
  /// Spread of the rotations (degrees) about their principal axes, largest first.
  Eigen::Vector3d rotationSpreadDeg = Eigen::Vector3d::Zero();
};

/// Solves [R_i | -I] [p_marker; p_fixed] = -t_i in least squares over all poses, with outlier
/// rejection. The rotation spread: every rotation relative to the (chordal) mean rotation as a
/// rotation vector; along each principal axis of those vectors, 2 x their RMS (degrees). Throws
/// std::invalid_argument for fewer than 4 poses, a pose that is not finite or not a rotation, a
/// bad option, or rotations whose second largest spread is below minRotationSpreadDeg (checked
/// on all poses and again on the inliers; the message gives the spread found and needed).
/// Also the hip centre: femur-marker poses while the leg is rotated give the hip centre in the
/// femur marker (pointInMarker) and in Tracker (pointInTracker).
PivotResult pivotCalibration(const std::vector<Eigen::Isometry3d>& markerToTracker,
                             const PivotOptions& options = {});

}  // namespace echoreg::core
