// `echoreg register`: a bone's surface registration (BoneToCT, e.g. FemurToCT) from A-mode points
// (a capture run through the detection chain, or a CSV of points), optionally with stylus points
// (the hybrid registration), started from an initial transform or from landmarks touched with
// the stylus. docs/registration.md.
#include "command_register.hpp"
#include "csv_table.hpp"
#include "json_values.hpp"
#include "model_file.hpp"
#include "path_check.hpp"
#include "pose_check.hpp"
#include "validators.hpp"

#include "echoreg/core/detection.hpp"
#include "echoreg/core/dwell.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/markups.hpp"
#include "echoreg/core/paired_point.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/surface_registration.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/mesh_io.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::cli {

namespace {

// Points from a CSV: x,y,z (or echoreg detect's x_mm,y_mm,z_mm, accepted rows only), optionally
// ox,oy,oz,dx,dy,dz,depth_mm (the beam, same frame).
std::vector<core::SurfacePoint> readPointsCsv(const std::string& path, double sigma) {
  if (std::filesystem::is_directory(path))
    throw core::FileError(path, "is a directory, expected a CSV file");
  std::ifstream in(path);
  if (!in)
    throw core::FileError(path, "cannot be opened");
  std::string line;
  if (!std::getline(in, line))
    throw core::FileError(path, "is empty (expected a header x,y,z,...)");
  const std::vector<std::string> header = splitCsvLine(line);
  std::map<std::string, std::size_t> column;
  for (std::size_t i = 0; i < header.size(); ++i)
    column[header[i]] = i;
  const auto has = [&](const char* name) { return column.count(name) != 0; };
  std::vector<std::string> xyz;
  if (has("x") && has("y") && has("z")) {
    xyz = {"x", "y", "z"};
  } else if (has("x_mm") && has("y_mm") && has("z_mm")) {
    xyz = {"x_mm", "y_mm", "z_mm"};
  } else {
    throw core::FileError(
        path, "has no columns x,y,z (or x_mm,y_mm,z_mm as echoreg detect --pose writes)");
  }
  // The beam: ox..dz with depth_mm (echoreg detect's CSV has depth_mm alone: no beam).
  const std::vector<std::string> beam{"ox", "oy", "oz", "dx", "dy", "dz", "depth_mm"};
  int beamColumns = 0;
  for (std::size_t k = 0; k < 6; ++k)
    beamColumns += has(beam[k].c_str()) ? 1 : 0;
  if (beamColumns != 0 && (beamColumns != 6 || !has("depth_mm"))) {
    throw core::FileError(path, "has some beam columns but not all of ox,oy,oz,dx,dy,dz,depth_mm");
  }
  const bool withBeam = beamColumns == 6;
  std::vector<core::SurfacePoint> points;
  std::size_t lineNumber = 1;
  while (std::getline(in, line)) {
    ++lineNumber;
    if (line.empty() || line == "\r")
      continue;
    const std::vector<std::string> cells = splitCsvLine(line);
    const auto cell = [&](const std::string& name) -> const std::string& {
      const std::size_t at = column.at(name);
      if (at >= cells.size())
        throw core::FileError(path, fmt::format("line {}: no column {}", lineNumber, name));
      return cells[at];
    };
    if (has("status") && cell("status") != "accepted")
      continue;
    if (cell(xyz[0]).empty() && cell(xyz[1]).empty() && cell(xyz[2]).empty()) {
      if (has("status"))
        continue;  // echoreg detect leaves rejected frames' points empty
      throw core::FileError(path, fmt::format("line {}: no point", lineNumber));
    }
    const Eigen::Vector3d p(parseCsvNumber(cell(xyz[0]), path, lineNumber, xyz[0]),
                            parseCsvNumber(cell(xyz[1]), path, lineNumber, xyz[1]),
                            parseCsvNumber(cell(xyz[2]), path, lineNumber, xyz[2]));
    core::SurfacePoint point;
    if (withBeam) {
      double v[7];
      for (std::size_t k = 0; k < 7; ++k)
        v[k] = parseCsvNumber(cell(beam[k]), path, lineNumber, beam[k]);
      const Eigen::Vector3d origin(v[0], v[1], v[2]), direction(v[3], v[4], v[5]);
      if (std::abs(direction.norm() - 1.0) > 1e-3) {
        throw core::FileError(
            path, fmt::format("line {}: beam direction dx,dy,dz is not unit (length {:.4g})",
                              lineNumber, direction.norm()));
      }
      point = core::beamSurfacePoint(origin, direction, v[6], sigma);
      if ((point.point - p).norm() > 0.01) {
        throw core::FileError(
            path, fmt::format("line {}: x,y,z is {:.3f} mm from origin + depth * direction",
                              lineNumber, (point.point - p).norm()));
      }
    } else {
      point.point = p;
      point.sigmaMm = sigma;
    }
    points.push_back(point);
  }
  if (points.empty())
    throw core::FileError(path, "holds no points");
  return points;
}

// Points (with their beams, in the bone frame) of a capture's detection: each accepted frame's
// beam, from the same poses the pipeline placed its point with. The capture's row goes to
// `report`; an assumed sampling frequency, to `warnings` as well.
std::vector<core::SurfacePoint> capturePoints(const CaptureDetection& capture,
                                              const CaptureDetectionRequest& request,
                                              double ultrasoundSigma, nlohmann::json& report,
                                              std::vector<std::string>& warnings) {
  const core::SequenceDetection& detection = capture.detection;
  const core::Sequence& sequence = capture.sequence();
  std::vector<core::SurfacePoint> points;
  for (const core::FrameDetection& f : detection.frames) {
    if (!f.accepted() || !f.depthMm || !f.pointMm)
      continue;
    const auto& transforms = sequence.frames[static_cast<std::size_t>(f.frame)].transforms;
    const Eigen::Matrix4d beamToBone = transforms.at(request.referenceTransform).matrix.inverse() *
                                       transforms.at(request.poseTransform).matrix *
                                       request.beamToProbe;
    const Eigen::Vector3d origin = beamToBone.topRightCorner<3, 1>();
    const Eigen::Vector3d direction = beamToBone.block<3, 1>(0, 2).normalized();
    points.push_back(core::beamSurfacePoint(origin, direction, *f.depthMm, ultrasoundSigma));
  }
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, count] : detection.rejectedByReason)
    rejected[reason] = count;
  const std::string samplingSource = samplingFrequencySource(request.settings, sequence);
  if (samplingSource == "assumed")
    warnings.push_back(assumedSamplingFrequencyWarning(request.capture,
                                                       detection.params.depth.samplingFrequencyHz));
  report.push_back({{"capture", request.capture},
                    {"frames", detection.frames.size()},
                    {"accepted", detection.accepted},
                    {"rejected_by_reason", rejected},
                    {"speed_of_sound_mps", detection.params.depth.speedOfSoundMps},
                    {"sampling_frequency_hz", detection.params.depth.samplingFrequencyHz},
                    {"sampling_frequency_source", samplingSource}});
  return points;
}

