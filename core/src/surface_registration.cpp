#include "echoreg/core/surface_registration.hpp"

#include "echoreg/core/random.hpp"
#include "robust_solve.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string number(double value, const char* format = "%.4g") {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument("surface registration: " + message);
}

// One point's closest point and the plane the point-to-plane residual uses.
struct Correspondence {
  Eigen::Vector3d foot = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit; the distance's gradient, outward
  double signedDistance = 0.0;                        // n . (y - foot)
  bool excluded = false;  // the closest point lies on a triangle that is not bone (a scan cap)
};

Correspondence correspond(const MeshLocator& locator, const Eigen::Vector3d& y,
                          const std::vector<bool>& excluded = {}) {
  const ClosestPoint closest = locator.closest(y);
  Correspondence c;
  c.excluded = !excluded.empty() && excluded[static_cast<std::size_t>(closest.triangle)];
  c.foot = closest.point;
  const Eigen::Vector3d faceNormal = triangleNormal(locator.mesh(), closest.triangle);
  const Eigen::Vector3d d = y - closest.point;
  const double distance = d.norm();
  // Inside a triangle the distance's gradient is the face normal; on an edge or vertex it is the
  // direction from the foot, signed to agree with the face normal (outside positive).
  const bool onBoundary = closest.barycentric.minCoeff() < 1e-9;
  if (onBoundary && distance > 1e-9) {
    const Eigen::Vector3d direction = d / distance;
    c.normal = direction.dot(faceNormal) >= 0.0 ? direction : Eigen::Vector3d(-direction);
  } else {
    c.normal = faceNormal;
  }
  c.signedDistance = c.normal.dot(d);
  if (onBoundary && distance > 1e-9)
    c.signedDistance = std::copysign(distance, c.signedDistance);
  return c;
}

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

void validate(const std::vector<SurfacePoint>& points, const std::vector<LandmarkPair>& landmarks,
              const SurfaceRegistrationOptions& o) {
  require(points.size() >= 3, "at least 3 points needed, got " + std::to_string(points.size()));
  bool anyBeam = false;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SurfacePoint& p = points[i];
    const std::string name = "point " + std::to_string(i);
    require(p.point.allFinite(), name + " is not finite");
    require(std::isfinite(p.sigmaMm) && p.sigmaMm > 0.0, name + ": sigma must be > 0 mm");
    require(std::isfinite(p.surfaceOffsetMm) && p.surfaceOffsetMm >= 0.0,
            name + ": surface offset must be >= 0 mm");
    if (p.hasBeam) {
      anyBeam = true;
      require(p.beamOrigin.allFinite() && p.beamDirection.allFinite() && std::isfinite(p.depthMm),
              name + ": beam is not finite");
      require(std::abs(p.beamDirection.norm() - 1.0) < 1e-6, name + ": beam direction is not unit");
      require(p.depthMm >= 0.0, name + ": negative depth " + number(p.depthMm));
    }
  }
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const LandmarkPair& l = landmarks[i];
    const std::string name = "landmark " + (l.name.empty() ? std::to_string(i) : l.name);
    require(l.bone.allFinite() && l.model.allFinite(), name + " is not finite");
    require(std::isfinite(l.sigmaMm) && l.sigmaMm > 0.0, name + ": sigma must be > 0 mm");
  }
  require(!o.fitSpeedOfSound || anyBeam,
          "the speed of sound can only be fitted for points with their beams (origin, direction, "
          "depth)");
  require(o.fitSpeedOfSound
              ? o.minSpeedScale > 0.0 && o.minSpeedScale < 1.0 && o.maxSpeedScale > 1.0
              : true,
          "speed-of-sound bounds must bracket 1");
  require(o.lossScale >= 0.0 && std::isfinite(o.lossScale), "loss scale must be >= 0");
  require(o.trimFraction >= 0.0 && o.trimFraction < 0.5, "trim fraction must be in [0, 0.5)");
  require(o.gateSigmas > 0.0, "gate must be > 0 sigmas");
  require(o.restarts >= 0 && o.restarts <= 1000, "restarts must be in 0..1000");
  require(o.axisStarts >= 1 && o.axisStarts <= 360, "axis starts must be in 1..360");
  require(!o.searchAboutAxis || (o.axisPoint.allFinite() && o.axisDirection.norm() > 1e-9),
          "the search axis needs a point and a non-zero direction");
  require(o.maxIterations >= 1, "at least one iteration");
  require(o.toleranceMm > 0.0 && o.plainRmsChangeMm > 0.0, "tolerances must be > 0");
  require(o.maxRmsMm > 0.0 && o.maxStartDistanceMm > 0.0,
          "max RMS and max start distance must be > 0");
  require(o.minInlierFraction > 0.0 && o.minInlierFraction <= 1.0,
          "min inlier fraction must be in (0, 1]");
  require(o.initial.matrix().allFinite(), "initial pose is not finite");
}

