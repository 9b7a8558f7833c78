// Throughput of the A-line signal chain: records per second for each envelope alone and for the
// whole chain (SignalDetector::detect) with the "default" and "mozes2008" presets.
//
// Records are 4096-sample uint8 specimen A-lines (50 MHz) from the labelled generator with a
// fixed seed, 256 of them cycled. Every timed iteration converts one uint8 record to float (the
// digitiser's bytes have to become floats in the real pipeline too) and runs the stage on it.
// Each benchmark runs on one thread and on every core; each thread owns its detector and
// buffers. Rates are wall-clock (UseRealTime), so "records_per_s" is the aggregate throughput and
// "records_per_s_per_thread" the same divided by the thread count.
//
// The target for the default chain is >= 100,000 records/s per core.
//
//   bench_signal_chain [--benchmark_min_time=0.2] [--benchmark_filter=chain]

#include "aline_generator.hpp"

#include "echoreg/core/detection.hpp"
#include "echoreg/core/envelope.hpp"
#include "echoreg/core/peaks.hpp"

#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace {

constexpr int kSamples = 4096;
constexpr int kRecords = 256;
constexpr std::uint64_t kSeed = 2008;
constexpr int kRingDown = 200;

// kRecords x kSamples bytes, row-major, built once before any benchmark runs.
const std::vector<std::uint8_t>& records() {
  static const std::vector<std::uint8_t> bytes = [] {
    echoreg::test::SpecimenSetOptions options;
    options.records = kRecords;
    options.samplesPerRecord = kSamples;
    options.seed = kSeed;
    std::vector<std::uint8_t> all;
    all.reserve(static_cast<std::size_t>(kRecords) * kSamples);
    for (const auto& line : echoreg::test::makeSpecimenSet(options)) {
      all.insert(all.end(), line.samples.begin(), line.samples.end());
    }
    return all;
  }();
  return bytes;
}

// Converts record `index` (mod kRecords) to float.
inline void convert(std::size_t index, float* out) {
  const std::uint8_t* in = records().data() + (index % kRecords) * kSamples;
  for (int i = 0; i < kSamples; ++i)
    out[i] = static_cast<float>(in[i]);
}

// Each thread starts at its own place in the set so threads do not run in lockstep.
std::size_t firstRecord(const benchmark::State& state) {
  return static_cast<std::size_t>(state.thread_index()) * 37U;
}

void reportRates(benchmark::State& state) {
  const auto done = static_cast<double>(state.iterations());
  state.SetItemsProcessed(state.iterations());
  state.counters["records_per_s"] = benchmark::Counter(done, benchmark::Counter::kIsRate);
  state.counters["records_per_s_per_thread"] =
      benchmark::Counter(done, benchmark::Counter::kAvgThreadsRate);
}

void envelopeBenchmark(benchmark::State& state, echoreg::core::EnvelopeParams params) {
  echoreg::core::EnvelopeDetector detector(params);
  std::vector<float> samples(kSamples), envelope(kSamples);
  std::size_t index = firstRecord(state);
  for (auto _ : state) {
    convert(index++, samples.data());
    detector.compute(samples.data(), kSamples, envelope.data());
    benchmark::DoNotOptimize(envelope.data());
    benchmark::ClobberMemory();
  }
  reportRates(state);
}

// The preset as detect runs it: adapted once to the benchmark's records (transducer band,
// ring-down, shadow rule), outside the timed loop as adaptToCapture runs once per capture.
echoreg::core::DetectionParams adaptedPreset(const std::string& preset) {
  const echoreg::core::RecordSource source = [](int index, std::vector<float>& out) {
    out.resize(kSamples);
    convert(static_cast<std::size_t>(index), out.data());
  };
  return echoreg::core::adaptToCapture(echoreg::core::detectionPreset(preset), kRecords, kSamples,
                                       source, std::nullopt);
}

void chainBenchmark(benchmark::State& state, const std::string& preset) {
  echoreg::core::SignalDetector detector(adaptedPreset(preset));
  std::vector<float> samples(kSamples);
  std::size_t index = firstRecord(state);
  std::int64_t accepted = 0;
  for (auto _ : state) {
    convert(index++, samples.data());
    const echoreg::core::SignalDetection detection = detector.detect(samples.data(), kSamples);
    accepted += detection.accepted() ? 1 : 0;
    benchmark::DoNotOptimize(detection);
  }
  reportRates(state);
  state.counters["accepted_fraction"] =
      benchmark::Counter(static_cast<double>(accepted), benchmark::Counter::kAvgIterations);
}

