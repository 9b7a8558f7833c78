#include "echoreg/core/fits.hpp"

#include "robust_solve.hpp"
#include "solve_calls.hpp"

#include "echoreg/core/number_text.hpp"
#include "echoreg/core/random.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::core {

namespace {

constexpr double kRadiansToDegrees = 57.29577951308232087680;
// Points whose out-of-plane RMS is below this share of their largest RMS extent lie in a plane.
constexpr double kCoplanarRelative = 1e-6;

void checkOutlierOptions(double outlierSigmas, double minOutlierMm, int maxRounds,
                         const char* what) {
  const std::string prefix = std::string(what) + ": ";
  if (!std::isfinite(outlierSigmas) || outlierSigmas <= 0.0)
    throw std::invalid_argument(prefix + "outlierSigmas must be > 0 (got " +
                                number(outlierSigmas, "%.6g") + ")");
  if (!std::isfinite(minOutlierMm) || minOutlierMm < 0.0)
    throw std::invalid_argument(prefix + "minOutlierMm must be >= 0 (got " +
                                number(minOutlierMm, "%.6g") + ")");
  if (maxRounds < 1)
    throw std::invalid_argument(prefix + "maxRounds must be >= 1 (got " +
                                std::to_string(maxRounds) + ")");
}

// max(outlierSigmas * 1.4826 * median |r|, minOutlierMm) over the residuals of the points used.
double outlierThreshold(const std::vector<double>& residuals, const std::vector<bool>& used,
                        double outlierSigmas, double minOutlierMm) {
  std::vector<double> magnitudes;
  magnitudes.reserve(residuals.size());
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (used[i])
      magnitudes.push_back(std::abs(residuals[i]));
  }
  return detail::robustThreshold(magnitudes, outlierSigmas, minOutlierMm);
}

int countTrue(const std::vector<bool>& flags) {
  return static_cast<int>(std::count(flags.begin(), flags.end(), true));
}

// ---------------------------------------------------------------------------------------------
// Sphere

struct Spread {
  Eigen::Vector3d centroid;
  double thinMm;  // RMS extent along the least spread direction
  double wideMm;  // RMS extent along the most spread direction
};

Spread pointSpread(const std::vector<Eigen::Vector3d>& points) {
  Spread spread{Eigen::Vector3d::Zero(), 0.0, 0.0};
  for (const auto& p : points)
    spread.centroid += p;
  spread.centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d d = p - spread.centroid;
    covariance += d * d.transpose();
  }
  covariance /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance, Eigen::EigenvaluesOnly);
  spread.thinMm = std::sqrt(std::max(eigen.eigenvalues()[0], 0.0));
  spread.wideMm = std::sqrt(std::max(eigen.eigenvalues()[2], 0.0));
  return spread;
}

// Refuses points that cannot determine a sphere's centre: all equal, or in one plane.
void checkSphereSpread(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                       std::size_t total) {
  const Spread spread = pointSpread(points);
  const std::string which = points.size() == total
                                ? "the " + std::to_string(points.size()) + " points"
                                : "the " + std::to_string(points.size()) + " points kept (of " +
                                      std::to_string(total) + ")";
  if (spread.wideMm == 0.0)
    throw std::invalid_argument(which + " are all the same point: they determine no sphere");
  if (spread.thinMm <= kCoplanarRelative * spread.wideMm) {
    if (knownRadius) {
      throw std::invalid_argument(
          which +
          " lie in one plane: with a known radius the centre could be on either side "
          "of it; collect points off that plane");
    }
    throw std::invalid_argument(which +
                                " lie in one plane: they determine no sphere with a free radius; "
                                "collect points off that plane (or give the radius)");
  }
}

