// Shared by the calibration solvers (fits.cpp, beam_calibration.cpp): the robust outlier
// threshold and the Ceres Levenberg-Marquardt settings. Private to echoreg::core.
#pragma once

#include <ceres/ceres.h>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace echoreg::core::detail {

/// Median (the mean of the two middle values for an even count); 0 for none.
inline double median(std::vector<double> values) {
  if (values.empty())
    return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1)
    return *middle;
  const double upper = *middle;
  const double lower = *std::max_element(values.begin(), middle);
  return 0.5 * (lower + upper);
}

/// max(sigmas * 1.4826 * median |r|, minimum): 1.4826 x MAD is a robust standard deviation.
inline double robustThreshold(const std::vector<double>& absoluteResiduals, double sigmas,
                              double minimum) {
  if (absoluteResiduals.empty())
    return minimum;
  return std::max(sigmas * 1.4826 * median(absoluteResiduals), minimum);
}

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

}  // namespace echoreg::core::detail
