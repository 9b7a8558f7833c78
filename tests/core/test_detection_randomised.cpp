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

#include <Eigen/Core>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

// What a user knows of the capture's acquisition.
test::AcquisitionFacts factsOf(const test::RandomisedCapture& capture) {
  test::AcquisitionFacts facts;
  facts.samplingFrequencyHz = capture.samplingFrequencyHz;
  facts.speedOfSoundMps = capture.speedOfSoundMps;
  facts.delayS = capture.delayS;
  facts.windowMinMm = capture.windowMinMm;
  facts.windowMaxMm = capture.windowMaxMm;
  return facts;
}

// The capture's frames with their labels, as the scorer takes them.
std::vector<test::LabelledRecord> recordsOf(const test::RandomisedCapture& capture) {
  std::vector<test::LabelledRecord> records;
  for (const test::RandomisedFrame& frame : capture.frames)
    records.push_back({&frame.samples, frame.hasBone, frame.ambiguous, frame.boneDepthMm});
  return records;
}

test::DetectionScore scoreRandomised(const DetectionParams& preset, const std::string& profile,
                                     std::uint64_t seed) {
  test::RandomisedSetOptions options;
  options.profile = profile;
  options.seed = seed;
  const std::vector<test::RandomisedCapture> captures = test::makeRandomisedSet(options);
  test::DetectionScore total;
  for (const test::RandomisedCapture& capture : captures) {
    total.add(test::scoreCapture(preset, factsOf(capture), recordsOf(capture)));
  }
  return total;
}

// Seeds 1-3 were looked at while the default was built (stops 11-13 chose between candidate
// values on them pooled); seeds 4-6 were first run after stop 13's changes, as a held-out check
// (the default only).
TEST(DetectionRandomised, EveryProfileAndSeed) {
  for (const char* profile : {"randomised", "invivo-holder", "specimen-standoff"}) {
    for (std::uint64_t seed : {1U, 2U, 3U, 4U, 5U, 6U}) {
      for (const char* name : {"default", "mozes2008", "shadow"}) {
        const bool heldOut = seed >= 4;
        if (heldOut && std::string(name) != "default")
          continue;
        const test::DetectionScore score = scoreRandomised(detectionPreset(name), profile, seed);
        std::cout << "[ measured ] " << profile << " seed " << seed
                  << (heldOut ? " (held out)" : "") << ", " << name << ": " << test::describe(score)
                  << "\n";
        if (std::string(name) == "default") {
          // Regression bounds a little above what the default reaches today (FN 2-24 %, FP
          // 3-26 %, wrong echo 0-19 %; issue 12 asks for 5 %: not met on these sets;
          // docs/detection.md has the table). The capture's context (stop 30) took the misses
          // over seeds 1-6 from 25.8 to 19.9 % (randomised), 11.1 to 7.1 (in vivo) and 9.2 to
          // 4.8 (specimen), the false positives from 17.6 to 19.9, 7.5 to 9.2 and 10.4 to 11.8.
          // The old default ("shadow") misses 52-100 % of these bones.
          EXPECT_LE(score.falseNegativeRate(), 0.30) << profile << " seed " << seed;
          // In vivo, bone whose cortex rings just behind its echo (a leading echo and its
          // ringing tail, peaks.cpp's ringingTailOf), and the capture's context: FN 3.9-9.4 %
          // per seed today, 10.6-17.6 before the context, 19-28 % before the leading echo was
          // recognised.
          if (std::string(profile) == "invivo-holder") {
            EXPECT_LE(score.falseNegativeRate(), 0.12) << profile << " seed " << seed;
            // The peaks of the cortex's ringing behind bone's echo are not bone (peaks.cpp,
            // ringsOnFrom): echoes taken more than 0.5 mm from bone 0.7-5.3 % per seed today,
            // 5.7-5.9 % over seeds 1-3 and 4-6 before (most of them 0.5-1.5 mm too deep).
            EXPECT_LE(score.wrongEchoRate(), 0.06) << profile << " seed " << seed;
          }
          EXPECT_LE(score.falsePositiveRate(), 0.28) << profile << " seed " << seed;
          EXPECT_LE(score.wrongEchoRate(), 0.31) << profile << " seed " << seed;
          EXPECT_LE(score.medianErrorMm(), 0.1) << profile << " seed " << seed;
        }
      }
    }
  }
}

