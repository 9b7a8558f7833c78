// libFuzzer harness of `echoreg detect --params` files: the input merged as detect merges it
// (cli/src/detection_params), resolved over a small capture's header, then the detection chain run
// over that capture with the parameters. A FileError naming the file (the reader) or a
// std::invalid_argument (a value out of range: detect's "bad parameter") is the expected answer
// to bad bytes; any other exception, a crash, a sanitizer report, a hang (parameters that make
// the chain run for ever) or an allocation beyond the fuzzer's limit is a finding.
#include "fuzz_input.hpp"

#include "detection_params.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence_detection.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace {

// 16 A-lines of 1000 samples at 50 MHz: an echo of 9 MHz at sample 600 (23 mm at 1540 m/s) over
// deterministic noise, and a shadow behind it, so that every policy has something to find.
const echoreg::core::Sequence& capture() {
  static const echoreg::core::Sequence sequence = [] {
    echoreg::core::Sequence s;
    constexpr int kSamples = 1000;
    constexpr int kFrames = 16;
    s.elementType = echoreg::core::ElementType::Int16;
    s.frameSize = {kSamples, 1};
    s.acquisition.samplingFrequencyHz = 50e6;
    s.acquisition.speedOfSoundMps = 1540.0;
    std::uint32_t state = 12345;
    for (int f = 0; f < kFrames; ++f) {
      echoreg::core::SequenceFrame frame;
      frame.timestampS = 0.01 * f;
      s.frames.push_back(frame);
      for (int i = 0; i < kSamples; ++i) {
        state = state * 1664525u + 1013904223u;
        const double noise = (static_cast<double>(state >> 16) / 65536.0 - 0.5) * 40.0;
        const double tissue = i < 600 ? 3.0 : 0.3;
        const double t = (i - 600 - f % 3) / 50e6;
        const double echo = 3000.0 * std::exp(-t * t / (2.0 * 1.5e-7 * 1.5e-7)) *
                            std::cos(2.0 * 3.141592653589793 * 9e6 * t);
        const auto value = static_cast<std::int16_t>(std::lround(tissue * noise + echo));
        std::uint8_t bytes[2];
        std::memcpy(bytes, &value, 2);
        s.pixels.push_back(bytes[0]);
        s.pixels.push_back(bytes[1]);
      }
    }
    return s;
  }();
  return sequence;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = echoreg::fuzz::writeInput(data, size, ".json");
  std::string preset;
  echoreg::cli::TunableSettings settings;
  try {
    echoreg::cli::mergeParamsFile(path, preset, settings);
  } catch (const echoreg::core::FileError&) {
    return 0;
  }
  echoreg::core::DetectionParams params;
  try {
    params = echoreg::cli::resolveParams(preset, settings, capture());
    echoreg::core::detectSequence(capture(), params);
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