// The algebraic fit |p|^2 = 2 c.p + (r^2 - |c|^2), linear in (c, k), on points centred and
// scaled for conditioning. Returns the centre and radius (the radius is the mean distance to the
// centre when r^2 comes out <= 0, which only very poor data gives).
void algebraicSphere(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d& centre,
                     double& radiusMm) {
  const Spread spread = pointSpread(points);
  const double scale = spread.wideMm;
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d q = (points[static_cast<std::size_t>(i)] - spread.centroid) / scale;
    a.row(i) << 2.0 * q.x(), 2.0 * q.y(), 2.0 * q.z(), 1.0;
    b[i] = q.squaredNorm();
  }
  const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
  const Eigen::Vector3d scaledCentre = x.head<3>();
  centre = spread.centroid + scale * scaledCentre;
  const double radiusSquared = x[3] + scaledCentre.squaredNorm();
  if (radiusSquared > 0.0 && std::isfinite(radiusSquared)) {
    radiusMm = scale * std::sqrt(radiusSquared);
  } else {
    radiusMm = 0.0;
    for (const auto& p : points)
      radiusMm += (p - centre).norm();
    radiusMm /= static_cast<double>(points.size());
  }
}

// Geometric refinement of (centre, radius) with Ceres' Levenberg-Marquardt, in the solver module.
void refineSphere(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                  Eigen::Vector3d& centre, double& radiusMm) {
  detail::refineSphereInSolverModule(points, knownRadius, centre, radiusMm);
}

// The sphere through four points, or false when they are (nearly) coplanar.
bool sphereThrough(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                   const Eigen::Vector3d& p3, Eigen::Vector3d& centre, double& radiusMm) {
  // 2 (p_j - p_0) . (c - p_0) = |p_j - p_0|^2, j = 1..3.
  Eigen::Matrix3d a;
  a.row(0) = 2.0 * (p1 - p0);
  a.row(1) = 2.0 * (p2 - p0);
  a.row(2) = 2.0 * (p3 - p0);
  const double scale = a.rowwise().norm().prod();
  const double determinant = a.determinant();
  if (!(std::abs(determinant) > 1e-3 * scale))
    return false;
  const Eigen::Vector3d b((p1 - p0).squaredNorm(), (p2 - p0).squaredNorm(),
                          (p3 - p0).squaredNorm());
  const Eigen::Vector3d offset = a.partialPivLu().solve(b);
  centre = p0 + offset;
  radiusMm = offset.norm();
  return std::isfinite(radiusMm);
}

// A robust first inlier set: the least-median-of-squares sphere (Rousseeuw 1984) over a fixed
// number of four-point samples drawn from a stream seeded by the point count (deterministic),
// then the points within the outlier threshold of that sphere. A plain least-squares start can be
// dragged far enough by stray points on a partial sphere that the rounds never recover (1 % of
// 60 deg caps with 10 % strays); the consensus start does not. Returns all points when no sample
// gives a sphere.
std::vector<bool> consensusInliers(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                                   const SphereFitOptions& options) {
  constexpr int kSamples = 128;
  const std::size_t n = points.size();
  Rng rng = Rng::derive(2008, "fit-sphere-consensus", n);
  std::vector<double> best;
  double bestMedian = std::numeric_limits<double>::infinity();
  std::vector<double> residuals(n), magnitudes(n);
  for (int sample = 0; sample < kSamples; ++sample) {
    std::size_t index[4];
    for (int k = 0; k < 4; ++k) {
      bool repeated = true;
      while (repeated) {
        index[k] = static_cast<std::size_t>(rng.below(n));
        repeated = std::find(index, index + k, index[k]) != index + k;
      }
    }
    Eigen::Vector3d centre;
    double radiusMm = 0.0;
    if (!sphereThrough(points[index[0]], points[index[1]], points[index[2]], points[index[3]],
                       centre, radiusMm)) {
      continue;
    }
    if (knownRadius)
      radiusMm = *options.radiusMm;
    for (std::size_t i = 0; i < n; ++i) {
      residuals[i] = (points[i] - centre).norm() - radiusMm;
      magnitudes[i] = std::abs(residuals[i]);
    }
    std::nth_element(magnitudes.begin(), magnitudes.begin() + static_cast<std::ptrdiff_t>(n / 2),
                     magnitudes.end());
    if (magnitudes[n / 2] < bestMedian) {
      bestMedian = magnitudes[n / 2];
      best = residuals;
    }
  }
  std::vector<bool> inlier(n, true);
  if (best.empty())
    return inlier;
  const double threshold =
      outlierThreshold(best, inlier, options.outlierSigmas, options.minOutlierMm);
  for (std::size_t i = 0; i < n; ++i)
    inlier[i] = std::abs(best[i]) <= threshold;
  return inlier;
}

