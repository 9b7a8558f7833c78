// Shared by the calibration solvers (fits.cpp, beam_calibration.cpp) and the robust surface
// registration: the robust outlier threshold. Private to echoreg::core (and the solver module,
// solve/, which holds the Ceres half of those solvers).
#pragma once

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

}  // namespace echoreg::core::detail
