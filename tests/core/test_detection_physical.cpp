// The detection presets scored on the physical A-line generator (tests/support/physical_alines):
// signals written from pulse-echo physics by someone who had not read the detector. Besides the
// scores (loose regression bounds over what the default measures today), the generator itself is
// checked: determinism, its labels against its own contrast rule, an independent look at the
// digitised records where it says the bone is, the share of positives and the depth conversion.
#include "detection_scoring.hpp"
#include "physical_alines.hpp"

#include "echoreg/core/detection.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace echoreg::test {
namespace {

const PhysicalSet& physicalSet(const std::string& profile, std::uint64_t seed) {
  static std::map<std::pair<std::string, std::uint64_t>, PhysicalSet> cache;
  const auto key = std::make_pair(profile, seed);
  auto found = cache.find(key);
  if (found == cache.end())
    found = cache.emplace(key, generatePhysicalSet(profile, seed)).first;
  return found->second;
}

// Moving energy of the record around its median (the code of zero signal), over about one period
// of the transducer: an envelope estimate that knows nothing of the generator's components.
std::vector<double> movingEnergy(const std::vector<float>& samples, int window) {
  std::vector<float> sorted = samples;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double zero = sorted[sorted.size() / 2];
  const int n = static_cast<int>(samples.size());
  std::vector<double> energy(samples.size(), 0.0);
  for (int i = 0; i < n; ++i) {
    double sum = 0.0;
    for (int k = std::max(0, i - window / 2); k <= std::min(n - 1, i + window / 2); ++k) {
      const double value = samples[static_cast<std::size_t>(k)] - zero;
      sum += value * value;
    }
    energy[static_cast<std::size_t>(i)] = sum;
  }
  return energy;
}

double depthOf(const AcquisitionFacts& facts, double sampleIndex) {
  return (sampleIndex / facts.samplingFrequencyHz + facts.delayS) * facts.speedOfSoundMps * 1000.0 /
         2.0;
}

TEST(PhysicalAlines, SameSeedGivesTheSameRecordsAndAnotherSeedOthers) {
  const PhysicalSet first = generatePhysicalSet("holder", 11);
  const PhysicalSet again = generatePhysicalSet("holder", 11);
  const PhysicalSet other = generatePhysicalSet("holder", 12);
  ASSERT_EQ(first.captures.size(), again.captures.size());
  for (std::size_t c = 0; c < first.captures.size(); ++c) {
    ASSERT_EQ(first.captures[c].frames.size(), again.captures[c].frames.size());
    EXPECT_EQ(first.captures[c].name, again.captures[c].name);
    for (std::size_t f = 0; f < first.captures[c].frames.size(); ++f) {
      const PhysicalFrame& a = first.captures[c].frames[f];
      const PhysicalFrame& b = again.captures[c].frames[f];
      ASSERT_EQ(a.samples, b.samples) << first.captures[c].name << " frame " << f;
      EXPECT_EQ(a.hasBone, b.hasBone);
      EXPECT_EQ(a.ambiguous, b.ambiguous);
      EXPECT_EQ(a.boneDepthMm, b.boneDepthMm);
      EXPECT_EQ(a.kind, b.kind);
    }
  }
  EXPECT_NE(first.captures.front().frames.front().samples,
            other.captures.front().frames.front().samples);
}

TEST(PhysicalAlines, UnknownProfileIsRefusedWithTheValidNames) {
  try {
    generatePhysicalSet("tank", 1);
    FAIL() << "an unknown profile was accepted";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("'tank'"), std::string::npos) << message;
    for (const std::string& name : physicalProfileNames())
      EXPECT_NE(message.find(name), std::string::npos) << message;
  }
}

