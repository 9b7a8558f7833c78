// `echoreg calibrate`: BeamToProbe from a sphere in a water bath (Mozes 2008, section 4.2), and
// `echoreg pivot`: the fixed point of a marker's poses (a stylus tip, the hip centre).
#include "command_calibrate.hpp"

#include "capture_detection.hpp"
#include "commands.hpp"
#include "detection_params.hpp"
#include "json_values.hpp"
#include "path_check.hpp"
#include "pose_check.hpp"
#include "validators.hpp"

#include "echoreg/core/beam_calibration.hpp"
#include "echoreg/core/calibration_gate.hpp"
#include "echoreg/core/detection.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/fits.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/transform_file.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>

namespace echoreg::cli {

namespace {

// The poses of `transform` ("StylusToTracker") in a capture, OK frames only, with their frame
// numbers. Throws FileError when the capture has no such transform or none of it is valid.
std::vector<std::pair<int, Eigen::Isometry3d>> validPoses(const core::Sequence& sequence,
                                                          const std::string& path,
                                                          const std::string& transform) {
  const std::vector<std::string> names = sequence.transformNames();
  if (std::find(names.begin(), names.end(), transform) == names.end()) {
    std::string have;
    for (const std::string& n : names)
      have += (have.empty() ? "" : ", ") + n + "Transform";
    throw core::FileError(path, "has no " + transform + "Transform" +
                                    (have.empty() ? std::string(" (it has no transforms)")
                                                  : " (it has " + have + ")"));
  }
  std::vector<std::pair<int, Eigen::Isometry3d>> poses;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const auto it = sequence.frames[f].transforms.find(transform);
    if (it == sequence.frames[f].transforms.end() || !it->second.valid())
      continue;
    Eigen::Isometry3d pose;
    pose.matrix() = it->second.matrix;
    poses.emplace_back(static_cast<int>(f), pose);
  }
  if (poses.empty()) {
    throw core::FileError(path, "every " + transform + "Transform of its " +
                                    std::to_string(sequence.frames.size()) + " frames is INVALID");
  }
  return poses;
}

}  // namespace

nlohmann::json requestJson(const CalibrateOptions& o) {
  return {
      {"sphere_capture", o.sphereCapture},
      {"stylus_tip_to_stylus", o.tipFile},
      {"capture", o.capture},
      {"out", o.out},
      {"sphere_radius_mm", o.sphereRadius},
      {"stylus_tip_radius_mm", o.tipRadius},
      {"free_radius", o.freeRadius},
      {"initial_mm", o.initial},
      {"speed_of_sound_mps", o.speedOfSound ? nlohmann::json(*o.speedOfSound) : nlohmann::json()},
      {"window_mm", o.windowMm},
      {"params", o.paramsFile},
      {"detection", settingsJson(o.detection)},
      {"mode", o.mode},
      {"fit_speed_of_sound", o.fitSpeed},
      {"json", o.json},
      {"max_rms_mm", o.gate.maxRmsMm},
      {"max_radius_error_mm", o.gate.maxRadiusErrorMm},
      {"max_far_side_share", o.gate.maxFarSideShare},
      {"speed_of_sound_range_mps", o.speedRange},
      {"max_condition", o.maxCondition}};
}

