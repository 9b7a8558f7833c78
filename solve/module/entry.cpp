// The solver module's entry points (solve/solve_module_abi.hpp): every exception is caught and
// handed back as a std::exception_ptr, which the caller rethrows.
#include "module.hpp"
#include "solve_module_abi.hpp"

#include "echoreg/core/loadable_module.hpp"

#include <exception>
#include <string>
#include <vector>

extern "C" {

__attribute__((visibility("default"))) const char* echoreg_solve_abi() {
  static const std::string abi = echoreg::solve::solveAbi();
  return abi.c_str();
}

__attribute__((visibility("default"))) void echoreg_solve_sphere(
    const std::vector<Eigen::Vector3d>* points, int knownRadius, Eigen::Vector3d* centre,
    double* radiusMm, std::exception_ptr* error) {
  echoreg::core::captureException(
      error, [&] { echoreg::solve::refineSphere(*points, knownRadius != 0, *centre, *radiusMm); });
}

__attribute__((visibility("default"))) void echoreg_solve_beam_round(
    int count, const std::vector<echoreg::core::detail::ShotData>* data,
    const std::vector<bool>* used, Eigen::VectorXd* x, echoreg::core::detail::BeamRound* out,
    std::exception_ptr* error) {
  echoreg::core::captureException(
      error, [&] { *out = echoreg::solve::beamRound(count, *data, *used, *x); });
}

__attribute__((visibility("default"))) void echoreg_solve_beam_jacobian(
    int count, const std::vector<echoreg::core::detail::ShotData>* data, const Eigen::VectorXd* x,
    echoreg::core::detail::ShotJacobian* jacobian, int* failedShot, std::exception_ptr* error) {
  echoreg::core::captureException(
      error, [&] { *failedShot = echoreg::solve::beamJacobian(count, *data, *x, *jacobian); });
}

__attribute__((visibility("default"))) void echoreg_solve_robust(
    const echoreg::core::MeshLocator* locator,
    const std::vector<echoreg::core::SurfacePoint>* points,
    const std::vector<echoreg::core::LandmarkPair>* landmarks,
    const echoreg::core::SurfaceRegistrationOptions* options, const Eigen::Isometry3d* start,
    echoreg::core::detail::Solution* out, std::exception_ptr* error) {
  echoreg::core::captureException(error, [&] {
    *out = echoreg::solve::solveRobust(*locator, *points, *landmarks, *options, *start);
  });
}

}  // extern "C"
