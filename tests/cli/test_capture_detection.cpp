// The detection that `register`, `calibrate` and the study's sweeps run: one pass through the
// VTK pipeline (filters/detection_pipeline.h), kept and re-used inside one process.
#include "capture_detection.hpp"
#include "cli_test_support.hpp"
#include "command_register.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"

#include <gtest/gtest.h>
#include <vtkImageData.h>

#include <filesystem>
#include <fstream>
#include <iterator>

namespace echoreg::cli {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

cli::CaptureDetectionRequest sweepRequest(const std::string& capture) {
  cli::CaptureDetectionRequest request;
  request.capture = capture;
  request.preset = "default";
  request.settings["history"] = 1;
  request.poseTransform = "ProbeToTracker";
  return request;
}

TEST(CaptureDetection, RunsThroughTheExecutiveOnceAndEqualsDetectSequence) {
  test::TempDir dir;
  const std::string capture = dir.file("sweep.igs.mha");
  const core::Sequence sequence = test::makeDemoSweep({200});
  core::writeSequence(sequence, capture);
  const cli::CaptureDetectionRequest request = sweepRequest(capture);
  const std::unique_ptr<cli::CaptureDetection> detected = cli::detectCapture(request);
  filters::DetectionPipeline& pipeline = detected->pipeline;
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.peaks->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.beamPoints->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.interSignal->GetExecutionCount(), 1);

  // The core's function on the same capture gives the same verdicts and points.
  const core::Sequence read = core::readSequence(capture);
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  const core::SequenceDetection expected =
      core::detectSequence(read, cli::requestParams(request, read), points);
  ASSERT_EQ(detected->detection.frames.size(), expected.frames.size());
  EXPECT_EQ(detected->detection.accepted, expected.accepted);
  EXPECT_GT(expected.accepted, 20);  // not a comparison of empty detections
  for (std::size_t f = 0; f < expected.frames.size(); ++f) {
    EXPECT_EQ(detected->detection.frames[f].reason, expected.frames[f].reason) << "frame " << f;
    EXPECT_EQ(detected->detection.frames[f].depthMm, expected.frames[f].depthMm) << "frame " << f;
    EXPECT_EQ(detected->detection.frames[f].pointMm, expected.frames[f].pointMm) << "frame " << f;
  }

  // Writing the points afterwards runs nothing again but the writer.
  pipeline.write(dir.file("points.csv"));
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.peaks->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.interSignal->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.writer->GetExecutionCount(), 1);
}

// register's, calibrate's and the study's detection streams the capture through the envelope in
// blocks of kStreamFramesPerBlock frames, as `detect` does, so its memory does not grow with the
// capture: a capture of two blocks gives exactly the whole capture's detection (the core's
// detectSequence, and the pipeline unstreamed, byte for byte) while only the last block's
// envelopes are held.
TEST(CaptureDetection, StreamsACaptureLongerThanABlockWithTheWholeCapturesResult) {
  constexpr int kBlock = filters::DetectionPipeline::kStreamFramesPerBlock;
  constexpr int kFrames = kBlock + 88;
  test::TempDir dir;
  const std::string capture = dir.file("sweep.igs.mha");
  core::writeSequence(test::makeDemoSweep({kFrames}), capture);
  const cli::CaptureDetectionRequest request = sweepRequest(capture);
  const std::unique_ptr<cli::CaptureDetection> detected = cli::detectCapture(request);
  filters::DetectionPipeline& pipeline = detected->pipeline;
  EXPECT_EQ(pipeline.peaks->GetFramesPerBlock(), kBlock);
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 2) << "one envelope execution per block";
  EXPECT_EQ(pipeline.peaks->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.envelope->GetFramesComputed(), kFrames) << "each frame enveloped once";
  int extent[6];
  pipeline.envelope->GetOutput()->GetExtent(extent);
  EXPECT_EQ(extent[2], kBlock) << "only the last block's envelopes are held";
  EXPECT_EQ(extent[3], kFrames - 1);
  pipeline.reader->GetOutput()->GetExtent(extent);
  EXPECT_EQ(extent[3] - extent[2] + 1, kFrames - kBlock) << "and only its A-lines";

  // The whole capture at once, by the core's function: the same verdicts, depths and points.
  const core::Sequence read = core::readSequence(capture);
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  const core::SequenceDetection expected =
      core::detectSequence(read, cli::requestParams(request, read), points);
  const core::SequenceDetection& streamed = detected->detection;
  ASSERT_EQ(streamed.frames.size(), expected.frames.size());
  EXPECT_EQ(streamed.accepted, expected.accepted);
  EXPECT_EQ(streamed.echoes, expected.echoes);
  EXPECT_EQ(streamed.rejectedByReason, expected.rejectedByReason);
  int acceptedInSecondBlock = 0;
  for (std::size_t f = 0; f < expected.frames.size(); ++f) {
    EXPECT_EQ(streamed.frames[f].reason, expected.frames[f].reason) << "frame " << f;
    EXPECT_EQ(streamed.frames[f].peakCount, expected.frames[f].peakCount) << "frame " << f;
    EXPECT_EQ(streamed.frames[f].sampleIndex, expected.frames[f].sampleIndex) << "frame " << f;
    EXPECT_EQ(streamed.frames[f].depthMm, expected.frames[f].depthMm) << "frame " << f;
    EXPECT_EQ(streamed.frames[f].pointMm, expected.frames[f].pointMm) << "frame " << f;
    if (f >= static_cast<std::size_t>(kBlock) && expected.frames[f].accepted())
      ++acceptedInSecondBlock;
  }
  EXPECT_GT(acceptedInSecondBlock, 5) << "not a comparison of an empty second block";

  // The points CSV: the same bytes as the pipeline with the whole capture at once.
  pipeline.write(dir.file("streamed.csv"));
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 2) << "writing runs nothing again";
  filters::DetectionPipeline whole;
  whole.open(capture, {request.poseTransform});
  whole.configure(cli::requestParams(request, whole.reader->GetSequence()), points);
  whole.write(dir.file("whole.csv"));
  EXPECT_EQ(whole.envelope->GetExecutionCount(), 1);
  EXPECT_EQ(slurp(dir.file("streamed.csv")), slurp(dir.file("whole.csv")));
}