// One start's state and outcome.
struct Solution {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  double scale = 1.0;
  int iterations = 0;
  bool settled = false;
  std::vector<bool> inlier;
};

std::vector<double> whitenedAbs(const std::vector<SurfacePoint>& points,
                                const std::vector<Correspondence>& c) {
  std::vector<double> z(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    z[i] = c[i].excluded
               ? 1e6
               : std::abs(c[i].signedDistance - points[i].surfaceOffsetMm) / points[i].sigmaMm;
  }
  return z;
}

// Points whose closest point lies on an excluded triangle are never inliers.
std::vector<bool> dropExcluded(std::vector<bool> inlier, const std::vector<Correspondence>& c) {
  for (std::size_t i = 0; i < inlier.size(); ++i) {
    if (c[i].excluded)
      inlier[i] = false;
  }
  return inlier;
}

std::vector<bool> selectInliers(const std::vector<double>& z, const SurfaceRegistrationOptions& o) {
  std::vector<bool> inlier(z.size(), true);
  if (o.loss == RobustLoss::Trim) {
    const std::size_t drop =
        static_cast<std::size_t>(std::floor(o.trimFraction * static_cast<double>(z.size())));
    if (drop == 0)
      return inlier;
    std::vector<std::size_t> order(z.size());
    for (std::size_t i = 0; i < order.size(); ++i)
      order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t l, std::size_t r) { return z[l] < z[r]; });
    for (std::size_t k = z.size() - drop; k < z.size(); ++k)
      inlier[order[k]] = false;
    return inlier;
  }
  const double gate = detail::robustThreshold(z, o.gateSigmas, o.gateSigmas);
  for (std::size_t i = 0; i < z.size(); ++i)
    inlier[i] = z[i] <= gate;
  return inlier;
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

Solution solveRobust(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                     const std::vector<LandmarkPair>& landmarks,
                     const SurfaceRegistrationOptions& o, const Eigen::Isometry3d& start) {
  Solution s;
  s.transform = start;
  const double lossScale = o.lossScale > 0.0 ? o.lossScale : defaultLossScale(o.loss);
  const std::unique_ptr<ceres::LossFunction> lossForCost(makeLoss(o.loss, lossScale));
  ceres::Solver::Options solver = detail::levenbergMarquardt(1e-12, 1e-12, 1e-12);
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

Solution solvePlain(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                    const SurfaceRegistrationOptions& o, const Eigen::Isometry3d& start) {
  Solution s;
  s.transform = start;
  s.inlier.assign(points.size(), true);
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::Matrix3Xd from(3, n), to(3, n);
  for (Eigen::Index i = 0; i < n; ++i)
    from.col(i) = points[static_cast<std::size_t>(i)].at(1.0);
  double previousRms = std::numeric_limits<double>::infinity();
  for (int iteration = 1; iteration <= o.maxIterations; ++iteration) {
    s.iterations = iteration;
    double sum = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const ClosestPoint closest = locator.closest(s.transform * Eigen::Vector3d(from.col(i)));
      to.col(i) = closest.point;
      sum += closest.distance * closest.distance;
    }
    const double rms = std::sqrt(sum / static_cast<double>(n));
    // The dissertation's stopping rule: the RMS (Eq. 4.4) no longer changes.
    if (std::abs(previousRms - rms) < o.plainRmsChangeMm) {
      s.settled = true;
      break;
    }
    previousRms = rms;
    s.transform.matrix() = Eigen::umeyama(from, to, false);
  }
  return s;
}

