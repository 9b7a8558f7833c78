// The whole capture-side chain through VTK's executive: reader -> envelope -> peaks ->
// beam points -> inter-signal, checked against the truth of synthetic captures, against the core's
// detectSequence, and for its demand-driven behaviour.
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"
#include "echoreg/filters/vtkEchoregEnvelopeFilter.h"
#include "echoreg/filters/vtkEchoregInterSignalFilter.h"
#include "echoreg/filters/vtkEchoregPeakFilter.h"
#include "echoreg/filters/vtkEchoregSequenceReader.h"
#include "filter_test_helpers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <vtkAlgorithm.h>
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace echoreg::test {
namespace {

struct Pipeline {
  vtkNew<vtkEchoregSequenceReader> reader;
  vtkNew<vtkEchoregEnvelopeFilter> envelope;
  vtkNew<vtkEchoregPeakFilter> peaks;
  vtkNew<vtkEchoregBeamPointsFilter> beamPoints;
  vtkNew<vtkEchoregInterSignalFilter> interSignal;

  Pipeline(const std::string& path, const core::DetectionParams& params) {
    reader->SetFileName(path);
    envelope->SetInputConnection(reader->GetOutputPort());
    envelope->SetParams(params.envelope);
    peaks->SetInputConnection(envelope->GetOutputPort());
    peaks->SetPeakParams(params.peaks);
    peaks->SetDepthConversion(params.depth);
    if (params.windowMinMm)
      peaks->SetWindowMinMm(*params.windowMinMm);
    if (params.windowMaxMm)
      peaks->SetWindowMaxMm(*params.windowMaxMm);
    beamPoints->SetInputConnection(peaks->GetOutputPort());
    interSignal->SetInputConnection(beamPoints->GetOutputPort());
    interSignal->SetInterSignalParams(params.interSignal);
  }
  vtkTable* table() { return interSignal->GetOutput(); }
  std::array<int, 5> counts() const {
    return {reader->GetExecutionCount(), envelope->GetExecutionCount(), peaks->GetExecutionCount(),
            beamPoints->GetExecutionCount(), interSignal->GetExecutionCount()};
  }
};

double valueAt(vtkTable* table, const char* column, vtkIdType row) {
  return table->GetValueByName(row, column).ToDouble();
}
std::string textAt(vtkTable* table, const char* column, vtkIdType row) {
  return vtkStringArray::SafeDownCast(table->GetColumnByName(column))->GetValue(row);
}

TEST(Pipeline, FindsEveryEchoAndPlacesItInTheBone) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 10;
  capture.probeStepMm = 2.0;
  capture.invalidProbeFrames = {5};
  capture.withFemur = true;
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(sequence, path);

  Pipeline pipeline(path, testDetectionParams(capture));
  pipeline.beamPoints->SetPoseTransformName("ProbeToTracker");
  pipeline.beamPoints->SetReferenceTransformName("FemurToTracker");
  pipeline.interSignal->Update();
  ASSERT_EQ(pipeline.interSignal->GetLastError(), "");

  vtkTable* table = pipeline.table();
  ASSERT_EQ(table->GetNumberOfRows(), capture.frames);
  const core::DepthConversion depth = capture.depth();
  for (int frame = 0; frame < capture.frames; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const double truthMm = depth.depthMm(capture.echoSample(frame));
    EXPECT_EQ(table->GetValueByName(frame, "frame").ToInt(), frame);
    EXPECT_NEAR(valueAt(table, "timestamp_s", frame), capture.timestampS(frame), 1e-9);
    EXPECT_NEAR(valueAt(table, "depth_mm", frame), truthMm, depth.mmPerSample());
    if (frame == 5) {
      EXPECT_EQ(textAt(table, "reason", frame), "invalid-pose");
      EXPECT_EQ(textAt(table, "status", frame), "rejected");
      EXPECT_TRUE(std::isnan(valueAt(table, "x_mm", frame)));
      continue;
    }
    EXPECT_EQ(textAt(table, "reason", frame), "");
    EXPECT_EQ(textAt(table, "status", frame), "accepted");
    const Eigen::Vector3d truth = capture.probeToTracker(frame).block<3, 1>(0, 3) +
                                  Eigen::Vector3d(0.0, 0.0, truthMm) - capture.femurOffsetMm;
    const Eigen::Vector3d point(valueAt(table, "x_mm", frame), valueAt(table, "y_mm", frame),
                                valueAt(table, "z_mm", frame));
    EXPECT_LE((point - truth).norm(), depth.mmPerSample())
        << point.transpose() << " vs " << truth.transpose();
  }

  vtkFieldData* fieldData = table->GetFieldData();
  EXPECT_NE(fieldData->GetAbstractArray("ProbeToTracker_Status"), nullptr) << "poses travel down";
  EXPECT_NE(fieldData->GetAbstractArray("SpeedOfSoundMps"), nullptr);
  auto* accepted = vtkIntArray::SafeDownCast(fieldData->GetAbstractArray("Count_accepted"));
  ASSERT_NE(accepted, nullptr);
  EXPECT_EQ(accepted->GetValue(0), capture.frames - 1);
  EXPECT_EQ(pipeline.interSignal->GetReasonCounts().at("invalid-pose"), 1);
}

TEST(Pipeline, ReRunsOnlyWhatIsDownstreamOfAChange) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 6;
  const std::string path = dir.file("capture.igs.nrrd");
  core::writeSequence(makeCapture(capture), path);
  Pipeline pipeline(path, testDetectionParams(capture));

  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 1, 1, 1, 1}));
  EXPECT_EQ(pipeline.reader->GetReadCount(), 1);

  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 1, 1, 1, 1})) << "nothing changed";

  pipeline.peaks->SetWindowMinMm(1.0);
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 1, 2, 2, 2})) << "a peak parameter";

  pipeline.interSignal->SetMinSpreadMm(0.5);
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 1, 2, 2, 3})) << "an inter-signal parameter";

  double beamToProbe[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2.5, 0, 0, 0, 1};
  pipeline.beamPoints->SetBeamToProbe(beamToProbe);
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 1, 2, 3, 4}))
      << "a calibration: the envelope and the peaks are not run again";

  pipeline.envelope->SetWindowSamples(25);
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 2, 3, 4, 5})) << "an envelope parameter";

  pipeline.envelope->SetWindowSamples(25);  // the same value: no change
  pipeline.peaks->SetWindowMinMm(1.0);
  pipeline.beamPoints->SetBeamToProbe(beamToProbe);
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{1, 2, 3, 4, 5}));

  pipeline.reader->Modified();
  pipeline.interSignal->Update();
  EXPECT_EQ(pipeline.counts(), (std::array<int, 5>{2, 3, 4, 5, 6})) << "the reader";
  EXPECT_EQ(pipeline.reader->GetReadCount(), 2);
}

