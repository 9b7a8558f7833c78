// The interface between echoreg::core's solvers (core/src/solve_calls.hpp) and the solver module,
// libechoreg_solve.so, which does their Ceres work: the sphere fit's refinement, the beam
// calibration's rounds and Jacobian, the robust surface registration. The module is opened with
// dlopen on the first solve of a process, so commands that never solve (`detect`, `info`, `serve`,
// `segment`, `simulate`...) do not load Ceres and its 18 shared libraries (docs/architecture.md,
// "Modules opened on demand").
//
// C entry points, so that dlsym finds them by name; C++ types cross by pointer, which holds because
// the module is built from the same sources by the same compiler (checked by solveAbi()). An
// exception thrown inside the module crosses as a std::exception_ptr and is rethrown by the caller.
#pragma once

#include "beam_model.hpp"
#include "solve_calls.hpp"
#include "surface_registration_detail.hpp"

#include <fmt/format.h>

#include <exception>
#include <string>
#include <vector>

#ifndef ECHOREG_VERSION
#error "ECHOREG_VERSION must be defined (core/CMakeLists.txt, solve/CMakeLists.txt)"
#endif

namespace echoreg::solve {

/// const char* echoreg_solve_abi(): the module's solveAbi().
inline constexpr const char* kAbiSymbol = "echoreg_solve_abi";

/// void echoreg_solve_sphere(const std::vector<Eigen::Vector3d>* points, int knownRadius,
/// Eigen::Vector3d* centre, double* radiusMm, std::exception_ptr* error).
inline constexpr const char* kSphereSymbol = "echoreg_solve_sphere";
using SphereFunction = void (*)(const std::vector<Eigen::Vector3d>*, int, Eigen::Vector3d*, double*,
                                std::exception_ptr*);

/// void echoreg_solve_beam_round(int count, const std::vector<ShotData>* data,
/// const std::vector<bool>* used, Eigen::VectorXd* x, BeamRound* out, std::exception_ptr* error).
inline constexpr const char* kBeamRoundSymbol = "echoreg_solve_beam_round";
using BeamRoundFunction = void (*)(int, const std::vector<core::detail::ShotData>*,
                                   const std::vector<bool>*, Eigen::VectorXd*,
                                   core::detail::BeamRound*, std::exception_ptr*);

/// void echoreg_solve_beam_jacobian(int count, const std::vector<ShotData>* data,
/// const Eigen::VectorXd* x, ShotJacobian* jacobian, int* failedShot, std::exception_ptr* error).
inline constexpr const char* kBeamJacobianSymbol = "echoreg_solve_beam_jacobian";
using BeamJacobianFunction = void (*)(int, const std::vector<core::detail::ShotData>*,
                                      const Eigen::VectorXd*, core::detail::ShotJacobian*, int*,
                                      std::exception_ptr*);

/// void echoreg_solve_robust(const MeshLocator* locator, const std::vector<SurfacePoint>* points,
/// const std::vector<LandmarkPair>* landmarks, const SurfaceRegistrationOptions* options,
/// const Eigen::Isometry3d* start, Solution* out, std::exception_ptr* error).
inline constexpr const char* kRobustSymbol = "echoreg_solve_robust";
using RobustFunction = void (*)(const core::MeshLocator*, const std::vector<core::SurfacePoint>*,
                                const std::vector<core::LandmarkPair>*,
                                const core::SurfaceRegistrationOptions*, const Eigen::Isometry3d*,
                                core::detail::Solution*, std::exception_ptr*);

/// The version, the compiler and the layout of the types that cross; the module and the executable
/// must agree on it.
inline std::string solveAbi() {
  return fmt::format(
      "echoreg {} / {} / ShotData {} BeamRound {} MeshLocator {} SurfacePoint {} LandmarkPair {} "
      "SurfaceRegistrationOptions {} Solution {}",
      ECHOREG_VERSION, __VERSION__, sizeof(core::detail::ShotData), sizeof(core::detail::BeamRound),
      sizeof(core::MeshLocator), sizeof(core::SurfacePoint), sizeof(core::LandmarkPair),
      sizeof(core::SurfaceRegistrationOptions), sizeof(core::detail::Solution));
}

}  // namespace echoreg::solve