// Truncated cost of a solution: sum over points of min(z_i^2, gate^2) with z_i = r_i / sigma_i
// and the fixed gate gateSigmas, plus the landmarks' squared whitened residuals.
double truncatedCost(const std::vector<SurfacePoint>& points, const std::vector<Correspondence>& c,
                     const std::vector<LandmarkPair>& landmarks, const Eigen::Isometry3d& t,
                     const SurfaceRegistrationOptions& o) {
  double cost = 0.0;
  const double cap = o.gateSigmas * o.gateSigmas;
  const std::vector<double> z = whitenedAbs(points, c);
  for (double value : z)
    cost += std::min(value * value, cap);
  if (o.useLandmarks && o.method == SurfaceMethod::Robust) {
    for (const LandmarkPair& l : landmarks)
      cost += ((t * l.bone - l.model) / l.sigmaMm).squaredNorm();
  }
  return cost;
}

Eigen::Isometry3d rotationAbout(const Eigen::Vector3d& point, const Eigen::Vector3d& axis,
                                double angle) {
  Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
  r.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  r.translation() = point - r.linear() * point;
  return r;
}

}  // namespace

std::string_view surfaceMethodName(SurfaceMethod method) {
  return method == SurfaceMethod::Plain ? "plain" : "robust";
}

SurfaceMethod parseSurfaceMethod(std::string_view name) {
  if (name == "plain")
    return SurfaceMethod::Plain;
  if (name == "robust")
    return SurfaceMethod::Robust;
  throw std::invalid_argument("unknown registration method \"" + std::string(name) +
                              "\" (plain or robust)");
}

std::string_view robustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::Huber:
      return "huber";
    case RobustLoss::Cauchy:
      return "cauchy";
    case RobustLoss::Tukey:
      return "tukey";
    case RobustLoss::Trim:
      return "trim";
  }
  return "huber";
}

RobustLoss parseRobustLoss(std::string_view name) {
  if (name == "huber")
    return RobustLoss::Huber;
  if (name == "cauchy")
    return RobustLoss::Cauchy;
  if (name == "tukey")
    return RobustLoss::Tukey;
  if (name == "trim")
    return RobustLoss::Trim;
  throw std::invalid_argument("unknown loss \"" + std::string(name) +
                              "\" (huber, cauchy, tukey or trim)");
}

SurfacePoint beamSurfacePoint(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                              double depthMm, double sigmaMm) {
  SurfacePoint p;
  p.hasBeam = true;
  p.beamOrigin = origin;
  const double length = direction.norm();
  p.beamDirection = length > 0.0 ? Eigen::Vector3d(direction / length) : direction;
  p.depthMm = depthMm;
  p.point = origin + depthMm * p.beamDirection;
  p.sigmaMm = sigmaMm;
  return p;
}

