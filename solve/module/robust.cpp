// The robust surface registration's solve of one start (core/src/surface_registration_robust.cpp):
// point-to-plane with the speed of sound, a robust loss or trim, and the landmarks, with Ceres.
#include "module.hpp"

#include "solver_options.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace echoreg::solve {

using core::LandmarkPair;
using core::MeshLocator;
using core::RobustLoss;
using core::SurfacePoint;
using core::SurfaceRegistrationOptions;
using core::detail::correspond;
using core::detail::Correspondence;
using core::detail::dropExcluded;
using core::detail::selectInliers;
using core::detail::Solution;
using core::detail::whitenedAbs;

namespace {

// Point-to-plane residual of one point for the pose increment (angle-axis w about the centroid,
// translation v) and the speed-of-sound scale s: y = R(w) (a + s b) + v + centroid, where a + s b
// is the point under the current pose minus the centroid.
struct PlaneResidual {
  Eigen::Vector3d a, b, normal, centroidMinusFoot;
  double offset = 0.0;
  double invSigma = 1.0;

  template <typename T>
  bool operator()(const T* pose, const T* scale, T* residual) const {
    const T p[3] = {T(a.x()) + scale[0] * T(b.x()), T(a.y()) + scale[0] * T(b.y()),
                    T(a.z()) + scale[0] * T(b.z())};
    T r[3];
    ceres::AngleAxisRotatePoint(pose, p, r);
    T along = T(0.0);
    for (int k = 0; k < 3; ++k)
      along += T(normal[k]) * (r[k] + pose[3 + k] + T(centroidMinusFoot[k]));
    residual[0] = (along - T(offset)) * T(invSigma);
    return true;
  }
};

struct LandmarkResidual {
  Eigen::Vector3d a;  // bone landmark under the current pose minus the centroid
  Eigen::Vector3d centroidMinusModel;
  double invSigma = 1.0;

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const T p[3] = {T(a.x()), T(a.y()), T(a.z())};
    T r[3];
    ceres::AngleAxisRotatePoint(pose, p, r);
    for (int k = 0; k < 3; ++k)
      residual[k] = (r[k] + pose[3 + k] + T(centroidMinusModel[k])) * T(invSigma);
    return true;
  }
};

double defaultLossScale(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::Huber:
      return 1.345;
    case RobustLoss::Cauchy:
      return 2.385;
    case RobustLoss::Tukey:
      return 4.685;
    case RobustLoss::Trim:
      return 0.0;
  }
  return 0.0;
}

ceres::LossFunction* makeLoss(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::Huber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::Cauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::Tukey:
      return new ceres::TukeyLoss(scale);
    case RobustLoss::Trim:
      return nullptr;
  }
  return nullptr;
}

// The pose increment of one solve (angle-axis pose[0..2] about `centroid`, translation
// pose[3..5]) taken `k` times.
Eigen::Isometry3d increment(const double* pose, const Eigen::Vector3d& centroid, double k) {
  const Eigen::Vector3d w = k * Eigen::Vector3d(pose[0], pose[1], pose[2]);
  const double angle = w.norm();
  const Eigen::Matrix3d delta = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                            : Eigen::Matrix3d::Identity();
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.linear() = delta;
  step.translation() = centroid + k * Eigen::Vector3d(pose[3], pose[4], pose[5]) - delta * centroid;
  return step;
}

// The robust objective at (transform, scale) over the given inliers, closest points re-found:
// sum of rho(z_i^2) (rho the loss; z_i^2 for Trim) plus the landmarks' squared whitened residuals.
double objective(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                 const std::vector<LandmarkPair>& landmarks, const std::vector<bool>& inlier,
                 const ceres::LossFunction* loss, bool useLandmarks, const Eigen::Isometry3d& t,
                 double scale, const SurfaceRegistrationOptions& o) {
  double cost = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!inlier[i])
      continue;
    const Correspondence c = correspond(locator, t * points[i].at(scale), o.excludedTriangles);
    // A point moved onto an excluded triangle costs as much as a gated outlier.
    const double z = c.excluded
                         ? o.gateSigmas
                         : (c.signedDistance - points[i].surfaceOffsetMm) / points[i].sigmaMm;
    double rho[3] = {z * z, 1.0, 0.0};
    if (loss != nullptr)
      loss->Evaluate(z * z, rho);
    cost += rho[0];
  }
  if (useLandmarks) {
    for (const LandmarkPair& l : landmarks)
      cost += ((t * l.bone - l.model) / l.sigmaMm).squaredNorm();
  }
  return cost;
}

}  // namespace

