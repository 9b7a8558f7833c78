// The chain frame by frame gives what the chain over the whole capture gives: with the
// capture-dependent settings measured on the same A-lines, LiveDetector accepts the frames
// detectSequence accepts, at the same points (the oracle is the offline chain `register` runs).
// And a pose stream that stops makes the frames after it stale, each with its reason.
#include "aline_generator.hpp"
#include "demo_capture.hpp"

#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/live/live_detector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

namespace echoreg::live {
namespace {

// The demo sweep with a FemurToTracker on every frame (a bone marker that moves a little).
core::Sequence sweepWithBone(int frames) {
  test::DemoSweepOptions options;
  options.frames = frames;
  core::Sequence sweep = test::makeDemoSweep(options);
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    core::TrackedTransform femur;
    femur.matrix.topRightCorner<3, 1>() =
        Eigen::Vector3d(5.0 + 0.01 * static_cast<double>(f), -3.0, 20.0);
    sweep.frames[f].transforms["FemurToTracker"] = femur;
  }
  return sweep;
}

LiveDetectorOptions optionsFor(const core::Sequence& sweep, int adaptFrames) {
  LiveDetectorOptions options;
  options.params = core::detectionPreset("default");
  options.params.depth = core::depthFromSequence(sweep, options.params.depth);
  options.params.envelope.samplingFrequencyHz = options.params.depth.samplingFrequencyHz;
  options.params.interSignal.history = 1;  // register's default: each echo judged alone
  options.params.interSignal.minSpreadMm = 1.0;
  options.headerFrequencyHz = sweep.acquisition.transducerFrequencyHz;
  options.points.poseTransform = "ProbeToTracker";
  options.points.referenceTransform = "FemurToTracker";
  options.points.beamToProbe(2, 3) = 4.0;
  options.adaptFrames = adaptFrames;
  return options;
}

PoseLookup exactPose(const core::SequenceFrame& frame, const std::string& name) {
  PoseLookup lookup;
  const core::TrackedTransform& t = frame.transforms.at(name);
  if (t.valid())
    lookup.matrix = t.matrix;
  else
    lookup.refusal = name + " is " + t.status;
  return lookup;
}

TEST(LiveDetector, AcceptsTheFramesAndPointsOfTheOfflineChain) {
  core::Sequence sweep = sweepWithBone(600);
  // Frame 310, one of those whose probe is INVALID, holds no echo at all (all samples zero).
  const std::size_t frameBytes = sweep.samplesPerFrame() * core::elementSize(sweep.elementType);
  std::fill_n(sweep.pixels.begin() + static_cast<std::ptrdiff_t>(310 * frameBytes), frameBytes, 0);
  const LiveDetectorOptions options = optionsFor(sweep, 600);
  const core::SequenceDetection offline =
      core::detectSequence(sweep, options.params, options.points);

  LiveDetector live(options);
  std::vector<LiveFrame> decided;
  std::vector<float> samples;
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    sweep.frameSamples(f, samples);
    const std::vector<LiveFrame> now =
        live.add(static_cast<int>(f), *sweep.frames[f].timestampS, samples,
                 exactPose(sweep.frames[f], "ProbeToTracker"),
                 exactPose(sweep.frames[f], "FemurToTracker"), {});
    decided.insert(decided.end(), now.begin(), now.end());
  }
  ASSERT_EQ(decided.size(), sweep.frames.size());
  int accepted = 0;
  for (std::size_t f = 0; f < decided.size(); ++f) {
    const core::FrameDetection& expected = offline.frames[f];
    ASSERT_EQ(decided[f].accepted(), expected.accepted())
        << "frame " << f << ": live " << decided[f].reason << ", offline "
        << core::rejectReasonName(expected.reason);
    // Refused frames give register's reason too: a frame whose probe pose is INVALID is
    // invalid-pose only where its echo would have been accepted, else the echo's reason (live
    // counted every such frame invalid-pose: 1,298 against register's 470 on a long sweep).
    if (!expected.accepted()) {
      EXPECT_EQ(decided[f].reason, core::rejectReasonName(expected.reason)) << "frame " << f;
    }
    if (expected.accepted()) {
      ++accepted;
      EXPECT_LT((decided[f].point->point - *expected.pointMm).norm(), 1e-9) << "frame " << f;
      EXPECT_TRUE(decided[f].point->hasBeam);
    }
  }
  EXPECT_EQ(accepted, offline.accepted);
  EXPECT_GT(accepted, 50);
  // The 20 frames whose probe was INVALID are refused by the pose, with its words, where their
  // echo was found.
  EXPECT_EQ(decided[305].reason, "invalid-pose");
  EXPECT_EQ(decided[305].detail, "ProbeToTracker is INVALID");
  EXPECT_EQ(decided[310].reason, core::rejectReasonName(offline.frames[310].reason));
  EXPECT_NE(decided[310].reason, "invalid-pose");
}

