// Detection rates on the domain-randomised labelled captures of tests/support/randomised_alines,
// a generator written from a description of the physics by someone who had not read the
// detector: every capture judged alone with only its acquisition facts (sampling frequency,
// assumed speed of sound, delay and, for the in-vivo holder, the depth window a user would set);
// the transducer frequency, the ring-down and the shadow rule are what the default measures.
// The bounds are regression bounds at today's rates, not the targets.
#include "detection_scoring.hpp"
#include "randomised_alines.hpp"

#include "echoreg/core/detection.hpp"

#include <gtest/gtest.h>

#include <iostream>
#include <string>
#include <vector>

namespace echoreg {
namespace {

test::DetectionScore scoreRandomised(const DetectionParams& preset, const std::string& profile,
                                     std::uint64_t seed) {
  test::RandomisedSetOptions options;
  options.profile = profile;
  options.seed = seed;
  const std::vector<test::RandomisedCapture> captures = test::makeRandomisedSet(options);
  test::DetectionScore total;
  for (const test::RandomisedCapture& capture : captures) {
    test::AcquisitionFacts facts;
    facts.samplingFrequencyHz = capture.samplingFrequencyHz;
    facts.speedOfSoundMps = capture.speedOfSoundMps;
    facts.delayS = capture.delayS;
    facts.windowMinMm = capture.windowMinMm;
    facts.windowMaxMm = capture.windowMaxMm;
    std::vector<test::LabelledRecord> records;
    for (const test::RandomisedFrame& frame : capture.frames) {
      test::LabelledRecord record;
      record.samples = &frame.samples;
      record.hasBone = frame.hasBone;
      record.ambiguous = frame.ambiguous;
      record.boneDepthMm = frame.boneDepthMm;
      records.push_back(record);
    }
    total.add(test::scoreCapture(preset, facts, records));
  }
  return total;
}

TEST(DetectionRandomised, EveryProfileAndSeed) {
  for (const char* profile : {"randomised", "invivo-holder", "specimen-standoff"}) {
    for (std::uint64_t seed : {1U, 2U, 3U}) {
      for (const char* name : {"default", "mozes2008", "shadow"}) {
        const test::DetectionScore score = scoreRandomised(detectionPreset(name), profile, seed);
        std::cout << "[ measured ] " << profile << " seed " << seed << ", " << name << ": "
                  << test::describe(score) << "\n";
        if (std::string(name) == "default") {
          // Regression bounds at what the default reaches today (issue 12 asks for 5 %: not met
          // on these sets; docs/detection.md has the table). The old default ("shadow") misses
          // 52-100 % of these bones.
          EXPECT_LE(score.falseNegativeRate(), 0.50) << profile << " seed " << seed;
          EXPECT_LE(score.falsePositiveRate(), 0.42) << profile << " seed " << seed;
          if (std::string(profile) != "randomised") {
            EXPECT_LE(score.medianErrorMm(), 0.1) << profile << " seed " << seed;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace echoreg