// Largest over smallest singular value of d(|p - c| - r)/d(c[, r]) over the points.
double sphereConditionNumber(const std::vector<Eigen::Vector3d>& points,
                             const Eigen::Vector3d& centre, bool knownRadius) {
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd jacobian(n, knownRadius ? 3 : 4);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(i)] - centre;
    const double length = d.norm();
    const Eigen::Vector3d unit =
        length > 0.0 ? Eigen::Vector3d(d / length) : Eigen::Vector3d::Zero();
    jacobian(i, 0) = -unit.x();
    jacobian(i, 1) = -unit.y();
    jacobian(i, 2) = -unit.z();
    if (!knownRadius)
      jacobian(i, 3) = -1.0;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jacobian);
  const auto& values = svd.singularValues();
  const double smallest = values[values.size() - 1];
  if (!(smallest > 0.0))
    return std::numeric_limits<double>::infinity();
  return values[0] / smallest;
}

// ---------------------------------------------------------------------------------------------
// Pivot

Eigen::Matrix3d projectToRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * fix * svd.matrixV().transpose();
}

Eigen::Vector3d rotationSpreadDeg(const std::vector<Eigen::Isometry3d>& poses,
                                  const std::vector<bool>& used) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  int count = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!used[i])
      continue;
    sum += poses[i].linear();
    ++count;
  }
  const Eigen::Matrix3d meanInverse = projectToRotation(sum).transpose();
  std::vector<Eigen::Vector3d> vectors;
  vectors.reserve(static_cast<std::size_t>(count));
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!used[i])
      continue;
    const Eigen::AngleAxisd relative(Eigen::Matrix3d(meanInverse * poses[i].linear()));
    vectors.push_back(relative.angle() * relative.axis());
    mean += vectors.back();
  }
  mean /= static_cast<double>(count);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& v : vectors)
    covariance += (v - mean) * (v - mean).transpose();
  covariance /= static_cast<double>(count);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d values = eigen.eigenvalues();  // ascending
  Eigen::Vector3d spread;
  for (int k = 0; k < 3; ++k)
    spread[k] = 2.0 * std::sqrt(std::max(values[2 - k], 0.0)) * kRadiansToDegrees;
  return spread;
}

void checkRotationSpread(const Eigen::Vector3d& spreadDeg, double minimumDeg,
                         const std::string& which) {
  if (spreadDeg[1] >= minimumDeg)
    return;
  throw std::invalid_argument(which + " rotate " + number(spreadDeg[0], 1) +
                              " deg about one axis and " + number(spreadDeg[1], 1) +
                              " deg about the others: pivot the marker in two directions (at "
                              "least " +
                              number(minimumDeg, 0) +
                              " deg each; spread = 2 x RMS rotation about each principal axis)");
}

void checkPose(const Eigen::Isometry3d& pose, std::size_t index) {
  const std::string which = "pose " + std::to_string(index);
  if (!pose.matrix().topRows<3>().allFinite())
    throw std::invalid_argument(which + " is not finite");
  const Eigen::Matrix3d r = pose.linear();
  const double orthogonality =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-6 || r.determinant() <= 0.0) {
    throw std::invalid_argument(
        which + " is not a rigid transform: its rotation part has max |R^T R - I| = " +
        number(orthogonality, "%.6g") + " and determinant " + number(r.determinant(), "%.6g"));
  }
}

}  // namespace

