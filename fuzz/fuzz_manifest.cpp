// libFuzzer harness of the study manifest (DIR/study.json) as `echoreg study run` and `study
// compare` read it (cli/src/study_manifest.hpp): the input written as study.json in a folder of its
// own and read into the typed StudyManifest, then every file a bone's steps ask of it looked up as
// the study looks them up. A FileError naming the manifest is the expected answer to bad bytes; any
// other exception (a raw JSON library message), a crash, a sanitizer report or a hang is a finding.
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
    const echoreg::cli::StudyManifest manifest = echoreg::cli::readStudyManifest(folder);
    for (const std::string* file :
         {&manifest.ctDicom, &manifest.landmarks.ct, &manifest.landmarks.capture,
          &manifest.calibration.pivotCapture, &manifest.calibration.sphereCapture,
          &manifest.calibration.capture, &manifest.truth.transforms, &manifest.truth.shots,
          &manifest.truth.patella})
      echoreg::cli::outsideStudyFolder(*file);
    for (const echoreg::cli::ManifestBone& bone : manifest.bones) {
      for (const std::string* file :
           {&bone.model, &bone.initial, &bone.mechanical, &bone.hipRotation})
        echoreg::cli::outsideStudyFolder(*file);
      for (const std::string& capture : bone.ultrasound)
        echoreg::cli::outsideStudyFolder(capture);
      if (manifest.bone(bone.name) != &bone)
        __builtin_trap();  // the bones are looked up by name: each name once
    }
  } catch (const echoreg::core::FileError&) {
  }
  return 0;
}
