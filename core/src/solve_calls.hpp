// How echoreg::core reaches the solver module (solve/solve_module_abi.hpp), which holds the Ceres
// half of the sphere fit, the beam calibration and the robust surface registration: Ceres and the
// libraries it brings (glog, SuiteSparse, LAPACK, BLAS, gfortran: 18 shared libraries, about 10 ms
// at every process start on this project's machine) load only in a process that solves. Each
// function opens the module on its first call (core::moduleSymbol) and rethrows what the module
// threw. Private to echoreg::core.
#pragma once

#include "beam_model.hpp"
#include "surface_registration_detail.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace echoreg::core::detail {

/// The outcome of one Levenberg-Marquardt solve of the beam calibration's used shots.
struct BeamRound {
  bool usable = false;     ///< Ceres' IsSolutionUsable
  bool converged = false;  ///< terminated by convergence
  int iterations = 0;      ///< Ceres' iterations, the initial evaluation not counted
  std::string message;     ///< Ceres' summary message
};

/// One row per shot, one column per parameter.
using ShotJacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Geometric refinement of a sphere (centre, radius; the radius held when known) through
/// `points`. Throws std::invalid_argument when the solve fails.
void refineSphereInSolverModule(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                                Eigen::Vector3d& centre, double& radiusMm);

/// Solves the beam calibration's `count` parameters `x` (updated) over the shots `used` marks.
BeamRound beamRoundInSolverModule(int count, const std::vector<ShotData>& data,
                                  const std::vector<bool>& used, Eigen::VectorXd& x);

/// The residuals' Jacobian at `x`; the index of the first shot whose residual cannot be
/// evaluated, or -1.
int beamJacobianInSolverModule(int count, const std::vector<ShotData>& data,
                               const Eigen::VectorXd& x, ShotJacobian& jacobian);

/// The robust point-to-plane solve of one start (surface_registration_detail.hpp's solveRobust).
Solution solveRobustInSolverModule(const MeshLocator& locator,
                                   const std::vector<SurfacePoint>& points,
                                   const std::vector<LandmarkPair>& landmarks,
                                   const SurfaceRegistrationOptions& options,
                                   const Eigen::Isometry3d& start);

}  // namespace echoreg::core::detail