SphereFit fitSphere(const std::vector<Eigen::Vector3d>& points, const SphereFitOptions& options) {
  const bool knownRadius = options.radiusMm.has_value();
  if (knownRadius && !(std::isfinite(*options.radiusMm) && *options.radiusMm > 0.0)) {
    throw std::invalid_argument("fitSphere: the known radius must be a finite number > 0 mm (got " +
                                number(*options.radiusMm, "%.6g") + ")");
  }
  checkOutlierOptions(options.outlierSigmas, options.minOutlierMm, options.maxRounds, "fitSphere");
  if (!(options.maxConditionNumber >= 1.0))
    throw std::invalid_argument("fitSphere: maxConditionNumber must be >= 1 (got " +
                                number(options.maxConditionNumber, "%.6g") + ")");
  const std::size_t minimum = knownRadius ? 3 : 4;
  if (points.size() < minimum) {
    throw std::invalid_argument("fitSphere: " + std::to_string(points.size()) +
                                " points are too few: a sphere with " +
                                (knownRadius ? "a known radius" : "a free radius") +
                                " needs at least " + std::to_string(minimum));
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite())
      throw std::invalid_argument("fitSphere: point " + std::to_string(i) + " is not finite");
  }

  SphereFit fit;
  // With rounds to spare, the first round fits a robust consensus of the points (with fewer than
  // 8 points, or when that consensus is too small, all of them).
  fit.inlier.assign(points.size(), true);
  constexpr std::size_t kConsensusMinimumPoints = 8;
  if (options.maxRounds > 1 && points.size() >= kConsensusMinimumPoints) {
    std::vector<bool> consensus = consensusInliers(points, knownRadius, options);
    std::vector<Eigen::Vector3d> agreeing;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (consensus[i])
        agreeing.push_back(points[i]);
    }
    if (agreeing.size() >= std::max(minimum, points.size() / 2)) {
      const Spread spread = pointSpread(agreeing);
      if (spread.thinMm > kCoplanarRelative * spread.wideMm)
        fit.inlier = std::move(consensus);
    }
  }
  fit.residualsMm.assign(points.size(), 0.0);
  std::vector<Eigen::Vector3d> used;
  used.reserve(points.size());
  for (int round = 0; round < options.maxRounds; ++round) {
    used.clear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (fit.inlier[i])
        used.push_back(points[i]);
    }
    if (used.size() < minimum) {
      throw std::invalid_argument("fitSphere: only " + std::to_string(used.size()) + " of " +
                                  std::to_string(points.size()) +
                                  " points agree with one sphere (at least " +
                                  std::to_string(minimum) + " needed)");
    }
    checkSphereSpread(used, knownRadius, points.size());
    algebraicSphere(used, fit.centre, fit.radiusMm);
    if (knownRadius)
      fit.radiusMm = *options.radiusMm;
    refineSphere(used, knownRadius, fit.centre, fit.radiusMm);
    if (!(fit.radiusMm > 0.0)) {
      throw std::invalid_argument("fitSphere: the points fit no sphere (the radius came out " +
                                  number(fit.radiusMm, "%.6g") + " mm)");
    }
    for (std::size_t i = 0; i < points.size(); ++i)
      fit.residualsMm[i] = (points[i] - fit.centre).norm() - fit.radiusMm;
    if (round + 1 == options.maxRounds)
      break;
    const double threshold =
        outlierThreshold(fit.residualsMm, fit.inlier, options.outlierSigmas, options.minOutlierMm);
    std::vector<bool> next(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      next[i] = std::abs(fit.residualsMm[i]) <= threshold;
    if (next == fit.inlier)
      break;
    fit.inlier = std::move(next);
  }

  fit.inliers = countTrue(fit.inlier);
  double sum = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (fit.inlier[i])
      sum += fit.residualsMm[i] * fit.residualsMm[i];
  }
  fit.rmsMm = std::sqrt(sum / static_cast<double>(fit.inliers));
  fit.conditionNumber = sphereConditionNumber(used, fit.centre, knownRadius);
  if (!(fit.conditionNumber <= options.maxConditionNumber)) {
    const Spread spread = pointSpread(used);
    throw std::invalid_argument(
        "fitSphere: the points cover too small a part of the sphere (condition number " +
        number(fit.conditionNumber, "%.6g") + " > " + number(options.maxConditionNumber, "%.6g") +
        "; " + std::to_string(used.size()) + " points spread " + number(spread.wideMm, 2) +
        " mm RMS across and " + number(spread.thinMm, 2) + " mm RMS deep): " +
        (knownRadius ? "collect points over more of the sphere"
                     : "collect points over more of the sphere, or give the radius"));
  }
  return fit;
}

