// The chain frame by frame gives what the chain over the whole capture gives: with the
// capture-dependent settings measured on the same A-lines, LiveDetector accepts the frames
// detectSequence accepts, at the same points (the oracle is the offline chain `register` runs).
// And a pose stream that stops makes the frames after it stale, each with its reason.
#include "demo_capture.hpp"

#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/live/live_detector.hpp"

#include <gtest/gtest.h>

#include <map>

namespace echoreg::live {
namespace {

// The demo sweep with a FemurToTracker on every frame (a bone marker that moves a little).
Sequence sweepWithBone(int frames) {
  test::DemoSweepOptions options;
  options.frames = frames;
  Sequence sweep = test::makeDemoSweep(options);
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    TrackedTransform femur;
    femur.matrix.topRightCorner<3, 1>() =
        Eigen::Vector3d(5.0 + 0.01 * static_cast<double>(f), -3.0, 20.0);
    sweep.frames[f].transforms["FemurToTracker"] = femur;
  }
  return sweep;
}

LiveDetectorOptions optionsFor(const Sequence& sweep, int adaptFrames) {
  LiveDetectorOptions options;
  options.params = detectionPreset("default");
  options.params.depth = depthFromSequence(sweep, options.params.depth);
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

PoseLookup exactPose(const SequenceFrame& frame, const std::string& name) {
  PoseLookup lookup;
  const TrackedTransform& t = frame.transforms.at(name);
  if (t.valid())
    lookup.matrix = t.matrix;
  else
    lookup.refusal = name + " is " + t.status;
  return lookup;
}

TEST(LiveDetector, AcceptsTheFramesAndPointsOfTheOfflineChain) {
  const Sequence sweep = sweepWithBone(600);
  const LiveDetectorOptions options = optionsFor(sweep, 600);
  const SequenceDetection offline = detectSequence(sweep, options.params, options.points);

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
    const FrameDetection& expected = offline.frames[f];
    ASSERT_EQ(decided[f].accepted(), expected.accepted())
        << "frame " << f << ": live " << decided[f].reason << ", offline "
        << rejectReasonName(expected.reason);
    if (expected.accepted()) {
      ++accepted;
      EXPECT_LT((decided[f].point->point - *expected.pointMm).norm(), 1e-9) << "frame " << f;
      EXPECT_TRUE(decided[f].point->hasBeam);
    }
  }
  EXPECT_EQ(accepted, offline.accepted);
  EXPECT_GT(accepted, 50);
  // The 20 frames whose probe was INVALID are refused by the pose, with its words.
  EXPECT_EQ(decided[305].reason, "invalid-pose");
  EXPECT_EQ(decided[305].detail, "ProbeToTracker is INVALID");
}

TEST(LiveDetector, FramesWaitForTheAdaptationThenFlowOneByOne) {
  const Sequence sweep = sweepWithBone(100);
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
  const Sequence sweep = sweepWithBone(200);
  LiveDetector live(optionsFor(sweep, 20));
  PoseBuffer poses(0.1);
  std::map<std::string, int> reasons;
  std::string example;
  std::vector<float> samples;
  for (std::size_t f = 0; f < sweep.frames.size(); ++f) {
    const SequenceFrame& frame = sweep.frames[f];
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