// The capture's context (ProminenceParams::contextFrames, EchoContext): on seeds that nobody had
// looked at when its constants were chosen (16-18; chosen on 1-6, checked on 10-15), the strapped
// holder in vivo and the specimen under a water standoff, where the probe stays on one bone. It
// takes a not-bone record's echo at the depth its predecessors agree on: misses fall by 3.8 and
// 4.6 points (13.8 -> 10.0 %, 6.9 -> 2.3 %), false positives rise by 1.3 and 1.4 (4.8 -> 6.1 %,
// 9.4 -> 10.8 %), the depths stay as accurate.
TEST(DetectionRandomised, TheCapturesContextFindsBoneTheRecordAloneCannotSee) {
  for (const char* profile : {"invivo-holder", "specimen-standoff"}) {
    test::DetectionScore alone, withContext;
    DetectionParams off = detectionPreset("default");
    off.peaks.prominence.contextFrames = 0;
    for (std::uint64_t seed : {16U, 17U, 18U}) {
      alone.add(scoreRandomised(off, profile, seed));
      withContext.add(scoreRandomised(detectionPreset("default"), profile, seed));
    }
    std::cout << "[ measured ] " << profile
              << " seeds 16-18, each record alone: " << test::describe(alone) << "\n[ measured ] "
              << profile
              << " seeds 16-18, with the capture's context: " << test::describe(withContext)
              << "\n";
    EXPECT_LE(withContext.falseNegativeRate(), alone.falseNegativeRate() - 0.03) << profile;
    EXPECT_LE(withContext.falsePositiveRate(), alone.falsePositiveRate() + 0.02) << profile;
    EXPECT_LE(withContext.wrongEchoRate(), alone.wrongEchoRate() + 0.005) << profile;
    EXPECT_LE(withContext.medianErrorMm(), 0.1) << profile;
    // Seeds no rule was chosen on: bone's echo taken before its ringing's stronger peaks (stop
    // 31, ringsOnFrom) took the in-vivo wrong echoes from 4.5 to 1.5 %.
    if (std::string(profile) == "invivo-holder") {
      EXPECT_LE(withContext.wrongEchoRate(), 0.03) << profile;
    }
  }
}

// An uncoupled transducer of the strapped holder (in-vivo profile, seed 14, capture 28: 50
// frames, no bone): after the ring-down its lens rings, bounces 0.9 mm apart from the face, each
// weaker than the one before, and the capture is judged by the shadow. Its sixth bounce peaked
// 0.1 % above its fifth (the envelope's ripple puts bounces of one height up to 10 % apart), so
// the train headed by the third bounce was no air and the shadow rule took that bounce for bone
// in 48 frames. A bounce may now peak within the ripple of the one before it (isAirTrain).
TEST(DetectionRandomised, AnUncoupledHolderTransducerRingsAsAir) {
  test::RandomisedSetOptions options;
  options.profile = "invivo-holder";
  options.seed = 14;
  const test::RandomisedCapture capture = test::makeRandomisedSet(options).at(28);
  int uncoupled = 0;
  for (const test::RandomisedFrame& frame : capture.frames)
    uncoupled += frame.kind == "uncoupled";
  ASSERT_EQ(uncoupled, 50) << capture.description;
  const test::DetectionScore score =
      test::scoreCapture(detectionPreset("default"), factsOf(capture), recordsOf(capture));
  std::cout << "[ measured ] in-vivo seed 14 capture 28 (uncoupled): " << test::describe(score)
            << "\n";
  EXPECT_EQ(score.negatives, 50);
  EXPECT_LE(score.falsePositives, 2);
}