// Stylus points on the bone: the ball-tip centre (bone frame) of every dwell of the stylus (a
// touched point is held still for a moment; docs/registration.md).
std::vector<core::SurfacePoint> stylusPoints(const std::string& path,
                                             const Eigen::Isometry3d& tipToStylus,
                                             const std::string& referenceTransform,
                                             const RegisterOptions& o, PoseNotes& poseNotes) {
  const core::Sequence capture =
      readTrackedSequence(path, {"StylusToTracker", referenceTransform}, poseNotes);
  std::vector<core::Dwell> dwells;
  try {
    const core::StylusTrack track =
        core::stylusTipTrack(capture, tipToStylus, "StylusToTracker", referenceTransform);
    // A touched point is held for a fraction of a second (the simulator: 0.2 s at 100 Hz), much
    // shorter than a landmark's dwell.
    core::DwellOptions dwellOptions;
    dwellOptions.minDurationS = 0.1;
    dwellOptions.minFrames = 5;
    dwellOptions.smoothingS = 0.05;
    dwellOptions.mergeDistanceMm = o.stylusSpacing;
    dwells = core::detectDwells(track.tipInReference, track.timestampsS, track.valid, dwellOptions);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(path, e.what());
  }
  std::vector<core::SurfacePoint> points;
  for (const core::Dwell& d : dwells) {
    core::SurfacePoint p;
    p.point = d.meanMm;
    p.source = core::PointSource::Stylus;
    p.sigmaMm = o.stylusSigma;
    p.surfaceOffsetMm = o.stylusTipRadius;
    points.push_back(p);
  }
  if (points.empty())
    throw core::FileError(path, "has no dwell of the stylus (no touched point)");
  return points;
}

struct LandmarkInit {
  std::vector<core::LandmarkPair> pairs;
  nlohmann::json report;
};

