#include "echoreg/core/number_text.hpp"

#include <cstdio>

namespace echoreg::core {

namespace {

// printf's text of `value` with `format`, however long (the copies before this one cut it at 63
// characters: "%.2f" of 1e70).
template <typename... Args>
std::string printed(const char* format, Args... args) {
  char text[64];
  const int length = std::snprintf(text, sizeof text, format, args...);
  if (length < 0)
    return {};
  if (static_cast<std::size_t>(length) < sizeof text)
    return std::string(text, static_cast<std::size_t>(length));
  std::string longer(static_cast<std::size_t>(length) + 1, '\0');
  std::snprintf(longer.data(), longer.size(), format, args...);
  longer.resize(static_cast<std::size_t>(length));
  return longer;
}

}  // namespace

std::string number(double value, const char* format) {
  return printed(format, value);
}

std::string number(double value, int decimals) {
  return printed("%.*f", decimals, value);
}

}  // namespace echoreg::core