int runCalibrate(const CalibrateOptions& o, const Streams& io) {
  CommandPaths()
      .input("--sphere-capture", o.sphereCapture)
      .input("--stylus-tip-to-stylus", o.tipFile)
      .input("--capture", o.capture)
      .input("--params", o.paramsFile)
      .transformOutput("--out", o.out)
      .check();
  if (!(o.sphereRadius > 0.0 && std::isfinite(o.sphereRadius))) {
    throw std::invalid_argument(
        fmt::format("--sphere-radius must be a finite number > 0 mm, got {}", o.sphereRadius));
  }
  if (!(o.tipRadius >= 0.0 && std::isfinite(o.tipRadius))) {
    throw std::invalid_argument(
        fmt::format("--stylus-tip-radius must be a finite number >= 0 mm, got {}", o.tipRadius));
  }
  if (o.initial.size() != 3 ||
      !std::all_of(o.initial.begin(), o.initial.end(), [](double v) { return std::isfinite(v); })) {
    throw std::invalid_argument("--initial X Y Z must be finite numbers, in mm");
  }
  // The quality gate's thresholds (docs/calibration.md, "Quality gate").
  core::CalibrationGate gate = o.gate;
  if (!(o.speedRange.size() == 2 && o.speedRange[0] > 0.0 && o.speedRange[1] > o.speedRange[0] &&
        std::isfinite(o.speedRange[1]))) {
    throw std::invalid_argument(
        "--speed-of-sound-range must be MIN MAX in m/s with 0 < MIN < MAX, finite");
  }
  gate.minSpeedOfSoundMps = o.speedRange[0];
  gate.maxSpeedOfSoundMps = o.speedRange[1];
  if (!(gate.maxRadiusErrorMm > 0.0)) {
    throw std::invalid_argument(
        fmt::format("--max-radius-error must be > 0 mm, got {}", gate.maxRadiusErrorMm));
  }
  if (!(gate.maxRmsMm > 0.0)) {
    throw std::invalid_argument(fmt::format("--max-rms must be > 0 mm, got {}", gate.maxRmsMm));
  }
  if (!(o.maxCondition >= 1.0)) {
    throw std::invalid_argument(
        fmt::format("--max-condition must be >= 1, got {}", o.maxCondition));
  }
  const std::string speedRange =
      fmt::format("{:.0f}-{:.0f} m/s", gate.minSpeedOfSoundMps, gate.maxSpeedOfSoundMps);
  if (o.speedOfSound &&
      !(*o.speedOfSound >= gate.minSpeedOfSoundMps && *o.speedOfSound <= gate.maxSpeedOfSoundMps)) {
    throw std::invalid_argument(fmt::format(
        "--speed-of-sound must be the bath's speed of sound within {} (--speed-of-sound-range), "
        "got {}",
        speedRange, *o.speedOfSound));
  }
  if (o.windowMm.size() == 2 && !(o.windowMm[0] >= 0.0 && o.windowMm[1] > o.windowMm[0])) {
    throw std::invalid_argument(
        fmt::format("--window-mm must be MIN MAX with 0 <= MIN < MAX, got {} {}", o.windowMm[0],
                    o.windowMm[1]));
  }
  // 1. The sphere's centre from the stylus tips.
  const core::TransformFile tip = core::readTransformFile(o.tipFile, "StylusTip", "Stylus");
  PoseNotes poseNotes;
  const core::Sequence sphereSequence =
      readTrackedSequence(o.sphereCapture, {"StylusToTracker"}, poseNotes);
  const auto stylusPoses = validPoses(sphereSequence, o.sphereCapture, "StylusToTracker");
  std::vector<Eigen::Vector3d> tips;
  for (const auto& [frame, pose] : stylusPoses) {
    tips.push_back(pose * Eigen::Vector3d(tip.matrix.topRightCorner<3, 1>()));
  }
  core::SphereFitOptions sphereOptions;
  if (!o.freeRadius)
    sphereOptions.radiusMm = o.sphereRadius + o.tipRadius;
  core::SphereFit sphere;
  try {
    sphere = core::fitSphere(tips, sphereOptions);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.sphereCapture,
                          std::string("the stylus points give no sphere: ") + e.what());
  }
  const double sphereRadius = o.freeRadius ? sphere.radiusMm - o.tipRadius : o.sphereRadius;
  // The radius the stylus points themselves give, to check the known one against (a wrong
  // --stylus-tip-radius or --sphere-radius moves the centre, and the calibration, by as much).
  double freeRadius = std::numeric_limits<double>::quiet_NaN();
  if (!o.freeRadius) {
    try {
      freeRadius = core::fitSphere(tips, core::SphereFitOptions{}).radiusMm;
    } catch (const std::invalid_argument&) {
      // a cap too small to fix the radius: the known radius is not checked
    }
  }

  // 2. The sphere's echo in every shot: the calibration preset (window-max) in the window.
  // reader -> envelope -> peaks -> beam points -> inter-signal (capture_detection.hpp)
  const std::unique_ptr<CaptureDetection> shotsCapture = openCapture(o.capture, {"ProbeToTracker"});
  poseNotes.reorthonormalised += shotsCapture->poseNotes.reorthonormalised;
  poseNotes.lines.insert(poseNotes.lines.end(), shotsCapture->poseNotes.lines.begin(),
                         shotsCapture->poseNotes.lines.end());
  const core::Sequence& shotsSequence = shotsCapture->sequence();
  // The parameters through the resolver every command that detects uses: the calibration
  // preset (or the --params file's), the header, --params, the flags.
  std::string preset;
  TunableSettings settings = o.detection;
  if (o.speedOfSound)
    settings["speed-of-sound"] = *o.speedOfSound;
  if (o.windowMm.size() == 2)
    settings["window-mm"] = o.windowMm;
  if (!o.paramsFile.empty())
    mergeParamsFile(o.paramsFile, preset, settings);
  if (preset.empty())
    preset = "calibration";
  // The shots are independent: no temporal or spatial filter, whatever --params says.
  settings["history"] = 1;
  settings["min-spread-mm"] = 0.0;
  core::DetectionParams params;
  try {
    params = resolveParams(preset, settings, shotsSequence);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("bad parameter: ") + e.what());
  }
  const double speed = params.depth.speedOfSoundMps;
  if (!(speed >= gate.minSpeedOfSoundMps && speed <= gate.maxSpeedOfSoundMps)) {
    if (settings.count("speed-of-sound") != 0) {
      throw core::FileError(
          o.paramsFile, fmt::format("speed-of-sound must be the bath's speed of sound within {} "
                                    "(--speed-of-sound-range), got {}",
                                    speedRange, speed));
    }
    throw core::FileError(
        o.capture, fmt::format("the speed of sound of its header, {} m/s, is outside {} "
                               "(--speed-of-sound-range): give the bath's with --speed-of-sound",
                               speed, speedRange));
  }
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  runDetection(*shotsCapture, params, points);
  const core::SequenceDetection& detection = shotsCapture->detection;
  std::vector<core::BeamShot> shots;
  std::vector<int> shotFrames;
  for (const core::FrameDetection& f : detection.frames) {
    if (!f.accepted())
      continue;
    core::BeamShot shot;
    shot.probeToTracker.matrix() = shotsSequence.frames[static_cast<std::size_t>(f.frame)]
                                       .transforms.at("ProbeToTracker")
                                       .matrix;
    shot.depthMm = *f.depthMm;
    shots.push_back(shot);
    shotFrames.push_back(f.frame);
  }

  // 3. BeamToProbe.
  core::BeamCalibrationOptions options;
  options.mode =
      o.mode == "beam" ? core::BeamCalibrationMode::Beam : core::BeamCalibrationMode::Translation;
  options.fitSpeedOfSound = o.fitSpeed;
  options.assumedSpeedOfSoundMps = params.depth.speedOfSoundMps;
  options.sphereCentreTracker = sphere.centre;
  options.sphereRadiusMm = sphereRadius;
  options.initialBeamToProbe.translation() =
      Eigen::Vector3d(o.initial[0], o.initial[1], o.initial[2]);
  options.maxConditionNumber = o.maxCondition;
  core::BeamCalibrationResult result;
  try {
    result = core::calibrateBeam(shots, options);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.capture, fmt::format("{} sphere echoes found in {} frames; {}",
                                                 shots.size(), detection.frames.size(), e.what()));
  }
  // 4. The quality gate: a converged solution can still be wrong; refused, it is not written.
  std::vector<std::string> problems =
      core::calibrationGateProblems(shots, options, result, sphere.rmsMm, gate);
  if (std::isfinite(freeRadius) &&
      !(std::abs(freeRadius - (o.sphereRadius + o.tipRadius)) <= gate.maxRadiusErrorMm)) {
    problems.insert(problems.begin(),
                    fmt::format("the stylus points lie on a sphere of radius {:.2f} mm, not the "
                                "{:.2f} mm of --sphere-radius + --stylus-tip-radius (more than "
                                "--max-radius-error {} mm apart): check both",
                                freeRadius, o.sphereRadius + o.tipRadius, gate.maxRadiusErrorMm));
  }
  if (!problems.empty()) {
    std::string list;
    for (const std::string& problem : problems)
      list += (list.empty() ? "" : "; ") + problem;
    throw std::runtime_error(fmt::format(
        "{}: not written: the calibration of {} is implausible: {} (thresholds --max-rms {} mm, "
        "--speed-of-sound-range {}; docs/calibration.md)",
        o.out, o.capture, list, gate.maxRmsMm, speedRange));
  }

  nlohmann::json rejected = nlohmann::json::object();
  int rejectedCount = 0;
  for (const auto& [reason, count] : detection.rejectedByReason) {
    rejected[reason] = count;
    rejectedCount += count;
  }
  int outliers = 0;
  nlohmann::json perShot = nlohmann::json::array();
  for (std::size_t i = 0; i < shots.size(); ++i) {
    outliers += result.used[i] ? 0 : 1;
    // The echo mapped with the calibration (and the fitted speed): the point the figure draws.
    const Eigen::Vector3d point =
        shots[i].probeToTracker *
        (result.beamToProbe *
         Eigen::Vector3d(
             0, 0, shots[i].depthMm * result.speedOfSoundMps / options.assumedSpeedOfSoundMps));
    perShot.push_back({{"frame", shotFrames[i]},
                       {"depth_mm", shots[i].depthMm},
                       {"point_mm", vec(point)},
                       {"residual_mm", result.residualsMm[i]},
                       {"used", static_cast<bool>(result.used[i])}});
  }
  if (outliers > 0)
    rejected["outlier"] = outliers;
  rejectedCount += outliers;
  nlohmann::json parameters = nlohmann::json::object();
  for (std::size_t p = 0; p < result.parameterNames.size(); ++p) {
    parameters[result.parameterNames[p]] = {
        {"value", result.parameters[static_cast<Eigen::Index>(p)]},
        {"std", result.parameterStdDev[static_cast<Eigen::Index>(p)]}};
  }
  core::TransformFile out;
  out.from = "Beam";
  out.to = "Probe";
  out.matrix = result.beamToProbe.matrix();
  out.extra = {{"rms_mm", result.rmsMm},
               {"condition_number", result.conditionNumber},
               {"shots_used", static_cast<int>(shots.size()) - outliers},
               {"shots_rejected", rejectedCount},
               {"shots_rejected_by_reason", rejected},
               {"sphere_center_mm", vec(sphere.centre)},
               {"sphere_radius_mm", sphereRadius},
               {"sphere_fit_rms_mm", sphere.rmsMm},
               {"sphere_points_used", sphere.inliers},
               {"speed_of_sound_mps", result.speedOfSoundMps},
               {"assumed_speed_of_sound_mps", options.assumedSpeedOfSoundMps},
               {"mode", o.mode},
               {"parameters", parameters},
               {"iterations", result.iterations},
               {"converged", result.converged},
               {"poses_reorthonormalised", poseNotes.reorthonormalised},
               {"shots", perShot}};
  const std::string tfm = core::writeTransformFile(o.out, out);
  if (o.json) {
    nlohmann::json summary = out.extra;
    summary.erase("shots");
    summary["out"] = o.out;
    summary["tfm"] = tfm;
    summary["matrix"] = core::matrixRows(out.matrix);
    io.out << summary.dump(2) << "\n";
  } else {
    const Eigen::Vector3d t = result.beamToProbe.translation();
    io.out << fmt::format(
        "{}: BeamToProbe translation ({:.2f}, {:.2f}, {:.2f}) mm, RMS {:.3f} mm, condition number "
        "{:.2f}, {} shots used, {} rejected; speed of sound {:.1f} m/s\n",
        o.out, t.x(), t.y(), t.z(), result.rmsMm, result.conditionNumber,
        static_cast<int>(shots.size()) - outliers, rejectedCount, result.speedOfSoundMps);
  }
  poseNotes.print(io.err, "calibrate");
  return 0;
}