TEST(PhysicalAlines, LabelsFollowTheContrastRuleAndLieInTheRecord) {
  for (const std::string& profile : physicalProfileNames()) {
    for (const PhysicalCapture& capture : physicalSet(profile, 1).captures) {
      const double lastDepthMm =
          depthOf(capture.facts, double(capture.frames.front().samples.size() - 1));
      for (const PhysicalFrame& frame : capture.frames) {
        SCOPED_TRACE(capture.name + " " + frame.kind);
        const bool boneKind = frame.kind.rfind("bone", 0) == 0;
        EXPECT_FALSE(frame.hasBone && frame.ambiguous);
        if (!boneKind) {
          EXPECT_FALSE(frame.hasBone);
          EXPECT_FALSE(frame.ambiguous);
          EXPECT_LT(frame.boneDepthMm, 0.0);
          continue;
        }
        EXPECT_GE(frame.boneDepthMm, depthOf(capture.facts, 0.0));
        EXPECT_LE(frame.boneDepthMm, lastDepthMm);
        EXPECT_EQ(frame.hasBone, frame.contrastDb >= kPositiveContrastDb);
        EXPECT_EQ(frame.ambiguous, frame.contrastDb >= kNegativeContrastDb &&
                                       frame.contrastDb < kPositiveContrastDb);
        if (capture.facts.windowMinMm && frame.hasBone) {
          EXPECT_GE(frame.boneDepthMm, *capture.facts.windowMinMm);
          EXPECT_LE(frame.boneDepthMm, *capture.facts.windowMaxMm);
        }
      }
    }
  }
}

// Where a positive's echo stands well clear (>= 20 dB), the digitised record's own energy peaks
// at the labelled depth as the facts convert it: sample index, sampling frequency, delay and
// speed of sound agree between the labels and the records (delayed captures included).
TEST(PhysicalAlines, ClearPositivesPeakInTheRecordAtTheirLabelledDepth) {
  std::vector<double> errorsMm;
  int delayedFrames = 0;
  for (const std::string& profile : physicalProfileNames()) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      for (const PhysicalCapture& capture : physicalSet(profile, seed).captures) {
        const double fs = capture.facts.samplingFrequencyHz;
        const int period =
            std::max(3, static_cast<int>(std::lround(fs / capture.transducerFrequencyHz)));
        const double mmPerSample = capture.facts.speedOfSoundMps * 1000.0 / (2.0 * fs);
        for (const PhysicalFrame& frame : capture.frames) {
          if (!frame.hasBone || frame.contrastDb < 20.0)
            continue;
          const std::vector<double> energy = movingEnergy(frame.samples, period);
          const double labelIndex =
              (frame.boneDepthMm * 2.0 / (capture.facts.speedOfSoundMps * 1000.0) -
               capture.facts.delayS) *
              fs;
          const int reach = static_cast<int>(1.0 / mmPerSample);
          const int low = std::max(0, static_cast<int>(labelIndex) - reach);
          const int high =
              std::min(static_cast<int>(energy.size()) - 1, static_cast<int>(labelIndex) + reach);
          const auto peak = std::max_element(energy.begin() + low, energy.begin() + high + 1);
          // The middle of the maximal run (a clipped echo is flat on top).
          auto runEnd = peak;
          while (runEnd + 1 != energy.begin() + high + 1 && *(runEnd + 1) == *peak)
            ++runEnd;
          const double index = 0.5 * double((peak - energy.begin()) + (runEnd - energy.begin()));
          errorsMm.push_back(std::fabs(depthOf(capture.facts, index) - frame.boneDepthMm));
          if (capture.facts.delayS > 0.0)
            ++delayedFrames;
        }
      }
    }
  }
  ASSERT_GT(errorsMm.size(), 300u);
  EXPECT_GT(delayedFrames, 50) << "no delayed capture checks the delay's part of the depth";
  std::sort(errorsMm.begin(), errorsMm.end());
  const double median = errorsMm[errorsMm.size() / 2];
  const double p90 = errorsMm[errorsMm.size() * 9 / 10];
  std::printf(
      "[ measured ] oracle depth vs label: median %.3f mm, 90th percentile %.3f mm (%zu "
      "frames, %d delayed)\n",
      median, p90, errorsMm.size(), delayedFrames);
  EXPECT_LE(median, 0.05);
  EXPECT_LE(p90, 0.25);
}

