// Numbers in the text of messages and reports, printed as printf prints them, so that every
// caller that names a format gets the same bytes as before (one copy instead of one per file).
#pragma once

#include <string>

namespace echoreg::core {

/// `value` as printf prints it with `format`, the conversion of one double: "%.6g" (what
/// std::ostream prints by default), "%.3g", "%.2f"...
std::string number(double value, const char* format);

/// `value` with `decimals` digits after the point (printf's "%.*f", the same text as fmt's
/// "{:.{}f}").
std::string number(double value, int decimals);

}  // namespace echoreg::core