PivotResult pivotCalibration(const std::vector<Eigen::Isometry3d>& markerToTracker,
                             const PivotOptions& options) {
  checkOutlierOptions(options.outlierSigmas, options.minOutlierMm, options.maxRounds,
                      "pivotCalibration");
  if (!std::isfinite(options.minRotationSpreadDeg) || options.minRotationSpreadDeg < 0.0) {
    throw std::invalid_argument("pivotCalibration: minRotationSpreadDeg must be >= 0 (got " +
                                number(options.minRotationSpreadDeg, "%.6g") + ")");
  }
  constexpr std::size_t kMinimumPoses = 4;
  const std::size_t n = markerToTracker.size();
  if (n < kMinimumPoses) {
    throw std::invalid_argument("pivotCalibration: " + std::to_string(n) +
                                " poses are too few (at least 4 needed)");
  }
  for (std::size_t i = 0; i < n; ++i)
    checkPose(markerToTracker[i], i);

  PivotResult result;
  result.inlier.assign(n, true);
  result.residualsMm.assign(n, 0.0);
  result.rotationSpreadDeg = rotationSpreadDeg(markerToTracker, result.inlier);
  checkRotationSpread(result.rotationSpreadDeg, options.minRotationSpreadDeg,
                      "pivotCalibration: the " + std::to_string(n) + " poses");

  for (int round = 0; round < options.maxRounds; ++round) {
    const int used = countTrue(result.inlier);
    if (static_cast<std::size_t>(used) < kMinimumPoses) {
      throw std::invalid_argument("pivotCalibration: only " + std::to_string(used) + " of " +
                                  std::to_string(n) +
                                  " poses agree on one fixed point (at least 4 needed)");
    }
    if (round > 0) {
      result.rotationSpreadDeg = rotationSpreadDeg(markerToTracker, result.inlier);
      checkRotationSpread(result.rotationSpreadDeg, options.minRotationSpreadDeg,
                          "pivotCalibration: the " + std::to_string(used) +
                              " poses that agree (of " + std::to_string(n) + ")");
    }
    Eigen::MatrixXd a(3 * used, 6);
    Eigen::VectorXd b(3 * used);
    Eigen::Index row = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!result.inlier[i])
        continue;
      a.block<3, 3>(row, 0) = markerToTracker[i].linear();
      a.block<3, 3>(row, 3) = -Eigen::Matrix3d::Identity();
      b.segment<3>(row) = -markerToTracker[i].translation();
      row += 3;
    }
    const Eigen::Matrix<double, 6, 1> x = a.colPivHouseholderQr().solve(b);
    result.pointInMarker = x.head<3>();
    result.pointInTracker = x.tail<3>();
    for (std::size_t i = 0; i < n; ++i) {
      result.residualsMm[i] =
          (markerToTracker[i] * result.pointInMarker - result.pointInTracker).norm();
    }
    if (round + 1 == options.maxRounds)
      break;
    const double threshold = outlierThreshold(result.residualsMm, result.inlier,
                                              options.outlierSigmas, options.minOutlierMm);
    std::vector<bool> next(n);
    for (std::size_t i = 0; i < n; ++i)
      next[i] = result.residualsMm[i] <= threshold;
    if (next == result.inlier)
      break;
    result.inlier = std::move(next);
  }

  result.inliers = countTrue(result.inlier);
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (result.inlier[i])
      sum += result.residualsMm[i] * result.residualsMm[i];
  }
  result.rmsMm = std::sqrt(sum / static_cast<double>(result.inliers));
  return result;
}

}  // namespace echoreg::core