std::vector<bool> scanEndCaps(const TriangleMesh& mesh, double toleranceMm) {
  std::vector<bool> caps(mesh.triangles.size(), false);
  if (mesh.triangles.empty())
    return caps;
  const auto box = bounds(mesh);
  const double cosLimit = std::cos(10.0 * kPi / 180.0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    bool low = true;
    bool high = true;
    for (int k = 0; k < 3; ++k) {
      const double z =
          mesh.vertices[static_cast<std::size_t>(mesh.triangles[t][static_cast<std::size_t>(k)])]
              .z();
      low = low && z <= box[0].z() + toleranceMm;
      high = high && z >= box[1].z() - toleranceMm;
    }
    if (!low && !high)
      continue;
    const Eigen::Vector3d n = triangleNormal(mesh, static_cast<int>(t));
    caps[t] = std::abs(n.z()) >= cosLimit;
  }
  // The rim too: the triangles touching a cap, so that a point beyond the scan whose closest
  // point is the cap's edge is excluded whichever of the edge's triangles the search reports.
  std::vector<bool> capVertex(mesh.vertices.size(), false);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!caps[t])
      continue;
    for (int v : mesh.triangles[t])
      capVertex[static_cast<std::size_t>(v)] = true;
  }
  std::vector<bool> excluded = caps;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int v : mesh.triangles[t])
      excluded[t] = excluded[t] || capVertex[static_cast<std::size_t>(v)];
  }
  return excluded;
}

SurfaceRegistration::SurfaceRegistration(TriangleMesh model)
    : locator_([&] {
        require(!model.empty(), "the model has no triangles");
        const MeshCheck check = checkMesh(model);
        require(check.closed(), "the model is " + check.describe() +
                                    " (a closed, consistently wound surface is needed)");
        require(check.volumeMm3 > 0.0, "the model is wound inward (negative volume)");
        return std::move(model);
      }()) {}