core::detail::Solution solveRobust(const core::MeshLocator& locator,
                                   const std::vector<SurfacePoint>& points,
                                   const std::vector<LandmarkPair>& landmarks,
                                   const SurfaceRegistrationOptions& o,
                                   const Eigen::Isometry3d& start) {
  Solution s;
  s.transform = start;
  const double lossScale = o.lossScale > 0.0 ? o.lossScale : defaultLossScale(o.loss);
  const std::unique_ptr<ceres::LossFunction> lossForCost(makeLoss(o.loss, lossScale));
  ceres::Solver::Options solver = levenbergMarquardt(1e-12, 1e-12, 1e-12);
  solver.max_num_iterations = 20;
  const bool useLandmarks = o.useLandmarks && !landmarks.empty();
  std::vector<Correspondence> c(points.size());
  double previousRatio = 0.0;
  Eigen::Matrix<double, 7, 1> previousStep = Eigen::Matrix<double, 7, 1>::Zero();
  std::vector<bool> previousInlier;
  for (int iteration = 1; iteration <= o.maxIterations; ++iteration) {
    s.iterations = iteration;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> y(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      y[i] = s.transform * points[i].at(s.scale);
      c[i] = correspond(locator, y[i], o.excludedTriangles);
      centroid += y[i];
    }
    centroid /= static_cast<double>(points.size());
    s.inlier = dropExcluded(selectInliers(whitenedAbs(points, c), o), c);
    const auto costAt = [&](const Eigen::Isometry3d& t, double scale) {
      return objective(locator, points, landmarks, s.inlier, lossForCost.get(), useLandmarks, t,
                       scale, o);
    };
    const double before = costAt(s.transform, s.scale);

    double pose[6] = {0, 0, 0, 0, 0, 0};
    double scale = s.scale;
    ceres::Problem problem;
    const Eigen::Matrix3d rotation = s.transform.linear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!s.inlier[i])
        continue;
      const SurfacePoint& p = points[i];
      PlaneResidual r;
      if (p.hasBeam) {
        r.a = s.transform * p.beamOrigin - centroid;
        r.b = rotation * (p.depthMm * p.beamDirection);
      } else {
        r.a = s.transform * p.point - centroid;
        r.b = Eigen::Vector3d::Zero();
      }
      r.normal = c[i].normal;
      r.centroidMinusFoot = centroid - c[i].foot;
      r.offset = p.surfaceOffsetMm;
      r.invSigma = 1.0 / p.sigmaMm;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<PlaneResidual, 1, 6, 1>(new PlaneResidual(r)),
          makeLoss(o.loss, lossScale), pose, &scale);
    }
    if (useLandmarks) {
      for (const LandmarkPair& l : landmarks) {
        LandmarkResidual r;
        r.a = s.transform * l.bone - centroid;
        r.centroidMinusModel = centroid - l.model;
        r.invSigma = 1.0 / l.sigmaMm;
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<LandmarkResidual, 3, 6>(new LandmarkResidual(r)),
            nullptr, pose);
      }
    }
    // No inlier left (every point gated or beyond the model) and no landmark: nothing to solve.
    if (!problem.HasParameterBlock(pose))
      break;
    // The scale's block exists only when an inlier residual was added.
    if (problem.HasParameterBlock(&scale)) {
      if (!o.fitSpeedOfSound) {
        problem.SetParameterBlockConstant(&scale);
      } else {
        problem.SetParameterLowerBound(&scale, 0, o.minSpeedScale);
        problem.SetParameterUpperBound(&scale, 0, o.maxSpeedScale);
      }
    }
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    if (!summary.IsSolutionUsable())
      break;

    // The plane model's step, halved while it does not lower the true objective (closest points
    // re-found): every accepted step descends, so the iterations cannot cycle.
    const double deltaScale = scale - s.scale;
    double fraction = 1.0;
    Eigen::Isometry3d next = increment(pose, centroid, fraction) * s.transform;
    double after = costAt(next, s.scale + deltaScale);
    for (int halving = 0; halving < 8 && after > before; ++halving) {
      fraction *= 0.5;
      next = increment(pose, centroid, fraction) * s.transform;
      after = costAt(next, s.scale + fraction * deltaScale);
    }
    if (after > before) {  // no descent along the step: a stationary point
      s.settled = true;
      break;
    }
    const double nextScale = s.scale + fraction * deltaScale;
    double moved = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i)
      moved = std::max(moved, (next * points[i].at(nextScale) - y[i]).norm());
    s.transform = next;
    s.scale = nextScale;
    if (moved < o.toleranceMm || before - after <= 1e-12 * std::max(before, 1e-300)) {
      s.settled = true;
      break;
    }
    // Gauss-Newton on the distances converges linearly along weakly constrained directions: in a
    // long valley the points slide by a nearly constant fraction r of the last step each
    // iteration (r < 0: they zigzag across it, e.g. the speed-of-sound scale against a
    // translation). When two successive ratios agree and the inliers stay the same, the rest of
    // the geometric series is tried at once (Aitken's extrapolation: k = r / (1 - r) more of the
    // same step; k is about -1/2 for a zigzag), kept only if it lowers the objective. r is
    // measured on the steps as 7-vectors in mm (rotation in rad x 100 mm, scale x 20 mm).
    Eigen::Matrix<double, 7, 1> step;
    step << 100.0 * pose[0], 100.0 * pose[1], 100.0 * pose[2], pose[3], pose[4], pose[5],
        20.0 * deltaScale;
    step *= fraction;
    const double ratio = previousStep.squaredNorm() > 0.0
                             ? step.dot(previousStep) / previousStep.squaredNorm()
                             : 0.0;
    const bool steady = s.inlier == previousInlier && std::abs(ratio) > 0.3 &&
                        std::abs(ratio) < 0.995 &&
                        std::abs(ratio - previousRatio) < 0.05 * std::abs(ratio);
    previousRatio = ratio;
    previousStep = step;
    if (steady) {
      const double k = std::clamp(ratio / (1.0 - ratio), -0.5, 100.0) * fraction;
      const Eigen::Isometry3d jump = increment(pose, centroid, k) * s.transform;
      const double jumpScale =
          o.fitSpeedOfSound ? std::clamp(s.scale + k * deltaScale, o.minSpeedScale, o.maxSpeedScale)
                            : s.scale;
      if (costAt(jump, jumpScale) < after) {
        s.transform = jump;
        s.scale = jumpScale;
        previousRatio = 0.0;
        previousStep.setZero();
      }
    }
    previousInlier = s.inlier;
    // Keep the rotation exactly orthonormal over many iterations.
    s.transform.linear() =
        Eigen::Quaterniond(s.transform.rotation()).normalized().toRotationMatrix();
  }
  return s;
}

}  // namespace echoreg::solve
