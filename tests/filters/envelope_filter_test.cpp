#include "echoreg/filters/vtkEchoregEnvelopeFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>

namespace echoreg::test {
namespace {

// The oracle: the core detector run on each frame of the plain sequence.
std::vector<float> coreEnvelopes(const core::Sequence& sequence,
                                 const core::EnvelopeParams& params) {
  core::EnvelopeDetector detector(params);
  std::vector<float> all;
  std::vector<float> samples;
  std::vector<float> envelope;
  for (std::size_t frame = 0; frame < sequence.frameCount(); ++frame) {
    sequence.frameSamples(frame, samples);
    envelope.resize(samples.size());
    detector.compute(samples.data(), static_cast<int>(samples.size()), envelope.data());
    all.insert(all.end(), envelope.begin(), envelope.end());
  }
  return all;
}

class EnvelopeFilterMethods : public ::testing::TestWithParam<core::EnvelopeMethod> {};

TEST_P(EnvelopeFilterMethods, EveryRowEqualsTheCoreDetector) {
  SyntheticCapture capture;
  capture.frames = 40;  // enough rows for several parallel chunks
  const core::Sequence sequence = makeCapture(capture);
  core::EnvelopeParams params;
  params.method = GetParam();
  params.windowSamples = 31;
  params.ringDownSamples = 10;
  params.zeroPhase = GetParam() == core::EnvelopeMethod::Mozes ? false : true;

  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetParams(params);
  filter->SetInputData(imageOf(sequence));
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");

  vtkImageData* output = filter->GetOutput();
  int dimensions[3];
  output->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], capture.samples);
  EXPECT_EQ(dimensions[1], capture.frames);
  EXPECT_EQ(dimensions[2], 1);
  auto* envelopes = vtkFloatArray::SafeDownCast(output->GetPointData()->GetScalars());
  ASSERT_NE(envelopes, nullptr);
  EXPECT_STREQ(envelopes->GetName(), "Envelope");
  const std::vector<float> expected = coreEnvelopes(sequence, params);
  ASSERT_EQ(envelopes->GetNumberOfValues(), static_cast<vtkIdType>(expected.size()));
  for (vtkIdType i = 0; i < envelopes->GetNumberOfValues(); ++i) {
    ASSERT_FLOAT_EQ(envelopes->GetValue(i), expected[static_cast<std::size_t>(i)]) << "value " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(AllMethods, EnvelopeFilterMethods,
                         ::testing::Values(core::EnvelopeMethod::Mozes, core::EnvelopeMethod::Hann,
                                           core::EnvelopeMethod::StdDev,
                                           core::EnvelopeMethod::Hilbert));

// Streamed in blocks, the filter writes each block into the previous block's array when nothing
// else holds it (no fresh pages per block); a consumer that kept a block's envelopes keeps them.
TEST(EnvelopeFilter, BlocksReuseTheArrayUnlessAConsumerKeptIt) {
  SyntheticCapture capture;
  capture.frames = 40;
  const core::Sequence sequence = makeCapture(capture);
  const core::EnvelopeParams params;
  const std::vector<float> expected = coreEnvelopes(sequence, params);
  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetParams(params);
  filter->SetInputData(imageOf(sequence));
  const auto block = [&](int first, int last) {
    int extent[6] = {0, capture.samples - 1, first, last, 0, 0};
    filter->UpdateExtent(extent);
    EXPECT_EQ(filter->GetLastError(), "");
    return vtkFloatArray::SafeDownCast(filter->GetOutput()->GetPointData()->GetScalars());
  };
  const auto expectFrames = [&](vtkFloatArray* envelopes, int first, int last) {
    ASSERT_NE(envelopes, nullptr);
    const auto values = static_cast<vtkIdType>((last - first + 1) * capture.samples);
    ASSERT_EQ(envelopes->GetNumberOfValues(), values);
    const auto offset = static_cast<std::size_t>(first * capture.samples);
    for (vtkIdType i = 0; i < values; ++i) {
      ASSERT_FLOAT_EQ(envelopes->GetValue(i), expected[offset + static_cast<std::size_t>(i)])
          << "frames " << first << "-" << last << ", value " << i;
    }
  };

  vtkFloatArray* first = block(0, 9);
  expectFrames(first, 0, 9);
  const float* firstValues = first->GetPointer(0);
  vtkFloatArray* second = block(10, 19);
  expectFrames(second, 10, 19);
  EXPECT_EQ(second, first);
  EXPECT_EQ(second->GetPointer(0), firstValues);

  vtkNew<vtkImageData> kept;
  kept->ShallowCopy(filter->GetOutput());
  vtkFloatArray* third = block(20, 29);
  EXPECT_NE(third, second);
  expectFrames(third, 20, 29);
  expectFrames(vtkFloatArray::SafeDownCast(kept->GetPointData()->GetScalars()), 10, 19);
  EXPECT_EQ(filter->GetExecutionCount(), 3);
}

TEST(EnvelopeFilter, ConvertsAnyScalarTypeToFloat) {
  SyntheticCapture capture;
  capture.frames = 3;
  const core::Sequence sequence = makeCapture(capture);
  vtkSmartPointer<vtkImageData> image = imageOf(sequence);
  // The same A-lines as 16-bit samples: the envelope must not change.
  vtkNew<vtkShortArray> shorts;
  shorts->DeepCopy(image->GetPointData()->GetScalars());
  vtkNew<vtkImageData> shortImage;
  shortImage->DeepCopy(image);
  shortImage->GetPointData()->SetScalars(shorts);

  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetInputData(shortImage);
  filter->Update();
  const std::vector<float> expected = coreEnvelopes(sequence, filter->GetParams());
  auto* envelopes = vtkFloatArray::SafeDownCast(filter->GetOutput()->GetPointData()->GetScalars());
  ASSERT_NE(envelopes, nullptr);
  ASSERT_EQ(envelopes->GetNumberOfValues(), static_cast<vtkIdType>(expected.size()));
  for (vtkIdType i = 0; i < envelopes->GetNumberOfValues(); i += 7) {
    ASSERT_FLOAT_EQ(envelopes->GetValue(i), expected[static_cast<std::size_t>(i)]);
  }
}

TEST(EnvelopeFilter, PassesTheFieldDataThrough) {
  SyntheticCapture capture;
  capture.frames = 4;
  vtkSmartPointer<vtkImageData> image = imageOf(makeCapture(capture));
  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetInputData(image);
  filter->Update();
  vtkFieldData* passed = filter->GetOutput()->GetFieldData();
  ASSERT_EQ(passed->GetNumberOfArrays(), image->GetFieldData()->GetNumberOfArrays());
  for (const char* name : {"Timestamp", "ProbeToTracker", "ProbeToTracker_Valid",
                           "ProbeToTracker_Status", "SamplingFrequencyHz"}) {
    EXPECT_EQ(passed->GetAbstractArray(name), image->GetFieldData()->GetAbstractArray(name))
        << name << " is not the input's array";
  }
}

TEST(EnvelopeFilter, ParameterSettersModifyOnlyOnChange) {
  vtkNew<vtkEchoregEnvelopeFilter> filter;
  const vtkMTimeType start = filter->GetMTime();
  filter->SetParams(filter->GetParams());
  filter->SetWindowSamples(filter->GetWindowSamples());
  filter->SetMethodToHann();
  EXPECT_EQ(filter->GetMTime(), start);

  filter->SetMethodToMozes();
  EXPECT_GT(filter->GetMTime(), start);
  EXPECT_EQ(filter->GetMethod(), vtkEchoregEnvelopeFilter::METHOD_MOZES);
  EXPECT_STREQ(filter->GetMethodAsString(), "mozes");
  EXPECT_EQ(filter->GetParams().method, core::EnvelopeMethod::Mozes);

  const vtkMTimeType afterMethod = filter->GetMTime();
  core::EnvelopeParams params = filter->GetParams();
  params.cutoffNormalized = 0.02;
  filter->SetParams(params);
  EXPECT_GT(filter->GetMTime(), afterMethod);
  EXPECT_DOUBLE_EQ(filter->GetCutoffNormalized(), 0.02);

  filter->SetMethod(42);  // clamped
  EXPECT_EQ(filter->GetMethod(), vtkEchoregEnvelopeFilter::METHOD_HILBERT);
}

TEST(EnvelopeFilter, InvalidParametersFailThroughTheExecutive) {
  CapturedVtkOutput messages;
  SyntheticCapture capture;
  capture.frames = 2;
  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetInputData(imageOf(makeCapture(capture)));
  filter->SetWindowSamples(0);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("window"), std::string::npos) << filter->GetLastError();
  EXPECT_NE(messages.text().find("window"), std::string::npos);

  filter->SetWindowSamples(21);
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetLastError(), "");
}

