// SurfaceRegistration's plain ICP (the dissertation's, section 4.3): closest points and Umeyama
// until the RMS no longer changes (surface_registration_detail.hpp).
#include "surface_registration_detail.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <limits>

namespace echoreg::core::detail {

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

}  // namespace echoreg::core::detail