// The chain's two halves apart, for the time breakdown: the uint8 -> float conversion alone,
// and findPeaks alone on precomputed envelopes of the preset.
void conversionBenchmark(benchmark::State& state) {
  std::vector<float> samples(kSamples);
  std::size_t index = firstRecord(state);
  for (auto _ : state) {
    convert(index++, samples.data());
    benchmark::DoNotOptimize(samples.data());
    benchmark::ClobberMemory();
  }
  reportRates(state);
}

void peaksBenchmark(benchmark::State& state, const std::string& preset) {
  const echoreg::core::DetectionParams params = adaptedPreset(preset);
  echoreg::core::EnvelopeDetector envelopeDetector(params.envelope);
  const echoreg::core::PeakParams peakParams = echoreg::core::resolvePeakParams(params);
  std::vector<float> samples(kSamples);
  std::vector<float> envelopes(static_cast<std::size_t>(kRecords) * kSamples);
  for (std::size_t r = 0; r < kRecords; ++r) {
    convert(r, samples.data());
    envelopeDetector.compute(samples.data(), kSamples, envelopes.data() + r * kSamples);
  }
  std::size_t index = firstRecord(state);
  for (auto _ : state) {
    const float* envelope = envelopes.data() + (index++ % kRecords) * kSamples;
    const echoreg::core::PeakResult result =
        echoreg::core::findPeaks(peakParams, envelope, kSamples);
    benchmark::DoNotOptimize(result);
  }
  reportRates(state);
}

echoreg::core::EnvelopeParams envelope(echoreg::core::EnvelopeMethod method) {
  echoreg::core::EnvelopeParams params;
  params.method = method;
  params.ringDownSamples = kRingDown;
  return params;
}

echoreg::core::EnvelopeParams mozes(bool zeroPhase) {
  echoreg::core::EnvelopeParams params = envelope(echoreg::core::EnvelopeMethod::Mozes);
  params.butterworthOrder = 2;
  params.cutoffNormalized = 0.01;
  params.zeroPhase = zeroPhase;
  return params;
}

echoreg::core::EnvelopeParams windowed(echoreg::core::EnvelopeMethod method, int windowSamples) {
  echoreg::core::EnvelopeParams params = envelope(method);
  params.windowSamples = windowSamples;
  return params;
}

void threads(benchmark::internal::Benchmark* benchmark) {
  benchmark->UseRealTime()->Threads(1);
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  if (cores > 1)
    benchmark->Threads(cores);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv))
    return 1;
  records();  // generate the set before any timing

  using echoreg::core::EnvelopeMethod;
  struct Envelope {
    const char* name;
    echoreg::core::EnvelopeParams params;
  };
  const Envelope envelopes[] = {
      {"envelope/mozes_zero_phase", mozes(true)},
      {"envelope/mozes_causal", mozes(false)},
      {"envelope/hann_153", windowed(EnvelopeMethod::Hann, 153)},
      {"envelope/hann_7", windowed(EnvelopeMethod::Hann, 7)},
      {"envelope/stddev_25", windowed(EnvelopeMethod::StdDev, 25)},
      {"envelope/hilbert", envelope(EnvelopeMethod::Hilbert)},
  };
  for (const Envelope& e : envelopes) {
    threads(benchmark::RegisterBenchmark(e.name, envelopeBenchmark, e.params));
  }
  for (const std::string preset : {"default", "mozes2008"}) {
    threads(benchmark::RegisterBenchmark(("chain/" + preset).c_str(), chainBenchmark, preset));
  }
  threads(benchmark::RegisterBenchmark("part/uint8_to_float", conversionBenchmark));
  for (const std::string preset : {"default", "mozes2008"}) {
    threads(benchmark::RegisterBenchmark(("part/find_peaks_" + preset).c_str(), peaksBenchmark,
                                         preset));
  }

  benchmark::AddCustomContext("records",
                              std::to_string(kRecords) + " x " + std::to_string(kSamples) +
                                  " uint8 specimen A-lines, seed " + std::to_string(kSeed));
  benchmark::AddCustomContext("target", ">= 100000 records/s per core for chain/default");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
