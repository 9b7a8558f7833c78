// `echoreg register`'s options and its steps that `echoreg live` shares: the model, the solver's
// options, the start (an initial pose or landmarks), and the whole command on given captures.
#pragma once

#include "commands.hpp"
#include "pose_check.hpp"

#include "echoreg/core/surface_registration.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace echoreg::cli {

struct RegisterOptions {
  std::string model, bone = "Femur", out;
  std::vector<std::string> captures;
  std::string calibration, pointsCsv;
  std::string initial, landmarksCt, landmarksCapture, tipFile, landmarkLabels;
  std::vector<int> landmarkDwells;
  double landmarkSigma = 3.0;
  std::string hipCentre, hipLabel = "hip_centre";
  double hipSigma = 2.0;
  std::vector<std::string> stylusCaptures;
  double stylusTipRadius = 0.0;
  double stylusSigma = 0.3;
  double stylusSpacing = 1.0;
  double ultrasoundSigma = 0.5;
  std::string preset = "default";
  double speedOfSound = 0.0;
  int history = 1;
  double minSpreadMm = 1.0;
  std::string method = "robust", loss = "huber";
  bool fitSpeed = false;
  bool openEnds = false;
  int restarts = 0;
  int axisStarts = 12;
  std::uint64_t seed = 1;
  double maxRms = 2.0;
  int maxPoints = 100000;
  bool json = false;
};

/// The options register and live share: --model, --bone, --calibration, the detection group
/// (--preset, --speed-of-sound, --history, --min-spread-mm, --ultrasound-sigma), the start group
/// (--initial or the landmarks, the hip centre), the solver (--method, --loss, --open-ends,
/// --fit-speed-of-sound, --restarts, --seed, --max-rms, --max-points), --out and --json. Returns
/// the --calibration option (register ties it to --capture).
CLI::Option* addRegistrationOptions(CLI::App* cmd, const std::shared_ptr<RegisterOptions>& o);

/// Usage errors of the start (exit 2), for a parse_complete_callback.
void checkRegistrationStart(const std::string& command, const RegisterOptions& o);

/// The model (checked, with the scan caps excluded for --open-ends) and the solver's options.
struct RegistrationModel {
  std::unique_ptr<core::SurfaceRegistration> model;
  core::SurfaceRegistrationOptions options;
  int capTriangles = 0;
};
/// Throws FileError naming the model, std::invalid_argument for a bad --bone or sigma.
RegistrationModel loadRegistrationModel(const RegisterOptions& o);

/// The start: --initial into options.initial, or the landmarks touched in --landmarks-capture
/// (paired-point with 3 or more; with 2, their line and the search about it).
struct RegistrationStart {
  std::vector<core::LandmarkPair> landmarks;
  nlohmann::json report;
};
RegistrationStart registrationStart(const RegisterOptions& o,
                                    core::SurfaceRegistrationOptions& options,
                                    PoseNotes& poseNotes);

/// `echoreg register` on parsed options (o.captures, o.pointsCsv or o.stylusCaptures given).
int runRegister(const RegisterOptions& o, const Streams& io);

}  // namespace echoreg::cli