SurfaceRegistrationResult SurfaceRegistration::registerPoints(
    const std::vector<SurfacePoint>& points, const std::vector<LandmarkPair>& landmarks,
    const SurfaceRegistrationOptions& options) const {
  validate(points, landmarks, options);
  require(options.excludedTriangles.empty() ||
              options.excludedTriangles.size() == locator_.mesh().triangles.size(),
          "excluded triangles: one flag per triangle of the model is needed");
  const bool robust = options.method == SurfaceMethod::Robust;

  // The starts: the initial pose, rotations of it about the axis, random perturbations.
  std::vector<Eigen::Isometry3d> starts{options.initial};
  if (options.searchAboutAxis) {
    const Eigen::Vector3d point = options.initial * options.axisPoint;
    const Eigen::Vector3d axis = options.initial.linear() * options.axisDirection.normalized();
    for (int k = 1; k < options.axisStarts; ++k)
      starts.push_back(rotationAbout(point, axis, 2.0 * kPi * k / options.axisStarts) *
                       options.initial);
  }
  if (options.restarts > 0) {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const SurfacePoint& p : points)
      centroid += options.initial * p.point;
    centroid /= static_cast<double>(points.size());
    const std::size_t base = starts.size();
    Rng rng = Rng::derive(options.seed, "surface-registration-restarts");
    for (int k = 0; k < options.restarts; ++k) {
      Eigen::Vector3d axis(rng.normal(), rng.normal(), rng.normal());
      if (axis.norm() < 1e-12)
        axis = Eigen::Vector3d::UnitZ();
      const double angle = rng.uniform(-1.0, 1.0) * options.restartRotationDeg * kPi / 180.0;
      Eigen::Vector3d shift(rng.normal(), rng.normal(), rng.normal());
      shift *= rng.uniform() * options.restartTranslationMm / std::max(shift.norm(), 1e-12);
      Eigen::Isometry3d perturbation = rotationAbout(centroid, axis, angle);
      perturbation.pretranslate(shift);
      starts.push_back(perturbation * starts[static_cast<std::size_t>(k) % base]);
    }
  }

  // How far the points start from the surface (the best start's median distance).
  double startDistance = std::numeric_limits<double>::infinity();
  for (const Eigen::Isometry3d& start : starts) {
    std::vector<double> distances;
    for (const SurfacePoint& p : points)
      distances.push_back(locator_.closest(start * p.at(1.0)).distance);
    startDistance = std::min(startDistance, detail::median(distances));
  }

  double bestCost = std::numeric_limits<double>::infinity();
  Solution chosen;
  std::vector<Correspondence> c(points.size());
  std::vector<std::pair<Eigen::Isometry3d, double>> solutions;  // every start's end and cost
  for (const Eigen::Isometry3d& start : starts) {
    const Solution s = robust ? solveRobust(locator_, points, landmarks, options, start)
                              : solvePlain(locator_, points, options, start);
    for (std::size_t i = 0; i < points.size(); ++i)
      c[i] = correspond(locator_, s.transform * points[i].at(s.scale), options.excludedTriangles);
    const double cost = truncatedCost(points, c, landmarks, s.transform, options);
    solutions.push_back({s.transform, cost});
    if (cost < bestCost) {
      bestCost = cost;
      chosen = s;
    }
  }
  // Another start ending elsewhere at nearly the best cost: the data cannot tell the two apart.
  std::string ambiguity;
  {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const SurfacePoint& p : points)
      centroid += chosen.transform * p.at(chosen.scale);
    centroid /= static_cast<double>(points.size());
    for (const auto& [transform, cost] : solutions) {
      if (cost > options.ambiguityCostRatio * bestCost + 1e-9)
        continue;
      const Eigen::Isometry3d d = transform * chosen.transform.inverse();
      const double angle = Eigen::AngleAxisd(d.linear()).angle() * 180.0 / kPi;
      const double shift = (d * centroid - centroid).norm();
      if (angle > options.ambiguityDeg || shift > options.ambiguityMm) {
        ambiguity =
            "another start ends " + number(angle, "%.3g") + " deg / " + number(shift, "%.3g") +
            " mm away at a cost within " + number(options.ambiguityCostRatio, "%.3g") +
            " x the best: the points cannot tell the two poses apart; add landmarks (e.g. the "
            "hip centre) or points on other regions";
        break;
      }
    }
  }

  SurfaceRegistrationResult result;
  result.transform = chosen.transform;
  result.speedOfSoundScale = chosen.scale;
  result.iterations = chosen.iterations;
  result.starts = static_cast<int>(starts.size());
  result.cost = bestCost;
  for (std::size_t i = 0; i < points.size(); ++i)
    c[i] = correspond(locator_, chosen.transform * points[i].at(chosen.scale),
                      options.excludedTriangles);
  // Inliers at the end: the robust gate (or the trim) at the solution; plain keeps every point.
  result.inlier = robust ? dropExcluded(selectInliers(whitenedAbs(points, c), options), c)
                         : std::vector<bool>(points.size(), true);
  double sumIn = 0.0, sumAll = 0.0;
  result.residualsMm.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double r = c[i].signedDistance - points[i].surfaceOffsetMm;
    result.residualsMm[i] = r;
    sumAll += r * r;
    if (result.inlier[i]) {
      sumIn += r * r;
      ++result.pointsUsed;
    }
  }
  result.pointsRejected = static_cast<int>(points.size()) - result.pointsUsed;
  result.rmsAllMm = std::sqrt(sumAll / static_cast<double>(points.size()));
  result.rmsMm = result.pointsUsed > 0 ? std::sqrt(sumIn / result.pointsUsed) : 0.0;
  for (const LandmarkPair& l : landmarks)
    result.landmarkResidualsMm.push_back((chosen.transform * l.bone - l.model).norm());

  // How well the solution is determined: the Gauss-Newton matrix of the whitened point-to-plane
  // residuals (and landmarks) over a rotation w about the inliers' centroid, a translation v and,
  // when fitted, the scale s: d r_i = ((y_i - c) x n_i) . w + n_i . v + n_i . (R b_i) ds.
  {
    const bool withScale = robust && options.fitSpeedOfSound;
    const int dims = withScale ? 7 : 6;
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(dims, dims);
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    int used = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!result.inlier[i])
        continue;
      centroid += chosen.transform * points[i].at(chosen.scale);
      ++used;
    }
    if (used > 0) {
      centroid /= used;
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (!result.inlier[i])
          continue;
        const Eigen::Vector3d y = chosen.transform * points[i].at(chosen.scale);
        Eigen::VectorXd j(dims);
        j.head<3>() = (y - centroid).cross(c[i].normal);
        j.segment<3>(3) = c[i].normal;
        if (withScale) {
          j(6) = points[i].hasBeam ? c[i].normal.dot(chosen.transform.linear() *
                                                     (points[i].depthMm * points[i].beamDirection))
                                   : 0.0;
        }
        j /= points[i].sigmaMm;
        h += j * j.transpose();
      }
      if (robust && options.useLandmarks) {
        for (const LandmarkPair& l : landmarks) {
          const Eigen::Vector3d r = chosen.transform * l.bone - centroid;
          for (int a = 0; a < 3; ++a) {
            Eigen::VectorXd j = Eigen::VectorXd::Zero(dims);
            const Eigen::Vector3d e = Eigen::Vector3d::Unit(a);
            j.head<3>() = r.cross(e);  // d(w x r)_a / dw = (r x e_a)
            j(3 + a) = 1.0;
            j /= l.sigmaMm;
            h += j * j.transpose();
          }
        }
      }
      const Eigen::FullPivLU<Eigen::MatrixXd> lu(h);
      if (!lu.isInvertible()) {
        result.rotationSigmaDeg = std::numeric_limits<double>::infinity();
        result.translationSigmaMm = std::numeric_limits<double>::infinity();
      } else {
        const Eigen::MatrixXd cov = lu.inverse();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rot(cov.topLeftCorner<3, 3>());
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> tra(cov.block<3, 3>(3, 3));
        result.rotationSigmaDeg = std::sqrt(std::max(0.0, rot.eigenvalues()(2))) * 180.0 / kPi;
        result.weakestAxis = rot.eigenvectors().col(2);
        result.translationSigmaMm = std::sqrt(std::max(0.0, tra.eigenvalues()(2)));
      }
    }
  }

  // Points closest to an excluded triangle (beyond the scanned part of the model) are not
  // counted against the inlier fraction: nothing there could match them.
  for (const Correspondence& ci : c)
    result.pointsBeyondModel += ci.excluded ? 1 : 0;
  const int minimumInliers = std::max(
      3, static_cast<int>(
             std::ceil(options.minInlierFraction *
                       static_cast<double>(points.size() -
                                           static_cast<std::size_t>(result.pointsBeyondModel)))));
  const int constraints =
      result.pointsUsed +
      (robust && options.useLandmarks ? 3 * static_cast<int>(landmarks.size()) : 0);
  if (startDistance > options.maxStartDistanceMm) {
    result.message = "the points start " + number(startDistance, "%.3g") +
                     " mm (median) from the surface, beyond " +
                     number(options.maxStartDistanceMm, "%.3g") +
                     " mm: wrong frame, model or start?";
  } else if (constraints < 6) {
    result.message =
        "only " + std::to_string(result.pointsUsed) +
        " points (and landmarks) for 6 degrees of freedom: at least 6 constraints needed";
  } else if (!chosen.settled) {
    result.message =
        "did not settle within " + std::to_string(options.maxIterations) + " iterations";
  } else if (result.pointsUsed < minimumInliers) {
    result.message =
        "only " + std::to_string(result.pointsUsed) + " of " +
        std::to_string(points.size() - static_cast<std::size_t>(result.pointsBeyondModel)) +
        " points lie near the surface (at least " + std::to_string(minimumInliers) + " needed)";
  } else if (!ambiguity.empty()) {
    result.message = ambiguity;
  } else if (robust && (result.rotationSigmaDeg > options.maxRotationSigmaDeg ||
                        result.translationSigmaMm > options.maxTranslationSigmaMm)) {
    const Eigen::Vector3d& a = result.weakestAxis;
    result.message = "the points leave the pose undetermined: rotation +-" +
                     number(result.rotationSigmaDeg, "%.3g") + " deg (1 sigma) about (" +
                     number(a.x(), "%.2f") + ", " + number(a.y(), "%.2f") + ", " +
                     number(a.z(), "%.2f") + "), translation +-" +
                     number(result.translationSigmaMm, "%.3g") +
                     " mm; add landmarks (e.g. the hip centre) or points on other regions";
  } else if (result.rmsMm > options.maxRmsMm) {
    result.message = "the points end far from the surface: RMS " + number(result.rmsMm, "%.3g") +
                     " mm over the inliers, above the limit " + number(options.maxRmsMm, "%.3g") +
                     " mm";
  }
  result.converged = result.message.empty();
  return result;
}

