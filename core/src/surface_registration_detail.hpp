// Private declarations of SurfaceRegistration (surface_registration.cpp), shared by its pieces
// (not installed):
//   - surface_registration_starts.cpp: the starting poses (and the landmarks' two-point pose);
//   - surface_registration_robust.cpp: the robust point-to-plane solver (Ceres), inliers;
//   - surface_registration_icp.cpp: the dissertation's plain ICP;
//   - surface_registration_diagnostics.cpp: the cost that picks a start, the ambiguity between
//     starts, the pose's uncertainty, the reason a registration did not converge, the RMS.
#pragma once

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/number_text.hpp"
#include "echoreg/core/surface_registration.hpp"

#include <Eigen/Geometry>

#include <string>
#include <utility>
#include <vector>

namespace echoreg::core::detail {

constexpr double kPi = 3.14159265358979323846;

void require(bool condition, const std::string& message);

// One point's closest point and the plane the point-to-plane residual uses.
struct Correspondence {
  Eigen::Vector3d foot = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit; the distance's gradient, outward
  double signedDistance = 0.0;                        // n . (y - foot)
  bool excluded = false;  // the closest point lies on a triangle that is not bone (a scan cap)
};

Correspondence correspond(const MeshLocator& locator, const Eigen::Vector3d& y,
                          const std::vector<bool>& excluded = {});

// One start's state and outcome.
struct Solution {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  double scale = 1.0;
  int iterations = 0;
  bool settled = false;
  std::vector<bool> inlier;
};

// |r_i| / sigma_i of each point (an excluded point: 1e6).
std::vector<double> whitenedAbs(const std::vector<SurfacePoint>& points,
                                const std::vector<Correspondence>& c);

// Points whose closest point lies on an excluded triangle are never inliers.
std::vector<bool> dropExcluded(std::vector<bool> inlier, const std::vector<Correspondence>& c);

// The robust gate (or the trim) over the whitened residuals `z`.
std::vector<bool> selectInliers(const std::vector<double>& z, const SurfaceRegistrationOptions& o);

// --- The starts (surface_registration_starts.cpp) ---------------------------------------------

Eigen::Isometry3d rotationAbout(const Eigen::Vector3d& point, const Eigen::Vector3d& axis,
                                double angle);

// The starts: the initial pose, rotations of it about the axis, random perturbations.
std::vector<Eigen::Isometry3d> registrationStarts(const std::vector<SurfacePoint>& points,
                                                  const SurfaceRegistrationOptions& options);

// How far the points start from the surface (the best start's median distance).
double startDistanceMm(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                       const std::vector<Eigen::Isometry3d>& starts);

// --- The solvers: one start each --------------------------------------------------------------

// Robust point-to-plane with the speed of sound (surface_registration_robust.cpp).
Solution solveRobust(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                     const std::vector<LandmarkPair>& landmarks,
                     const SurfaceRegistrationOptions& o, const Eigen::Isometry3d& start);

// The dissertation's plain ICP (surface_registration_icp.cpp).
Solution solvePlain(const MeshLocator& locator, const std::vector<SurfacePoint>& points,
                    const SurfaceRegistrationOptions& o, const Eigen::Isometry3d& start);

// --- Diagnostics (surface_registration_diagnostics.cpp) ---------------------------------------

// Truncated cost of a solution: sum over points of min(z_i^2, gate^2) with z_i = r_i / sigma_i
// and the fixed gate gateSigmas, plus the landmarks' squared whitened residuals.
double truncatedCost(const std::vector<SurfacePoint>& points, const std::vector<Correspondence>& c,
                     const std::vector<LandmarkPair>& landmarks, const Eigen::Isometry3d& t,
                     const SurfaceRegistrationOptions& o);

// Another start ending elsewhere at nearly the best cost: the data cannot tell the two apart.
// Empty when none does, else the message.
std::string ambiguityOf(const std::vector<SurfacePoint>& points, const Solution& chosen,
                        const std::vector<std::pair<Eigen::Isometry3d, double>>& solutions,
                        double bestCost, const SurfaceRegistrationOptions& options);

// How well the solution is determined: the Gauss-Newton matrix of the whitened point-to-plane
// residuals (and landmarks) over a rotation w about the inliers' centroid, a translation v and,
// when fitted, the scale s: d r_i = ((y_i - c) x n_i) . w + n_i . v + n_i . (R b_i) ds.
// Sets `result`'s rotation and translation sigmas and weakest axis from its inliers.
void estimatePoseUncertainty(const std::vector<SurfacePoint>& points,
                             const std::vector<LandmarkPair>& landmarks,
                             const std::vector<Correspondence>& c, const Solution& chosen,
                             const SurfaceRegistrationOptions& options, bool robust,
                             SurfaceRegistrationResult& result);

// Why the registration did not converge (empty when it did): the first of the checks that fails.
std::string failureMessage(const std::vector<SurfacePoint>& points,
                           const std::vector<LandmarkPair>& landmarks,
                           const SurfaceRegistrationOptions& options,
                           const SurfaceRegistrationResult& result, const Solution& chosen,
                           double startDistance, const std::string& ambiguity, bool robust);

}  // namespace echoreg::core::detail