TEST(CaptureDetection, SharedDetectionRunsOncePerRequestAndIsTheDetectCommandsBytes) {
  test::TempDir dir;
  const std::string capture = dir.file("sweep.igs.mha");
  core::writeSequence(test::makeDemoSweep({200}), capture);
  cli::CaptureDetections detections;
  const cli::CaptureDetectionRequest request = sweepRequest(capture);
  cli::CaptureDetection& first = detections.get(request);
  first.pipeline.write(dir.file("shared.csv"));
  cli::CaptureDetection& again = detections.get(request);
  EXPECT_EQ(&first, &again);
  EXPECT_EQ(detections.runs(), 1);
  EXPECT_EQ(again.pipeline.envelope->GetExecutionCount(), 1);

  // The same settings through `echoreg detect` give the same bytes.
  const auto result = test::runEchoreg({"detect", capture, "--pose", "ProbeToTracker", "--history",
                                        "1", "--out", dir.file("detect.csv")});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  EXPECT_EQ(slurp(dir.file("shared.csv")), slurp(dir.file("detect.csv")));

  // Another request (a new speed of sound) is a new detection, with other depths.
  cli::CaptureDetectionRequest faster = request;
  faster.settings["speed-of-sound"] = 1600.0;
  cli::CaptureDetection& other = detections.get(faster);
  EXPECT_EQ(detections.runs(), 2);
  EXPECT_EQ(other.detection.params.depth.speedOfSoundMps, 1600.0);
}

TEST(CaptureDetection, ChangedParameterRerunsOnlyWhatFollowsIt) {
  test::TempDir dir;
  const std::string capture = dir.file("sweep.igs.mha");
  core::writeSequence(test::makeDemoSweep({200}), capture);
  const cli::CaptureDetectionRequest request = sweepRequest(capture);
  const std::unique_ptr<cli::CaptureDetection> detected = cli::detectCapture(request);
  filters::DetectionPipeline& pipeline = detected->pipeline;
  const core::SequenceDetection before = detected->detection;

  // A new calibration (BeamToProbe): the points and the inter-signal filter run again, not the
  // envelope or the peaks.
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  points.beamToProbe(2, 3) = 5.0;
  cli::runDetection(*detected, before.params, points);
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.peaks->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.beamPoints->GetExecutionCount(), 2);
  EXPECT_EQ(pipeline.interSignal->GetExecutionCount(), 2);
  bool moved = false;
  for (std::size_t f = 0; f < before.frames.size(); ++f) {
    const auto& a = before.frames[f].pointMm;
    const auto& b = detected->detection.frames[f].pointMm;
    if (a && b)
      moved = moved || (*a - *b).norm() > 4.0;
  }
  EXPECT_TRUE(moved);

  // A new peak threshold: the peaks and what follows, not the envelope.
  core::DetectionParams params = before.params;
  params.peaks.prominence.minSnr *= 2.0;
  cli::runDetection(*detected, params, points);
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.peaks->GetExecutionCount(), 2);
  EXPECT_EQ(pipeline.beamPoints->GetExecutionCount(), 3);
  EXPECT_EQ(pipeline.interSignal->GetExecutionCount(), 3);
}

