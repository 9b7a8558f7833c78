// libFuzzer harness of the NRRD volume reader (segmentation/nrrd_volume: int16 CT or uint8 mask
// volumes with their LPS geometry, raw or gzip, as 3D Slicer writes them). A FileError naming the
// file is the expected answer to bad bytes; any other exception, a crash, a sanitizer report, a
// leak, a hang or an allocation beyond the fuzzer's limit (sizes not checked against the data) is
// a finding.
#include "fuzz_input.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/segmentation/nrrd_volume.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = echoreg::fuzz::writeInput(data, size, ".nrrd");
  try {
    const echoreg::segmentation::NrrdVolume volume = echoreg::segmentation::readNrrdVolume(path);
    const std::size_t voxels = volume.image.voxelCount();
    if ((volume.isMask ? volume.mask.size() : volume.image.hu.size()) != voxels)
      __builtin_trap();  // the voxels read are the voxels the sizes claim
  } catch (const echoreg::core::FileError&) {
  }
  return 0;
}
