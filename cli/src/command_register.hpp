// `echoreg register` as a typed request: the command parses its flags into RegisterOptions, and
// the study fills one per registration (no command line in between) and shares each sweep's
// detection between the sweep's points and its registration (CaptureDetections). `echoreg live`
// shares the options, the model, the solver's options and the start.
#pragma once

#include "capture_detection.hpp"
#include "commands.hpp"
#include "pose_check.hpp"

#include "echoreg/core/surface_registration.hpp"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace echoreg::cli {

/// Every setting of a registration; the defaults are the command's.
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
  std::string preset;      ///< detection preset; "" = the --params file's, else "default"
  std::string paramsFile;  ///< --params: the detection's tunables as a JSON object
  /// The detection's tunables given (detection_params.hpp); register's own defaults, below
  /// --params, are history 1 and min-spread-mm 1 (sweepDetectionRequest).
  TunableSettings detection;
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
/// (--preset, --params, every tunable of detection_params.hpp, --ultrasound-sigma), the start group
/// (--initial or the landmarks, the hip centre), the solver (--method, --loss, --open-ends,
/// --fit-speed-of-sound, --restarts, --seed, --max-rms, --max-points), --out and --json. Returns
/// the --calibration option (register ties it to --capture).
/// `ownTunables`: detection tunables the command declares itself (live: --sampling-frequency,
/// which also goes into its recording's header).
CLI::Option* addRegistrationOptions(CLI::App* cmd, const std::shared_ptr<RegisterOptions>& o,
                                    const std::set<std::string>& ownTunables = {});

/// --method and --loss of the surface solver, checked by core's parseSurfaceMethod and
/// parseRobustLoss (the names they accept, their message): register, live and study run.
void addSolverOptions(CLI::App* cmd, std::string& method, std::string& loss);

/// The solver's method and loss as a registration records them: {"method", "loss"}, the loss null
/// for plain (it uses none). Throws std::invalid_argument for a name core does not know.
nlohmann::json solverJson(const std::string& method, const std::string& loss);

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

/// The detection request of one capture of a registration: its preset, speed of sound, temporal
/// and spatial filters, the probe's pose in the bone's frame, through `beamToProbe`.
CaptureDetectionRequest sweepDetectionRequest(const RegisterOptions& options,
                                              const std::string& capture,
                                              const Eigen::Matrix4d& beamToProbe);

/// The request as JSON, every field: the study's cache key.
nlohmann::json requestJson(const RegisterOptions& options);

/// The points a registration runs on and where they came from.
struct RegistrationPoints {
  std::vector<core::SurfacePoint> points;
  /// The result's "sources": one object per capture, CSV or stylus capture.
  nlohmann::json sources = nlohmann::json::array();
  /// The detection's speed of sound, m/s, when the points were detected from A-lines.
  std::optional<double> speedOfSoundMps;
  PoseNotes poseNotes;
  /// Said in the result's "warnings" and on stderr (e.g. a capture's assumed sampling frequency).
  std::vector<std::string> warnings;
};
/// The bounds the solver needs (at most --max-points, at least 3, beams for
/// --fit-speed-of-sound), checked before it runs: std::invalid_argument, or FileError naming the
/// points' file (the first of --points, --capture, --stylus-points, else --model).
void checkRegistrationPoints(const RegisterOptions& options,
                             const std::vector<core::SurfacePoint>& points);
/// register's last step: the solver on `points` (give them to checkRegistrationPoints first)
/// from `start`, then the <Bone>ToCT JSON (with the sources, the residual of every point, the
/// start's report) and its .tfm written, the summary on io.out and the warnings on io.err;
/// returns 1 when it did not converge. `live`
/// calls it with the points it detected while the A-lines came, so the end of a session writes
/// register's files without reading its recording again. `command` names the command in the
/// messages on io.err ("echoreg live: warning: ...").
int solveAndWrite(const RegisterOptions& options, const RegistrationModel& model,
                  const RegistrationStart& start, const RegistrationPoints& points,
                  const Streams& io, const std::string& command = "register");
/// Runs the registration and writes its <Bone>ToCT JSON and .tfm; returns the exit code (1 when
/// it did not converge). With `shared`, each capture's detection is taken from (or run into) it.
/// Throws for bad input as the command does.
int runRegister(const RegisterOptions& options, const Streams& io,
                CaptureDetections* shared = nullptr);

}  // namespace echoreg::cli
