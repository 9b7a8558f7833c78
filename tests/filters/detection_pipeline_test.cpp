// echoreg::filters::DetectionPipeline, the path `echoreg detect` takes: its detection must be
// detectSequence's, number for number, its CSV written whole or not at all, and a change re-runs
// only the steps downstream of it.
#include "echoreg/filters/detection_pipeline.h"
#include "echoreg/core/sequence_detection.hpp"
#include "filter_test_helpers.hpp"
#include "randomised_sequence.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <vtkTable.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace echoreg::test {
namespace {

void expectSameDetection(const core::SequenceDetection& actual,
                         const core::SequenceDetection& expected) {
  ASSERT_EQ(actual.frames.size(), expected.frames.size());
  for (std::size_t f = 0; f < expected.frames.size(); ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    const core::FrameDetection& a = actual.frames[f];
    const core::FrameDetection& e = expected.frames[f];
    EXPECT_EQ(a.frame, e.frame);
    EXPECT_EQ(a.timestampS, e.timestampS);
    EXPECT_EQ(core::rejectReasonName(a.reason), core::rejectReasonName(e.reason));
    EXPECT_EQ(a.peakCount, e.peakCount);
    EXPECT_EQ(a.sampleIndex, e.sampleIndex);
    EXPECT_EQ(a.depthMm, e.depthMm);
    ASSERT_EQ(a.pointMm.has_value(), e.pointMm.has_value());
    if (e.pointMm) {
      EXPECT_EQ(*a.pointMm, *e.pointMm);
    }
  }
  EXPECT_EQ(actual.accepted, expected.accepted);
  EXPECT_EQ(actual.rejectedByReason, expected.rejectedByReason);
  EXPECT_EQ(actual.echoes, expected.echoes);
  EXPECT_EQ(actual.fromContext, expected.fromContext);
  EXPECT_EQ(actual.analysis.ringDownSamples, expected.analysis.ringDownSamples);
  EXPECT_EQ(actual.analysis.transducerFrequencyHz, expected.analysis.transducerFrequencyHz);
  EXPECT_EQ(actual.analysis.shadowRule, expected.analysis.shadowRule);
  EXPECT_EQ(core::detectionWarnings(actual), core::detectionWarnings(expected));
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

SyntheticCapture trackedCapture() {
  SyntheticCapture capture;
  capture.frames = 40;
  capture.probeStepMm = 0.3;
  capture.echoStepSamples = 3.0;
  capture.invalidProbeFrames = {4, 11};
  capture.withFemur = true;
  return capture;
}

class DetectionPipelineAgainstCore : public ::testing::TestWithParam<std::string> {};

TEST_P(DetectionPipelineAgainstCore, SameDetectionAsDetectSequence) {
  TempDir dir;
  const SyntheticCapture capture = trackedCapture();
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(sequence, path);

  core::DetectionParams params =
      GetParam() == "test" ? testDetectionParams(capture) : core::detectionPreset(GetParam());
  params.depth = core::depthFromSequence(sequence, params.depth);
  params.envelope.samplingFrequencyHz = params.depth.samplingFrequencyHz;
  params.interSignal.minSpreadMm = 0.4;
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  points.referenceTransform = "FemurToTracker";
  points.beamToProbe(0, 3) = 1.5;
  const core::SequenceDetection expected = core::detectSequence(sequence, params, points);
  if (GetParam() == "test") {
    ASSERT_GT(expected.accepted, 0);
    ASSERT_GT(expected.rejectedByReason.count("invalid-pose"), 0U);
  }

  filters::DetectionPipeline pipeline;
  pipeline.open(path, {});
  pipeline.configure(params, points);
  expectSameDetection(pipeline.run(), expected);
  EXPECT_EQ(pipeline.params().envelope, expected.params.envelope) << "adapted as detectSequence";
}

// The capture's context (EchoContext) judges the records in frame order across the blocks a
// streamed capture is read in: a capture of the blind generator (in-vivo holder, seed 16, its
// 7th capture, 7 records taken from their context) gives detectSequence's detection whole and in
// blocks of 7 records.
TEST(DetectionPipeline, TheCapturesContextCrossesBlocksAsDetectSequenceDoes) {
  TempDir dir;
  RandomisedSetOptions options;
  options.profile = "invivo-holder";
  options.seed = 16;
  const std::vector<RandomisedCapture> captures = makeRandomisedSet(options);
  ASSERT_GT(captures.size(), 6U);
  const core::Sequence sequence = randomisedSequence(captures[6]);
  const std::string path = dir.file("holder.igs.mha");
  core::writeSequence(sequence, path);
  core::DetectionParams params = core::detectionPreset("default");
  params.depth = core::depthFromSequence(sequence, params.depth);
  params.envelope.samplingFrequencyHz = params.depth.samplingFrequencyHz;
  const core::SequenceDetection expected = core::detectSequence(sequence, params);
  EXPECT_GT(expected.fromContext, 0);

  for (const int block : {0, 7}) {
    SCOPED_TRACE("frames per block " + std::to_string(block));
    filters::DetectionPipeline pipeline;
    pipeline.open(path, {});
    pipeline.configure(params, {});
    pipeline.setFramesPerBlock(block);
    expectSameDetection(pipeline.run(), expected);
  }
  core::DetectionParams off = params;
  off.peaks.prominence.contextFrames = 0;
  const core::SequenceDetection alone = core::detectSequence(sequence, off);
  EXPECT_EQ(alone.fromContext, 0);
  EXPECT_EQ(expected.echoes, alone.echoes + expected.fromContext);
}

INSTANTIATE_TEST_SUITE_P(Presets, DetectionPipelineAgainstCore,
                         ::testing::Values("test", "default", "mozes2008", "calibration",
                                           "shadow"));

TEST(DetectionPipeline, UntrackedCaptureWritesTheCsvWithoutPoints) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 12;
  const std::string path = dir.file("capture.igs.nrrd");
  core::writeSequence(makeCapture(capture), path);
  filters::DetectionPipeline pipeline;
  pipeline.open(path, {});
  pipeline.configure(testDetectionParams(capture), {});
  const std::string out = dir.file("depths.csv");
  pipeline.write(out);
  const std::string csv = readText(out);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm");
  const core::SequenceDetection detection = pipeline.run();
  EXPECT_EQ(static_cast<std::size_t>(std::count(csv.begin(), csv.end(), '\n')),
            detection.frames.size() + 1);
  ASSERT_GT(detection.accepted, 0);
  for (const core::FrameDetection& frame : detection.frames) {
    if (!frame.depthMm)
      continue;
    char depth[32];
    std::snprintf(depth, sizeof depth, ",%.4f\n", *frame.depthMm);
    EXPECT_NE(csv.find(depth), std::string::npos) << depth << " in\n" << csv;
  }
}

TEST(DetectionPipeline, ACalibrationChangeReRunsOnlyThePointsAndTheFilters) {
  TempDir dir;
  const SyntheticCapture capture = trackedCapture();
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(makeCapture(capture), path);
  filters::DetectionPipeline pipeline;
  pipeline.open(path, {"ProbeToTracker"});
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  pipeline.configure(testDetectionParams(capture), points);
  const std::string out = dir.file("depths.csv");
  pipeline.write(out);
  const core::SequenceDetection before = pipeline.run();
  const auto counts = [&] {
    return std::array<int, 6>{
        pipeline.reader->GetExecutionCount(),      pipeline.envelope->GetExecutionCount(),
        pipeline.peaks->GetExecutionCount(),       pipeline.beamPoints->GetExecutionCount(),
        pipeline.interSignal->GetExecutionCount(), pipeline.writer->GetExecutionCount()};
  };
  EXPECT_EQ(counts(), (std::array<int, 6>{1, 1, 1, 1, 1, 1})) << "run() after write(): no re-run";

  pipeline.configure(testDetectionParams(capture), points);
  pipeline.run();
  EXPECT_EQ(counts(), (std::array<int, 6>{1, 1, 1, 1, 1, 1})) << "the same parameters";

  points.beamToProbe(2, 3) = 4.0;
  pipeline.configure(testDetectionParams(capture), points);
  const core::SequenceDetection after = pipeline.run();
  EXPECT_EQ(counts(), (std::array<int, 6>{1, 1, 1, 2, 2, 1})) << "a new BeamToProbe";
  ASSERT_EQ(after.accepted, before.accepted);
  for (std::size_t f = 0; f < after.frames.size(); ++f) {
    if (after.frames[f].pointMm && before.frames[f].pointMm) {
      EXPECT_NEAR((*after.frames[f].pointMm - *before.frames[f].pointMm).norm(), 4.0, 1e-9);
    }
  }
}

// `detect` streams the capture in blocks of frames (setFramesPerBlock): the same detection and the
// same CSV as the whole capture at once, every frame enveloped once, and never more than a block
// of envelopes held. 40 frames in blocks of 7: five full blocks and one of 5.
TEST(DetectionPipeline, StreamedInBlocksGivesTheSameDetectionHoldingOneBlock) {
  TempDir dir;
  const SyntheticCapture capture = trackedCapture();
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(sequence, path);
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  points.referenceTransform = "FemurToTracker";
  const core::DetectionParams params = testDetectionParams(capture);

  filters::DetectionPipeline whole;
  whole.open(path, {});
  whole.configure(params, points);
  whole.peaks->PeakListOn();
  whole.write(dir.file("whole.csv"));
  const core::SequenceDetection expected = whole.run();
  ASSERT_GT(expected.accepted, 0);

  filters::DetectionPipeline streamed;
  streamed.open(path, {});
  streamed.configure(params, points);
  streamed.peaks->PeakListOn();
  streamed.setFramesPerBlock(7);
  streamed.write(dir.file("streamed.csv"));
  expectSameDetection(streamed.run(), expected);
  EXPECT_EQ(readText(dir.file("streamed.csv")), readText(dir.file("whole.csv")));

  // Port 1 (every frame's peaks) is filled across the blocks too.
  vtkTable* wholeList = whole.peaks->GetOutput(1);
  vtkTable* streamedList = streamed.peaks->GetOutput(1);
  ASSERT_GT(wholeList->GetNumberOfRows(), capture.frames - 1);
  ASSERT_EQ(streamedList->GetNumberOfRows(), wholeList->GetNumberOfRows());
  for (vtkIdType row = 0; row < wholeList->GetNumberOfRows(); ++row) {
    for (int column = 0; column < 3; ++column) {
      EXPECT_EQ(streamedList->GetValue(row, column), wholeList->GetValue(row, column))
          << "peak " << row << ", column " << column;
    }
  }

  EXPECT_EQ(streamed.peaks->GetExecutionCount(), 1);
  EXPECT_EQ(streamed.envelope->GetExecutionCount(), 6) << "one execution per block";
  EXPECT_EQ(streamed.reader->GetExecutionCount(), 6);
  EXPECT_EQ(streamed.envelope->GetFramesComputed(), capture.frames) << "each frame once";
  int extent[6];
  streamed.envelope->GetOutput()->GetExtent(extent);
  EXPECT_EQ(extent[2], 35) << "only the last block's envelopes are held";
  EXPECT_EQ(extent[3], 39);
  streamed.reader->GetOutput()->GetExtent(extent);
  EXPECT_EQ(extent[3] - extent[2] + 1, 5) << "and only its A-lines";

  // A new BeamToProbe still re-runs only the points and the inter-signal filter.
  points.beamToProbe(2, 3) = 4.0;
  streamed.configure(params, points);
  streamed.run();
  EXPECT_EQ(streamed.envelope->GetFramesComputed(), capture.frames);
  EXPECT_EQ(streamed.peaks->GetExecutionCount(), 1);

  // A new peak threshold: the price of streaming, every block's envelopes are computed again.
  core::DetectionParams stricter = params;
  stricter.peaks.thresholdFactor *= 1.5;
  streamed.configure(stricter, points);
  streamed.run();
  EXPECT_EQ(streamed.peaks->GetExecutionCount(), 2);
  EXPECT_EQ(streamed.envelope->GetFramesComputed(), 2 * capture.frames);

  // A failing step is still an error through the executive, named by its words.
  CapturedVtkOutput messages;
  streamed.peaks->SetWindowMinMm(30.0);
  streamed.peaks->SetWindowMaxMm(10.0);
  try {
    streamed.run();
    FAIL() << "a window whose minimum is above its maximum must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("invalid peak parameters"), std::string::npos) << e.what();
  }
}

TEST(DetectionPipeline, BadInputIsAnErrorInTheCoresWordsAndWritesNothing) {
  CapturedVtkOutput messages;
  TempDir dir;
  {
    filters::DetectionPipeline pipeline;
    try {
      pipeline.open(dir.file("absent.igs.mha"), {});
      FAIL() << "an absent capture must be an error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("absent.igs.mha"), std::string::npos) << e.what();
    }
  }
  const SyntheticCapture capture = trackedCapture();
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(makeCapture(capture), path);
  {
    filters::DetectionPipeline pipeline;
    pipeline.open(path, {});
    core::PointFrameOptions points;
    points.poseTransform = "ProbeToTracker";
    points.referenceTransform = "TibiaToTracker";
    try {
      pipeline.configure(testDetectionParams(capture), points);
      FAIL() << "a transform the capture does not hold must be an error";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("no transform TibiaToTracker"), std::string::npos)
          << e.what();
    }
    points.referenceTransform.clear();
    pipeline.configure(testDetectionParams(capture), points);
    const std::string out = dir.file("missing-folder/depths.csv");
    EXPECT_THROW(pipeline.write(out), std::runtime_error);
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  {
    core::Sequence stylus;
    stylus.frames.resize(3);
    for (auto& frame : stylus.frames)
      frame.transforms["StylusToTracker"] = core::TrackedTransform();
    const std::string stylusPath = dir.file("stylus.igs.mha");
    core::writeSequence(stylus, stylusPath);
    filters::DetectionPipeline pipeline;
    pipeline.open(stylusPath, {});
    EXPECT_THROW(pipeline.configure(testDetectionParams(capture), {}), std::invalid_argument);
  }
}

TEST(DetectionPipeline, MatchesDetectSequenceOnThePublicAgilentRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  const core::Sequence sequence = core::readSequence(path);
  for (const std::string preset : {"default", "calibration"}) {
    SCOPED_TRACE(preset);
    core::DetectionParams params = core::detectionPreset(preset);
    params.depth = core::depthFromSequence(sequence, params.depth);
    params.envelope.samplingFrequencyHz = params.depth.samplingFrequencyHz;
    filters::DetectionPipeline pipeline;
    pipeline.open(path, {});
    pipeline.configure(params, {});
    expectSameDetection(pipeline.run(), core::detectSequence(sequence, params));
  }
}

}  // namespace
}  // namespace echoreg::test