// The landmarks touched in the capture (dwells of the stylus tip in the bone's frame), matched in
// order to the named CT landmarks.
LandmarkInit landmarksFromCapture(const RegisterOptions& o, const std::string& referenceTransform,
                                  PoseNotes& poseNotes) {
  const std::vector<core::MarkupPoint> all = core::readMarkupPoints(o.landmarksCt);
  std::vector<core::MarkupPoint> chosen;
  if (o.landmarkLabels.empty()) {
    for (const core::MarkupPoint& p : all) {
      if (o.hipCentre.empty() || p.label != o.hipLabel)
        chosen.push_back(p);  // the hip is no dwell
    }
  } else {
    for (const std::string& label : splitCsvLine(o.landmarkLabels)) {
      const auto found = std::find_if(all.begin(), all.end(),
                                      [&](const core::MarkupPoint& p) { return p.label == label; });
      if (found == all.end()) {
        std::string have;
        for (const core::MarkupPoint& p : all)
          have += (have.empty() ? "" : ", ") + p.label;
        throw core::FileError(o.landmarksCt,
                              "has no landmark '" + label + "' (it has " + have + ")");
      }
      chosen.push_back(*found);
    }
  }
  if (chosen.size() < 2) {
    throw core::FileError(
        o.landmarksCt, fmt::format("{} landmark(s) chosen: at least 2 are needed", chosen.size()));
  }
  const core::TransformFile tip = core::readTransformFile(o.tipFile, "StylusTip", "Stylus");
  Eigen::Isometry3d tipToStylus;
  tipToStylus.matrix() = tip.matrix;
  const core::Sequence capture =
      readTrackedSequence(o.landmarksCapture, {"StylusToTracker", referenceTransform}, poseNotes);
  std::vector<core::Dwell> dwells;
  try {
    const core::StylusTrack track =
        core::stylusTipTrack(capture, tipToStylus, "StylusToTracker", referenceTransform);
    dwells = core::detectDwells(track.tipInReference, track.timestampsS, track.valid,
                                core::DwellOptions{});
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.landmarksCapture, e.what());
  }
  std::vector<Eigen::Vector3d> ct;
  for (const core::MarkupPoint& p : chosen)
    ct.push_back(p.positionLps);
  std::vector<int> index;
  double runnerUp = std::numeric_limits<double>::infinity();
  if (!o.landmarkDwells.empty()) {
    if (o.landmarkDwells.size() != chosen.size()) {
      throw std::invalid_argument(fmt::format("--landmark-dwells gives {} dwells for {} landmarks",
                                              o.landmarkDwells.size(), chosen.size()));
    }
    for (int d : o.landmarkDwells) {
      if (d < 0 || static_cast<std::size_t>(d) >= dwells.size()) {
        throw core::FileError(
            o.landmarksCapture,
            fmt::format("has {} dwells; --landmark-dwells names dwell {}", dwells.size(), d));
      }
    }
    index = o.landmarkDwells;
  } else if (chosen.size() >= 3) {
    try {
      const core::DwellMatch match = core::matchDwellsInOrder(dwells, ct);
      index = match.dwellIndex;
      runnerUp = match.runnerUpFreMm;
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o.landmarksCapture, e.what());
    }
  } else {
    // Two landmarks: the in-order pair of dwells whose distance best matches the CT's.
    if (dwells.size() < 2) {
      throw core::FileError(
          o.landmarksCapture,
          fmt::format("{} dwell(s) of the stylus found: 2 needed", dwells.size()));
    }
    const double length = (ct[1] - ct[0]).norm();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < dwells.size(); ++i) {
      for (std::size_t j = i + 1; j < dwells.size(); ++j) {
        const double mismatch = std::abs((dwells[j].meanMm - dwells[i].meanMm).norm() - length);
        if (mismatch < best) {
          runnerUp = best;
          best = mismatch;
          index = {static_cast<int>(i), static_cast<int>(j)};
        } else {
          runnerUp = std::min(runnerUp, mismatch);
        }
      }
    }
    if (best > 15.0) {
      throw core::FileError(
          o.landmarksCapture,
          fmt::format(
              "no two dwells lie {:.1f} mm apart as {} and {} do (best {:.1f} mm off); name them "
              "with --landmark-dwells",
              length, chosen[0].label, chosen[1].label, best));
    }
    if (runnerUp - best < 2.0) {
      throw core::FileError(
          o.landmarksCapture,
          fmt::format(
              "{} dwells and two pairs match the landmarks' distance within 2 mm of each other; "
              "name the dwells with --landmark-dwells",
              dwells.size()));
    }
  }
  LandmarkInit init;
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    const core::Dwell& d = dwells[static_cast<std::size_t>(index[i])];
    init.pairs.push_back({chosen[i].label, d.meanMm, chosen[i].positionLps, o.landmarkSigma});
    list.push_back({{"label", chosen[i].label},
                    {"dwell", index[i]},
                    {"first_frame", d.firstFrame},
                    {"last_frame", d.lastFrame},
                    {"measured_mm", vec(d.meanMm)}});
  }
  if (!o.hipCentre.empty()) {
    // The hip centre: the pivot of the femur's marker (echoreg pivot --marker FemurToTracker)
    // paired with the CT landmark --hip-label; far from the knee, it fixes the rotations.
    const core::TransformFile hip = core::readTransformFile(o.hipCentre, "", o.bone);
    const auto found = std::find_if(
        all.begin(), all.end(), [&](const core::MarkupPoint& p) { return p.label == o.hipLabel; });
    if (found == all.end())
      throw core::FileError(o.landmarksCt, "has no landmark '" + o.hipLabel + "' (--hip-label)");
    init.pairs.push_back(
        {o.hipLabel, hip.matrix.topRightCorner<3, 1>(), found->positionLps, o.hipSigma});
    list.push_back({{"label", o.hipLabel},
                    {"measured_mm", vec(hip.matrix.topRightCorner<3, 1>())},
                    {"from", o.hipCentre}});
  }
  init.report = {{"dwells_found", dwells.size()}, {"landmarks", list}};
  if (std::isfinite(runnerUp))
    init.report["runner_up_mm"] = runnerUp;
  return init;
}

}  // namespace

RegistrationModel loadRegistrationModel(const RegisterOptions& o) {
  if (o.bone.empty() || o.bone.find("To") != std::string::npos) {
    throw std::invalid_argument("--bone must name the bone's frame, e.g. Femur, got '" + o.bone +
                                "'");
  }
  if (!(o.ultrasoundSigma > 0.0) || !(o.stylusSigma > 0.0) || !(o.landmarkSigma > 0.0)) {
    throw std::invalid_argument(
        "--ultrasound-sigma, --stylus-sigma and --landmark-sigma must be > 0 mm");
  }
  if (o.stylusTipRadius < 0.0)
    throw std::invalid_argument("--stylus-tip-radius must be >= 0 mm");
  RegistrationModel loaded;
  core::SurfaceRegistrationOptions& options = loaded.options;
  options.method = core::parseSurfaceMethod(o.method);
  options.loss = core::parseRobustLoss(o.loss);
  options.fitSpeedOfSound = o.fitSpeed;
  options.restarts = o.restarts;
  options.seed = o.seed;
  options.axisStarts = o.axisStarts;
  options.maxRmsMm = o.maxRms;

  // The model first: a bad model fails before the long detection.
  int& capTriangles = loaded.capTriangles;
  try {
    core::TriangleMesh mesh = readModelFile(o.model);
    if (o.openEnds) {
      options.excludedTriangles = core::scanEndCaps(mesh);
      capTriangles = static_cast<int>(
          std::count(options.excludedTriangles.begin(), options.excludedTriangles.end(), true));
      if (capTriangles == 0) {
        throw core::FileError(o.model,
                              "--open-ends: the model has no flat cap at its lowest or highest z "
                              "(was it cut by the scan range?)");
      }
    }
    loaded.model = std::make_unique<core::SurfaceRegistration>(std::move(mesh));
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.model, e.what());
  }

  return loaded;
}