// detect's progress line on a terminal comes from these events: the envelope and peak filters
// report between slices of rows, from the calling thread, up to 1.
TEST(Pipeline, TheHeavyStepsReportTheirProgress) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 600;
  capture.samples = 400;
  capture.firstEchoSample = 200.25;
  capture.echoStepSamples = 0.0;
  const std::string path = dir.file("capture.igs.nrrd");
  core::writeSequence(makeCapture(capture), path);
  Pipeline pipeline(path, testDetectionParams(capture));
  struct Seen {
    std::vector<double> progress;
  };
  Seen envelope, peaks;
  const auto record = [](vtkObject* caller, unsigned long, void* data, void*) {
    static_cast<Seen*>(data)->progress.push_back(vtkAlgorithm::SafeDownCast(caller)->GetProgress());
  };
  vtkNew<vtkCallbackCommand> onEnvelope, onPeaks;
  onEnvelope->SetCallback(record);
  onEnvelope->SetClientData(&envelope);
  onPeaks->SetCallback(record);
  onPeaks->SetClientData(&peaks);
  pipeline.envelope->AddObserver(vtkCommand::ProgressEvent, onEnvelope);
  pipeline.peaks->AddObserver(vtkCommand::ProgressEvent, onPeaks);
  pipeline.interSignal->Update();
  ASSERT_EQ(pipeline.interSignal->GetLastError(), "");
  for (const Seen* seen : {&envelope, &peaks}) {
    // 600 rows in slices of 256: 256, 512, 600 (and the executive's own 0 and 1).
    ASSERT_GE(seen->progress.size(), 3U);
    EXPECT_TRUE(std::is_sorted(seen->progress.begin(), seen->progress.end()));
    EXPECT_DOUBLE_EQ(seen->progress.back(), 1.0);
    EXPECT_NE(std::find_if(seen->progress.begin(), seen->progress.end(),
                           [](double p) { return p > 0.4 && p < 0.45; }),
              seen->progress.end())
        << "256 of 600 rows";
  }
}

TEST(Pipeline, ReaderFailureStopsTheChainWithoutAnException) {
  CapturedVtkOutput messages;
  TempDir dir;
  SyntheticCapture capture;
  const std::string path = dir.file("absent.igs.mha");
  Pipeline pipeline(path, testDetectionParams(capture));
  EXPECT_NO_THROW(pipeline.interSignal->Update());
  EXPECT_EQ(pipeline.interSignal->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.reader->GetLastError().find(path), std::string::npos);
  EXPECT_EQ(pipeline.table()->GetNumberOfRows(), 0);
  EXPECT_EQ(pipeline.envelope->GetExecutionCount(), 0);
  EXPECT_EQ(pipeline.interSignal->GetExecutionCount(), 0);
}

TEST(Pipeline, TrackerOnlyCaptureFlowsThroughAsAnEmptyTableWithPoses) {
  CapturedVtkOutput messages;
  TempDir dir;
  core::Sequence sequence;
  sequence.frames.resize(4);
  for (auto& frame : sequence.frames)
    frame.transforms["StylusToTracker"] = core::TrackedTransform();
  const std::string path = dir.file("stylus.igs.mha");
  core::writeSequence(sequence, path);

  SyntheticCapture capture;
  Pipeline pipeline(path, testDetectionParams(capture));
  EXPECT_EQ(pipeline.interSignal->GetExecutive()->Update(), 1);
  EXPECT_EQ(pipeline.table()->GetNumberOfRows(), 0);
  EXPECT_NE(pipeline.table()->GetFieldData()->GetAbstractArray("StylusToTracker"), nullptr);
  EXPECT_EQ(pipeline.interSignal->GetReasonCounts().at("accepted"), 0);
  EXPECT_NE(messages.text().find("no samples"), std::string::npos);
}

