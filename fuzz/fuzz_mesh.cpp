// libFuzzer harness of the bone models as the commands read them (cli/src/model_file.hpp: STL,
// VTP, PLY, OBJ through VTK's readers and echoreg's checks). The first byte picks the kind, the
// rest is the file. A refusal (an exception naming the file) is the
// expected answer to bad bytes; a crash, a hang or a sanitizer report in echoreg's code is a
// finding.
#include "fuzz_input.hpp"

#include "model_file.hpp"

#include <vtkObject.h>

#include <cstddef>
#include <cstdint>
#include <new>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1)
    return 0;
  vtkObject::GlobalWarningDisplayOff();  // VTK's readers report bad files on stderr
  static const char* const kKinds[] = {".stl", ".vtp", ".ply", ".obj"};
  const std::string path = echoreg::fuzz::writeInput(data + 1, size - 1, kKinds[data[0] % 4]);
  try {
    echoreg::cli::readModelFile(path);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
  }
  return 0;
}
