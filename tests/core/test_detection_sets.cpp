// Detection rates of every preset on every labelled set, one capture at a time, with only the
// acquisition facts given: the sets of tests/support/aline_generator (a water standoff over the
// knee, 9 MHz, 8-bit) and of tests/support/randomised_alines (written from a description of the
// physics by someone who had not read the detector: probes 3.5-15 MHz, 20-100 MHz sampling,
// 8/12/16-bit, baseline drift, standoffs, shallow and deep bone, reverberation). Each set has a
// tuning seed and held-out seeds; the default must hold on all of them.
#include "aline_generator.hpp"
#include "detection_scoring.hpp"

#include "echoreg/core/detection.hpp"

#include <gtest/gtest.h>

#include <iostream>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

test::DetectionScore scoreGeneratorSet(const DetectionParams& preset, std::uint64_t seed) {
  test::SpecimenSetOptions options;
  options.records = 400;
  options.seed = seed;
  const std::vector<test::LabelledALine> lines = test::makeSpecimenSet(options);
  std::vector<std::vector<float>> samples;
  samples.reserve(lines.size());
  for (const auto& line : lines)
    samples.emplace_back(line.samples.begin(), line.samples.end());
  test::AcquisitionFacts facts;
  facts.samplingFrequencyHz = options.pulse.samplingFrequencyHz;
  facts.speedOfSoundMps = 1540.0;
  DepthConversion depth;
  depth.samplingFrequencyHz = facts.samplingFrequencyHz;
  depth.speedOfSoundMps = facts.speedOfSoundMps;
  std::vector<test::LabelledRecord> records;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    test::LabelledRecord record;
    record.samples = &samples[i];
    record.hasBone = lines[i].hasBone;
    record.boneDepthMm = lines[i].hasBone ? depth.depthMm(lines[i].boneSample) : -1.0;
    records.push_back(record);
  }
  return test::scoreCapture(preset, facts, records);
}

TEST(DetectionSets, GeneratorSet) {
  for (const char* name : {"default", "mozes2008", "shadow"}) {
    for (std::uint64_t seed : {2008U, 1U, 2U, 3U}) {
      const test::DetectionScore score = scoreGeneratorSet(detectionPreset(name), seed);
      std::cout << "[ measured ] generator seed " << seed << ", " << name << ": "
                << test::describe(score) << "\n";
      if (std::string(name) == "default") {
        // The tuning seed 2008 misses 9 % (deep bone under faint speckle shows no measurable
        // shadow); the held-out seeds 4-5 %.
        EXPECT_LE(score.falseNegativeRate(), 0.10) << "seed " << seed;
        EXPECT_LE(score.falsePositiveRate(), 0.05) << "seed " << seed;
        EXPECT_LE(score.medianErrorMm(), 0.1) << "seed " << seed;
      }
    }
  }
}

}  // namespace
}  // namespace echoreg::core