RegistrationStart registrationStart(const RegisterOptions& o,
                                    core::SurfaceRegistrationOptions& options,
                                    PoseNotes& poseNotes) {
  const std::string reference = o.bone + "ToTracker";
  RegistrationStart start;
  std::vector<core::LandmarkPair>& landmarks = start.landmarks;
  nlohmann::json& initReport = start.report;
  if (!o.initial.empty()) {
    const core::TransformFile initial = core::readTransformFile(o.initial, o.bone, "CT");
    options.initial.matrix() = initial.matrix;
    initReport = {{"initial", o.initial}};
  } else {
    LandmarkInit init = landmarksFromCapture(o, reference, poseNotes);
    landmarks = init.pairs;
    initReport = init.report;
    const core::LandmarkSpread spread = core::landmarkSpread(landmarks);
    if (!spread.collinear) {
      std::vector<Eigen::Vector3d> bone, ct;
      std::vector<double> weights;
      for (const core::LandmarkPair& l : landmarks) {
        bone.push_back(l.bone);
        ct.push_back(l.model);
        weights.push_back(1.0 / (l.sigmaMm * l.sigmaMm));
      }
      const core::PairedPointResult paired = core::registerPairedPoints(bone, ct, weights);
      options.initial = paired.transform;
      initReport["method"] = "paired-point";
      initReport["fre_mm"] = paired.freMm;
    } else {
      // Two landmarks (or all on one line) leave the rotation about their line open: start from
      // evenly spaced turns about it and keep the start of least robust cost.
      const core::LandmarkPair& a = landmarks[static_cast<std::size_t>(spread.first)];
      const core::LandmarkPair& b = landmarks[static_cast<std::size_t>(spread.second)];
      try {
        options.initial = core::poseFromTwoLandmarks(a, b);
      } catch (const std::invalid_argument& e) {
        throw core::FileError(o.landmarksCapture, e.what());
      }
      options.searchAboutAxis = true;
      options.axisPoint = a.bone;
      options.axisDirection = b.bone - a.bone;
      initReport["method"] = "two-landmark line, rotation about it searched";
      initReport["axis_starts"] = o.axisStarts;
    }
  }

  return start;
}

CaptureDetectionRequest sweepDetectionRequest(const RegisterOptions& o, const std::string& capture,
                                              const Eigen::Matrix4d& beamToProbe) {
  CaptureDetectionRequest request;
  request.capture = capture;
  request.preset = o.preset;
  request.settings = o.detection;
  if (!o.paramsFile.empty())
    mergeParamsFile(o.paramsFile, request.preset, request.settings);
  // register's own defaults, below --params and the flags: each echo judged alone (the robust
  // loss rejects strays), and points at least 1 mm apart.
  request.settings.emplace("history", 1);
  request.settings.emplace("min-spread-mm", 1.0);
  if (request.preset.empty())
    request.preset = "default";
  request.poseTransform = "ProbeToTracker";
  request.referenceTransform = o.bone + "ToTracker";
  request.beamToProbe = beamToProbe;
  return request;
}

nlohmann::json requestJson(const RegisterOptions& o) {
  return {{"model", o.model},
          {"bone", o.bone},
          {"out", o.out},
          {"captures", o.captures},
          {"calibration", o.calibration},
          {"points", o.pointsCsv},
          {"initial", o.initial},
          {"landmarks_ct", o.landmarksCt},
          {"landmarks_capture", o.landmarksCapture},
          {"stylus_tip_to_stylus", o.tipFile},
          {"landmark_labels", o.landmarkLabels},
          {"landmark_dwells", o.landmarkDwells},
          {"landmark_sigma_mm", o.landmarkSigma},
          {"hip_centre", o.hipCentre},
          {"hip_label", o.hipLabel},
          {"hip_sigma_mm", o.hipSigma},
          {"stylus_points", o.stylusCaptures},
          {"stylus_tip_radius_mm", o.stylusTipRadius},
          {"stylus_sigma_mm", o.stylusSigma},
          {"stylus_spacing_mm", o.stylusSpacing},
          {"ultrasound_sigma_mm", o.ultrasoundSigma},
          {"preset", o.preset},
          {"params", o.paramsFile},
          {"detection", settingsJson(o.detection)},
          {"method", o.method},
          {"loss", o.loss},
          {"fit_speed_of_sound", o.fitSpeed},
          {"open_ends", o.openEnds},
          {"restarts", o.restarts},
          {"axis_starts", o.axisStarts},
          {"seed", o.seed},
          {"max_rms_mm", o.maxRms},
          {"max_points", o.maxPoints},
          {"json", o.json}};
}