// A sweep whose first second is unrepresentative: the probe is put down tilted 35 degrees, so
// its first 100 A-lines hold no bone echo (the generator's oblique incidence: tissue, fascia
// and the membrane's ringing); then the demo sweep over bone that casts its shadow. Measured on
// the first 64 A-lines alone, the shadow rule is the per-record one (bone's shadow in about 4 %
// of them), which accepts about a quarter of the tilted A-lines' echoes; the whole capture
// requires the shadow (offline, as register judges it). The live chain measures the rule again
// as the A-lines come and judges the frames so far by the new rule when it changes: its final
// points are the offline chain's. (Deciding every frame by the first 64 A-lines' rule, as live
// did before, accepted 14 echoes in the tilted second and 81 in all against the offline 57: 82
// frames differed.)
TEST(LiveDetector, AnUnrepresentativeStartIsJudgedAgainByTheWholeCapturesShadowRule) {
  core::Sequence sweep = sweepWithBone(400);
  constexpr int kTilted = 100;
  test::SpecimenSetOptions lineOptions;
  for (int f = 0; f < kTilted; ++f) {
    lineOptions.seed = 9000 + static_cast<std::uint64_t>(f);
    const test::LabelledALine line = test::makeSpecimenALine(8.0, 9.0, 35.0, lineOptions);
    ASSERT_FALSE(line.hasBone);
    std::copy(line.samples.begin(), line.samples.end(),
              sweep.pixels.begin() + static_cast<std::ptrdiff_t>(f) * 4096);
  }
  const LiveDetectorOptions options = optionsFor(sweep, 64);
  const core::SequenceDetection offline =
      core::detectSequence(sweep, options.params, options.points);
  ASSERT_EQ(offline.params.peaks.prominence.shadow, core::ShadowRule::Required);

  LiveDetector live(options);
  std::map<int, LiveFrame> accepted;  // the session's view: frame -> its accepted verdict
  int acceptedTiltedBeforeSwitch = 0;
  std::vector<ShadowRuleSwitch> switches;
  const auto take = [&](const std::vector<LiveFrame>& decided) {
    for (const LiveFrame& frame : decided) {
      if (frame.accepted())
        accepted[frame.frame] = frame;
    }
    if (std::optional<ShadowRuleSwitch> change = live.takeSwitch()) {
      for (const auto& [frame, verdict] : accepted)
        acceptedTiltedBeforeSwitch += frame < kTilted ? 1 : 0;
      accepted.clear();
      for (const LiveFrame& frame : change->accepted)
        accepted[frame.frame] = frame;
      switches.push_back(std::move(*change));
    }
  };
  std::vector<float> samples;
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    sweep.frameSamples(f, samples);
    take(live.add(static_cast<int>(f), *sweep.frames[f].timestampS, samples,
                  exactPose(sweep.frames[f], "ProbeToTracker"),
                  exactPose(sweep.frames[f], "FemurToTracker"), {}));
  }
  take(live.flush());

  // The first 64 chose the per-record rule; a later measurement over A-lines spread through all
  // received chose the shadow, once.
  const std::vector<ShadowMeasurement>& measured = live.shadowMeasurements();
  ASSERT_GE(measured.size(), 3u);
  EXPECT_EQ(measured.front().frames, 64);
  EXPECT_EQ(measured.front().trial.rule, core::ShadowRule::Auto);
  EXPECT_LT(measured.front().trial.share, 0.2);
  EXPECT_EQ(measured[1].frames, 128);
  EXPECT_EQ(measured.back().frames, 400);  // the end of the stream: every A-line
  EXPECT_EQ(measured.back().trial.records, 64);
  EXPECT_EQ(measured.back().trial.rule, core::ShadowRule::Required);
  ASSERT_EQ(switches.size(), 1u);
  EXPECT_EQ(switches[0].from, core::ShadowRule::Auto);
  EXPECT_EQ(switches[0].to, core::ShadowRule::Required);
  EXPECT_EQ(live.params().peaks.prominence.shadow, core::ShadowRule::Required);
  // What the first rule had accepted in the tilted second (none of it bone).
  EXPECT_GE(acceptedTiltedBeforeSwitch, 10);
  // The session's points are the offline chain's, frame for frame.
  int expectedAccepted = 0;
  for (std::size_t f = 0; f < offline.frames.size(); ++f) {
    const core::FrameDetection& expected = offline.frames[f];
    const auto found = accepted.find(static_cast<int>(f));
    ASSERT_EQ(found != accepted.end(), expected.accepted()) << "frame " << f;
    if (expected.accepted()) {
      ++expectedAccepted;
      EXPECT_LT((found->second.point->point - *expected.pointMm).norm(), 1e-9) << "frame " << f;
    }
  }
  EXPECT_EQ(static_cast<int>(accepted.size()), expectedAccepted);
  EXPECT_GT(expectedAccepted, 40);
  // The switch's verdicts count every frame received when it was measured.
  int counted = 0;
  for (const auto& [reason, count] : switches[0].verdicts)
    counted += count;
  EXPECT_EQ(counted, switches[0].measurement.frames);
}

