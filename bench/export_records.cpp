// Writes labelled specimen A-lines and echoreg's decisions on them, for the side-by-side
// comparison with a numpy/scipy reimplementation (bench/compare_scipy.py).
//
//   export_records OUT_DIR [--records N] [--preset shadow|mozes2008] [--seed S]
//
// Writes into OUT_DIR:
//   records.u8               N x 4096 uint8, row-major (the raw digitiser bytes)
//   labels.csv               index,has_bone,bone_sample,kind
//   decisions_<preset>.csv   index,accepted,reason,sample_index,depth_mm,peaks,threshold
//                            (sample_index and depth_mm empty when rejected; peaks = number of
//                            peaks above the threshold; threshold = the envelope threshold)
//   chain_<preset>.txt       key=value lines: preset, records, samples, seconds_per_record, every
//                            parameter of the chain as it ran (envelope, threshold, policy, bone
//                            signature, depth) and, for mozes envelopes, the designed Butterworth
//                            filter (butterworth_b, butterworth_a)
// and prints the C++ time per record: one thread, steady_clock, the whole chain including the
// uint8 -> float conversion, best of several passes over all records.

#include "aline_generator.hpp"

#include "echoreg/core/butterworth.hpp"
#include "echoreg/core/detection.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr int kSamples = 4096;

struct Options {
  std::filesystem::path outDir;
  int records = 2000;
  std::string preset = "shadow";
  std::uint64_t seed = 2008;
};

[[noreturn]] void usage(const std::string& problem) {
  if (!problem.empty())
    std::cerr << "export_records: " << problem << "\n";
  std::cerr << "usage: export_records OUT_DIR [--records N] [--preset shadow|mozes2008] "
               "[--seed S]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options options;
  bool haveDir = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        usage(arg + " needs a value");
      return argv[++i];
    };
    try {
      if (arg == "--records") {
        options.records = std::stoi(value());
        if (options.records < 1)
          usage("--records must be >= 1");
      } else if (arg == "--preset") {
        options.preset = value();
        // The scipy twin (compare_scipy.py) implements the bone and double policies: the
        // earlier default ("shadow") and the dissertation's chain.
        if (options.preset != "shadow" && options.preset != "mozes2008") {
          usage("--preset must be shadow or mozes2008");
        }
      } else if (arg == "--seed") {
        options.seed = std::stoull(value());
      } else if (arg == "-h" || arg == "--help") {
        usage("");
      } else if (!arg.empty() && arg[0] == '-') {
        usage("unknown option " + arg);
      } else if (!haveDir) {
        options.outDir = arg;
        haveDir = true;
      } else {
        usage("more than one OUT_DIR");
      }
    } catch (const std::logic_error&) {  // stoi/stoull: invalid or out of range
      usage("bad value for " + arg);
    }
  }
  if (!haveDir)
    usage("OUT_DIR is required");
  return options;
}

std::ofstream openForWriting(const std::filesystem::path& path, std::ios::openmode mode = {}) {
  std::ofstream out(path, std::ios::out | std::ios::trunc | mode);
  if (!out)
    throw std::runtime_error("cannot write " + path.string());
  return out;
}

// %.17g round-trips a double (sample indices, depths, thresholds).
std::string formatDouble(double value, int digits = 9) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

std::string join(const std::vector<double>& values) {
  std::string text;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0)
      text += ",";
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.17g", values[i]);
    text += buffer;
  }
  return text;
}

