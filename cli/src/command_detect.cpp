// `echoreg detect CAPTURE --out depths.csv`: the A-line chain over a capture.
#include "commands.hpp"
#include "path_check.hpp"
#include "pose_check.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/DetectionPipeline.h"

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
#include <type_traits>
#include <variant>
#include <vector>

namespace echoreg::cli {

namespace {

// A value of one tunable, as typed on the command line or in a --params file.
using TunableValue = std::variant<int, double, std::string, bool, std::vector<double>>;

// One tunable of the chain: its flag (and, without the dashes, its key in --params files), its
// help group and text, its type (the alternative held by `type`), and where it lands.
struct Tunable {
  const char* name;
  const char* group;
  const char* help;
  TunableValue type;
  std::function<void(DetectionParams&, const TunableValue&)> apply;
};

template <typename T>
const T& as(const TunableValue& value) {
  return std::get<T>(value);
}

// Every tunable, in the order they are applied. "preset" is applied before all of them (it sets
// the starting point), then the capture header, then these.
const std::vector<Tunable>& tunables() {
  using P = DetectionParams;
  using V = TunableValue;
  static const std::vector<Tunable> list{
      {"envelope", "Envelope", "Envelope: mozes | hann | stddev | hilbert (default hann)",
       std::string(),
       [](P& p, const V& v) { p.envelope.method = parseEnvelopeMethod(as<std::string>(v)); }},
      {"transducer-frequency", "Envelope",
       "Transducer centre frequency, Hz (default: capture header, else measured from the "
       "capture's spectrum); sets the high-pass, the envelope window and the hilbert band",
       0.0,
       [](P& p, const V& v) {
         p.transducerFrequencyHz = as<double>(v);
         p.envelope.transducerFrequencyHz = as<double>(v);
       }},
      {"ring-down", "Envelope",
       "Samples of ring-down at the start of each record (default: measured where the median "
       "record's burst ends; mozes2008 and calibration: 200)",
       0,
       [](P& p, const V& v) {
         p.adapt.ringDown = false;
         p.envelope.ringDownSamples = as<int>(v);
       }},
      {"high-pass", "Envelope",
       "Conditioning high-pass corner, Hz, 0 = remove the mean only (default: half the "
       "transducer frequency; mozes2008: 0)",
       0.0,
       [](P& p, const V& v) {
         p.adapt.highPassOfTransducer = 0.0;
         p.adapt.highPassHz = as<double>(v);
         p.envelope.highPassSamples = 0;
       }},
      {"butterworth-order", "Envelope", "mozes: Butterworth order 1..12, default 2", 0,
       [](P& p, const V& v) { p.envelope.butterworthOrder = as<int>(v); }},
      {"cutoff", "Envelope", "mozes: cutoff as a fraction of Nyquist, default 0.01", 0.0,
       [](P& p, const V& v) { p.envelope.cutoffNormalized = as<double>(v); }},
      {"causal", "Envelope",
       "mozes: one causal pass as the dissertation (delays peaks by 45 samples, 0.69 mm at "
       "50 MHz/1540 m/s, for order 2 at 0.01); --causal=false is zero-phase (the default)",
       false, [](P& p, const V& v) { p.envelope.zeroPhase = !as<bool>(v); }},
      {"envelope-window", "Envelope",
       "hann/stddev: window in samples (default: 1.25 transducer periods, 7 for 9 MHz at "
       "50 MHz; PLUS uses 153 at 420 MHz)",
       0,
       [](P& p, const V& v) {
         p.adapt.envelopeCycles = 0.0;
         p.envelope.windowSamples = as<int>(v);
       }},
      {"relative-bandwidth", "Envelope", "hilbert: -6 dB band / centre, default 0.8", 0.0,
       [](P& p, const V& v) { p.envelope.relativeBandwidth = as<double>(v); }},
      {"smoothing", "Envelope", "hilbert: box smoothing in samples, default 5", 0,
       [](P& p, const V& v) { p.envelope.smoothingSamples = as<int>(v); }},
      {"threshold-factor", "Peaks", "Threshold = factor x mean envelope (default 1.5)", 0.0,
       [](P& p, const V& v) {
         p.peaks.thresholdMode = ThresholdMode::FactorOfMean;
         p.peaks.thresholdFactor = as<double>(v);
       }},
      {"threshold-of-max", "Peaks", "Threshold = fraction x max envelope, (0, 1]", 0.0,
       [](P& p, const V& v) {
         p.peaks.thresholdMode = ThresholdMode::FractionOfMax;
         p.peaks.thresholdOfMax = as<double>(v);
       }},
      {"window-mm", "Peaks", "Processing window MIN MAX in mm", std::vector<double>(),
       [](P& p, const V& v) {
         p.windowMinMm = as<std::vector<double>>(v).at(0);
         p.windowMaxMm = as<std::vector<double>>(v).at(1);
       }},
      {"peaks", "Peaks",
       "Policy: prominence (default) | bone | single | double | window-max | first | max",
       std::string(),
       [](P& p, const V& v) { p.peaks.policy = parsePeakPolicy(as<std::string>(v)); }},
      {"echo-snr", "Prominence policy", "prominence: min peak / noise floor (8)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minSnr = as<double>(v); }},
      {"echo-over-median", "Prominence policy", "prominence: min peak / median envelope (3)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minOverMedian = as<double>(v); }},
      {"echo-prominence", "Prominence policy", "prominence: min prominence / peak, (0, 1] (0.5)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.minProminence = as<double>(v); }},
      {"echo-max-rise", "Prominence policy", "prominence: max leading edge, transducer periods (3)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.maxRiseCycles = as<double>(v); }},
      {"echo-contrast", "Prominence policy", "prominence: min peak / median before it (2)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minContrast = as<double>(v); }},
      {"echo-region-mm", "Prominence policy", "prominence: before/after region, mm (2)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.regionMm = as<double>(v); }},
      {"echo-wall-step", "Prominence policy",
       "prominence: median after / before an echo at which it is a wall (skin, membrane) (3)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.wallStep = as<double>(v); }},
      {"echo-air-reverberation", "Prominence policy",
       "prominence: a second bounce this strong (x peak) means air, an uncoupled probe (0.35)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.airReverberation = as<double>(v); }},
      {"echo-shadow", "Prominence policy",
       "prominence: auto (default: required where bone casts a shadow in a fifth of the "
       "capture, else each echo by its own shadow or ringing) | required | ignored",
       std::string(),
       [](P& p, const V& v) { p.peaks.prominence.shadow = parseShadowRule(as<std::string>(v)); }},
      {"echo-ringing", "Prominence policy",
       "prominence: ringing = the envelope behind the echo stays above this fraction of it (0.4)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.ringingFraction = as<double>(v); }},
      {"echo-ringing-contrast", "Prominence policy",
       "prominence: ringing counts only for an echo this many times the median before it (6)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.ringingContrast = as<double>(v); }},
      {"echo-inner-ratio", "Prominence policy",
       "prominence, shadow required: an echo this many times stronger just above the chosen one "
       "is the bone, the chosen one its inner cortex (2.5; 0 = off)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.innerEchoRatio = as<double>(v); }},
      {"echo-similar", "Prominence policy",
       "prominence: echoes within this fraction of the strongest compete on depth (0.6)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.similarRatio = as<double>(v); }},
      {"no-subsample", "Peaks", "Report the integer sample of the peak (no parabola)", false,
       [](P& p, const V& v) { p.peaks.subsample = !as<bool>(v); }},
      {"bone-region-mm", "Bone policy", "bone: tissue/shadow region length, mm (3)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.regionMm = as<double>(v); }},
      {"bone-gap-mm", "Bone policy", "bone: gap between the echo and the regions, mm (0.3)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.gapMm = as<double>(v); }},
      {"bone-shadow-ratio", "Bone policy", "bone: min tissue/shadow median ratio (2)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.minShadowRatio = as<double>(v); }},
      {"bone-contrast", "Bone policy", "bone: min peak/tissue median ratio (3.5)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.minContrast = as<double>(v); }},
      {"bone-max-width-mm", "Bone policy", "bone: max echo width at half maximum, mm (1)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.maxWidthMm = as<double>(v); }},
      {"bone-noise-factor", "Bone policy", "bone: shadow within this x noise floor counts (1.2)",
       0.0, [](P& p, const V& v) { p.peaks.bone.noiseFloorFactor = as<double>(v); }},
      {"bone-tissue-over-noise", "Bone policy", "bone: min tissue median / noise floor (1.5)", 0.0,
       [](P& p, const V& v) { p.peaks.bone.minTissueOverNoise = as<double>(v); }},
      {"sampling-frequency", "Depth", "Hz; default: capture header, else 50e6", 0.0,
       [](P& p, const V& v) { p.depth.samplingFrequencyHz = as<double>(v); }},
      {"delay", "Depth", "Acquisition delay, s; default: capture header, else 0", 0.0,
       [](P& p, const V& v) { p.depth.delayS = as<double>(v); }},
      {"speed-of-sound", "Depth", "m/s; default: capture header, else 1540", 0.0,
       [](P& p, const V& v) { p.depth.speedOfSoundMps = as<double>(v); }},
      {"temporal", "Inter-signal",
       "Temporal filter: neighbours (default: each depth against the frames nearest in time) | "
       "run (the dissertation's consecutive 3D run)",
       std::string(),
       [](P& p, const V& v) { p.interSignal.temporal = parseTemporalMode(as<std::string>(v)); }},
      {"history", "Inter-signal",
       "Temporal filter: frames that must agree, this one included (default 2; run: 3; 1 = off)", 0,
       [](P& p, const V& v) { p.interSignal.history = as<int>(v); }},
      {"consistency-mm", "Inter-signal", "Temporal filter: agreement, mm, default 0.5", 0.0,
       [](P& p, const V& v) { p.interSignal.consistencyMm = as<double>(v); }},
      {"max-depth-rate", "Inter-signal",
       "neighbours: how fast the depth may change, mm/s, default 30", 0.0,
       [](P& p, const V& v) { p.interSignal.maxDepthRateMmPerS = as<double>(v); }},
      {"max-gap", "Inter-signal", "neighbours: longest time to a neighbour, s, default 0.1", 0.0,
       [](P& p, const V& v) { p.interSignal.maxGapS = as<double>(v); }},
      {"min-spread-mm", "Inter-signal",
       "Spatial filter on tracked points (--pose): min distance between points, mm, default 1 "
       "(0 = off)",
       0.0, [](P& p, const V& v) { p.interSignal.minSpreadMm = as<double>(v); }},
  };
  return list;
}

// The tunables given so far, by name; flags first, then a --params file fills the rest.
using TunableSettings = std::map<std::string, TunableValue>;

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

// Registers every tunable as a flag of `cmd`, storing what is given into `settings`.
void addTunableFlags(CLI::App* cmd, TunableSettings& settings) {
  for (const Tunable& tunable : tunables()) {
    const std::string flag = std::string("--") + tunable.name;
    const std::string name = tunable.name;
    CLI::Option* option = std::visit(
        [&](const auto& type) -> CLI::Option* {
          using T = std::decay_t<decltype(type)>;
          if constexpr (std::is_same_v<T, bool>) {
            // --causal, --causal=true and --causal=false all mean what they say.
            return cmd->add_flag_function(
                flag, [&settings, name](std::int64_t count) { settings[name] = count > 0; },
                tunable.help);
          } else {
            return cmd->add_option_function<T>(
                flag, [&settings, name](const T& value) { settings[name] = value; }, tunable.help);
          }
        },
        tunable.type);
    if (std::holds_alternative<std::vector<double>>(tunable.type))
      option->expected(2);
    option->group(tunable.group);
  }
}

// Fills the tunables not given as flags from a --params file; unknown keys are errors.
void mergeParamsFile(const std::string& file, std::string& preset, TunableSettings& settings) {
  if (std::filesystem::is_directory(file))
    throw FileError(file, "is a directory, expected a JSON file");
  std::ifstream in(file);
  if (!in)
    throw FileError(file, "cannot be opened");
  nlohmann::json params;
  try {
    params = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw FileError(file, std::string("is not valid JSON: ") + e.what());
  }
  if (!params.is_object())
    throw FileError(file, "must hold a JSON object of parameters");
  for (const auto& [key, value] : params.items()) {
    if (key == "preset") {
      if (!value.is_string())
        throw FileError(file, "parameter \"preset\" must be a string");
      if (preset.empty())
        preset = value.get<std::string>();
      continue;
    }
    const auto& list = tunables();
    const auto tunable = std::find_if(list.begin(), list.end(),
                                      [&key = key](const Tunable& t) { return key == t.name; });
    if (tunable == list.end()) {
      throw FileError(file,
                      fmt::format("unknown parameter \"{}\" (see echoreg detect --help)", key));
    }
    if (settings.count(key) != 0)
      continue;  // the flag wins
    try {
      settings[key] = std::visit(
          [&value = value](const auto& type) -> TunableValue {
            using T = std::decay_t<decltype(type)>;
            if constexpr (std::is_same_v<T, int>) {
              // 30 and 30.0 are the same count of samples; 30.5 is not a count.
              if (value.is_number_float()) {
                const double number = value.get<double>();
                if (!(std::floor(number) == number) || std::fabs(number) > 1e9) {
                  throw nlohmann::json::type_error::create(302, "", nullptr);
                }
                return static_cast<int>(number);
              }
              if (!value.is_number_integer())
                throw nlohmann::json::type_error::create(302, "", nullptr);
            }
            return value.get<T>();
          },
          tunable->type);
    } catch (const nlohmann::json::exception&) {
      const char* expected = std::visit(
          [](const auto& type) -> const char* {
            using T = std::decay_t<decltype(type)>;
            if constexpr (std::is_same_v<T, int>)
              return "a whole number";
            if constexpr (std::is_same_v<T, double>)
              return "a number";
            if constexpr (std::is_same_v<T, bool>)
              return "true or false";
            if constexpr (std::is_same_v<T, std::string>)
              return "a string";
            return "[min, max]";
          },
          tunable->type);
      throw FileError(
          file, fmt::format("parameter \"{}\" must be {}, found {}", key, expected, value.dump()));
    }
    if (key == "window-mm" && as<std::vector<double>>(settings[key]).size() != 2) {
      throw FileError(file, "parameter \"window-mm\" must be [min, max] in mm");
    }
  }
}

DetectionParams resolveParams(const std::string& preset, const TunableSettings& settings,
                              const Sequence& sequence) {
  if (settings.count("threshold-factor") != 0 && settings.count("threshold-of-max") != 0) {
    throw std::invalid_argument("give threshold-factor or threshold-of-max, not both");
  }
  DetectionParams params = detectionPreset(preset.empty() ? "default" : preset);
  params.depth = depthFromSequence(sequence, params.depth);
  for (const Tunable& tunable : tunables()) {
    const auto given = settings.find(tunable.name);
    if (given != settings.end())
      tunable.apply(params, given->second);
  }
  params.envelope.samplingFrequencyHz = params.depth.samplingFrequencyHz;
  validate(params);
  return params;
}

nlohmann::json summary(const SequenceDetection& detection, const DetectionParams& params,
                       const DetectOptions& options, const std::string& preset,
                       int posesReorthonormalised) {
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
          {"envelope", std::string(envelopeMethodName(params.envelope.method))},
          {"peaks", std::string(peakPolicyName(params.peaks.policy))},
          {"sampling_frequency_hz", params.depth.samplingFrequencyHz},
          {"delay_s", params.depth.delayS},
          {"speed_of_sound_mps", params.depth.speedOfSoundMps},
          {"echoes_before_inter_signal", detection.echoes},
          {"transducer_frequency_hz", detection.analysis.transducerFrequencyHz},
          {"transducer_frequency_source", detection.analysis.transducerFrequencySource},
          {"ring_down_samples", detection.analysis.ringDownSamples},
          {"ring_down_source", detection.analysis.ringDownSource},
          {"high_pass_samples", detection.analysis.highPassSamples},
          {"shadow_rule", detection.analysis.shadowRule},
          {"shadow_share", detection.analysis.shadowShare},
          {"envelope_window_samples", detection.analysis.envelopeWindowSamples},
          {"warnings", detectionWarnings(detection)},
          {"poses_reorthonormalised", posesReorthonormalised}};
}

}  // namespace

CommandAction addDetectCommand(CLI::App& app) {
  auto o = std::make_shared<DetectOptions>();
  CLI::App* cmd = app.add_subcommand(
      "detect",
      "Find the bone (or sphere) echo in every A-line of a capture: envelope, peaks, depth,\n"
      "then the temporal and spatial inter-signal filters. Writes one CSV row per frame:\n"
      "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm (+ x_mm,y_mm,z_mm with "
      "--pose).\n"
      "Parameter precedence: flags > --params file > capture header > what the preset measures\n"
      "from the capture (transducer band, ring-down, shadow rule) > --preset. Warns when most\n"
      "frames are rejected, with the reason and the setting to blame. docs/detection.md\n"
      "documents every parameter.");
  cmd->add_option("capture", o->capture,
                  "A-line capture (PLUS sequence: .igs.mha, .mhd, .igs.nrrd)")
      ->required();
  cmd->add_option("--out", o->out, "CSV to write (written whole or not at all)")->required();
  cmd->add_option("--params", o->paramsFile,
                  "JSON object of parameters named as the flags, without dashes");
  cmd->add_flag("--json", o->json, "Print a JSON summary: frames, accepted, rejected by reason");
  cmd->add_option(
      "--preset", o->preset,
      "default (any probe and anatomy: band, ring-down and shadow rule measured from the "
      "capture, the prominence policy), mozes2008 (the dissertation's chain as it was), "
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
    if (!o->paramsFile.empty())
      mergeParamsFile(o->paramsFile, preset, settings);
    // reader -> envelope -> peaks -> beam points -> inter-signal -> writer (DetectionPipeline.h)
    filters::DetectionPipeline pipeline;
    const Sequence& sequence = pipeline.open(o->capture, {o->pose, o->reference});
    PoseNotes poseNotes;
    for (const auto& [transform, report] : pipeline.reader->GetRigidPoseReports()) {
      poseNotes.reorthonormalised += report.reorthonormalised;
      if (auto line = rigidPoseNote(report, o->capture, transform))
        poseNotes.lines.push_back(*line);
    }
    poseNotes.print(io.err, "detect");
    const DetectionParams params = [&] {
      try {
        return resolveParams(preset, settings, sequence);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("bad parameter: ") + e.what());
      }
    }();
    PointFrameOptions points;
    points.poseTransform = o->pose;
    points.referenceTransform = o->reference;
    if (!o->beamToProbeFile.empty())
      points.beamToProbe = readTransformFile(o->beamToProbeFile, "Beam", "Probe").matrix;
    try {
      pipeline.configure(params, points);
    } catch (const std::invalid_argument& e) {
      throw FileError(o->capture, e.what());
    }
    // Long captures on a terminal: the heavy steps' progress on one line.
    const bool showProgress = io.errIsTerminal && sequence.frameCount() > 2000;
    struct ProgressLine {
      std::ostream* err;
      std::size_t frames;
      const char* step;
    };
    ProgressLine envelopeLine{&io.err, sequence.frameCount(), "envelopes"};
    ProgressLine echoLine{&io.err, sequence.frameCount(), "echoes   "};
    vtkNew<vtkCallbackCommand> envelopeProgress, echoProgress;
    if (showProgress) {
      const auto print = [](vtkObject* caller, unsigned long, void* data, void*) {
        const auto* line = static_cast<const ProgressLine*>(data);
        const double done = vtkAlgorithm::SafeDownCast(caller)->GetProgress();
        *line->err << fmt::format("\rdetect: {} frames, {} {:3.0f} %", line->frames, line->step,
                                  100.0 * done)
                   << std::flush;
      };
      envelopeProgress->SetCallback(print);
      envelopeProgress->SetClientData(&envelopeLine);
      echoProgress->SetCallback(print);
      echoProgress->SetClientData(&echoLine);
      pipeline.envelope->AddObserver(vtkCommand::ProgressEvent, envelopeProgress);
      pipeline.peaks->AddObserver(vtkCommand::ProgressEvent, echoProgress);
    }
    pipeline.write(o->out);
    if (showProgress)
      io.err << "\n";
    const SequenceDetection detection = pipeline.run();
    for (const std::string& warning : detectionWarnings(detection)) {
      io.err << "echoreg detect: warning: " << warning << "\n";
    }
    if (o->json) {
      io.out
          << summary(detection, detection.params, *o, preset, poseNotes.reorthonormalised).dump(2)
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
