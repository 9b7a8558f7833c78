// SurfaceRegistration's diagnostics: the cost that picks a start, the ambiguity between starts,
// the pose's uncertainty, why a registration did not converge, and the RMS of points to a surface
// (surface_registration_detail.hpp).
#include "surface_registration_detail.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>

namespace echoreg::core::detail {

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

std::string ambiguityOf(const std::vector<SurfacePoint>& points, const Solution& chosen,
                        const std::vector<std::pair<Eigen::Isometry3d, double>>& solutions,
                        double bestCost, const SurfaceRegistrationOptions& options) {
  std::string ambiguity;
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
  return ambiguity;
}

void estimatePoseUncertainty(const std::vector<SurfacePoint>& points,
                             const std::vector<LandmarkPair>& landmarks,
                             const std::vector<Correspondence>& c, const Solution& chosen,
                             const SurfaceRegistrationOptions& options, bool robust,
                             SurfaceRegistrationResult& result) {
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

std::string failureMessage(const std::vector<SurfacePoint>& points,
                           const std::vector<LandmarkPair>& landmarks,
                           const SurfaceRegistrationOptions& options,
                           const SurfaceRegistrationResult& result, const Solution& chosen,
                           double startDistance, const std::string& ambiguity, bool robust) {
  std::string message;
  const int minimumInliers = std::max(
      3, static_cast<int>(
             std::ceil(options.minInlierFraction *
                       static_cast<double>(points.size() -
                                           static_cast<std::size_t>(result.pointsBeyondModel)))));
  const int constraints =
      result.pointsUsed +
      (robust && options.useLandmarks ? 3 * static_cast<int>(landmarks.size()) : 0);
  if (startDistance > options.maxStartDistanceMm) {
    message = "the points start " + number(startDistance, "%.3g") +
              " mm (median) from the surface, beyond " +
              number(options.maxStartDistanceMm, "%.3g") + " mm: wrong frame, model or start?";
  } else if (constraints < 6) {
    message = "only " + std::to_string(result.pointsUsed) +
              " points (and landmarks) for 6 degrees of freedom: at least 6 constraints needed";
  } else if (!chosen.settled) {
    message = "did not settle within " + std::to_string(options.maxIterations) + " iterations";
  } else if (result.pointsUsed < minimumInliers) {
    message = "only " + std::to_string(result.pointsUsed) + " of " +
              std::to_string(points.size() - static_cast<std::size_t>(result.pointsBeyondModel)) +
              " points lie near the surface (at least " + std::to_string(minimumInliers) +
              " needed)";
  } else if (!ambiguity.empty()) {
    message = ambiguity;
  } else if (robust && (result.rotationSigmaDeg > options.maxRotationSigmaDeg ||
                        result.translationSigmaMm > options.maxTranslationSigmaMm)) {
    const Eigen::Vector3d& a = result.weakestAxis;
    message = "the points leave the pose undetermined: rotation +-" +
              number(result.rotationSigmaDeg, "%.3g") + " deg (1 sigma) about (" +
              number(a.x(), "%.2f") + ", " + number(a.y(), "%.2f") + ", " + number(a.z(), "%.2f") +
              "), translation +-" + number(result.translationSigmaMm, "%.3g") +
              " mm; add landmarks (e.g. the hip centre) or points on other regions";
  } else if (result.rmsMm > options.maxRmsMm) {
    message = "the points end far from the surface: RMS " + number(result.rmsMm, "%.3g") +
              " mm over the inliers, above the limit " + number(options.maxRmsMm, "%.3g") + " mm";
  }
  return message;
}

}  // namespace echoreg::core::detail

namespace echoreg::core {

using detail::require;

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
