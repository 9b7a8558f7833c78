// `echoreg landmarks`: a paired-point registration from a stylus dwelling on landmarks (the
// initial registration of a bone, or PLUS's phantom registration): dwells found in the tracked
// tip, matched in order to the landmark file, registered by weighted Horn/Umeyama.
#include "commands.hpp"
#include "json_values.hpp"
#include "path_check.hpp"
#include "pose_check.hpp"
#include "validators.hpp"

#include "echoreg/core/dwell.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/markups.hpp"
#include "echoreg/core/paired_point.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::cli {

namespace {

// "ReferenceToTracker" -> "Reference". Throws std::invalid_argument for a name without "To".
std::string fromFrame(const std::string& transform, const char* option) {
  const auto at = transform.find("To");
  if (at == std::string::npos || at == 0) {
    throw std::invalid_argument(std::string(option) +
                                " must name a transform like ReferenceToTracker, got '" +
                                transform + "'");
  }
  return transform.substr(0, at);
}

// Splits "a,b,c" into its non-empty names.
std::vector<std::string> splitLabels(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::size_t end = comma == std::string::npos ? text.size() : comma;
    if (end > start)
      out.push_back(text.substr(start, end - start));
    if (comma == std::string::npos)
      break;
    start = comma + 1;
  }
  return out;
}

struct LandmarksOptions {
  std::string capture, tipFile, reference = "ReferenceToTracker", stylus = "StylusToTracker";
  std::string landmarks, labels, landmarksFrame = "CT", out;
  core::DwellOptions dwell;
  bool invert = false;
  bool json = false;
};

int runLandmarks(const LandmarksOptions& o, const Streams& io) {
  CommandPaths()
      .input("--capture", o.capture)
      .input("--stylus-tip-to-stylus", o.tipFile)
      .input("--landmarks", o.landmarks)
      .transformOutput("--out", o.out)
      .check();
  const std::string referenceFrame =
      o.reference == "Tracker" ? std::string("Tracker") : fromFrame(o.reference, "--reference");
  fromFrame(o.stylus, "--stylus");
  if (o.landmarksFrame.empty())
    throw std::invalid_argument("--landmarks-frame must not be empty");

  // The landmarks, all of the file or the named ones in the given order.
  const std::vector<core::MarkupPoint> all = core::readMarkupPoints(o.landmarks);
  std::vector<core::MarkupPoint> landmarks;
  if (o.labels.empty()) {
    landmarks = all;
  } else {
    for (const std::string& label : splitLabels(o.labels)) {
      const core::MarkupPoint* found = nullptr;
      for (const core::MarkupPoint& p : all) {
        if (p.label == label)
          found = &p;
      }
      if (found == nullptr) {
        std::string have;
        for (const core::MarkupPoint& p : all)
          have += (have.empty() ? "" : ", ") + p.label;
        throw core::FileError(o.landmarks, "has no landmark '" + label + "' (it has " + have + ")");
      }
      landmarks.push_back(*found);
    }
  }
  if (landmarks.size() < 3) {
    throw core::FileError(
        o.landmarks, fmt::format("{} landmarks{}: at least 3 are needed for a registration",
                                 landmarks.size(), o.labels.empty() ? "" : " named by --labels"));
  }

  const core::TransformFile tip = core::readTransformFile(o.tipFile, "StylusTip", "Stylus");
  Eigen::Isometry3d tipToStylus;
  tipToStylus.matrix() = tip.matrix;
  PoseNotes poseNotes;
  const core::Sequence capture = readTrackedSequence(
      o.capture, {o.stylus, o.reference == "Tracker" ? std::string() : o.reference}, poseNotes);
  core::StylusTrack track;
  std::vector<core::Dwell> dwells;
  try {
    track = core::stylusTipTrack(capture, tipToStylus, o.stylus,
                                 o.reference == "Tracker" ? std::string() : o.reference);
    dwells = core::detectDwells(track.tipInReference, track.timestampsS, track.valid, o.dwell);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.capture, e.what());
  }
  std::vector<Eigen::Vector3d> positions;
  for (const core::MarkupPoint& p : landmarks)
    positions.push_back(p.positionLps);
  core::DwellMatch match;
  try {
    match = core::matchDwellsInOrder(dwells, positions);
  } catch (const std::invalid_argument& e) {
    std::string detail = e.what();
    if (dwells.size() < landmarks.size()) {
      detail += fmt::format(
          " (a dwell: {} frames over {} s within {} mm; see --max-motion-mm, --min-duration-s)",
          o.dwell.minFrames, o.dwell.minDurationS, o.dwell.maxMotionMm);
    }
    throw core::FileError(dwells.size() < landmarks.size() ? o.capture : o.landmarks, detail);
  }

  const core::PairedPointResult& r = match.registration;
  nlohmann::json perLandmark = nlohmann::json::array();
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const core::Dwell& d = dwells[static_cast<std::size_t>(match.dwellIndex[i])];
    perLandmark.push_back({{"label", landmarks[i].label},
                           {"landmark_mm", vec(landmarks[i].positionLps)},
                           {"measured_mm", vec(d.meanMm)},
                           {"residual_mm", r.residualsMm[i]},
                           {"first_frame", d.firstFrame},
                           {"last_frame", d.lastFrame},
                           {"frames", d.frames},
                           {"spread_mm", d.spreadMm}});
  }
  nlohmann::json skipped = nlohmann::json::array();
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    bool used = false;
    for (int i : match.dwellIndex)
      used = used || static_cast<std::size_t>(i) == k;
    if (!used) {
      skipped.push_back({{"first_frame", dwells[k].firstFrame},
                         {"last_frame", dwells[k].lastFrame},
                         {"measured_mm", vec(dwells[k].meanMm)}});
    }
  }
  core::TransformFile out;
  out.from = o.invert ? referenceFrame : o.landmarksFrame;
  out.to = o.invert ? o.landmarksFrame : referenceFrame;
  out.matrix = o.invert ? Eigen::Matrix4d(r.transform.inverse().matrix())
                        : Eigen::Matrix4d(r.transform.matrix());
  out.extra = {
      {"fre_mm", r.freMm},
      {"runner_up_fre_mm", std::isfinite(match.runnerUpFreMm) ? nlohmann::json(match.runnerUpFreMm)
                                                              : nlohmann::json(nullptr)},
      {"dwells_found", dwells.size()},
      {"dwells_skipped", skipped},
      {"frames", capture.frames.size()},
      {"poses_reorthonormalised", poseNotes.reorthonormalised},
      {"dwell_options",
       {{"max_motion_mm", o.dwell.maxMotionMm},
        {"min_duration_s", o.dwell.minDurationS},
        {"min_frames", o.dwell.minFrames},
        {"merge_distance_mm", o.dwell.mergeDistanceMm}}},
      {"landmarks", perLandmark}};
  const std::string tfm = core::writeTransformFile(o.out, out);
  if (o.json) {
    nlohmann::json summary = out.extra;
    summary["out"] = o.out;
    summary["tfm"] = tfm;
    summary["from"] = out.from;
    summary["to"] = out.to;
    summary["matrix"] = core::matrixRows(out.matrix);
    io.out << summary.dump(2) << "\n";
  } else {
    const Eigen::Vector3d t = out.matrix.topRightCorner<3, 1>();
    io.out << fmt::format(
        "{}: {}To{} translation ({:.2f}, {:.2f}, {:.2f}) mm, FRE {:.3f} mm over {} landmarks; "
        "{} dwells found, {} skipped\n",
        o.out, out.from, out.to, t.x(), t.y(), t.z(), r.freMm, landmarks.size(), dwells.size(),
        skipped.size());
    for (const nlohmann::json& l : perLandmark) {
      io.out << fmt::format("  {}: frames {}-{}, residual {:.2f} mm\n",
                            l["label"].get<std::string>(), l["first_frame"].get<int>(),
                            l["last_frame"].get<int>(), l["residual_mm"].get<double>());
    }
  }
  poseNotes.print(io.err, "landmarks");
  return 0;
}

}  // namespace

