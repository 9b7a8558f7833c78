#include "echoreg/filters/sequence_field_data.h"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>

#include <cmath>

namespace echoreg::test {
namespace {

using filters::SequenceFieldData;

Eigen::Matrix4d numberedMatrix(double start) {
  Eigen::Matrix4d matrix;
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col)
      matrix(row, col) = start + row * 4 + col;
  }
  return matrix;
}

// Three frames: frame 1 has no timestamp, ProbeToTracker is INVALID in frame 2, StylusToTracker
// appears only in frame 1.
core::Sequence threeFrames() {
  core::Sequence sequence;
  sequence.frames.resize(3);
  sequence.frames[0].timestampS = 1.5;
  sequence.frames[2].timestampS = 2.5;
  for (int frame = 0; frame < 3; ++frame) {
    core::TrackedTransform probe;
    probe.matrix = numberedMatrix(100.0 * frame);
    probe.status = frame == 2 ? "INVALID" : "OK";
    sequence.frames[static_cast<std::size_t>(frame)].transforms["ProbeToTracker"] = probe;
  }
  core::TrackedTransform stylus;
  stylus.matrix = numberedMatrix(-7.0);
  sequence.frames[1].transforms["StylusToTracker"] = stylus;
  sequence.acquisition.samplingFrequencyHz = 50e6;
  sequence.acquisition.speedOfSoundMps = 1480.0;
  sequence.acquisition.transducer = "Olympus V312";
  return sequence;
}

TEST(SequenceFieldData, WritesTheDocumentedArrays) {
  vtkNew<vtkFieldData> fieldData;
  SequenceFieldData::write(threeFrames(), fieldData);

  auto* timestamps = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("Timestamp"));
  ASSERT_NE(timestamps, nullptr);
  ASSERT_EQ(timestamps->GetNumberOfTuples(), 3);
  EXPECT_DOUBLE_EQ(timestamps->GetValue(0), 1.5);
  EXPECT_TRUE(std::isnan(timestamps->GetValue(1)));

  auto* probe = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker"));
  ASSERT_NE(probe, nullptr);
  EXPECT_EQ(probe->GetNumberOfComponents(), 16);
  EXPECT_EQ(probe->GetNumberOfTuples(), 3);
  // Row-major: component 3 is the x translation, component 4 the first of the second row.
  EXPECT_DOUBLE_EQ(probe->GetComponent(1, 3), 103.0);
  EXPECT_DOUBLE_EQ(probe->GetComponent(1, 4), 104.0);

  auto* valid =
      vtkUnsignedCharArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker_Valid"));
  auto* status = vtkStringArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker_Status"));
  ASSERT_NE(valid, nullptr);
  ASSERT_NE(status, nullptr);
  EXPECT_EQ(valid->GetValue(0), 1);
  EXPECT_EQ(valid->GetValue(2), 0);
  EXPECT_EQ(status->GetValue(2), "INVALID");

  auto* stylusStatus =
      vtkStringArray::SafeDownCast(fieldData->GetAbstractArray("StylusToTracker_Status"));
  ASSERT_NE(stylusStatus, nullptr);
  EXPECT_EQ(stylusStatus->GetValue(0), "");
  EXPECT_EQ(stylusStatus->GetValue(1), "OK");
  auto* stylus = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("StylusToTracker"));
  EXPECT_TRUE(std::isnan(stylus->GetComponent(0, 0)));

  auto* sampling = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("SamplingFrequencyHz"));
  ASSERT_NE(sampling, nullptr);
  EXPECT_EQ(sampling->GetNumberOfTuples(), 1);
  EXPECT_DOUBLE_EQ(sampling->GetValue(0), 50e6);
  EXPECT_EQ(fieldData->GetAbstractArray("DelayS"), nullptr) << "absent settings get no array";
}