void checkRegistrationPoints(const RegisterOptions& o,
                             const std::vector<core::SurfacePoint>& points) {
  // Bounded before the solver runs: its time and memory grow with the points (10^6 took 103 s and
  // 1.6 GB), and an A-mode registration uses tens to thousands.
  if (points.size() > static_cast<std::size_t>(o.maxPoints)) {
    const std::string from = !o.pointsCsv.empty()     ? "--points " + o.pointsCsv
                             : o.captures.size() == 1 ? "--capture " + o.captures.front()
                             : !o.captures.empty()    ? std::string("--capture")
                                                      : std::string("--stylus-points");
    throw std::invalid_argument(fmt::format(
        "{} gives {} points, more than --max-points {} (the registration's time and memory grow "
        "with the points; A-mode registrations use tens to thousands): thin the points, or raise "
        "--max-points",
        from, points.size(), o.maxPoints));
  }
  if (points.size() < 3) {
    const std::string from = !o.pointsCsv.empty()        ? o.pointsCsv
                             : !o.captures.empty()       ? o.captures.front()
                             : !o.stylusCaptures.empty() ? o.stylusCaptures.front()
                                                         : o.model;
    throw core::FileError(
        from,
        fmt::format("{} point(s) found: at least 3 are needed for a registration", points.size()));
  }
  if (o.fitSpeed && std::none_of(points.begin(), points.end(),
                                 [](const core::SurfacePoint& p) { return p.hasBeam; })) {
    throw std::invalid_argument(
        "--fit-speed-of-sound needs the points' beams: give --capture, or a CSV with "
        "ox,oy,oz,dx,dy,dz,depth_mm");
  }
}

int runRegister(const RegisterOptions& o, const Streams& io, CaptureDetections* shared) {
  CommandPaths()
      .input("--model", o.model)
      .inputs("--capture", o.captures)
      .input("--calibration", o.calibration)
      .input("--params", o.paramsFile)
      .input("--points", o.pointsCsv)
      .inputs("--stylus-points", o.stylusCaptures)
      .input("--initial", o.initial)
      .input("--landmarks-ct", o.landmarksCt)
      .input("--landmarks-capture", o.landmarksCapture)
      .input("--stylus-tip-to-stylus", o.tipFile)
      .input("--hip-centre", o.hipCentre)
      .transformOutput("--out", o.out)
      .check();
  const std::string reference = o.bone + "ToTracker";
  RegistrationModel loaded = loadRegistrationModel(o);
  core::SurfaceRegistrationOptions& options = loaded.options;

  // The points.
  PoseNotes poseNotes;
  std::vector<std::string> warnings;
  std::vector<core::SurfacePoint> points;
  nlohmann::json sources = nlohmann::json::array();
  std::optional<double> speedOfSound;  ///< the detection's, when the points were detected here
  if (!o.pointsCsv.empty()) {
    points = readPointsCsv(o.pointsCsv, o.ultrasoundSigma);
    sources.push_back({{"points", o.pointsCsv}, {"count", points.size()}});
  } else if (!o.captures.empty()) {
    const core::TransformFile calibration = core::readTransformFile(o.calibration, "Beam", "Probe");
    for (const std::string& capture : o.captures) {
      const CaptureDetectionRequest request = sweepDetectionRequest(o, capture, calibration.matrix);
      std::unique_ptr<CaptureDetection> own;
      CaptureDetection& detected =
          shared != nullptr ? shared->get(request) : *(own = detectCapture(request));
      poseNotes.reorthonormalised += detected.poseNotes.reorthonormalised;
      poseNotes.lines.insert(poseNotes.lines.end(), detected.poseNotes.lines.begin(),
                             detected.poseNotes.lines.end());
      speedOfSound = detected.detection.params.depth.speedOfSoundMps;
      const std::vector<core::SurfacePoint> found =
          capturePoints(detected, request, o.ultrasoundSigma, sources, warnings);
      points.insert(points.end(), found.begin(), found.end());
    }
  }
  if (!o.stylusCaptures.empty()) {
    const core::TransformFile tip = core::readTransformFile(o.tipFile, "StylusTip", "Stylus");
    Eigen::Isometry3d tipToStylus;
    tipToStylus.matrix() = tip.matrix;
    for (const std::string& capture : o.stylusCaptures) {
      const std::vector<core::SurfacePoint> found =
          stylusPoints(capture, tipToStylus, reference, o, poseNotes);
      points.insert(points.end(), found.begin(), found.end());
      sources.push_back({{"stylus_capture", capture}, {"points", found.size()}});
    }
  }
  checkRegistrationPoints(o, points);

  // The start.
  const RegistrationStart start = registrationStart(o, options, poseNotes);
  RegistrationPoints gathered;
  gathered.points = std::move(points);
  gathered.sources = std::move(sources);
  gathered.speedOfSoundMps = speedOfSound;
  gathered.poseNotes = std::move(poseNotes);
  gathered.warnings = std::move(warnings);
  return solveAndWrite(o, loaded, start, gathered, io);
}

