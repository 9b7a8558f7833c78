// `echoreg detect CAPTURE --out depths.csv`: the A-line chain over a capture.
#include "commands.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <ostream>

namespace echoreg::cli {

namespace {

// Every tunable of the chain as it appears on the command line and in --params files (the JSON
// keys are the flag names without the leading dashes). Unset values keep the preset's, then the
// capture header's (acquisition), then the params file's.
struct DetectFlags {
  std::optional<std::string> preset;
  std::optional<std::string> envelope;
  std::optional<int> ringDownSamples;
  std::optional<int> butterworthOrder;
  std::optional<double> cutoff;
  bool causal = false;
  std::optional<int> envelopeWindow;
  std::optional<double> transducerFrequencyHz;
  std::optional<double> relativeBandwidth;
  std::optional<int> smoothing;
  std::optional<double> thresholdFactor;
  std::optional<double> thresholdOfMax;
  std::vector<double> windowMm;
  std::optional<std::string> peaks;
  bool noSubsample = false;
  std::optional<double> boneRegionMm, boneGapMm, boneShadowRatio, boneContrast, boneMaxWidthMm,
      boneNoiseFactor, boneTissueOverNoise;
  std::optional<double> samplingFrequencyHz;
  std::optional<double> delayS;
  std::optional<double> speedOfSoundMps;
  std::optional<int> history;
  std::optional<double> consistencyMm;
  std::optional<double> minSpreadMm;
};

struct DetectOptions {
  std::string capture;
  std::string out;
  std::string paramsFile;
  std::string pose;
  std::string reference;
  std::string beamToProbeFile;
  bool json = false;
  DetectFlags flags;
};

template <typename T>
void take(const nlohmann::json& params, const char* key, std::optional<T>& slot,
          const std::string& file) {
  if (!params.contains(key)) return;
  try {
    slot = params.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw FileError(file, fmt::format("parameter \"{}\" has the wrong type", key));
  }
}

// Fills unset flags from a --params file; flags given on the command line win.
void mergeParamsFile(const std::string& file, DetectFlags& flags) {
  if (std::filesystem::is_directory(file)) throw FileError(file, "is a directory, expected a JSON file");
  std::ifstream in(file);
  if (!in) throw FileError(file, "cannot be opened");
  nlohmann::json params;
  try {
    params = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw FileError(file, std::string("is not valid JSON: ") + e.what());
  }
  if (!params.is_object()) throw FileError(file, "must hold a JSON object of parameters");
  static const std::vector<std::string> known{
      "preset", "envelope", "ring-down", "butterworth-order", "cutoff", "causal",
      "envelope-window", "transducer-frequency", "relative-bandwidth", "smoothing",
      "threshold-factor", "threshold-of-max", "window-mm", "peaks", "no-subsample",
      "bone-region-mm", "bone-gap-mm", "bone-shadow-ratio", "bone-contrast",
      "bone-max-width-mm", "bone-noise-factor", "bone-tissue-over-noise",
      "sampling-frequency", "delay", "speed-of-sound", "history", "consistency-mm",
      "min-spread-mm"};
  for (const auto& [key, value] : params.items()) {
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      throw FileError(file, fmt::format("unknown parameter \"{}\" (see echoreg detect --help)", key));
    }
  }
  const auto fill = [&](const char* key, auto& slot) {
    if (!slot) take(params, key, slot, file);
  };
  fill("preset", flags.preset);
  fill("envelope", flags.envelope);
  fill("ring-down", flags.ringDownSamples);
  fill("butterworth-order", flags.butterworthOrder);
  fill("cutoff", flags.cutoff);
  fill("envelope-window", flags.envelopeWindow);
  fill("transducer-frequency", flags.transducerFrequencyHz);
  fill("relative-bandwidth", flags.relativeBandwidth);
  fill("smoothing", flags.smoothing);
  fill("threshold-factor", flags.thresholdFactor);
  fill("threshold-of-max", flags.thresholdOfMax);
  fill("peaks", flags.peaks);
  fill("bone-region-mm", flags.boneRegionMm);
  fill("bone-gap-mm", flags.boneGapMm);
  fill("bone-shadow-ratio", flags.boneShadowRatio);
  fill("bone-contrast", flags.boneContrast);
  fill("bone-max-width-mm", flags.boneMaxWidthMm);
  fill("bone-noise-factor", flags.boneNoiseFactor);
  fill("bone-tissue-over-noise", flags.boneTissueOverNoise);
  fill("sampling-frequency", flags.samplingFrequencyHz);
  fill("delay", flags.delayS);
  fill("speed-of-sound", flags.speedOfSoundMps);
  fill("history", flags.history);
  fill("consistency-mm", flags.consistencyMm);
  fill("min-spread-mm", flags.minSpreadMm);
  if (!flags.causal && params.contains("causal")) flags.causal = params["causal"].get<bool>();
  if (!flags.noSubsample && params.contains("no-subsample")) {
    flags.noSubsample = params["no-subsample"].get<bool>();
  }
  if (flags.windowMm.empty() && params.contains("window-mm")) {
    try {
      flags.windowMm = params["window-mm"].get<std::vector<double>>();
    } catch (const nlohmann::json::exception&) {
      throw FileError(file, "parameter \"window-mm\" must be [min, max] in mm");
    }
    if (flags.windowMm.size() != 2) throw FileError(file, "parameter \"window-mm\" must be [min, max] in mm");
  }
}

DetectionParams resolveParams(const DetectFlags& flags, const Sequence& sequence) {
  DetectionParams params = detectionPreset(flags.preset.value_or("default"));
  params.depth = depthFromSequence(sequence, params.depth);
  EnvelopeParams& e = params.envelope;
  if (flags.envelope) e.method = parseEnvelopeMethod(*flags.envelope);
  if (flags.ringDownSamples) e.ringDownSamples = *flags.ringDownSamples;
  if (flags.butterworthOrder) e.butterworthOrder = *flags.butterworthOrder;
  if (flags.cutoff) e.cutoffNormalized = *flags.cutoff;
  if (flags.causal) e.zeroPhase = false;
  if (flags.envelopeWindow) e.windowSamples = *flags.envelopeWindow;
  if (flags.transducerFrequencyHz) e.transducerFrequencyHz = *flags.transducerFrequencyHz;
  if (flags.relativeBandwidth) e.relativeBandwidth = *flags.relativeBandwidth;
  if (flags.smoothing) e.smoothingSamples = *flags.smoothing;
  PeakParams& p = params.peaks;
  if (flags.thresholdFactor && flags.thresholdOfMax) {
    throw std::invalid_argument("give --threshold-factor or --threshold-of-max, not both");
  }
  if (flags.thresholdFactor) {
    p.thresholdMode = ThresholdMode::FactorOfMean;
    p.thresholdFactor = *flags.thresholdFactor;
  }
  if (flags.thresholdOfMax) {
    p.thresholdMode = ThresholdMode::FractionOfMax;
    p.thresholdOfMax = *flags.thresholdOfMax;
  }
  if (flags.peaks) p.policy = parsePeakPolicy(*flags.peaks);
  if (flags.noSubsample) p.subsample = false;
  if (flags.boneRegionMm) p.bone.regionMm = *flags.boneRegionMm;
  if (flags.boneGapMm) p.bone.gapMm = *flags.boneGapMm;
  if (flags.boneShadowRatio) p.bone.minShadowRatio = *flags.boneShadowRatio;
  if (flags.boneContrast) p.bone.minContrast = *flags.boneContrast;
  if (flags.boneMaxWidthMm) p.bone.maxWidthMm = *flags.boneMaxWidthMm;
  if (flags.boneNoiseFactor) p.bone.noiseFloorFactor = *flags.boneNoiseFactor;
  if (flags.boneTissueOverNoise) p.bone.minTissueOverNoise = *flags.boneTissueOverNoise;
  if (flags.samplingFrequencyHz) params.depth.samplingFrequencyHz = *flags.samplingFrequencyHz;
  if (flags.delayS) params.depth.delayS = *flags.delayS;
  if (flags.speedOfSoundMps) params.depth.speedOfSoundMps = *flags.speedOfSoundMps;
  e.samplingFrequencyHz = params.depth.samplingFrequencyHz;
  if (flags.windowMm.size() == 2) {
    params.windowMinMm = flags.windowMm[0];
    params.windowMaxMm = flags.windowMm[1];
  }
  if (flags.history) params.interSignal.history = *flags.history;
  if (flags.consistencyMm) params.interSignal.consistencyMm = *flags.consistencyMm;
  if (flags.minSpreadMm) params.interSignal.minSpreadMm = *flags.minSpreadMm;
  validate(params);
  return params;
}

Eigen::Matrix4d readBeamToProbe(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw FileError(file, "cannot be opened");
  nlohmann::json transform;
  try {
    transform = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw FileError(file, std::string("is not valid JSON: ") + e.what());
  }
  if (!transform.contains("matrix") || !transform["matrix"].is_array() || transform["matrix"].size() != 4) {
    throw FileError(file, "needs \"matrix\": 4 rows of 4 numbers");
  }
  Eigen::Matrix4d matrix;
  for (int r = 0; r < 4; ++r) {
    const auto& row = transform["matrix"][static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 4) throw FileError(file, "needs \"matrix\": 4 rows of 4 numbers");
    for (int c = 0; c < 4; ++c) {
      const auto& value = row[static_cast<std::size_t>(c)];
      if (!value.is_number() || !std::isfinite(value.get<double>())) {
        throw FileError(file, fmt::format("matrix[{}][{}] is not a finite number", r, c));
      }
      matrix(r, c) = value.get<double>();
    }
  }
  if (transform.contains("from") && transform["from"] != "Beam") {
    throw FileError(file, "expected a BeamToProbe transform (\"from\": \"Beam\")");
  }
  return matrix;
}

std::string optionalNumber(const std::optional<double>& value, int decimals) {
  return value ? fmt::format("{:.{}f}", *value, decimals) : std::string();
}

void writeCsv(const SequenceDetection& detection, bool withPoints, const std::string& path) {
  AtomicFile file(path);
  std::ostream& csv = file.stream();
  csv << "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm";
  if (withPoints) csv << ",x_mm,y_mm,z_mm";
  csv << "\n";
  for (const FrameDetection& f : detection.frames) {
    csv << f.frame << ',' << (f.timestampS ? fmt::format("{}", *f.timestampS) : std::string()) << ','
        << (f.accepted() ? "accepted" : "rejected") << ',' << rejectReasonName(f.reason) << ','
        << f.peakCount << ',' << optionalNumber(f.sampleIndex, 3) << ','
        << optionalNumber(f.depthMm, 4);
    if (withPoints) {
      if (f.pointMm) {
        csv << fmt::format(",{:.4f},{:.4f},{:.4f}", f.pointMm->x(), f.pointMm->y(), f.pointMm->z());
      } else {
        csv << ",,,";
      }
    }
    csv << "\n";
  }
  file.commit();
}

nlohmann::json summary(const SequenceDetection& detection, const DetectionParams& params,
                       const DetectOptions& options, const DetectFlags& flags) {
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, count] : detection.rejectedByReason) rejected[reason] = count;
  return {{"capture", options.capture},
          {"out", options.out},
          {"preset", flags.preset.value_or("default")},
          {"frames", detection.frames.size()},
          {"accepted", detection.accepted},
          {"rejected", detection.frames.size() - static_cast<std::size_t>(detection.accepted)},
          {"rejected_by_reason", rejected},
          {"envelope", std::string(envelopeMethodName(params.envelope.method))},
          {"peaks", std::string(peakPolicyName(params.peaks.policy))},
          {"sampling_frequency_hz", params.depth.samplingFrequencyHz},
          {"delay_s", params.depth.delayS},
          {"speed_of_sound_mps", params.depth.speedOfSoundMps}};
}

}  // namespace

