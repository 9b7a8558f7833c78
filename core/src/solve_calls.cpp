// echoreg::core's calls into the solver module (solve_calls.hpp, solve/solve_module_abi.hpp).
#include "solve_calls.hpp"

#include "echoreg/core/loadable_module.hpp"
#include "solve_module_abi.hpp"

#include <exception>

#ifndef ECHOREG_SOLVE_MODULE_FILE_NAME
#error "ECHOREG_SOLVE_MODULE_FILE_NAME must be defined (core/CMakeLists.txt)"
#endif

namespace echoreg::core::detail {

namespace {

/// The entry point `symbol` of EXE_DIR/../lib/echoreg/libechoreg_solve.so, opened on the first
/// call of the process. Throws FileError naming the module's path when it is missing, not the
/// module, or the module of another build.
template <typename Function>
Function solverFunction(const char* symbol) {
  const ModuleIdentity identity{"solver module", "echoreg_solve",
                                "fits spheres, calibrates beams and registers surfaces (Ceres)",
                                solve::kAbiSymbol, solve::solveAbi()};
  return moduleFunction<Function>(ECHOREG_SOLVE_MODULE_FILE_NAME, identity, symbol);
}

}  // namespace

void refineSphereInSolverModule(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                                Eigen::Vector3d& centre, double& radiusMm) {
  std::exception_ptr error;
  solverFunction<solve::SphereFunction>(solve::kSphereSymbol)(&points, knownRadius ? 1 : 0, &centre,
                                                              &radiusMm, &error);
  rethrowFromModule(error);
}

BeamRound beamRoundInSolverModule(int count, const std::vector<ShotData>& data,
                                  const std::vector<bool>& used, Eigen::VectorXd& x) {
  BeamRound round;
  std::exception_ptr error;
  solverFunction<solve::BeamRoundFunction>(solve::kBeamRoundSymbol)(count, &data, &used, &x, &round,
                                                                    &error);
  rethrowFromModule(error);
  return round;
}

int beamJacobianInSolverModule(int count, const std::vector<ShotData>& data,
                               const Eigen::VectorXd& x, ShotJacobian& jacobian) {
  int failed = -1;
  std::exception_ptr error;
  solverFunction<solve::BeamJacobianFunction>(solve::kBeamJacobianSymbol)(
      count, &data, &x, &jacobian, &failed, &error);
  rethrowFromModule(error);
  return failed;
}

Solution solveRobustInSolverModule(const MeshLocator& locator,
                                   const std::vector<SurfacePoint>& points,
                                   const std::vector<LandmarkPair>& landmarks,
                                   const SurfaceRegistrationOptions& options,
                                   const Eigen::Isometry3d& start) {
  Solution solution;
  std::exception_ptr error;
  solverFunction<solve::RobustFunction>(solve::kRobustSymbol)(&locator, &points, &landmarks,
                                                              &options, &start, &solution, &error);
  rethrowFromModule(error);
  return solution;
}

}  // namespace echoreg::core::detail