TEST(CaptureDetection, BadCaptureNamesTheFile) {
  test::TempDir dir;
  const std::string missing = dir.file("missing.igs.mha");
  try {
    cli::detectCapture(sweepRequest(missing));
    FAIL() << "a missing capture was read";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string capture = dir.file("sweep.igs.mha");
  core::writeSequence(test::makeDemoSweep({20}), capture);
  cli::CaptureDetectionRequest unknown = sweepRequest(capture);
  unknown.referenceTransform = "FemurToTracker";
  try {
    cli::detectCapture(unknown);
    FAIL() << "a transform the capture lacks was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("FemurToTracker"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(capture), std::string::npos) << e.what();
  }
  cli::CaptureDetectionRequest preset = sweepRequest(capture);
  preset.preset = "nonsense";
  EXPECT_THROW(cli::detectCapture(preset), std::invalid_argument);
}

// register's detection: its own defaults (history 1, min-spread-mm 1) under --params, the flags
// over both; the same resolver as detect's.
TEST(CaptureDetection, RegisterResolvesFlagsOverParamsOverItsDefaults) {
  test::TempDir dir;
  const std::string params = dir.file("params.json");
  std::ofstream(params) << R"({"preset": "shadow", "history": 3, "speed-of-sound": 1500,
                              "echo-snr": 5})";
  cli::RegisterOptions options;
  options.bone = "Femur";
  options.paramsFile = params;
  options.detection["speed-of-sound"] = 1600.0;
  const cli::CaptureDetectionRequest request =
      cli::sweepDetectionRequest(options, "sweep.igs.mha", Eigen::Matrix4d::Identity());
  EXPECT_EQ(request.preset, "shadow");
  EXPECT_EQ(std::get<int>(request.settings.at("history")), 3);
  EXPECT_EQ(std::get<double>(request.settings.at("speed-of-sound")), 1600.0);
  EXPECT_EQ(std::get<double>(request.settings.at("min-spread-mm")), 1.0);
  EXPECT_EQ(std::get<double>(request.settings.at("echo-snr")), 5.0);
  EXPECT_EQ(request.referenceTransform, "FemurToTracker");

  cli::RegisterOptions plain;
  const cli::CaptureDetectionRequest defaults =
      cli::sweepDetectionRequest(plain, "sweep.igs.mha", Eigen::Matrix4d::Identity());
  EXPECT_EQ(defaults.preset, "default");
  EXPECT_EQ(std::get<int>(defaults.settings.at("history")), 1);

  const std::string unknown = dir.file("unknown.json");
  std::ofstream(unknown) << R"({"histroy": 3})";
  cli::RegisterOptions bad;
  bad.paramsFile = unknown;
  try {
    cli::sweepDetectionRequest(bad, "sweep.igs.mha", Eigen::Matrix4d::Identity());
    FAIL() << "an unknown parameter was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(unknown), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("histroy"), std::string::npos) << e.what();
  }
}

TEST(CaptureDetection, RegisterTakesParamsOnlyWithACapture) {
  test::TempDir dir;
  const std::string params = dir.file("params.json");
  std::ofstream(params) << R"({"history": 3})";
  const auto result = test::runEchoreg({"register", "--model", dir.file("m.vtp"), "--points",
                                        dir.file("p.csv"), "--params", params, "--initial",
                                        dir.file("i.json"), "--out", dir.file("o.json")});
  EXPECT_EQ(result.exitCode, 2) << result.err;
  EXPECT_NE(result.err.find("--params"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.json")));
  const auto help = test::runEchoreg({"register", "--help"});
  EXPECT_NE(help.out.find("--params"), std::string::npos);
  EXPECT_NE(help.out.find("--echo-snr"), std::string::npos);  // the shared table's flags
}

// study run --params: read and checked before any step, a bad one named, nothing written.
TEST(CaptureDetection, StudyRefusesABadParamsFileBeforeAnyStep) {
  test::TempDir dir;
  const std::string study = dir.file("study");
  std::filesystem::create_directories(study);
  std::ofstream(study + "/study.json")
      << R"({"format": "echoreg-study", "version": 1, "bones": {"femur": {}}})";
  const std::string params = dir.file("params.json");
  std::ofstream(params) << R"({"echo-snr": "six"})";
  const auto result = test::runEchoreg({"study", "run", study, "--params", params});
  EXPECT_EQ(result.exitCode, 1) << result.err;
  EXPECT_NE(result.err.find(params), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("echo-snr"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(study + "/results"));
  const auto missing = test::runEchoreg({"study", "run", study, "--params", dir.file("no.json")});
  EXPECT_EQ(missing.exitCode, 1) << missing.err;
  EXPECT_NE(missing.err.find("no.json"), std::string::npos) << missing.err;
  EXPECT_FALSE(std::filesystem::exists(study + "/results"));
}

}  // namespace
}  // namespace echoreg::cli