int solveAndWrite(const RegisterOptions& o, const RegistrationModel& loaded,
                  const RegistrationStart& start, const RegistrationPoints& gathered,
                  const Streams& io, const std::string& command) {
  const std::vector<core::SurfacePoint>& points = gathered.points;
  const core::SurfaceRegistrationOptions& options = loaded.options;
  const PoseNotes& poseNotes = gathered.poseNotes;
  const int capTriangles = loaded.capTriangles;
  const int ultrasoundCount =
      static_cast<int>(std::count_if(points.begin(), points.end(), [](const core::SurfacePoint& p) {
        return p.source == core::PointSource::Ultrasound;
      }));
  const std::vector<core::LandmarkPair>& landmarks = start.landmarks;
  const nlohmann::json& initReport = start.report;

  const core::SurfaceRegistrationResult r =
      loaded.model->registerPoints(points, landmarks, options);

  core::TransformFile out;
  out.from = o.bone;
  out.to = "CT";
  out.matrix = r.transform.matrix();
  nlohmann::json residuals = nlohmann::json::array();
  for (std::size_t i = 0; i < points.size(); ++i) {
    residuals.push_back(
        {{"source", points[i].source == core::PointSource::Stylus ? "stylus" : "ultrasound"},
         {"residual_mm", r.residualsMm[i]},
         {"inlier", static_cast<bool>(r.inlier[i])}});
  }
  nlohmann::json landmarkResiduals = nlohmann::json::array();
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    landmarkResiduals.push_back(
        {{"label", landmarks[i].name}, {"residual_mm", r.landmarkResidualsMm[i]}});
  out.extra = {
      {"rms_mm", r.rmsMm},
      {"rms_over", "inliers"},
      {"excluded_cap_triangles", capTriangles},
      {"points_beyond_model", r.pointsBeyondModel},
      {"rotation_sigma_deg", std::isfinite(r.rotationSigmaDeg) ? nlohmann::json(r.rotationSigmaDeg)
                                                               : nlohmann::json("inf")},
      {"translation_sigma_mm", std::isfinite(r.translationSigmaMm)
                                   ? nlohmann::json(r.translationSigmaMm)
                                   : nlohmann::json("inf")},
      {"weakest_rotation_axis", {r.weakestAxis.x(), r.weakestAxis.y(), r.weakestAxis.z()}},
      {"rms_all_mm", r.rmsAllMm},
      {"points_used", r.pointsUsed},
      {"points_rejected", r.pointsRejected},
      {"ultrasound_points", ultrasoundCount},
      {"stylus_points", static_cast<int>(points.size()) - ultrasoundCount},
      {"speed_of_sound_scale", r.speedOfSoundScale},
      {"iterations", r.iterations},
      {"starts", r.starts},
      {"converged", r.converged},
      {"method", o.method},
      {"loss", options.method == core::SurfaceMethod::Robust ? nlohmann::json(o.loss)
                                                             : nlohmann::json(nullptr)},
      {"sources", gathered.sources},
      {"start", initReport},
      {"landmark_residuals", landmarkResiduals},
      {"points", residuals}};
  if (gathered.speedOfSoundMps)
    out.extra["speed_of_sound_mps"] = *gathered.speedOfSoundMps * r.speedOfSoundScale;
  if (!r.converged)
    out.extra["message"] = r.message;
  // A start from two landmarks leaves the rotation about their line to the surface points: on a
  // round surface (the femur's condyles) a wrong rotation can fit them as well as the right one,
  // and no fit statistic shows it. Said in the result and on stderr, never silently.
  std::vector<std::string> warnings = gathered.warnings;
  if (options.searchAboutAxis) {
    warnings.push_back(
        "started from two landmarks: the rotation about their line rests on the surface points "
        "alone, which a round surface cannot always fix (docs/registration.md, finding b); " +
        std::string(o.bone == "Femur" ? "give --hip-centre" : "give a third landmark") +
        " to tie it down");
  }
  out.extra["warnings"] = warnings;
  out.extra["poses_reorthonormalised"] = poseNotes.reorthonormalised;
  const std::string tfm = core::writeTransformFile(o.out, out);
  if (o.json) {
    nlohmann::json summary = out.extra;
    summary.erase("points");
    summary["out"] = o.out;
    summary["tfm"] = tfm;
    summary["matrix"] = core::matrixRows(out.matrix);
    io.out << summary.dump(2) << "\n";
  } else {
    io.out << fmt::format(
        "{}: {}ToCT, RMS {:.3f} mm over {} inliers ({:.3f} mm over all {}), {} rejected, "
        "speed-of-sound scale {:.4f}, {} iterations, {} start(s){}\n",
        o.out, o.bone, r.rmsMm, r.pointsUsed, r.rmsAllMm, points.size(), r.pointsRejected,
        r.speedOfSoundScale, r.iterations, r.starts, r.converged ? "" : ", NOT CONVERGED");
  }
  for (const std::string& warning : warnings)
    io.err << "echoreg " << command << ": warning: " << warning << "\n";
  poseNotes.print(io.err, command);
  if (!r.converged) {
    io.err << fmt::format("echoreg {}: {}: not converged: {} (written with \"converged\": false)\n",
                          command, o.out, r.message);
    return 1;
  }
  return 0;
}