Eigen::Isometry3d poseFromTwoLandmarks(const LandmarkPair& a, const LandmarkPair& b,
                                       double angleRad, double maxLengthMismatchMm) {
  const Eigen::Vector3d boneLine = b.bone - a.bone;
  const Eigen::Vector3d modelLine = b.model - a.model;
  require(boneLine.allFinite() && modelLine.allFinite(), "landmarks are not finite");
  require(boneLine.norm() >= 1.0 && modelLine.norm() >= 1.0,
          "landmarks " + a.name + " and " + b.name + " lie within 1 mm of each other");
  require(std::abs(boneLine.norm() - modelLine.norm()) <= maxLengthMismatchMm,
          "landmarks " + a.name + " and " + b.name + " are " + number(boneLine.norm(), "%.1f") +
              " mm apart on the bone but " + number(modelLine.norm(), "%.1f") +
              " mm apart on the model (swapped or wrong landmarks?)");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond::FromTwoVectors(boneLine, modelLine).toRotationMatrix();
  const Eigen::Vector3d boneMid = 0.5 * (a.bone + b.bone);
  const Eigen::Vector3d modelMid = 0.5 * (a.model + b.model);
  t.translation() = modelMid - t.linear() * boneMid;
  return rotationAbout(modelMid, modelLine, angleRad) * t;
}

