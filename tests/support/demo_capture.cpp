#include "demo_capture.hpp"

#include "aline_generator.hpp"

#include "echoreg/core/depth.hpp"

#include <cmath>

namespace echoreg::test {

core::Sequence makeDemoSweep(const DemoSweepOptions& options, std::vector<double>* boneDepthMm) {
  constexpr double kPi = 3.14159265358979323846;
  core::Sequence sequence;
  sequence.elementType = core::ElementType::UInt8;
  sequence.frameSize = {4096, 1};
  sequence.acquisition.samplingFrequencyHz = 50e6;
  sequence.acquisition.delayS = 0.0;
  sequence.acquisition.speedOfSoundMps = 1540.0;
  sequence.acquisition.transducer = "single element 9 MHz, 6.35 mm, 25 mm focus (simulated)";
  sequence.pixels.reserve(static_cast<std::size_t>(options.frames) * 4096);
  if (boneDepthMm)
    boneDepthMm->clear();

  SpecimenSetOptions lineOptions;
  const core::DepthConversion depth;
  for (int f = 0; f < options.frames; ++f) {
    const double t = f / options.frameRateHz;
    const double alongMm = options.speedMmPerS * t;
    // Soft tissue thickens and thins along the thigh; the hand tilts now and then.
    const double tissueMm = 9.0 + 4.0 * std::sin(2.0 * kPi * alongMm / 80.0);
    const double standoffMm = 8.0 + 0.5 * std::sin(2.0 * kPi * t / 1.7);
    const bool oblique = f >= 400 && f < 450;
    const double incidenceDeg = oblique ? 35.0 : 4.0 + 3.0 * std::sin(2.0 * kPi * t / 2.3);
    lineOptions.seed = options.seed * 1000003ULL + static_cast<std::uint64_t>(f);
    const LabelledALine line = makeSpecimenALine(standoffMm, tissueMm, incidenceDeg, lineOptions);
    sequence.pixels.insert(sequence.pixels.end(), line.samples.begin(), line.samples.end());
    if (boneDepthMm)
      boneDepthMm->push_back(line.hasBone ? depth.depthMm(line.boneSample) : -1.0);

    core::SequenceFrame frame;
    frame.timestampS = 10.0 + t;
    // The probe points down (-z of the tracker), sliding along +x; its beam is its +z axis.
    core::TrackedTransform probe;
    probe.matrix << 1, 0, 0, alongMm,  //
        0, -1, 0, 50.0,                //
        0, 0, -1, 300.0,               //
        0, 0, 0, 1;
    probe.status = (f >= 300 && f < 320) ? "INVALID" : "OK";
    frame.transforms["ProbeToTracker"] = probe;
    frame.fields.emplace_back("ImageStatus", "OK");
    sequence.frames.push_back(std::move(frame));
  }
  return sequence;
}

}  // namespace echoreg::test
