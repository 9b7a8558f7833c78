// `echoreg study run`: what the run takes from the manifest and --params before it writes
// anything (command_study_detail.hpp).
#include "command_study_detail.hpp"

#include "path_check.hpp"

#include <fmt/format.h>

#include <filesystem>

namespace echoreg::cli::detail {

namespace fs = std::filesystem;

std::string capitalised(std::string name) {
  if (!name.empty())
    name[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(name[0])));
  return name;
}

const std::string& StudyReads::operator()(const std::string& file) {
  if (!file.empty() && outsideStudyFolder(file))
    outside_.insert(file);
  return file;
}

StudyParams readStudyParams(const StudyOptions& o, const StudyManifest& manifest) {
  StudyParams params;
  if (!o.paramsFile.empty()) {
    CommandPaths().input("--params", o.paramsFile).check();
    mergeParamsFile(o.paramsFile, params.preset, params.settings);
    params.file = fs::relative(fs::absolute(o.paramsFile), fs::absolute(manifest.dir))
                      .lexically_normal()
                      .generic_string();
  }
  return params;
}

core::FileError missingInputError(const std::string& studyDir, const std::string& file,
                                  const std::string& why) {
  return core::FileError(shownInStudy(studyDir, file), fmt::format("is missing ({})", why));
}

std::vector<ManifestCalibrationSession> checkCalibrationInputs(const StudyManifest& manifest,
                                                               const std::string& studyDir) {
  const auto requirePresent = [&](const std::string& file, const std::string& what) {
    if (!fs::exists(file))
      throw missingInputError(studyDir, file, fmt::format("{} in {}", what, manifest.path));
  };
  if (!manifest.calibration.pivotCapture.empty())
    requirePresent(manifest.calibration.pivotCapture, "calibration.pivot_capture");
  std::vector<ManifestCalibrationSession> sessions = manifest.calibration.sessions;
  const bool sessionList = !sessions.empty();
  if (!sessionList) {
    sessions.push_back(
        {manifest.require(manifest.calibration.sphereCapture, "calibration.sphere_capture"),
         manifest.require(manifest.calibration.capture, "calibration.capture")});
  }
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    for (const auto& [file, key] : {std::pair{sessions[k].sphereCapture, "sphere_capture"},
                                    std::pair{sessions[k].capture, "capture"}}) {
      requirePresent(file, sessionList ? fmt::format("the {} of calibration session {} of {}", key,
                                                     k + 1, sessions.size())
                                       : fmt::format("calibration.{}", key));
    }
  }
  return sessions;
}

}  // namespace echoreg::cli::detail
