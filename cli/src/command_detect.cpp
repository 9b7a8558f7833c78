// `echoreg detect CAPTURE --out depths.csv`: the A-line chain over a capture.
#include "commands.hpp"
#include "detection_params.hpp"
#include "path_check.hpp"
#include "pose_check.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/prefault.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/detection_pipeline.h"

#include <fmt/format.h>
#include <vtkAlgorithm.h>
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkNew.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace echoreg::cli {

namespace {

struct DetectOptions {
  std::string capture;
  std::string out;
  std::string paramsFile;
  std::string pose;
  std::string reference;
  std::string beamToProbeFile;
  std::string preset;
  bool json = false;
  TunableSettings settings;
};

nlohmann::json summary(const core::SequenceDetection& detection,
                       const core::DetectionParams& params, const DetectOptions& options,
                       const std::string& preset, int posesReorthonormalised,
                       const std::string& samplingSource,
                       const std::vector<std::string>& warnings) {
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, count] : detection.rejectedByReason)
    rejected[reason] = count;
  return {{"capture", options.capture},
          {"out", options.out},
          {"preset", preset.empty() ? "default" : preset},
          {"frames", detection.frames.size()},
          {"accepted", detection.accepted},
          {"rejected", detection.frames.size() - static_cast<std::size_t>(detection.accepted)},
          {"rejected_by_reason", rejected},
          {"envelope", std::string(core::envelopeMethodName(params.envelope.method))},
          {"peaks", std::string(core::peakPolicyName(params.peaks.policy))},
          {"sampling_frequency_hz", params.depth.samplingFrequencyHz},
          {"sampling_frequency_source", samplingSource},
          {"delay_s", params.depth.delayS},
          {"speed_of_sound_mps", params.depth.speedOfSoundMps},
          {"echoes_before_inter_signal", detection.echoes},
          {"echoes_from_context", detection.fromContext},
          {"transducer_frequency_hz", detection.analysis.transducerFrequencyHz},
          {"transducer_frequency_source", detection.analysis.transducerFrequencySource},
          {"ring_down_samples", detection.analysis.ringDownSamples},
          {"ring_down_source", detection.analysis.ringDownSource},
          {"high_pass_samples", detection.analysis.highPassSamples},
          {"shadow_rule", detection.analysis.shadowRule},
          {"shadow_share", detection.analysis.shadowShare},
          {"tgc_db_per_mm", detection.analysis.tgcDbPerMm},
          {"tgc_source", detection.analysis.tgcSource},
          {"envelope_window_samples", detection.analysis.envelopeWindowSamples},
          {"warnings", warnings},
          {"poses_reorthonormalised", posesReorthonormalised}};
}

}  // namespace