// A 3.9 MHz probe at 25 MHz (randomised profile, seed 12, capture 26: bone at 20.2 mm under 18 mm
// of tissue). The cortex's own echoes follow bone's, 0.47 and 0.85 mm behind it at a third of its
// height, and then the shadow: at 3.9 MHz each echo lasts about a third of a millimetre, and the
// train filled the 2 mm region behind the echo enough that its median saw no shadow (37 of 40
// bone frames missed). The regions hold at least 18 periods of the transducer now (stop 41).
TEST(DetectionRandomised, ALowFrequencyProbesBoneIsFoundBehindItsCortexsEchoes) {
  test::RandomisedSetOptions options;
  options.seed = 12;
  const test::RandomisedCapture capture = test::makeRandomisedSet(options).at(26);
  ASSERT_LT(capture.transducerFrequencyHz, 4e6) << capture.description;
  const test::DetectionScore score =
      test::scoreCapture(detectionPreset("default"), factsOf(capture), recordsOf(capture));
  std::cout << "[ measured ] randomised seed 12 capture 26 (3.9 MHz): " << test::describe(score)
            << "\n";
  ASSERT_GE(score.positives, 30);
  EXPECT_LE(score.falseNegativeRate(), 0.15);
  EXPECT_LE(score.wrongEchoRate(), 0.15);
}

// Issue 12, item 4: the temporal filter's defaults keep at least 90 % of the correct echoes of a
// bone that moves at realistic speeds (the generator's hand-held sweeps at 10-50 mm/s and 100 Hz
// with poses, and strapped holders at 45 Hz without).
TEST(DetectionRandomised, TheTemporalFilterKeepsMovingBone) {
  for (const char* profile : {"randomised", "invivo-holder"}) {
    test::RandomisedSetOptions options;
    options.profile = profile;
    options.seed = 2;
    int correct = 0, kept = 0;
    for (const test::RandomisedCapture& capture : test::makeRandomisedSet(options)) {
      DetectionParams params = test::withFacts(detectionPreset("default"), factsOf(capture));
      const RecordSource source = [&capture](int i, std::vector<float>& out) {
        out = capture.frames[static_cast<std::size_t>(i)].samples;
      };
      params = adaptToCapture(params, static_cast<int>(capture.frames.size()),
                              static_cast<int>(capture.frames.front().samples.size()), source,
                              std::nullopt);
      SignalDetector detector(params);
      std::vector<InterSignalInput> inputs;
      std::vector<bool> right;
      bool tracked = false;
      for (const test::RandomisedFrame& frame : capture.frames) {
        const SignalDetection d =
            detector.detect(frame.samples.data(), static_cast<int>(frame.samples.size()));
        InterSignalInput in;
        in.detected = d.accepted();
        in.depthMm = d.depthMm;
        in.timestampS = frame.timestampS;
        const Eigen::Vector4d beam(0.0, 0.0, d.depthMm, 1.0);
        in.pointMm = frame.hasPose ? Eigen::Vector3d((frame.probeToTracker * beam).head<3>())
                                   : Eigen::Vector3d(beam.head<3>());
        tracked = tracked || frame.hasPose;
        inputs.push_back(in);
        right.push_back(d.accepted() && frame.hasBone && !frame.ambiguous &&
                        std::fabs(d.depthMm - frame.boneDepthMm) <= 0.5);
      }
      InterSignalParams temporalOnly = params.interSignal;
      temporalOnly.minSpreadMm = 0.0;  // the spatial filter drops repeats on purpose
      const std::vector<RejectReason> verdict = applyInterSignal(temporalOnly, inputs, tracked);
      for (std::size_t f = 0; f < inputs.size(); ++f) {
        if (!right[f])
          continue;
        ++correct;
        if (verdict[f] == RejectReason::None)
          ++kept;
      }
    }
    const double share = correct ? static_cast<double>(kept) / correct : 0.0;
    std::cout << "[ measured ] " << profile << ": the temporal filter keeps " << kept << " of "
              << correct << " correct echoes (" << 100.0 * share << " %)\n";
    EXPECT_GE(share, 0.9) << profile;
  }
}

}  // namespace
}  // namespace echoreg::core
