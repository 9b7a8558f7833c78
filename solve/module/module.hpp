// The solver module's functions (libechoreg_solve.so), called through its entry points
// (entry.cpp, solve/solve_module_abi.hpp). Private to the module.
#pragma once

#include "beam_model.hpp"
#include "solve_calls.hpp"
#include "surface_registration_detail.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

namespace echoreg::solve {

/// core/src/fits.cpp's sphere refinement: the centre (and radius unless known) through `points`.
/// Throws std::invalid_argument when the solve fails.
void refineSphere(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                  Eigen::Vector3d& centre, double& radiusMm);

/// One round of the beam calibration (core/src/beam_calibration.cpp): the shots `used` marks, the
/// `count` parameters `x` solved in place.
core::detail::BeamRound beamRound(int count, const std::vector<core::detail::ShotData>& data,
                                  const std::vector<bool>& used, Eigen::VectorXd& x);

/// The beam calibration's Jacobian at `x`; the first shot that cannot be evaluated, or -1.
int beamJacobian(int count, const std::vector<core::detail::ShotData>& data,
                 const Eigen::VectorXd& x, core::detail::ShotJacobian& jacobian);

/// The robust point-to-plane solve of one start (core/src/surface_registration_detail.hpp).
core::detail::Solution solveRobust(const core::MeshLocator& locator,
                                   const std::vector<core::SurfacePoint>& points,
                                   const std::vector<core::LandmarkPair>& landmarks,
                                   const core::SurfaceRegistrationOptions& o,
                                   const Eigen::Isometry3d& start);

}  // namespace echoreg::solve
