// Number checks of options whose messages name the flag and the values it accepts in the user's
// words (issue 15, item 13): CLI11's PositiveNumber printed DBL_MAX to 300 digits, and it and
// Range let NaN through.
#pragma once

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>
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

/// A whole number from `minimum` to `maximum`: "--decimate: must be a whole number from 0 to
/// 100000000, got 2.5" (CLI11's Range said "Value 2.5 not in range" or could not convert it).
inline CLI::Validator wholeNumber(long long minimum, long long maximum) {
  const std::string text =
      "a whole number from " + std::to_string(minimum) + " to " + std::to_string(maximum);
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        long long value = 0;
        if (!CLI::detail::lexical_cast(input, value) || value < minimum || value > maximum) {
          return "must be " + text + ", got " + input;
        }
        return std::string();
      },
      text, "WHOLE");
}

/// Refuses an output that does not end in .png (any case), naming the flag: the figures are
/// written as PNG, and PNG bytes under a .jpg or .tif name would be misread by whatever opens them
/// by their name. Called after CommandPaths' check, so that an --out naming an input is reported
/// as such. Throws std::invalid_argument (exit 1).
inline void requirePngName(const std::string& flag, const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".png") {
    throw std::invalid_argument(
        flag + ": figures are written as PNG: give a name ending in .png, got \"" + path + "\"");
  }
}

}  // namespace echoreg::cli
