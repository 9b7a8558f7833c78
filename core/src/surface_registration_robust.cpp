// SurfaceRegistration's robust solver: point-to-plane with the speed of sound, a robust loss or
// trim, and the landmarks from one start (surface_registration_detail.hpp). The inliers are chosen
// here; the Ceres solve runs in the solver module (solve/module/robust.cpp).
#include "surface_registration_detail.hpp"

#include "robust_solve.hpp"
#include "solve_calls.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

namespace echoreg::core::detail {

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

Solution solveRobust(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                     const std::vector<LandmarkPair>& landmarks,
                     const SurfaceRegistrationOptions& o, const Eigen::Isometry3d& start) {
  return solveRobustInSolverModule(locator, points, landmarks, o, start);
}

}  // namespace echoreg::core::detail