TEST(EnvelopeFilter, InputWithoutSamplesWarnsAndPassesTheFieldDataThrough) {
  CapturedVtkOutput messages;
  core::Sequence trackerOnly;
  trackerOnly.frames.resize(5);
  for (auto& frame : trackerOnly.frames)
    frame.transforms["StylusToTracker"] = core::TrackedTransform();
  vtkSmartPointer<vtkImageData> image = imageOf(trackerOnly);

  vtkNew<vtkEchoregEnvelopeFilter> filter;
  filter->SetInputData(image);
  filter->Update();
  vtkImageData* output = filter->GetOutput();
  int dimensions[3];
  output->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], 0);
  EXPECT_EQ(dimensions[1], 5);
  EXPECT_EQ(output->GetNumberOfPoints(), 0);
  EXPECT_NE(output->GetFieldData()->GetAbstractArray("StylusToTracker"), nullptr);
  EXPECT_NE(messages.text().find("no samples"), std::string::npos) << messages.text();
}

TEST(EnvelopeFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregEnvelopeFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"Method", "RingDownSamples", "ButterworthOrder", "CutoffNormalized",
                           "ZeroPhase", "WindowSamples", "TransducerFrequencyHz",
                           "RelativeBandwidth", "SamplingFrequencyHz", "SmoothingSamples"}) {
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace echoreg::test
