// The detection parameters of every command that detects (detection_params.hpp).
#include "detection_params.hpp"

#include "validators.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/sequence_detection.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace echoreg::cli {

namespace {

template <typename T>
const T& as(const TunableValue& value) {
  return std::get<T>(value);
}

}  // namespace

const std::vector<Tunable>& tunables() {
  using P = core::DetectionParams;
  using V = TunableValue;
  static const std::vector<Tunable> list{
      {"envelope", "Envelope", "Envelope: mozes | hann | stddev | hilbert (default hann)",
       std::string(),
       [](P& p, const V& v) { p.envelope.method = core::parseEnvelopeMethod(as<std::string>(v)); }},
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
         p.peaks.thresholdMode = core::ThresholdMode::FactorOfMean;
         p.peaks.thresholdFactor = as<double>(v);
       }},
      {"threshold-of-max", "Peaks", "Threshold = fraction x max envelope, (0, 1]", 0.0,
       [](P& p, const V& v) {
         p.peaks.thresholdMode = core::ThresholdMode::FractionOfMax;
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
       [](P& p, const V& v) { p.peaks.policy = core::parsePeakPolicy(as<std::string>(v)); }},
      {"echo-snr", "Prominence policy", "prominence: min peak / noise floor (6)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minSnr = as<double>(v); }},
      {"echo-over-median", "Prominence policy", "prominence: min peak / median envelope (2)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minOverMedian = as<double>(v); }},
      {"echo-prominence", "Prominence policy", "prominence: min prominence / peak, (0, 1] (0.5)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.minProminence = as<double>(v); }},
      {"echo-max-rise", "Prominence policy", "prominence: max leading edge, transducer periods (3)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.maxRiseCycles = as<double>(v); }},
      {"echo-contrast", "Prominence policy", "prominence: min peak / median before it (2)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.minContrast = as<double>(v); }},
      {"echo-region-mm", "Prominence policy",
       "prominence: before/after region, mm, at least 18 transducer periods (2)", 0.0,
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
       [](P& p, const V& v) {
         p.peaks.prominence.shadow = core::parseShadowRule(as<std::string>(v));
       }},
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
      {"echo-noise-shadow", "Prominence policy",
       "prominence: an echo this many times the record's quiet level with only noise behind it "
       "is bone (shadow required: half the strongest echo, tissue before it; per record: water "
       "before it) (10; 0 = off)",
       0.0, [](P& p, const V& v) { p.peaks.prominence.noiseShadowEchoFactor = as<double>(v); }},
      {"echo-shadow-only", "Prominence policy",
       "prominence, shadow required: take only echoes with a shadow (default: in a record with "
       "none, its strongest echo when it rings, as shallow bone does)",
       false, [](P& p, const V& v) { p.peaks.prominence.shadowOnly = as<bool>(v); }},
      {"echo-similar", "Prominence policy",
       "prominence: echoes within this fraction of the strongest compete on depth (0.6)", 0.0,
       [](P& p, const V& v) { p.peaks.prominence.similarRatio = as<double>(v); }},
      {"echo-context", "Prominence policy",
       "prominence: a not-bone frame takes the echo that 0.6 of the frames before it, accepted "
       "alone, agree on (frames looked at, 10; 0 = off)",
       0, [](P& p, const V& v) { p.peaks.prominence.contextFrames = as<int>(v); }},
      {"tgc", "Peaks",
       "Time-gain compensation the front end applied, dB per mm of depth: shadows are judged "
       "against the noise at their own depth (default: measured from the steady rise of the "
       "capture's deep noise, none where it does not rise; 0 = none)",
       0.0, [](P& p, const V& v) { p.tgcDbPerMm = as<double>(v); },
       std::array<double, 2>{0.0, core::kMaxTgcDbPerMm}},
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
      {"speed-of-sound", "Depth",
       fmt::format("m/s; default: capture header, else {:.0f} (calibration preset: {:.0f})",
                   core::kTissueSpeedOfSoundMps, core::kWaterSpeedOfSoundMps),
       0.0, [](P& p, const V& v) { p.depth.speedOfSoundMps = as<double>(v); },
       std::array<double, 2>{core::kMinSpeedOfSoundMps, core::kMaxSpeedOfSoundMps}},
      {"temporal", "Inter-signal",
       "Temporal filter: neighbours (default: each depth against the frames nearest in time) | "
       "run (the dissertation's consecutive 3D run)",
       std::string(),
       [](P& p, const V& v) {
         p.interSignal.temporal = core::parseTemporalMode(as<std::string>(v));
       }},
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

// Registers every tunable as a flag of `cmd`, storing what is given into `settings`.
void addTunableFlags(CLI::App* cmd, TunableSettings& settings,
                     const std::set<std::string>& except) {
  for (const Tunable& tunable : tunables()) {
    if (except.count(tunable.name) != 0)
      continue;
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
    if (tunable.flagRange)
      option->check(finiteRange((*tunable.flagRange)[0], (*tunable.flagRange)[1]));
    option->group(tunable.group);
  }
}

std::set<std::string> mergeParamsFile(const std::string& file, std::string& preset,
                                      TunableSettings& settings) {
  // The project's JSON reader: the file named, the problem without the library's codes.
  return mergeParams(core::readJsonFile(file), file, preset, settings);
}

std::set<std::string> mergeParams(const nlohmann::json& params, const std::string& file,
                                  std::string& preset, TunableSettings& settings) {
  std::set<std::string> filled;
  if (!params.is_object())
    throw core::FileError(file, "must hold a JSON object of parameters");
  for (const auto& [key, value] : params.items()) {
    if (key == "preset") {
      if (!value.is_string())
        throw core::FileError(file, "parameter \"preset\" must be a string");
      if (preset.empty()) {
        preset = value.get<std::string>();
        filled.insert(key);
      }
      continue;
    }
    const auto& list = tunables();
    const auto tunable = std::find_if(list.begin(), list.end(),
                                      [&key = key](const Tunable& t) { return key == t.name; });
    if (tunable == list.end()) {
      throw core::FileError(
          file, fmt::format("unknown parameter \"{}\" (see echoreg detect --help)", key));
    }
    if (settings.count(key) != 0)
      continue;  // the flag wins
    try {
      settings[key] = std::visit(
          [&value = value](const auto& type) -> TunableValue {
            using T = std::decay_t<decltype(type)>;
            if constexpr (std::is_same_v<T, int>) {
              // 30 and 30.0 are the same count of samples; 30.5 is not a count, and a count
              // beyond an int (4294967303) is not wrapped round to a small one (7).
              if (!value.is_number())
                throw nlohmann::json::type_error::create(302, "", nullptr);
              const double number = value.get<double>();
              if (!(std::floor(number) == number) || std::fabs(number) > 1e9)
                throw nlohmann::json::type_error::create(302, "", nullptr);
              return static_cast<int>(number);
            } else {
              return value.get<T>();
            }
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
      throw core::FileError(
          file, fmt::format("parameter \"{}\" must be {}, found {}", key, expected, value.dump()));
    }
    if (key == "window-mm" && as<std::vector<double>>(settings[key]).size() != 2) {
      throw core::FileError(file, "parameter \"window-mm\" must be [min, max] in mm");
    }
    filled.insert(key);
  }
  return filled;
}

namespace {

// A tunable's value as the user wrote it: "0", "20 10", "gauss".
std::string valueText(const TunableValue& value) {
  return std::visit(
      [](const auto& v) -> std::string {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::vector<double>>)
          return fmt::format("{}", fmt::join(v, " "));
        else
          return fmt::format("{}", v);
      },
      value);
}

}  // namespace

core::DetectionParams resolveParams(const std::string& preset, const TunableSettings& settings,
                                    const core::Sequence& sequence, const ParamsSources& sources) {
  // A bad value names where it was given: "--speed-of-sound 0: speed of sound must be ...", or
  // the --params file and its key.
  const auto fromFile = [&](const std::string& name) {
    return !sources.paramsFile.empty() && sources.fromFile.count(name) != 0;
  };
  const auto refuse = [&](const std::string& name, const std::string& value,
                          const std::string& problem) {
    if (fromFile(name)) {
      throw core::FileError(sources.paramsFile,
                            fmt::format("parameter \"{}\" = {}: {}", name, value, problem));
    }
    throw std::invalid_argument(fmt::format("--{} {}: {}", name, value, problem));
  };
  if (settings.count("threshold-factor") != 0 && settings.count("threshold-of-max") != 0) {
    throw std::invalid_argument("give threshold-factor or threshold-of-max, not both");
  }
  core::DetectionParams base;
  try {
    base = core::detectionPreset(preset.empty() ? "default" : preset);
  } catch (const std::invalid_argument& e) {
    refuse("preset", preset, e.what());
  }
  base.depth = core::depthFromSequence(sequence, base.depth);
  base.envelope.samplingFrequencyHz = base.depth.samplingFrequencyHz;
  core::DetectionParams params = base;
  for (const Tunable& tunable : tunables()) {
    const auto given = settings.find(tunable.name);
    if (given != settings.end())
      tunable.apply(params, given->second);
  }
  params.envelope.samplingFrequencyHz = params.depth.samplingFrequencyHz;
  try {
    validate(params);
  } catch (const std::invalid_argument& whole) {
    // Which value is to blame: the first given one that is refused on its own over the preset
    // and the header (when those are good themselves).
    try {
      validate(base);
    } catch (const std::invalid_argument&) {
      throw whole;
    }
    for (const Tunable& tunable : tunables()) {
      const auto given = settings.find(tunable.name);
      if (given == settings.end())
        continue;
      core::DetectionParams alone = base;
      tunable.apply(alone, given->second);
      alone.envelope.samplingFrequencyHz = alone.depth.samplingFrequencyHz;
      try {
        validate(alone);
      } catch (const std::invalid_argument& e) {
        refuse(tunable.name, valueText(given->second), e.what());
      }
    }
    throw;
  }
  return params;
}

nlohmann::json settingsJson(const TunableSettings& settings) {
  nlohmann::json json = nlohmann::json::object();
  for (const auto& [name, value] : settings)
    std::visit([&json, &name = name](const auto& v) { json[name] = v; }, value);
  return json;
}

std::string samplingFrequencySource(const TunableSettings& settings,
                                    const core::Sequence& sequence) {
  if (settings.count("sampling-frequency") != 0)
    return "given";
  return sequence.acquisition.samplingFrequencyHz ? "header" : "assumed";
}

std::string assumedSamplingFrequencyWarning(const std::string& capture, double hz) {
  return fmt::format(
      "{} gives no sampling frequency and none was given: assumed {:g} MHz; every depth scales "
      "with it (--sampling-frequency)",
      capture, hz / 1e6);
}

}  // namespace echoreg::cli