// The pipeline and the core's detectSequence must give the same verdicts and points.
class PipelineAgainstCore : public ::testing::TestWithParam<std::string> {};

TEST_P(PipelineAgainstCore, SameVerdictsAndPointsAsDetectSequence) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 24;
  capture.probeStepMm = 0.3;
  capture.echoStepSamples = 3.0;
  capture.invalidProbeFrames = {4, 11};
  capture.withFemur = true;
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(sequence, path);

  core::DetectionParams params =
      GetParam() == "test" ? testDetectionParams(capture) : core::detectionPreset(GetParam());
  params.depth = core::depthFromSequence(sequence, params.depth);
  params.interSignal.history = 2;
  params.interSignal.consistencyMm = 0.5;
  params.interSignal.minSpreadMm = 0.4;
  core::PointFrameOptions points;
  points.poseTransform = "ProbeToTracker";
  points.referenceTransform = "FemurToTracker";
  points.beamToProbe(0, 3) = 1.5;
  const core::SequenceDetection expected = core::detectSequence(sequence, params, points);
  if (GetParam() == "test") {
    // The capture is built so that every stage has something to say.
    ASSERT_GT(expected.accepted, 0);
    ASSERT_GT(expected.rejectedByReason.count("inconsistent"), 0U);
    ASSERT_GT(expected.rejectedByReason.count("too-close"), 0U);
    ASSERT_GT(expected.rejectedByReason.count("invalid-pose"), 0U);
  }

  // detectSequence measures the capture (adaptToSequence) before it runs; the filters are given
  // what it measured.
  Pipeline pipeline(path, expected.params);
  pipeline.beamPoints->SetPoseTransformName(points.poseTransform);
  pipeline.beamPoints->SetReferenceTransformName(points.referenceTransform);
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> beamToProbe = points.beamToProbe;
  pipeline.beamPoints->SetBeamToProbe(beamToProbe.data());
  pipeline.interSignal->Update();
  ASSERT_EQ(pipeline.interSignal->GetLastError(), "");

  vtkTable* table = pipeline.table();
  ASSERT_EQ(table->GetNumberOfRows(), static_cast<vtkIdType>(expected.frames.size()));
  int acceptedFrames = 0;
  for (const core::FrameDetection& frame : expected.frames) {
    SCOPED_TRACE("frame " + std::to_string(frame.frame));
    EXPECT_EQ(textAt(table, "reason", frame.frame),
              std::string(core::rejectReasonName(frame.reason)));
    EXPECT_EQ(table->GetValueByName(frame.frame, "peaks").ToInt(), frame.peakCount);
    if (frame.sampleIndex) {
      EXPECT_NEAR(valueAt(table, "sample_index", frame.frame), *frame.sampleIndex, 1e-9);
    }
    if (frame.accepted()) {
      ++acceptedFrames;
      EXPECT_NEAR(valueAt(table, "depth_mm", frame.frame), *frame.depthMm, 1e-9);
      EXPECT_NEAR(valueAt(table, "x_mm", frame.frame), frame.pointMm->x(), 1e-9);
      EXPECT_NEAR(valueAt(table, "y_mm", frame.frame), frame.pointMm->y(), 1e-9);
      EXPECT_NEAR(valueAt(table, "z_mm", frame.frame), frame.pointMm->z(), 1e-9);
    }
  }
  EXPECT_EQ(acceptedFrames, expected.accepted);
  EXPECT_EQ(pipeline.interSignal->GetReasonCounts().at("accepted"), expected.accepted);
  for (const auto& [reason, count] : expected.rejectedByReason) {
    EXPECT_EQ(pipeline.interSignal->GetReasonCounts().at(reason), count) << reason;
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, PipelineAgainstCore,
                         ::testing::Values("test", "default", "mozes2008", "calibration"));

TEST(Pipeline, RunsOnThePublicAgilentRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  core::DetectionParams params = core::detectionPreset("calibration");
  Pipeline pipeline(path, params);
  pipeline.interSignal->SetHistory(1);
  pipeline.interSignal->SetMinSpreadMm(0.0);
  pipeline.interSignal->Update();
  ASSERT_EQ(pipeline.interSignal->GetLastError(), "");
  vtkTable* table = pipeline.table();
  ASSERT_EQ(table->GetNumberOfRows(), 150);
  int total = 0;
  for (const auto& [reason, count] : pipeline.interSignal->GetReasonCounts())
    total += count;
  EXPECT_EQ(total, 150);
  EXPECT_NE(table->GetFieldData()->GetAbstractArray("ZOffsetToTracker"), nullptr);
}

}  // namespace
}  // namespace echoreg::test