void addSolverOptions(CLI::App* cmd, std::string& method, std::string& loss) {
  // The names are core's (parseSurfaceMethod, parseRobustLoss): one list, one message.
  const auto accepted = [](auto parse, const char* names) {
    return CLI::Validator(
        [parse](std::string& input) -> std::string {
          try {
            parse(input);
          } catch (const std::invalid_argument& e) {
            return e.what();
          }
          return std::string();
        },
        names, "NAME");
  };
  cmd->add_option("--method", method, "robust, or plain (the dissertation's ICP)")
      ->check(accepted(core::parseSurfaceMethod, "plain or robust"))
      ->capture_default_str();
  cmd->add_option("--loss", loss, "robust: huber, cauchy, tukey or trim (10 %)")
      ->check(accepted(core::parseRobustLoss, "huber, cauchy, tukey or trim"))
      ->capture_default_str();
}

nlohmann::json solverJson(const std::string& method, const std::string& loss) {
  const bool robust = core::parseSurfaceMethod(method) == core::SurfaceMethod::Robust;
  core::parseRobustLoss(loss);
  return {{"method", method}, {"loss", robust ? nlohmann::json(loss) : nlohmann::json(nullptr)}};
}

CLI::Option* addRegistrationOptions(CLI::App* cmd, const std::shared_ptr<RegisterOptions>& o,
                                    const std::set<std::string>& ownTunables) {
  cmd->add_option("--model", o->model,
                  "Bone model in CT coordinates (.vtp, .stl, .ply, .obj), closed")
      ->required();
  cmd->add_option("--bone", o->bone, "The bone's tracker frame (its transform is <Bone>ToTracker)")
      ->capture_default_str();
  auto* calibration = cmd->add_option("--calibration", o->calibration,
                                      "BeamToProbe transform JSON (echoreg calibrate)")
                          ->group("Points");
  cmd->add_option("--preset", o->preset,
                  "Detection preset of the A-lines (see echoreg detect; default: the --params "
                  "file's, else default)")
      ->group("Points");
  cmd->add_option("--params", o->paramsFile,
                  "JSON object of detection parameters named as echoreg detect's flags, without "
                  "dashes (samples/params/); flags win over it")
      ->group("Points");
  // The detection's flags: three with register's ranges and defaults, the rest from the table
  // every command that detects shares (detection_params.hpp).
  TunableSettings& detection = o->detection;
  cmd->add_option_function<double>(
         "--speed-of-sound", [&detection](double v) { detection["speed-of-sound"] = v; },
         "Assumed speed, m/s (default: the capture's header)")
      ->check(finiteRange(core::kMinSpeedOfSoundMps, core::kMaxSpeedOfSoundMps))
      ->group("Points");
  cmd->add_option_function<int>(
         "--history", [&detection](int v) { detection["history"] = v; },
         "Temporal filter: frames that must agree (default 1 = off: each echo judged alone and "
         "the robust loss rejects strays; echoreg detect's default drops many frames of a quick "
         "sweep)")
      ->check(wholeNumber(1, 100))
      ->group("Points");
  cmd->add_option_function<double>(
         "--min-spread-mm", [&detection](double v) { detection["min-spread-mm"] = v; },
         "Spatial filter: min distance between points, mm (default 1; 0 = off)")
      ->check(finiteRange(0.0, 100.0))
      ->group("Points");
  std::set<std::string> declared = ownTunables;
  declared.insert({"speed-of-sound", "history", "min-spread-mm"});
  addTunableFlags(cmd, o->detection, declared);
  cmd->add_option("--ultrasound-sigma", o->ultrasoundSigma, "Ultrasound points' sigma, mm")
      ->capture_default_str()
      ->group("Points");
  auto* initial =
      cmd->add_option("--initial", o->initial, "Initial <Bone>ToCT transform JSON")->group("Start");
  auto* landmarksCt =
      cmd->add_option("--landmarks-ct", o->landmarksCt, "Landmarks in CT (3D Slicer .mrk.json)")
          ->group("Start");
  auto* landmarksCapture =
      cmd->add_option("--landmarks-capture", o->landmarksCapture,
                      "Capture of the stylus dwelling on them, in the same order")
          ->group("Start");
  cmd->add_option("--stylus-tip-to-stylus", o->tipFile,
                  "StylusTipToStylus transform JSON (echoreg pivot)")
      ->group("Start");
  cmd->add_option("--landmark-labels", o->landmarkLabels,
                  "Landmarks to use, comma-separated, in touch order")
      ->group("Start");
  cmd->add_option("--landmark-dwells", o->landmarkDwells,
                  "Dwell index per landmark (when the choice is ambiguous)")
      ->delimiter(',')
      ->group("Start");
  cmd->add_option("--landmark-sigma", o->landmarkSigma,
                  "Landmarks' localisation sigma, mm (their weight)")
      ->capture_default_str()
      ->group("Start");
  cmd->add_option("--hip-centre", o->hipCentre,
                  "Femur: HipCentreTo<Bone> JSON (echoreg pivot --marker FemurToTracker), paired "
                  "with the CT landmark --hip-label as one more landmark. Give it: from the two "
                  "epicondyles alone the rotation about their line rests on the distal femur's "
                  "round condyles, which can fit a wrong rotation well (docs/registration.md)")
      ->group("Start");
  cmd->add_option("--hip-label", o->hipLabel, "CT landmark of the hip centre")
      ->capture_default_str()
      ->group("Start");
  cmd->add_option("--hip-sigma", o->hipSigma, "Hip centre's localisation sigma, mm")
      ->capture_default_str()
      ->group("Start");
  cmd->add_option("--axis-starts", o->axisStarts, "Two landmarks: starts about their line")
      ->capture_default_str()
      ->check(wholeNumber(1, 360))
      ->group("Start");
  initial->excludes(landmarksCt);
  initial->excludes(landmarksCapture);
  landmarksCt->needs(landmarksCapture);
  landmarksCapture->needs(landmarksCt);
  cmd->add_option("--out", o->out, "<Bone>ToCT JSON to write (a .tfm is written beside it)")
      ->required();
  addSolverOptions(cmd, o->method, o->loss);
  cmd->add_flag(
      "--open-ends", o->openEnds,
      "The model was cut by the CT's scan range (echoreg segment closes it with flat caps at "
      "its lowest and highest z): points closest to those caps are not used");
  cmd->add_flag("--fit-speed-of-sound", o->fitSpeed,
                "robust: fit the speed-of-sound scale along each beam");
  cmd->add_option("--restarts", o->restarts,
                  "robust: extra starts perturbed by up to 10 deg / 10 mm")
      ->capture_default_str()
      ->check(wholeNumber(0, 1000));
  cmd->add_option("--seed", o->seed, "Seed of the restarts")->capture_default_str();
  cmd->add_option("--max-rms", o->maxRms, "Not converged when the inliers' RMS exceeds this, mm")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--max-points", o->maxPoints,
                  "Refuse more points than this (surface and stylus points together)")
      ->capture_default_str()
      ->check(wholeNumber(3, 100000000));
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  return calibration;
}