TEST(PhysicalAlines, EachProfileMixesPositivesAndTheNegativesItIsMeantToHave) {
  struct Expectation {
    std::string profile;
    double lowShare;
    double highShare;
    std::vector<std::string> negativeKinds;
  };
  const std::vector<Expectation> expectations = {
      {"handheld", 0.25, 0.85, {"off-bone", "uncoupled"}},
      {"holder", 0.4, 0.9, {"off-bone"}},
      {"phantom-water", 0.25, 0.85, {"off-bone"}},
  };
  for (const Expectation& expected : expectations) {
    int positives = 0;
    int negatives = 0;
    int ambiguous = 0;
    std::map<std::string, int> negativeKinds;
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      for (const PhysicalCapture& capture : physicalSet(expected.profile, seed).captures) {
        for (const PhysicalFrame& frame : capture.frames) {
          if (frame.ambiguous) {
            ++ambiguous;
          } else if (frame.hasBone) {
            ++positives;
          } else {
            ++negatives;
            ++negativeKinds[frame.kind.substr(0, frame.kind.find('+'))];
          }
        }
      }
    }
    const double share = double(positives) / double(positives + negatives);
    std::ostringstream kinds;
    for (const auto& [kind, count] : negativeKinds)
      kinds << " " << kind << " " << count;
    std::printf("[ measured ] %s seeds 1-3: %d positives, %d negatives (%s), %d ambiguous\n",
                expected.profile.c_str(), positives, negatives, kinds.str().c_str() + 1, ambiguous);
    EXPECT_GE(share, expected.lowShare) << expected.profile;
    EXPECT_LE(share, expected.highShare) << expected.profile;
    EXPECT_LT(ambiguous, (positives + negatives) / 4) << expected.profile;
    for (const std::string& kind : expected.negativeKinds)
      EXPECT_GT(negativeKinds[kind], 0) << expected.profile << " has no " << kind << " frame";
    EXPECT_GT(negativeKinds["bone"], 0) << expected.profile << " has no buried bone echo";
  }
}

TEST(PhysicalAlines, CodesFollowEachCapturesDigitiser) {
  int leftJustified = 0;
  int unsignedCaptures = 0;
  for (const std::string& profile : physicalProfileNames()) {
    for (const PhysicalCapture& capture : physicalSet(profile, 1).captures) {
      const double step = capture.leftJustified ? std::ldexp(1.0, 16 - capture.bits) : 1.0;
      const double half = std::ldexp(1.0, capture.bits - 1) * step;
      const double low = capture.isSigned ? -half : 0.0;
      const double high = (capture.isSigned ? half : 2.0 * half) - step;
      leftJustified += capture.leftJustified;
      unsignedCaptures += !capture.isSigned;
      for (const PhysicalFrame& frame : capture.frames) {
        for (float code : frame.samples) {
          ASSERT_GE(code, low) << capture.name;
          ASSERT_LE(code, high) << capture.name;
          ASSERT_EQ(std::fmod(double(code), step), 0.0) << capture.name;
        }
      }
    }
  }
  EXPECT_GT(leftJustified, 0);
  EXPECT_GT(unsignedCaptures, 0);
}

// --- Scores -----------------------------------------------------------------------------------

// Per qualifier of the frames' kinds: what the default misses and wrongly accepts (printed for
// the docs; the detector judges each record alone, as scoreCapture does).
void printKindsOfFailures(const std::string& profile, const core::DetectionParams& preset) {
  std::map<std::string, std::array<int, 4>> tally;  // positives, FN, negatives, FP
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    for (const PhysicalCapture& capture : physicalSet(profile, seed).captures) {
      const std::vector<LabelledRecord> records = capture.labelled();
      core::DetectionParams params = withFacts(preset, capture.facts);
      const core::RecordSource source = [&records](int index, std::vector<float>& out) {
        out = *records[static_cast<std::size_t>(index)].samples;
      };
      params = core::adaptToCapture(params, static_cast<int>(records.size()),
                                    static_cast<int>(records.front().samples->size()), source,
                                    std::nullopt);
      core::SignalDetector detector(params);
      std::array<int, 4> perCapture{};
      for (const PhysicalFrame& frame : capture.frames) {
        if (frame.ambiguous)
          continue;
        const bool accepted =
            detector.detect(frame.samples.data(), static_cast<int>(frame.samples.size()))
                .accepted();
        if (frame.hasBone) {
          ++perCapture[0];
          perCapture[1] += !accepted;
        } else {
          ++perCapture[2];
          perCapture[3] += accepted;
        }
        std::stringstream tags(frame.kind);
        std::string tag;
        while (std::getline(tags, tag, '+')) {
          std::array<int, 4>& counts = tally[tag];
          if (frame.hasBone) {
            ++counts[0];
            counts[1] += !accepted;
          } else {
            ++counts[2];
            counts[3] += accepted;
          }
        }
      }
      std::printf("[ captures ] seed %d %-75s default FN %d/%d, FP %d/%d\n", int(seed),
                  capture.name.c_str(), perCapture[1], perCapture[0], perCapture[3], perCapture[2]);
    }
  }
  for (const auto& [tag, counts] : tally)
    std::printf("[ kinds    ] %s default %-10s FN %d/%d, FP %d/%d\n", profile.c_str(), tag.c_str(),
                counts[1], counts[0], counts[3], counts[2]);
}

