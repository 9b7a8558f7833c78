// Whole-file reads for tests that compare outputs byte for byte.
#pragma once

#include <string>

namespace echoreg::test {

/// Every byte of a file ("" when it cannot be read).
std::string fileBytes(const std::string& path);

}  // namespace echoreg::test
