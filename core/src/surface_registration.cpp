// SurfaceRegistration (docs/registration.md): the model checked, the points and options
// validated, every start solved (robust or plain), the best start chosen and diagnosed. The pieces
// are in the files surface_registration_detail.hpp names.
#include "echoreg/core/surface_registration.hpp"

#include "surface_registration_detail.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::core::detail {

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument("surface registration: " + message);
}

Correspondence correspond(const MeshLocator& locator, const Eigen::Vector3d& y,
                          const std::vector<bool>& excluded) {
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

}  // namespace echoreg::core::detail

namespace echoreg::core {

using namespace detail;

namespace {

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
      require(p.depthMm >= 0.0, name + ": negative depth " + number(p.depthMm, "%.4g"));
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

  const std::vector<Eigen::Isometry3d> starts = registrationStarts(points, options);
  const double startDistance = startDistanceMm(locator_, points, starts);

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
  const std::string ambiguity = ambiguityOf(points, chosen, solutions, bestCost, options);

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

  // How well the solution is determined (the Gauss-Newton matrix at the solution).
  estimatePoseUncertainty(points, landmarks, c, chosen, options, robust, result);

  // Points closest to an excluded triangle (beyond the scanned part of the model) are not
  // counted against the inlier fraction: nothing there could match them.
  for (const Correspondence& ci : c)
    result.pointsBeyondModel += ci.excluded ? 1 : 0;
  result.message =
      failureMessage(points, landmarks, options, result, chosen, startDistance, ambiguity, robust);
  result.converged = result.message.empty();
  return result;
}

}  // namespace echoreg::core