namespace {

struct PivotCommandOptions {
  std::string capture, marker = "StylusToTracker", out, from;
  double minSpreadDeg = 15.0;
  double maxRmsMm = 2.0;
  bool json = false;
};

int runPivot(const PivotCommandOptions& o, const Streams& io) {
  CommandPaths().input("--capture", o.capture).transformOutput("--out", o.out).check();
  const auto at = o.marker.find("To");
  if (at == std::string::npos || at == 0) {
    throw std::invalid_argument("--marker must name a transform like StylusToTracker, got '" +
                                o.marker + "'");
  }
  const std::string markerFrame = o.marker.substr(0, at);
  std::string from = o.from;
  if (from.empty()) {
    from = markerFrame == "Stylus"  ? "StylusTip"
           : markerFrame == "Femur" ? "HipCentre"
                                    : markerFrame + "Pivot";
  }
  PoseNotes poseNotes;
  const core::Sequence sequence = readTrackedSequence(o.capture, {o.marker}, poseNotes);
  const auto poses = validPoses(sequence, o.capture, o.marker);
  std::vector<Eigen::Isometry3d> transforms;
  for (const auto& [frame, pose] : poses)
    transforms.push_back(pose);
  core::PivotOptions options;
  options.minRotationSpreadDeg = o.minSpreadDeg;
  core::PivotResult result;
  try {
    result = core::pivotCalibration(transforms, options);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.capture, e.what());
  }
  // The quality gate: poses that do not turn about one point (a stylus carried from landmark to
  // landmark, a divot that slipped) still give a least-squares point, 48 mm RMS off on PLUS's
  // landmark recording.
  if (!(result.rmsMm <= o.maxRmsMm)) {
    throw core::FileError(
        o.capture, fmt::format("the {} poses do not pivot about one point: the pivot point moves "
                               "{:.2f} mm RMS over {} poses, above --max-rms {:g} mm (a stylus in "
                               "a divot: 0.2-0.5 mm); nothing written",
                               o.marker, result.rmsMm, result.inliers, o.maxRmsMm));
  }
  core::TransformFile out;
  out.from = from;
  out.to = markerFrame;
  out.matrix.topRightCorner<3, 1>() = result.pointInMarker;
  out.extra = {{"rms_mm", result.rmsMm},
               {"pivot_point_tracker_mm", vec(result.pointInTracker)},
               {"poses_used", result.inliers},
               {"poses_rejected", static_cast<int>(sequence.frames.size()) - result.inliers},
               {"rotation_spread_deg", vec(result.rotationSpreadDeg)},
               {"poses_reorthonormalised", poseNotes.reorthonormalised}};
  const std::string tfm = core::writeTransformFile(o.out, out);
  if (o.json) {
    nlohmann::json summary = out.extra;
    summary["out"] = o.out;
    summary["tfm"] = tfm;
    summary["point_in_marker_mm"] = vec(result.pointInMarker);
    io.out << summary.dump(2) << "\n";
  } else {
    io.out << fmt::format(
        "{}: {}To{} ({:.2f}, {:.2f}, {:.2f}) mm, RMS {:.3f} mm over {} poses; rotations spread "
        "{:.1f}, {:.1f}, {:.1f} deg\n",
        o.out, from, markerFrame, result.pointInMarker.x(), result.pointInMarker.y(),
        result.pointInMarker.z(), result.rmsMm, result.inliers, result.rotationSpreadDeg.x(),
        result.rotationSpreadDeg.y(), result.rotationSpreadDeg.z());
  }
  poseNotes.print(io.err, "pivot");
  return 0;
}

}  // namespace