LandmarkSpread landmarkSpread(const std::vector<LandmarkPair>& landmarks, double minOffLineMm) {
  require(landmarks.size() >= 2,
          "at least 2 landmarks needed, got " + std::to_string(landmarks.size()));
  LandmarkSpread s;
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    for (std::size_t j = i + 1; j < landmarks.size(); ++j) {
      const double d = (landmarks[i].bone - landmarks[j].bone).norm();
      if (d > s.lengthMm) {
        s.lengthMm = d;
        s.first = static_cast<int>(i);
        s.second = static_cast<int>(j);
      }
    }
  }
  const Eigen::Vector3d a = landmarks[static_cast<std::size_t>(s.first)].bone;
  const Eigen::Vector3d b = landmarks[static_cast<std::size_t>(s.second)].bone;
  const Eigen::Vector3d u =
      s.lengthMm > 0.0 ? Eigen::Vector3d((b - a) / s.lengthMm) : Eigen::Vector3d::UnitX();
  for (const LandmarkPair& l : landmarks) {
    const Eigen::Vector3d d = l.bone - a;
    s.maxOffLineMm = std::max(s.maxOffLineMm, (d - d.dot(u) * u).norm());
  }
  s.collinear = s.maxOffLineMm <= minOffLineMm;
  return s;
}

double surfaceRmsMm(const MeshLocator& locator, const std::vector<Eigen::Vector3d>& points,
                    const Eigen::Isometry3d& transform) {
  require(!points.empty(), "no points for the RMS");
  double sum = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const double d = locator.closest(transform * p).distance;
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(points.size()));
}

}  // namespace echoreg::core
