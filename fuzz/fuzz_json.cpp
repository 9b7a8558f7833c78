// libFuzzer harness of the JSON readers: transform files (echoreg's and their checks of a rigid
// matrix) and 3D Slicer markups. A refusal (an exception naming the file) is the expected answer
// to bad bytes; a crash, a sanitizer report, a leak or a hang is a finding.
#include "fuzz_input.hpp"

#include "echoreg/core/markups.hpp"
#include "echoreg/core/transform_file.hpp"

#include <cstddef>
#include <cstdint>
#include <new>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = echoreg::fuzz::writeInput(data, size, ".json");
  try {
    echoreg::core::readTransformFile(path, "", "");
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
  }
  try {
    echoreg::core::readMarkups(path);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
  }
  return 0;
}