CommandAction addDetectCommand(CLI::App& app) {
  auto o = std::make_shared<DetectOptions>();
  CLI::App* cmd = app.add_subcommand(
      "detect",
      "Find the bone (or sphere) echo in every A-line of a capture: envelope, peaks, depth,\n"
      "the capture's context (--echo-context: a frame judged not-bone alone takes the echo the\n"
      "frames before it agree on), then the temporal and spatial inter-signal filters. Writes\n"
      "one CSV row per frame:\n"
      "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm (+ x_mm,y_mm,z_mm with "
      "--pose).\n"
      "Parameter precedence: flags > --params file > capture header > what the preset measures\n"
      "from the capture (transducer band, ring-down, time-gain compensation, shadow rule) >\n"
      "--preset. Warns when most frames are rejected, with the reason and the setting to\n"
      "blame. docs/detection.md documents every parameter.");
  cmd->add_option("capture", o->capture,
                  "A-line capture (PLUS sequence: .igs.mha, .mhd, .igs.nrrd)")
      ->required();
  cmd->add_option("--out", o->out, "CSV to write (written whole or not at all)")->required();
  cmd->add_option("--params", o->paramsFile,
                  "JSON object of parameters named as the flags, without dashes");
  cmd->add_flag("--json", o->json, "Print a JSON summary: frames, accepted, rejected by reason");
  cmd->add_option(
      "--preset", o->preset,
      "default (any probe and anatomy: band, ring-down, time-gain compensation and shadow rule "
      "measured from the capture, the prominence policy), mozes2008 (the dissertation's chain as "
      "it was), "
      "calibration (window-max in water), shadow (the earlier default: the bone policy after a "
      "200-sample ring-down)");
  addTunableFlags(cmd, o->settings);
  CLI::Option* pose =
      cmd->add_option("--pose", o->pose, "Transform giving 3D points, e.g. ProbeToTracker")
          ->group("Points");
  cmd->add_option("--reference", o->reference, "Express points in this frame, e.g. FemurToTracker")
      ->group("Points");
  // The calibration places the beam in the probe: without the probe's pose it would be ignored.
  cmd->add_option("--beam-to-probe", o->beamToProbeFile,
                  "BeamToProbe transform JSON (default identity; needs --pose)")
      ->group("Points")
      ->needs(pose);

  return [o](const Streams& io) {
    CommandPaths()
        .input("capture", o->capture)
        .input("--params", o->paramsFile)
        .input("--beam-to-probe", o->beamToProbeFile)
        .output("--out", o->out)
        .check();
    std::string preset = o->preset;
    TunableSettings settings = o->settings;
    ParamsSources sources{o->paramsFile, {}};
    if (!o->paramsFile.empty())
      sources.fromFile = mergeParamsFile(o->paramsFile, preset, settings);
    // The per-frame tables, strings and envelope blocks of a long capture are tens of megabytes
    // allocated in many blocks: on huge pages, a few page faults instead of thousands
    // (docs/benchmarks.md).
    core::reserveHugePageHeap(std::size_t{32} << 20);
    // reader -> envelope -> peaks -> beam points -> inter-signal -> writer (detection_pipeline.h)
    filters::DetectionPipeline pipeline;
    const core::Sequence& sequence = pipeline.open(o->capture, {o->pose, o->reference});
    PoseNotes poseNotes;
    for (const auto& [transform, report] : pipeline.reader->GetRigidPoseReports()) {
      poseNotes.reorthonormalised += report.reorthonormalised;
      if (auto line = core::rigidPoseNote(report, o->capture, transform))
        poseNotes.lines.push_back(*line);
    }
    poseNotes.print(io.err, "detect");
    const core::DetectionParams params = [&] {
      try {
        return resolveParams(preset, settings, sequence, sources);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("bad parameter: ") + e.what());
      }
    }();
    core::PointFrameOptions points;
    points.poseTransform = o->pose;
    points.referenceTransform = o->reference;
    if (!o->beamToProbeFile.empty())
      points.beamToProbe = core::readTransformFile(o->beamToProbeFile, "Beam", "Probe").matrix;
    try {
      pipeline.configure(params, points);
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o->capture, e.what());
    }
    // Streamed in blocks of frames: only one block's envelopes are held at any time.
    pipeline.setFramesPerBlock(filters::DetectionPipeline::kStreamFramesPerBlock);
    // Long captures on a terminal: the progress of the streamed envelopes and echoes on one line.
    const bool showProgress = io.errIsTerminal && sequence.frameCount() > 2000;
    struct ProgressLine {
      std::ostream* err;
      std::size_t frames;
    };
    ProgressLine progressLine{&io.err, sequence.frameCount()};
    vtkNew<vtkCallbackCommand> progress;
    if (showProgress) {
      progress->SetCallback([](vtkObject* caller, unsigned long, void* data, void*) {
        const auto* line = static_cast<const ProgressLine*>(data);
        const double done = vtkAlgorithm::SafeDownCast(caller)->GetProgress();
        *line->err << fmt::format("\rdetect: {} frames, {:3.0f} %", line->frames, 100.0 * done)
                   << std::flush;
      });
      progress->SetClientData(&progressLine);
      pipeline.peaks->AddObserver(vtkCommand::ProgressEvent, progress);
    }
    pipeline.write(o->out);
    if (showProgress)
      io.err << "\n";
    const core::SequenceDetection detection = pipeline.run();
    // Where the sampling frequency came from: every depth, and every length the detector takes
    // in mm, scales with it; an assumed one is said (PLUS's Agilent recording holds none: at the
    // assumed 50 MHz its depths are 8.4 times too large).
    const std::string samplingSource = samplingFrequencySource(settings, sequence);
    std::vector<std::string> warnings;
    if (samplingSource == "assumed")
      warnings.push_back(
          assumedSamplingFrequencyWarning(o->capture, params.depth.samplingFrequencyHz));
    for (const std::string& warning : core::detectionWarnings(detection))
      warnings.push_back(warning);
    for (const std::string& warning : warnings) {
      io.err << "echoreg detect: warning: " << warning << "\n";
    }
    if (o->json) {
      io.out << summary(detection, detection.params, *o, preset, poseNotes.reorthonormalised,
                        samplingSource, warnings)
                    .dump(2)
             << "\n";
    } else {
      io.out << fmt::format("{}: {} of {} frames accepted", o->out, detection.accepted,
                            detection.frames.size());
      for (const auto& [reason, count] : detection.rejectedByReason) {
        io.out << fmt::format(", {} {}", count, reason);
      }
      io.out << "\n";
    }
    return 0;
  };
}

}  // namespace echoreg::cli
