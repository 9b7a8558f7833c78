// SurfaceRegistration's starting poses, and the pose from two landmarks
// (surface_registration_detail.hpp).
#include "surface_registration_detail.hpp"

#include "echoreg/core/random.hpp"
#include "robust_solve.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace echoreg::core::detail {

Eigen::Isometry3d rotationAbout(const Eigen::Vector3d& point, const Eigen::Vector3d& axis,
                                double angle) {
  Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
  r.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  r.translation() = point - r.linear() * point;
  return r;
}

std::vector<Eigen::Isometry3d> registrationStarts(const std::vector<SurfacePoint>& points,
                                                  const SurfaceRegistrationOptions& options) {
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
  return starts;
}

double startDistanceMm(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                       const std::vector<Eigen::Isometry3d>& starts) {
  double startDistance = std::numeric_limits<double>::infinity();
  for (const Eigen::Isometry3d& start : starts) {
    std::vector<double> distances;
    for (const SurfacePoint& p : points)
      distances.push_back(locator.closest(start * p.at(1.0)).distance);
    startDistance = std::min(startDistance, detail::median(distances));
  }
  return startDistance;
}

}  // namespace echoreg::core::detail

namespace echoreg::core {

using detail::require;
using detail::rotationAbout;

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

}  // namespace echoreg::core