int run(const Options& options) {
  std::filesystem::create_directories(options.outDir);

  echoreg::test::SpecimenSetOptions setOptions;
  setOptions.records = options.records;
  setOptions.samplesPerRecord = kSamples;
  setOptions.seed = options.seed;
  const std::vector<echoreg::test::LabelledALine> set = echoreg::test::makeSpecimenSet(setOptions);
  const auto n = set.size();

  std::vector<std::uint8_t> bytes;
  bytes.reserve(n * kSamples);
  for (const auto& line : set)
    bytes.insert(bytes.end(), line.samples.begin(), line.samples.end());
  {
    std::ofstream out = openForWriting(options.outDir / "records.u8", std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    if (!out)
      throw std::runtime_error("cannot write records.u8");
  }
  {
    std::ofstream out = openForWriting(options.outDir / "labels.csv");
    out << "index,has_bone,bone_sample,kind\n";
    for (std::size_t i = 0; i < n; ++i) {
      out << i << "," << (set[i].hasBone ? 1 : 0) << "," << formatDouble(set[i].boneSample) << ","
          << set[i].kind << "\n";
    }
  }

  // The chain, timed: best of several passes over every record (at least three, at least 0.5 s).
  const echoreg::core::DetectionParams params = echoreg::core::detectionPreset(options.preset);
  echoreg::core::SignalDetector detector(params);
  std::vector<echoreg::core::SignalDetection> detections(n);
  std::vector<float> samples(kSamples);
  double best = std::numeric_limits<double>::infinity();
  double total = 0.0;
  int passes = 0;
  while (passes < 3 || (total < 0.5 && passes < 50)) {
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t r = 0; r < n; ++r) {
      const std::uint8_t* in = bytes.data() + r * kSamples;
      for (int i = 0; i < kSamples; ++i)
        samples[static_cast<std::size_t>(i)] = static_cast<float>(in[i]);
      detections[r] = detector.detect(samples.data(), kSamples);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    best = std::min(best, seconds);
    total += seconds;
    ++passes;
  }
  const double perRecord = best / static_cast<double>(n);

  {
    std::ofstream out = openForWriting(options.outDir / ("decisions_" + options.preset + ".csv"));
    out << "index,accepted,reason,sample_index,depth_mm,peaks,threshold\n";
    for (std::size_t i = 0; i < n; ++i) {
      const echoreg::core::SignalDetection& d = detections[i];
      out << i << "," << (d.accepted() ? 1 : 0) << ","
          << (d.accepted() ? std::string("accepted")
                           : std::string(echoreg::core::rejectReasonName(d.peaks.reason)))
          << ",";
      if (d.accepted()) {
        out << formatDouble(d.peaks.sampleIndex, 17) << "," << formatDouble(d.depthMm, 17);
      } else {
        out << ",";
      }
      out << "," << d.peaks.peaks.size() << "," << formatDouble(d.peaks.threshold, 17) << "\n";
    }
  }
  {
    // The timing and every parameter of the chain as it ran, so compare_scipy.py follows the
    // preset's current values instead of a copy of them.
    const echoreg::core::PeakParams peaks = echoreg::core::resolvePeakParams(params);
    const echoreg::core::EnvelopeParams& envelope = params.envelope;
    std::ofstream out = openForWriting(options.outDir / ("chain_" + options.preset + ".txt"));
    out << "preset=" << options.preset << "\n"
        << "records=" << n << "\n"
        << "samples=" << kSamples << "\n"
        << "seed=" << options.seed << "\n"
        << "passes=" << passes << "\n"
        << "seconds_per_record=" << formatDouble(perRecord) << "\n"
        << "envelope_method=" << echoreg::core::envelopeMethodName(envelope.method) << "\n"
        << "ring_down_samples=" << envelope.ringDownSamples << "\n"
        << "window_samples=" << envelope.windowSamples << "\n"
        << "butterworth_order=" << envelope.butterworthOrder << "\n"
        << "butterworth_cutoff=" << formatDouble(envelope.cutoffNormalized, 17) << "\n"
        << "butterworth_zero_phase=" << (envelope.zeroPhase ? 1 : 0) << "\n"
        << "threshold_mode="
        << (peaks.thresholdMode == echoreg::core::ThresholdMode::FactorOfMean ? "factor-of-mean"
                                                                              : "fraction-of-max")
        << "\n"
        << "threshold_factor=" << formatDouble(peaks.thresholdFactor, 17) << "\n"
        << "threshold_of_max=" << formatDouble(peaks.thresholdOfMax, 17) << "\n"
        << "window_begin=" << (peaks.windowBegin ? std::to_string(*peaks.windowBegin) : "") << "\n"
        << "window_end=" << (peaks.windowEnd ? std::to_string(*peaks.windowEnd) : "") << "\n"
        << "policy=" << echoreg::core::peakPolicyName(peaks.policy) << "\n"
        << "subsample=" << (peaks.subsample ? 1 : 0) << "\n"
        << "mm_per_sample=" << formatDouble(peaks.mmPerSample, 17) << "\n"
        << "bone_region_mm=" << formatDouble(peaks.bone.regionMm, 17) << "\n"
        << "bone_gap_mm=" << formatDouble(peaks.bone.gapMm, 17) << "\n"
        << "bone_min_shadow_ratio=" << formatDouble(peaks.bone.minShadowRatio, 17) << "\n"
        << "bone_min_contrast=" << formatDouble(peaks.bone.minContrast, 17) << "\n"
        << "bone_max_width_mm=" << formatDouble(peaks.bone.maxWidthMm, 17) << "\n"
        << "bone_noise_floor_factor=" << formatDouble(peaks.bone.noiseFloorFactor, 17) << "\n"
        << "bone_min_tissue_over_noise=" << formatDouble(peaks.bone.minTissueOverNoise, 17) << "\n"
        << "sampling_frequency_hz=" << formatDouble(params.depth.samplingFrequencyHz, 17) << "\n"
        << "delay_s=" << formatDouble(params.depth.delayS, 17) << "\n"
        << "speed_of_sound_mps=" << formatDouble(params.depth.speedOfSoundMps, 17) << "\n";
    if (envelope.method == echoreg::core::EnvelopeMethod::Mozes) {
      const echoreg::core::IirCoefficients filter = echoreg::core::designButterworthLowPass(
          envelope.butterworthOrder, envelope.cutoffNormalized);
      out << "butterworth_b=" << join(filter.b) << "\n"
          << "butterworth_a=" << join(filter.a) << "\n";
    }
  }

  // Against the labels: accepted positives within 1 mm of the true echo centre count as hits.
  const double mmPerSample = params.depth.mmPerSample();
  int positives = 0, hits = 0, misplaced = 0, falseAccepts = 0, accepted = 0;
  std::vector<double> errors;
  for (std::size_t i = 0; i < n; ++i) {
    const bool ok = detections[i].accepted();
    accepted += ok ? 1 : 0;
    if (set[i].hasBone) {
      ++positives;
      if (!ok)
        continue;
      const double error = detections[i].peaks.sampleIndex - set[i].boneSample;
      if (std::fabs(error) * mmPerSample <= 1.0) {
        ++hits;
        errors.push_back(error);
      } else {
        ++misplaced;
      }
    } else if (ok) {
      ++falseAccepts;
    }
  }
  double meanError = 0.0;
  for (double e : errors)
    meanError += e;
  if (!errors.empty())
    meanError /= static_cast<double>(errors.size());
  const int negatives = static_cast<int>(n) - positives;

  std::printf("export_records: %zu records (seed %llu) -> %s\n", n,
              static_cast<unsigned long long>(options.seed), options.outDir.string().c_str());
  std::printf(
      "  preset %-9s  C++ chain (1 thread, uint8->float included): %.3f us/record, "
      "%.0f records/s (best of %d passes)\n",
      options.preset.c_str(), perRecord * 1e6, 1.0 / perRecord, passes);
  std::printf(
      "  accepted %d/%zu; positives %d: %d within 1 mm (mean error %+.1f samples), %d "
      "misplaced, %d rejected; negatives %d: %d accepted\n",
      accepted, n, positives, hits, meanError, misplaced, positives - hits - misplaced, negatives,
      falseAccepts);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  try {
    return run(options);
  } catch (const std::exception& error) {
    std::cerr << "export_records: " << error.what() << "\n";
    return 1;
  }
}