CommandAction addDetectCommand(CLI::App& app) {
  auto o = std::make_shared<DetectOptions>();
  DetectFlags& f = o->flags;
  CLI::App* cmd = app.add_subcommand(
      "detect",
      "Find the bone (or sphere) echo in every A-line of a capture: envelope, peaks, depth,\n"
      "then the temporal and spatial inter-signal filters. Writes one CSV row per frame:\n"
      "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm (+ x_mm,y_mm,z_mm with --pose).\n"
      "Parameter precedence: flags > --params file > capture header > --preset. docs/detection.md\n"
      "documents every parameter.");
  cmd->add_option("capture", o->capture, "A-line capture (PLUS sequence: .igs.mha, .mhd, .igs.nrrd)")->required();
  cmd->add_option("--out", o->out, "CSV to write (written whole or not at all)")->required();
  cmd->add_option("--params", o->paramsFile, "JSON object of parameters named as the flags, without dashes");
  cmd->add_flag("--json", o->json, "Print a JSON summary: frames, accepted, rejected by reason");
  cmd->add_option("--preset", f.preset, "default (specimens: hann + bone policy), mozes2008 (the dissertation's chain as it was), calibration (window-max in water)");

  cmd->add_option("--envelope", f.envelope, "Envelope: mozes | hann | stddev | hilbert (default hann)")
      ->group("Envelope");
  cmd->add_option("--ring-down", f.ringDownSamples, "Samples zeroed at the start (ring-down), default 200")
      ->group("Envelope");
  cmd->add_option("--butterworth-order", f.butterworthOrder, "mozes: Butterworth order 1..12, default 2")
      ->group("Envelope");
  cmd->add_option("--cutoff", f.cutoff, "mozes: cutoff as a fraction of Nyquist, default 0.01")
      ->group("Envelope");
  cmd->add_flag("--causal", f.causal,
                "mozes: one causal pass as the dissertation (delays peaks by 45 samples, 0.69 mm at "
                "50 MHz/1540 m/s, for order 2 at 0.01); default zero-phase")
      ->group("Envelope");
  cmd->add_option("--envelope-window", f.envelopeWindow,
                  "hann/stddev: window in samples (default preset: 7; PLUS uses 153 at 420 MHz)")
      ->group("Envelope");
  cmd->add_option("--transducer-frequency", f.transducerFrequencyHz, "hilbert: band centre, Hz, default 9e6")
      ->group("Envelope");
  cmd->add_option("--relative-bandwidth", f.relativeBandwidth, "hilbert: -6 dB band / centre, default 0.8")
      ->group("Envelope");
  cmd->add_option("--smoothing", f.smoothing, "hilbert: box smoothing in samples, default 5")
      ->group("Envelope");

  cmd->add_option("--threshold-factor", f.thresholdFactor, "Threshold = factor x mean envelope (default 1.5)")
      ->group("Peaks");
  cmd->add_option("--threshold-of-max", f.thresholdOfMax, "Threshold = fraction x max envelope, (0, 1]")
      ->group("Peaks");
  cmd->add_option("--window-mm", f.windowMm, "Processing window MIN MAX in mm")->expected(2)->group("Peaks");
  cmd->add_option("--peaks", f.peaks,
                  "Policy: bone (default) | single | double | window-max | first | max")
      ->group("Peaks");
  cmd->add_flag("--no-subsample", f.noSubsample, "Report the integer sample of the peak (no parabola)")
      ->group("Peaks");
  cmd->add_option("--bone-region-mm", f.boneRegionMm, "bone: tissue/shadow region length, mm (3)")->group("Bone policy");
  cmd->add_option("--bone-gap-mm", f.boneGapMm, "bone: gap between the echo and the regions, mm (0.3)")->group("Bone policy");
  cmd->add_option("--bone-shadow-ratio", f.boneShadowRatio, "bone: min tissue/shadow median ratio (2)")->group("Bone policy");
  cmd->add_option("--bone-contrast", f.boneContrast, "bone: min peak/tissue median ratio (3.5)")->group("Bone policy");
  cmd->add_option("--bone-max-width-mm", f.boneMaxWidthMm, "bone: max echo width at half maximum, mm (1)")->group("Bone policy");
  cmd->add_option("--bone-noise-factor", f.boneNoiseFactor, "bone: shadow within this x noise floor counts (1.2)")->group("Bone policy");
  cmd->add_option("--bone-tissue-over-noise", f.boneTissueOverNoise, "bone: min tissue median / noise floor (1.5)")->group("Bone policy");

  cmd->add_option("--sampling-frequency", f.samplingFrequencyHz, "Hz; default: capture header, else 50e6")->group("Depth");
  cmd->add_option("--delay", f.delayS, "Acquisition delay, s; default: capture header, else 0")->group("Depth");
  cmd->add_option("--speed-of-sound", f.speedOfSoundMps, "m/s; default: capture header, else 1540")->group("Depth");

  cmd->add_option("--history", f.history, "Temporal filter: consecutive agreeing frames, default 3 (1 = off)")
      ->group("Inter-signal");
  cmd->add_option("--consistency-mm", f.consistencyMm, "Temporal filter: agreement, mm, default 0.5")
      ->group("Inter-signal");
  cmd->add_option("--min-spread-mm", f.minSpreadMm, "Spatial filter: min distance between points, mm, default 1 (0 = off)")
      ->group("Inter-signal");
  cmd->add_option("--pose", o->pose, "Transform giving 3D points, e.g. ProbeToTracker")->group("Points");
  cmd->add_option("--reference", o->reference, "Express points in this frame, e.g. FemurToTracker")->group("Points");
  cmd->add_option("--beam-to-probe", o->beamToProbeFile, "BeamToProbe transform JSON (default identity)")
      ->group("Points");

  return [o](const Streams& io) {
    if (std::filesystem::is_directory(o->capture)) {
      throw FileError(o->capture, "is a directory, expected a capture file");
    }
    DetectFlags flags = o->flags;
    if (!o->paramsFile.empty()) mergeParamsFile(o->paramsFile, flags);
    const Sequence sequence = readSequence(o->capture);
    const DetectionParams params = [&] {
      try {
        return resolveParams(flags, sequence);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("bad parameter: ") + e.what());
      }
    }();
    PointFrameOptions points;
    points.poseTransform = o->pose;
    points.referenceTransform = o->reference;
    if (!o->beamToProbeFile.empty()) points.beamToProbe = readBeamToProbe(o->beamToProbeFile);
    SequenceDetection detection;
    try {
      const bool showProgress = io.errIsTerminal && sequence.frameCount() > 2000;
      detection = detectSequence(sequence, params, points, [&](int done, int total) {
        if (showProgress) io.err << fmt::format("\rdetect: {}/{} frames", done, total) << std::flush;
      });
      if (showProgress) io.err << "\n";
    } catch (const std::invalid_argument& e) {
      throw FileError(o->capture, e.what());
    }
    writeCsv(detection, !points.poseTransform.empty(), o->out);
    if (o->json) {
      io.out << summary(detection, params, *o, flags).dump(2) << "\n";
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