CommandAction addCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Calibrate the tracked transducer on a sphere in a water bath (Mozes 2008, 4.2): the\n"
      "sphere's centre from stylus points on it, the sphere's echo in every A-line (window-max in\n"
      "--window-mm), then BeamToProbe by Levenberg-Marquardt (Ceres) on r - |p - c|. Writes the\n"
      "transform JSON with rms_mm, condition_number, per-parameter std, per-shot residuals, and a\n"
      "Slicer .tfm beside it. A calibration the quality gate finds implausible (RMS, speed of\n"
      "sound, condition number, the beam's geometry on the sphere) is refused and not written.");
  cmd->add_option("--sphere-capture", o->sphereCapture, "Stylus on the sphere (StylusToTracker)")
      ->required();
  cmd->add_option("--stylus-tip-to-stylus", o->tipFile,
                  "StylusTipToStylus transform JSON (from `echoreg pivot`)")
      ->required();
  cmd->add_option("--capture", o->capture, "A-line shots at the sphere (ProbeToTracker)")
      ->required();
  cmd->add_option("--sphere-radius", o->sphereRadius, "Sphere radius, mm")->capture_default_str();
  cmd->add_option(
         "--stylus-tip-radius", o->tipRadius,
         "Radius of the stylus' ball tip, mm: tip centres lie this much outside the sphere")
      ->capture_default_str();
  cmd->add_flag("--free-radius", o->freeRadius, "Fit the sphere's radius too (stylus points only)");
  cmd->add_option("--initial", o->initial,
                  "Initial BeamToProbe translation X Y Z, mm (e.g. a CMM measurement)")
      ->expected(3)
      ->required();
  cmd->add_option_function<double>(
      "--speed-of-sound", [o](double mps) { o->speedOfSound = mps; },
      "Assumed speed of sound in the bath, m/s (default: the capture's header, else the "
      "calibration preset's); within --speed-of-sound-range");
  cmd->add_option("--window-mm", o->windowMm, "Processing window MIN MAX, mm from the beam origin")
      ->expected(2);
  auto* params =
      cmd->add_option("--params", o->paramsFile,
                      "JSON object of detection parameters named as echoreg detect's "
                      "flags, without dashes (default preset: calibration; history and "
                      "min-spread-mm are fixed at 1 and 0, the shots being independent)");
  params->group("Detection");
  // The rest of the detection's flags, from the table every command that detects shares.
  addTunableFlags(cmd, o->detection, {"speed-of-sound", "window-mm", "history", "min-spread-mm"});
  cmd->add_option("--out", o->out, "Calibration JSON to write (a .tfm is written beside it)")
      ->required();
  cmd->add_option(
         "--mode", o->mode,
         "translation (3 parameters, beam along the probe's z: the dissertation's) or beam "
         "(origin and direction, 5)")
      ->check(CLI::IsMember({"translation", "beam"}))
      ->capture_default_str();
  cmd->add_flag("--fit-speed-of-sound", o->fitSpeed,
                "Fit the bath's speed of sound as one more parameter");
  cmd->add_option("--max-rms", o->gate.maxRmsMm,
                  "Quality gate: refuse (write nothing) when the echoes, or the stylus points, lie "
                  "further off the sphere than this RMS, mm (the dissertation's: 0.55-0.91)")
      ->capture_default_str()
      ->group("Quality gate");
  cmd->add_option("--max-radius-error", o->gate.maxRadiusErrorMm,
                  "Quality gate: refuse when the stylus points' own sphere is further than this "
                  "from --sphere-radius + --stylus-tip-radius, mm (without --free-radius)")
      ->capture_default_str()
      ->group("Quality gate");
  cmd->add_option("--speed-of-sound-range", o->speedRange,
                  "Quality gate: speeds of sound accepted, assumed or fitted, MIN MAX m/s (water "
                  "0-100 degC: 1402-1555)")
      ->expected(2)
      ->capture_default_str()
      ->group("Quality gate");
  cmd->add_option("--max-condition", o->maxCondition,
                  "Quality gate: refuse when the shots do not determine the answer (condition "
                  "number above this; the dissertation's: 6.2-14.2)")
      ->capture_default_str()
      ->group("Quality gate");
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  return [o](const Streams& io) { return runCalibrate(*o, io); };
}

