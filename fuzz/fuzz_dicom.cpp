// libFuzzer harness of the DICOM CT series reader (segmentation/dicom_series, through GDCM): the
// input is a folder of up to four files (parts of the input between fuzz_input.hpp's kNextFile
// markers), listed and read as `echoreg segment --dicom` and `info` read a series. The reader's
// answer to bad bytes is a FileError naming the folder; any other exception (GDCM's own, a
// std::bad_alloc, a message without the folder), a crash, a sanitizer report, a leak or a hang is
// a finding.
#include "fuzz_input.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/segmentation/dicom_series.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string folder = echoreg::fuzz::writeFolderInput(data, size, ".dcm", 4);
  echoreg::segmentation::DicomReadOptions options;
  options.threads = 1;  // the fuzzer's process stays one thread; the result is the same bytes
  try {
    echoreg::segmentation::listDicomSeries(folder);
  } catch (const echoreg::core::FileError&) {
  }
  try {
    echoreg::segmentation::readDicomSeriesWithWarnings(folder, options);
  } catch (const echoreg::core::FileError&) {
  }
  return 0;
}