TEST(SequenceFieldData, ReadsBackWhatItWrote) {
  const core::Sequence sequence = threeFrames();
  vtkNew<vtkFieldData> fieldData;
  SequenceFieldData::write(sequence, fieldData);
  const SequenceFieldData read(fieldData);

  EXPECT_EQ(read.frameCount(), 3);
  EXPECT_DOUBLE_EQ(read.timestampS(2), 2.5);
  EXPECT_TRUE(std::isnan(read.timestampS(1)));
  EXPECT_TRUE(std::isnan(read.timestampS(3)));
  EXPECT_EQ(read.transformNames(), (std::vector<std::string>{"ProbeToTracker", "StylusToTracker"}));
  EXPECT_TRUE(read.hasTransform("ProbeToTracker"));
  EXPECT_FALSE(read.hasTransform("Timestamp"));

  ASSERT_TRUE(read.validMatrix("ProbeToTracker", 1).has_value());
  EXPECT_TRUE(read.validMatrix("ProbeToTracker", 1)->isApprox(numberedMatrix(100.0)));
  EXPECT_FALSE(read.validMatrix("ProbeToTracker", 2).has_value()) << "INVALID is not valid";
  EXPECT_FALSE(read.validMatrix("ProbeToTracker", 3).has_value()) << "out of range";
  EXPECT_FALSE(read.validMatrix("StylusToTracker", 0).has_value()) << "absent in frame 0";
  EXPECT_FALSE(read.validMatrix("FemurToTracker", 0).has_value()) << "no such transform";
  ASSERT_TRUE(read.transform("ProbeToTracker", 2).has_value());
  EXPECT_EQ(read.transform("ProbeToTracker", 2)->status, "INVALID");

  const core::AcquisitionSettings settings = read.acquisition();
  EXPECT_EQ(settings.samplingFrequencyHz, sequence.acquisition.samplingFrequencyHz);
  EXPECT_EQ(settings.speedOfSoundMps, sequence.acquisition.speedOfSoundMps);
  EXPECT_FALSE(settings.delayS.has_value());
  EXPECT_EQ(settings.transducer, "Olympus V312");

  const std::vector<core::SequenceFrame> frames = read.frames();
  ASSERT_EQ(frames.size(), 3U);
  for (std::size_t frame = 0; frame < frames.size(); ++frame) {
    EXPECT_EQ(frames[frame].timestampS, sequence.frames[frame].timestampS);
    ASSERT_EQ(frames[frame].transforms.size(), sequence.frames[frame].transforms.size());
    for (const auto& [name, transform] : sequence.frames[frame].transforms) {
      const core::TrackedTransform& back = frames[frame].transforms.at(name);
      EXPECT_EQ(back.status, transform.status);
      EXPECT_TRUE(back.matrix.isApprox(transform.matrix)) << name << " frame " << frame;
    }
  }
}

TEST(SequenceFieldData, NullOrForeignFieldDataHoldsNothing) {
  const SequenceFieldData none(nullptr);
  EXPECT_EQ(none.frameCount(), 0);
  EXPECT_TRUE(none.transformNames().empty());
  EXPECT_TRUE(std::isnan(none.timestampS(0)));

  // A 16-component array alone is not a transform: the _Valid and _Status arrays are missing.
  vtkNew<vtkFieldData> fieldData;
  vtkNew<vtkDoubleArray> lonely;
  lonely->SetName("LonelyToTracker");
  lonely->SetNumberOfComponents(16);
  lonely->SetNumberOfTuples(2);
  fieldData->AddArray(lonely);
  const SequenceFieldData foreign(fieldData);
  EXPECT_TRUE(foreign.transformNames().empty());
  EXPECT_FALSE(foreign.validMatrix("LonelyToTracker", 0).has_value());
}

TEST(SequenceFieldData, RewritingRemovesSettingsNoLongerStated) {
  vtkNew<vtkFieldData> fieldData;
  SequenceFieldData::write(threeFrames(), fieldData);
  core::Sequence plain = threeFrames();
  plain.acquisition = core::AcquisitionSettings();
  SequenceFieldData::write(plain, fieldData);
  EXPECT_EQ(fieldData->GetAbstractArray("SamplingFrequencyHz"), nullptr);
  EXPECT_EQ(fieldData->GetAbstractArray("Transducer"), nullptr);
}

}  // namespace
}  // namespace echoreg::test
