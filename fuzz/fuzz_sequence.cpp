// libFuzzer harness of the PLUS sequence readers (MetaImage and NRRD, chosen by the content as
// readSequence does). A refusal (an exception naming the file) is the expected answer to bad
// bytes; a crash, a sanitizer report, a leak, a hang or std::bad_alloc (a size not checked before
// allocating) is a finding.
#include "fuzz_input.hpp"

#include "echoreg/core/sequence.hpp"

#include <cstddef>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = echoreg::fuzz::writeInput(data, size, ".igs.mha");
  try {
    const echoreg::core::Sequence sequence = echoreg::core::readSequence(path);
    std::vector<float> samples;
    for (std::size_t f = 0; f < sequence.frameCount() && sequence.hasPixels(); ++f)
      sequence.frameSamples(f, samples);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
  }
  return 0;
}
