// libFuzzer harness of the study manifest (DIR/study.json) as `echoreg study run` reads it
// (cli/src/study_manifest.hpp): the input written as study.json in a folder of its own, read and
// checked, then every file and number a bone's steps ask of it looked up as the study looks them
// up. A FileError naming the manifest is the expected answer to bad bytes; any other exception
// (a raw JSON library message), a crash, a sanitizer report or a hang is a finding.
#include "fuzz_input.hpp"

#include "study_manifest.hpp"

#include "echoreg/core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <filesystem>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string folder =
      echoreg::fuzz::tempFolder() + "/echoreg-fuzz-" + std::to_string(::getpid()) + ".study";
  std::filesystem::create_directories(folder);
  echoreg::fuzz::writeBytes(folder + "/study.json", reinterpret_cast<const char*>(data), size);
  try {
    const echoreg::cli::Manifest manifest(folder);
    for (const char* pointer :
         {"/ct/dicom", "/landmarks/ct", "/landmarks/capture", "/calibration/pivot_capture",
          "/calibration/sphere_capture", "/calibration/capture", "/truth/transforms",
          "/truth/shots", "/truth/patella", "/bones/femur/hip_rotation"})
      manifest.file(pointer, false);
    const nlohmann::json bones = manifest.at("/bones");
    for (const auto& [bone, entry] : bones.items()) {
      static_cast<void>(entry);
      const std::string key = "/bones/" + bone;
      manifest.file(key + "/model", false);
      manifest.file(key + "/initial", false);
      manifest.file(key + "/mechanical", false);
      manifest.file("/truth/" + bone, false);
      manifest.at(key + "/segment/seeds_ct");
      const nlohmann::json captures = manifest.at(key + "/ultrasound");
      for (const auto& capture : captures)
        manifest.resolve(capture.get<std::string>());
    }
  } catch (const echoreg::FileError&) {
  }
  return 0;
}