CommandAction addLandmarksCommand(CLI::App& app) {
  auto o = std::make_shared<LandmarksOptions>();
  CLI::App* cmd = app.add_subcommand(
      "landmarks",
      "Paired-point registration from a stylus touching landmarks: the tip in the reference\n"
      "marker's frame, the dwells where it rests, matched in order to the landmarks (when the\n"
      "stylus rested elsewhere too, the in-order choice of dwells with the smallest FRE), then\n"
      "Horn/Umeyama. Writes LandmarksFrameTo<Reference> (or its inverse with --invert) with the\n"
      "FRE and per-landmark residuals, and a Slicer .tfm beside it.");
  cmd->add_option("--capture", o->capture,
                  "Tracker capture of the stylus on the landmarks (PLUS sequence)")
      ->required();
  cmd->add_option("--stylus-tip-to-stylus", o->tipFile,
                  "StylusTipToStylus transform JSON (from `echoreg pivot`)")
      ->required();
  cmd->add_option("--reference", o->reference,
                  "The reference marker's transform, e.g. ReferenceToTracker, FemurToTracker "
                  "('Tracker': none)")
      ->capture_default_str();
  cmd->add_option("--stylus", o->stylus, "The stylus' transform")->capture_default_str();
  cmd->add_option("--landmarks", o->landmarks,
                  "Landmarks (3D Slicer .mrk.json), in the order touched")
      ->required();
  cmd->add_option(
      "--labels", o->labels,
      "Comma-separated labels of the landmarks touched, in order (default: all of the file)");
  cmd->add_option("--landmarks-frame", o->landmarksFrame,
                  "Name of the landmarks' frame, e.g. CT, Phantom")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Transform JSON to write (a .tfm is written beside it)")
      ->required();
  cmd->add_flag("--invert", o->invert,
                "Write <Reference>To<LandmarksFrame> (e.g. FemurToCT) instead");
  cmd->add_option("--max-motion-mm", o->dwell.maxMotionMm,
                  "Largest tip motion within a resting run, mm")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--min-duration-s", o->dwell.minDurationS, "Shortest dwell, s")
      ->capture_default_str()
      ->check(finiteNumber(0.0, true));
  cmd->add_option("--min-frames", o->dwell.minFrames, "Fewest valid frames in a dwell")
      ->capture_default_str()
      ->check(wholeNumber(2, 1000000));
  cmd->add_option("--merge-distance-mm", o->dwell.mergeDistanceMm,
                  "Consecutive dwells closer than this are one landmark (pivoting on it), mm")
      ->capture_default_str()
      ->check(finiteNumber(0.0, true));
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  return [o](const Streams& io) { return runLandmarks(*o, io); };
}

}  // namespace echoreg::cli