TEST(LiveDetector, FramesWaitForTheAdaptationThenFlowOneByOne) {
  const core::Sequence sweep = sweepWithBone(100);
  LiveDetector live(optionsFor(sweep, 40));
  std::vector<float> samples;
  for (std::size_t f = 0; f < 100; ++f) {
    sweep.frameSamples(f, samples);
    const std::size_t now = live.add(static_cast<int>(f), *sweep.frames[f].timestampS, samples,
                                     exactPose(sweep.frames[f], "ProbeToTracker"),
                                     exactPose(sweep.frames[f], "FemurToTracker"), {})
                                .size();
    EXPECT_EQ(now, f < 39 ? 0u : f == 39 ? 40u : 1u) << "frame " << f;
  }
  EXPECT_TRUE(live.adapted());
  EXPECT_TRUE(live.flush().empty());
}

TEST(LiveDetector, APoseStreamThatStopsMakesTheFramesStale) {
  const core::Sequence sweep = sweepWithBone(200);
  LiveDetector live(optionsFor(sweep, 20));
  PoseBuffer poses(0.1);
  std::map<std::string, int> reasons;
  std::string example;
  std::vector<float> samples;
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    const core::SequenceFrame& frame = sweep.frames[f];
    const double t = *frame.timestampS;
    if (f < 100)  // the probe's poses stop after frame 99 (the femur's go on)
      poses.add("ProbeToTracker", {t, frame.transforms.at("ProbeToTracker").matrix, "OK"});
    poses.add("FemurToTracker", {t, frame.transforms.at("FemurToTracker").matrix, "OK"});
    sweep.frameSamples(f, samples);
    for (const LiveFrame& decided :
         live.add(static_cast<int>(f), t, samples, poses.at("ProbeToTracker", t),
                  poses.at("FemurToTracker", t), {})) {
      ++reasons[decided.reason];
      if (decided.reason == "stale-pose" && example.empty())
        example = decided.detail;
    }
  }
  // 100 Hz: frames 100-109 are within 0.1 s of the last pose and held (109 is at the limit,
  // where rounding decides); 110-199 are stale.
  EXPECT_NEAR(reasons["stale-pose"], 90, 1);
  EXPECT_EQ(example.rfind("stale pose: the newest ProbeToTracker is 0.1", 0), 0u) << example;
  EXPECT_NE(example.find("s older than the A-line (tolerance 0.100 s)"), std::string::npos)
      << example;
}

}  // namespace
}  // namespace echoreg::live
