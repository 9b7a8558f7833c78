// The Ceres settings the solver module's problems share. Private to the module.
#pragma once

#include <ceres/ceres.h>

namespace echoreg::solve {

/// Levenberg-Marquardt, dense QR, one thread (deterministic), silent.
inline ceres::Solver::Options levenbergMarquardt(double functionTolerance, double gradientTolerance,
                                                 double parameterTolerance) {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_QR;
  options.num_threads = 1;
  options.minimizer_progress_to_stdout = false;
  options.logging_type = ceres::SILENT;
  options.max_num_iterations = 200;
  options.function_tolerance = functionTolerance;
  options.gradient_tolerance = gradientTolerance;
  options.parameter_tolerance = parameterTolerance;
  return options;
}

}  // namespace echoreg::solve
