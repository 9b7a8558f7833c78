#include "echoreg/filters/vtkEchoregEnvelopeFilter.h"
#include "echoreg/filters/vtkEchoregPeakFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <cmath>

namespace echoreg::test {
namespace {

struct PeakChain {
  vtkNew<vtkEchoregEnvelopeFilter> envelope;
  vtkNew<vtkEchoregPeakFilter> peaks;

  PeakChain(const SyntheticCapture& capture, vtkImageData* image) {
    const core::DetectionParams params = testDetectionParams(capture);
    envelope->SetParams(params.envelope);
    envelope->SetInputData(image);
    peaks->SetPeakParams(params.peaks);
    peaks->SetDepthConversion(params.depth);
    peaks->SetInputConnection(envelope->GetOutputPort());
  }
  vtkTable* table() { return peaks->GetOutput(); }
};

template <typename Array>
Array* columnOf(vtkTable* table, const char* name) {
  return Array::SafeDownCast(table->GetColumnByName(name));
}

TEST(PeakFilter, FindsEverySyntheticEchoWithinOneSample) {
  SyntheticCapture capture;
  const core::Sequence sequence = makeCapture(capture);
  PeakChain chain(capture, imageOf(sequence));
  chain.peaks->Update();
  ASSERT_EQ(chain.peaks->GetLastError(), "");

  vtkTable* table = chain.table();
  ASSERT_EQ(table->GetNumberOfRows(), capture.frames);
  auto* frames = columnOf<vtkIntArray>(table, "frame");
  auto* timestamps = columnOf<vtkDoubleArray>(table, "timestamp_s");
  auto* peakCounts = columnOf<vtkIntArray>(table, "peaks");
  auto* samples = columnOf<vtkDoubleArray>(table, "sample_index");
  auto* depths = columnOf<vtkDoubleArray>(table, "depth_mm");
  auto* reasons = columnOf<vtkStringArray>(table, "reason");
  auto* thresholds = columnOf<vtkDoubleArray>(table, "threshold");
  for (auto* column : std::initializer_list<vtkAbstractArray*>{
           frames, timestamps, peakCounts, samples, depths, reasons, thresholds}) {
    ASSERT_NE(column, nullptr);
  }

  const core::DepthConversion depth = capture.depth();
  for (int frame = 0; frame < capture.frames; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    EXPECT_EQ(frames->GetValue(frame), frame);
    EXPECT_DOUBLE_EQ(timestamps->GetValue(frame), capture.timestampS(frame));
    EXPECT_EQ(reasons->GetValue(frame), "");
    EXPECT_EQ(peakCounts->GetValue(frame), 1);
    EXPECT_GT(thresholds->GetValue(frame), 0.0);
    EXPECT_NEAR(samples->GetValue(frame), capture.echoSample(frame), 1.0);
    EXPECT_NEAR(depths->GetValue(frame), depth.depthMm(capture.echoSample(frame)),
                depth.mmPerSample());
  }
}

// The first peak above `factor` times the envelope's mean, in the capture's millimetres.
core::PeakParams firstPeakAbove(const SyntheticCapture& capture, double factor) {
  core::PeakParams params = testDetectionParams(capture).peaks;
  params.policy = core::PeakPolicy::First;
  params.thresholdMode = core::ThresholdMode::FactorOfMean;
  params.thresholdFactor = factor;
  params.mmPerSample = capture.depth().mmPerSample();
  return params;
}

TEST(PeakFilter, RowsEqualTheCoreFindPeaks) {
  SyntheticCapture capture;
  capture.frames = 6;
  const core::Sequence sequence = makeCapture(capture);
  PeakChain chain(capture, imageOf(sequence));
  const core::PeakParams params = firstPeakAbove(capture, 3.0);
  chain.peaks->SetPeakParams(params);
  chain.peaks->Update();

  auto* envelopes =
      vtkFloatArray::SafeDownCast(chain.envelope->GetOutput()->GetPointData()->GetScalars());
  ASSERT_NE(envelopes, nullptr);
  vtkTable* table = chain.table();
  for (int frame = 0; frame < capture.frames; ++frame) {
    const core::PeakResult expected =
        core::findPeaks(params, envelopes->GetPointer(frame * capture.samples), capture.samples);
    EXPECT_EQ(columnOf<vtkIntArray>(table, "peaks")->GetValue(frame),
              static_cast<int>(expected.peaks.size()));
    EXPECT_EQ(columnOf<vtkStringArray>(table, "reason")->GetValue(frame),
              std::string(core::rejectReasonName(expected.reason)));
    EXPECT_DOUBLE_EQ(columnOf<vtkDoubleArray>(table, "threshold")->GetValue(frame),
                     expected.threshold);
    if (expected.accepted()) {
      EXPECT_DOUBLE_EQ(columnOf<vtkDoubleArray>(table, "sample_index")->GetValue(frame),
                       expected.sampleIndex);
    }
  }
}

// Port 1 lists every frame's peaks (what `figure signals` draws) only when asked: detect does not
// pay for it. Turning it on re-runs the peak filter, not the envelope.
TEST(PeakFilter, PeakListHoldsEveryFramesPeaksWhenAsked) {
  SyntheticCapture capture;
  capture.frames = 6;
  const core::Sequence sequence = makeCapture(capture);
  PeakChain chain(capture, imageOf(sequence));
  const core::PeakParams params = firstPeakAbove(capture, 0.8);
  chain.peaks->SetPeakParams(params);
  chain.peaks->Update(1);
  ASSERT_EQ(chain.peaks->GetLastError(), "");
  EXPECT_EQ(chain.peaks->GetOutput(1)->GetNumberOfRows(), 0);
  const int envelopeRuns = chain.envelope->GetExecutionCount();

  chain.peaks->PeakListOn();
  chain.peaks->Update(1);
  EXPECT_EQ(chain.envelope->GetExecutionCount(), envelopeRuns);
  vtkTable* list = chain.peaks->GetOutput(1);
  auto* frames = columnOf<vtkIntArray>(list, "frame");
  auto* indices = columnOf<vtkIntArray>(list, "sample_index");
  auto* values = columnOf<vtkDoubleArray>(list, "value");
  ASSERT_NE(frames, nullptr);
  ASSERT_NE(indices, nullptr);
  ASSERT_NE(values, nullptr);
  auto* envelopes =
      vtkFloatArray::SafeDownCast(chain.envelope->GetOutput()->GetPointData()->GetScalars());
  ASSERT_NE(envelopes, nullptr);
  vtkIdType row = 0;
  std::size_t total = 0;
  for (int frame = 0; frame < capture.frames; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const core::PeakResult expected =
        core::findPeaks(params, envelopes->GetPointer(frame * capture.samples), capture.samples);
    total += expected.peaks.size();
    EXPECT_EQ(columnOf<vtkIntArray>(chain.table(), "peaks")->GetValue(frame),
              static_cast<int>(expected.peaks.size()));
    for (const core::Peak& peak : expected.peaks) {
      ASSERT_LT(row, list->GetNumberOfRows());
      EXPECT_EQ(frames->GetValue(row), frame);
      EXPECT_EQ(indices->GetValue(row), peak.index);
      EXPECT_DOUBLE_EQ(values->GetValue(row), static_cast<double>(peak.value));
      ++row;
    }
  }
  EXPECT_GT(total, static_cast<std::size_t>(capture.frames));  // several peaks in some frames
  EXPECT_EQ(list->GetNumberOfRows(), static_cast<vtkIdType>(total));
}

TEST(PeakFilter, WindowInMillimetresRejectsEchoesOutsideIt) {
  SyntheticCapture capture;
  capture.frames = 3;
  PeakChain chain(capture, imageOf(makeCapture(capture)));
  const double echoDepthMm = capture.depth().depthMm(capture.echoSample(0));
  chain.peaks->SetWindowMinMm(echoDepthMm + 2.0);
  chain.peaks->Update();
  vtkTable* table = chain.table();
  for (int frame = 0; frame < capture.frames; ++frame) {
    EXPECT_EQ(columnOf<vtkStringArray>(table, "reason")->GetValue(frame), "outside-window");
    EXPECT_TRUE(std::isnan(columnOf<vtkDoubleArray>(table, "depth_mm")->GetValue(frame)));
    EXPECT_TRUE(std::isnan(columnOf<vtkDoubleArray>(table, "sample_index")->GetValue(frame)));
  }

  // Opening the window again (NaN) brings the echoes back.
  chain.peaks->SetWindowMinMm(std::nan(""));
  chain.peaks->SetWindowMaxMm(echoDepthMm + 2.0);
  chain.peaks->Update();
  EXPECT_EQ(columnOf<vtkStringArray>(chain.table(), "reason")->GetValue(0), "");
}

TEST(PeakFilter, WindowSettersModifyOnlyOnChange) {
  vtkNew<vtkEchoregPeakFilter> filter;
  const vtkMTimeType start = filter->GetMTime();
  filter->SetWindowMinMm(std::nan(""));
  filter->SetPeakParams(filter->GetPeakParams());
  filter->SetDepthConversion(filter->GetDepthConversion());
  EXPECT_EQ(filter->GetMTime(), start);
  filter->SetWindowMinMm(5.0);
  const vtkMTimeType afterWindow = filter->GetMTime();
  EXPECT_GT(afterWindow, start);
  filter->SetWindowMinMm(5.0);
  EXPECT_EQ(filter->GetMTime(), afterWindow);
  filter->SetSpeedOfSoundMps(1480.0);
  EXPECT_GT(filter->GetMTime(), afterWindow);
  EXPECT_DOUBLE_EQ(filter->GetDepthConversion().speedOfSoundMps, 1480.0);
}

TEST(PeakFilter, PassesTheFieldDataThroughToTheTable) {
  SyntheticCapture capture;
  capture.frames = 2;
  vtkSmartPointer<vtkImageData> image = imageOf(makeCapture(capture));
  PeakChain chain(capture, image);
  chain.peaks->Update();
  vtkFieldData* fieldData = chain.table()->GetFieldData();
  // The input's arrays, plus the count of echoes the capture's context took.
  EXPECT_EQ(fieldData->GetNumberOfArrays(), image->GetFieldData()->GetNumberOfArrays() + 1);
  EXPECT_EQ(fieldData->GetAbstractArray("ProbeToTracker"),
            image->GetFieldData()->GetAbstractArray("ProbeToTracker"));
  ASSERT_NE(fieldData->GetAbstractArray("EchoesFromContext"), nullptr);
}

TEST(PeakFilter, InvalidWindowFailsThroughTheExecutive) {
  CapturedVtkOutput messages;
  SyntheticCapture capture;
  capture.frames = 2;
  PeakChain chain(capture, imageOf(makeCapture(capture)));
  chain.peaks->SetWindowMinMm(20.0);
  chain.peaks->SetWindowMaxMm(10.0);
  EXPECT_EQ(chain.peaks->GetExecutive()->Update(), 0);
  EXPECT_NE(chain.peaks->GetLastError().find("window"), std::string::npos)
      << chain.peaks->GetLastError();
  EXPECT_NE(messages.text().find("window"), std::string::npos);
}

TEST(PeakFilter, InputWithoutSamplesGivesAnEmptyTableWithAWarning) {
  CapturedVtkOutput messages;
  core::Sequence trackerOnly;
  trackerOnly.frames.resize(4);
  vtkNew<vtkEchoregPeakFilter> filter;
  filter->SetInputData(imageOf(trackerOnly));
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetOutput()->GetNumberOfRows(), 0);
  EXPECT_NE(filter->GetOutput()->GetColumnByName("depth_mm"), nullptr);
  EXPECT_NE(filter->GetOutput()->GetFieldData()->GetAbstractArray("Timestamp"), nullptr);
  EXPECT_NE(messages.text().find("no samples"), std::string::npos);
}

TEST(PeakFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregPeakFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"ThresholdMode", "ThresholdFactor", "ThresholdOfMax", "WindowBegin",
                           "WindowEnd", "Policy", "BoneRegionMm", "BoneGapMm", "BoneMinShadowRatio",
                           "BoneMinContrast", "BoneMaxWidthMm", "Subsample", "SamplingFrequencyHz",
                           "DelayS", "SpeedOfSoundMps", "WindowMinMm", "WindowMaxMm"}) {
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace echoreg::test