struct Bound {
  double falseNegative;
  double falsePositive;
  double wrongEcho;  ///< of the accepted positives, more than 0.5 mm from the bone
};

void scoreProfile(const std::string& profile, Bound defaultBound) {
  DetectionScore pooledDefault;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    for (const std::string presetName : {"default", "shadow", "mozes2008"}) {
      const core::DetectionParams preset = core::detectionPreset(presetName);
      DetectionScore total;
      for (const PhysicalCapture& capture : physicalSet(profile, seed).captures)
        total.add(scoreCapture(preset, capture.facts, capture.labelled()));
      std::printf("[ measured ] physical %s seed %d %-9s %s\n", profile.c_str(), int(seed),
                  presetName.c_str(), describe(total).c_str());
      ASSERT_GT(total.positives, 100);
      ASSERT_GT(total.negatives, 30);
      if (presetName == "default") {
        EXPECT_LE(total.medianErrorMm(), 0.1) << profile << " " << seed;
        pooledDefault.add(total);
      }
    }
  }
  std::printf("[ measured ] physical %s seeds 1-3 default   %s\n", profile.c_str(),
              describe(pooledDefault).c_str());
  EXPECT_LE(pooledDefault.falseNegativeRate(), defaultBound.falseNegative) << profile;
  EXPECT_LE(pooledDefault.falsePositiveRate(), defaultBound.falsePositive) << profile;
  EXPECT_LE(pooledDefault.wrongEchoRate(), defaultBound.wrongEcho) << profile;
  printKindsOfFailures(profile, core::detectionPreset("default"));
}

// Bounds on the default, seeds 1-3 pooled: about 4 points above what it measures after stop
// 23's change (handheld FN 35.6 % FP 20.2 %, holder 27.0 % / 10.3 %, phantom-water 49.2 % /
// 19.6 %; stop 25: phantom-water 23.1 % / 18.7 % since bare bone in water is seen, holder
// 18.7 % / 10.4 % with a shadow quieter than the rest of a short record; after stop 13: 40.7
// / 17.9, 29.8 / 10.3, 65.1 / 17.7; before it 56.6 / 17.6, 37.7 / 10.3, 79.3 / 14.7), to catch a
// regression, not to claim the 5 %. Wrong echoes (stop 32, when a fascia under the skin
// lost its borrowed shadow): handheld 9.3 %, holder 0.2 % (7.2 % before), phantom-water 0.5 %.
// Stop 33, shadows judged against the noise at their depth under a measured time-gain
// compensation: handheld FN 32.3 -> 27.3 %, FP 19.2 -> 14.6 %, wrong echo 9.3 -> 7.3 %;
// phantom-water FN 9.3 -> 9.5 %, wrong echo 0.5 -> 0.9 %; holder unchanged.
TEST(DetectionPhysical, HandheldSweeps) {
  scoreProfile("handheld", {0.32, 0.19, 0.11});
}
TEST(DetectionPhysical, StrappedHolder) {
  scoreProfile("holder", {0.23, 0.14, 0.03});
}
TEST(DetectionPhysical, PhantomInWater) {
  scoreProfile("phantom-water", {0.27, 0.23, 0.03});
}

}  // namespace
}  // namespace echoreg::test