void checkRegistrationStart(const std::string& command, const RegisterOptions& o) {
  if (o.initial.empty() && o.landmarksCt.empty()) {
    throw CLI::ValidationError(
        command, "give the start: --initial, or --landmarks-ct with --landmarks-capture");
  }
  if (!o.hipCentre.empty() && o.landmarksCt.empty()) {
    throw CLI::ValidationError(command,
                               "--hip-centre needs --landmarks-ct and --landmarks-capture");
  }
}

CommandAction addRegisterCommand(CLI::App& app) {
  auto o = std::make_shared<RegisterOptions>();
  CLI::App* cmd = app.add_subcommand(
      "register",
      "Register a bone to its CT model from A-mode points (docs/registration.md): points in the\n"
      "bone tracker's frame (--bone) from captures through the detection chain, or from a CSV;\n"
      "optionally stylus points too (the hybrid registration, each source weighted by its sigma).\n"
      "Start from --initial, or from landmarks touched with the stylus (paired-point with 3 or\n"
      "more; with 2, their line, the rotation about it searched with the surface points).\n"
      "Writes <Bone>ToCT JSON (rms_mm over the inliers, rms_all_mm, points_used, points_rejected,\n"
      "speed_of_sound_scale, iterations, converged, per-point residuals) and a Slicer .tfm.\n"
      "Exit 1 with a message for bad input. A registration that did not converge (did not\n"
      "settle, too few inliers, or inliers' RMS above --max-rms) is still written, with\n"
      "\"converged\": false, reported on stderr, and the exit code is 1.");
  CLI::Option* calibration = addRegistrationOptions(cmd, o);
  auto* capture =
      cmd->add_option("--capture", o->captures, "A-line capture(s) of the bone (PLUS sequence)")
          ->group("Points");
  auto* csv =
      cmd->add_option(
             "--points", o->pointsCsv,
             "CSV of points in the bone frame: x,y,z [+ ox,oy,oz,dx,dy,dz,depth_mm], or the CSV "
             "of echoreg detect --pose ... --reference (x_mm,y_mm,z_mm of accepted rows)")
          ->group("Points");
  capture->needs(calibration);
  calibration->needs(capture);
  csv->excludes(capture);
  cmd->get_option("--params")->needs(capture);
  cmd->add_option(
         "--stylus-points", o->stylusCaptures,
         "Capture(s) of the stylus on the bone (hybrid registration; needs --stylus-tip-to-stylus)")
      ->group("Stylus points");
  cmd->add_option("--stylus-tip-radius", o->stylusTipRadius,
                  "Ball-tip radius of that stylus, mm (study manifest)")
      ->capture_default_str()
      ->group("Stylus points");
  cmd->add_option("--stylus-sigma", o->stylusSigma, "Stylus points' sigma, mm")
      ->capture_default_str()
      ->group("Stylus points");
  cmd->add_option("--stylus-spacing", o->stylusSpacing,
                  "Dwells of the stylus closer than this are one point, mm")
      ->capture_default_str()
      ->group("Stylus points");
  // Usage errors (exit 2) found once everything is parsed.
  cmd->parse_complete_callback([o] {
    if (o->captures.empty() && o->pointsCsv.empty() && o->stylusCaptures.empty()) {
      throw CLI::ValidationError("register",
                                 "give the points: --capture with --calibration, --points, or "
                                 "--stylus-points (the mechanical probe alone)");
    }
    checkRegistrationStart("register", *o);
    if ((!o->landmarksCt.empty() || !o->stylusCaptures.empty()) && o->tipFile.empty()) {
      throw CLI::ValidationError(
          "register", "--landmarks-capture and --stylus-points need --stylus-tip-to-stylus");
    }
  });
  return [o](const Streams& io) { return runRegister(*o, io); };
}

}  // namespace echoreg::cli