CommandAction addPivotCommand(CLI::App& app) {
  auto o = std::make_shared<PivotCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "pivot",
      "Pivot calibration: the point fixed in the marker's frame while it rotates about it (a\n"
      "stylus tip in a divot, or the hip centre from FemurToTracker while the leg is circled).\n"
      "Refuses poses that do not rotate enough in two directions, and poses that are not rigid\n"
      "(tracker rounding within 1e-2 is re-orthonormalised and counted).");
  cmd->add_option("--capture", o->capture, "Tracker capture (PLUS sequence)")->required();
  cmd->add_option("--marker", o->marker,
                  "The marker's transform, e.g. StylusToTracker, FemurToTracker")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Transform JSON to write (a .tfm is written beside it)")
      ->required();
  cmd->add_option(
      "--from", o->from,
      "Name of the pivot point's frame (default StylusTip for a stylus, HipCentre for the "
      "femur)");
  cmd->add_option("--min-spread-deg", o->minSpreadDeg, "Rotation needed about two axes, degrees")
      ->capture_default_str()
      ->check(finiteRange(0.0, 90.0));
  cmd->add_option("--max-rms", o->maxRmsMm,
                  "Quality gate: refuse (write nothing) when the pivot point moves more than this "
                  "RMS over the poses used, mm (a stylus in a divot: 0.2-0.5; the hip centre of a "
                  "circled femur: about 1)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  return [o](const Streams& io) { return runPivot(*o, io); };
}

}  // namespace echoreg::cli
