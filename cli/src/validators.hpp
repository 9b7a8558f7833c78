// Number checks of options whose messages name the flag and the values it accepts in the user's
// words (issue 15, item 13): CLI11's PositiveNumber printed DBL_MAX to 300 digits, and it and
// Range let NaN through.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <sstream>
#include <string>

namespace echoreg::cli {

/// A finite number above `minimum` (at least `minimum` when `inclusive`): "--max-rms: must be a
/// finite number > 0, got -1" (exit 2, wrong usage).
inline CLI::Validator finiteNumber(double minimum, bool inclusive) {
  std::ostringstream rule;
  rule << "a finite number " << (inclusive ? ">= " : "> ") << minimum;
  const std::string text = rule.str();
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        double value = 0.0;
        if (!CLI::detail::lexical_cast(input, value) || !std::isfinite(value) ||
            (inclusive ? value < minimum : value <= minimum)) {
          return "must be " + text + ", got " + input;
        }
        return std::string();
      },
      text, "FINITE");
}

/// A finite number from `minimum` to `maximum`: "--min-spread-deg: must be a number from 0 to
/// 90, got nan".
inline CLI::Validator finiteRange(double minimum, double maximum) {
  std::ostringstream rule;
  rule << "a number from " << minimum << " to " << maximum;
  const std::string text = rule.str();
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        double value = 0.0;
        if (!CLI::detail::lexical_cast(input, value) || !(value >= minimum && value <= maximum)) {
          return "must be " + text + ", got " + input;
        }
        return std::string();
      },
      text, "RANGE");
}

}  // namespace echoreg::cli
