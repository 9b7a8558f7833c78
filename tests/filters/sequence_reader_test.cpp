#include "echoreg/filters/vtkEchoregSequenceReader.h"
#include "filter_test_helpers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace echoreg::test {
namespace {

class SequenceReaderFormats : public ::testing::TestWithParam<std::string> {};

TEST_P(SequenceReaderFormats, ReadsALinesAndTheirFieldData) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 5;
  capture.samples = 300;
  capture.firstEchoSample = 150.0;
  capture.invalidProbeFrames = {3};
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture" + GetParam());
  core::writeSequence(sequence, path);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  reader->Update();
  ASSERT_EQ(reader->GetLastError(), "");

  vtkImageData* image = reader->GetOutput();
  int dimensions[3];
  image->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], capture.samples);
  EXPECT_EQ(dimensions[1], capture.frames);
  EXPECT_EQ(dimensions[2], 1);
  EXPECT_EQ(image->GetSpacing()[0], 1.0);
  EXPECT_EQ(image->GetOrigin()[1], 0.0);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  ASSERT_NE(scalars, nullptr);
  EXPECT_STREQ(scalars->GetName(), "ALines");
  EXPECT_EQ(scalars->GetDataType(), VTK_UNSIGNED_CHAR);
  ASSERT_EQ(static_cast<std::size_t>(scalars->GetNumberOfValues()), sequence.pixels.size());
  EXPECT_EQ(std::memcmp(scalars->GetVoidPointer(0), sequence.pixels.data(), sequence.pixels.size()),
            0);
  // x is the sample, y the frame.
  EXPECT_EQ(image->GetScalarComponentAsDouble(7, 2, 0, 0),
            sequence.pixels[2 * static_cast<std::size_t>(capture.samples) + 7]);

  vtkFieldData* fieldData = image->GetFieldData();
  EXPECT_EQ(image->GetPointData()->GetArray("Timestamp"), nullptr) << "field data, not points";
  auto* timestamps = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("Timestamp"));
  ASSERT_NE(timestamps, nullptr);
  ASSERT_EQ(timestamps->GetNumberOfTuples(), capture.frames);
  EXPECT_NEAR(timestamps->GetValue(4), capture.timestampS(4), 1e-9);
  auto* probe = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker"));
  ASSERT_NE(probe, nullptr);
  EXPECT_EQ(probe->GetNumberOfComponents(), 16);
  EXPECT_EQ(probe->GetNumberOfTuples(), capture.frames);
  EXPECT_DOUBLE_EQ(probe->GetComponent(1, 7), 5.0);  // row 1, column 3: y translation
  auto* valid =
      vtkUnsignedCharArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker_Valid"));
  auto* status = vtkStringArray::SafeDownCast(fieldData->GetAbstractArray("ProbeToTracker_Status"));
  ASSERT_NE(valid, nullptr);
  ASSERT_NE(status, nullptr);
  EXPECT_EQ(valid->GetValue(2), 1);
  EXPECT_EQ(valid->GetValue(3), 0);
  EXPECT_EQ(status->GetValue(3), "INVALID");
  auto* sampling = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray("SamplingFrequencyHz"));
  ASSERT_NE(sampling, nullptr);
  EXPECT_DOUBLE_EQ(sampling->GetValue(0), capture.samplingFrequencyHz);
  ASSERT_NE(fieldData->GetAbstractArray("SpeedOfSoundMps"), nullptr);

  EXPECT_EQ(reader->GetSequence().frameCount(), sequence.frameCount());
  EXPECT_EQ(reader->GetSequence().pixels, sequence.pixels);
}

INSTANTIATE_TEST_SUITE_P(MetaImageAndNrrd, SequenceReaderFormats,
                         ::testing::Values(".igs.mha", ".igs.nrrd", ".mhd"),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           return param.param == ".igs.mha"    ? std::string("mha")
                                  : param.param == ".igs.nrrd" ? std::string("nrrd")
                                                               : std::string("mhd");
                         });

TEST(SequenceReader, KeepsTheElementTypeOfTheFile) {
  TempDir dir;
  const std::pair<core::ElementType, int> types[] = {{core::ElementType::Int8, VTK_SIGNED_CHAR},
                                                     {core::ElementType::Int16, VTK_SHORT},
                                                     {core::ElementType::Float32, VTK_FLOAT}};
  for (const auto& [elementType, vtkType] : types) {
    core::Sequence sequence;
    sequence.elementType = elementType;
    sequence.frameSize = {16, 1};
    sequence.frames.resize(3);
    for (auto& frame : sequence.frames)
      frame.timestampS = 1.0;
    sequence.pixels.assign(3 * 16 * core::elementSize(elementType), 0);
    sequence.pixels[core::elementSize(elementType)] =
        3;  // sample 1 of frame 0 is small and positive
    const std::string path = dir.file(std::string(core::elementTypeName(elementType)) + ".mha");
    core::writeSequence(sequence, path);

    vtkNew<vtkEchoregSequenceReader> reader;
    reader->SetFileName(path);
    reader->Update();
    ASSERT_EQ(reader->GetLastError(), "") << core::elementTypeName(elementType);
    vtkDataArray* scalars = reader->GetOutput()->GetPointData()->GetScalars();
    ASSERT_NE(scalars, nullptr);
    EXPECT_EQ(scalars->GetDataType(), vtkType) << core::elementTypeName(elementType);
    EXPECT_EQ(scalars->GetNumberOfTuples(), 48);
    EXPECT_EQ(scalars->GetComponent(0, 0), 0.0);
    EXPECT_GT(scalars->GetComponent(1, 0), 0.0) << "bytes in host order, sample 1 nonzero";
  }
}

TEST(SequenceReader, TrackerOnlyCaptureIsAnImageWithoutPointsButWithFieldData) {
  TempDir dir;
  core::Sequence sequence;
  sequence.frames.resize(7);
  for (std::size_t frame = 0; frame < sequence.frames.size(); ++frame) {
    sequence.frames[frame].timestampS = 0.1 * static_cast<double>(frame);
    sequence.frames[frame].transforms["StylusToTracker"] = core::TrackedTransform();
  }
  const std::string path = dir.file("stylus.igs.mha");
  core::writeSequence(sequence, path);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  reader->Update();
  ASSERT_EQ(reader->GetLastError(), "");
  vtkImageData* image = reader->GetOutput();
  int extent[6];
  image->GetExtent(extent);
  EXPECT_EQ(extent[0], 0);
  EXPECT_EQ(extent[1], -1);
  EXPECT_EQ(extent[2], 0);
  EXPECT_EQ(extent[3], 6);
  int dimensions[3];
  image->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], 0);
  EXPECT_EQ(dimensions[1], 7);
  EXPECT_EQ(image->GetNumberOfPoints(), 0);
  EXPECT_EQ(image->GetPointData()->GetScalars(), nullptr);
  auto* stylus =
      vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("StylusToTracker"));
  ASSERT_NE(stylus, nullptr);
  EXPECT_EQ(stylus->GetNumberOfTuples(), 7);
}

TEST(SequenceReader, ReadsTheFileOnceUntilSomethingChanges) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 3;
  capture.samples = 100;
  capture.firstEchoSample = 50.0;
  const std::string first = dir.file("first.igs.mha");
  const std::string second = dir.file("second.igs.mha");
  core::writeSequence(makeCapture(capture), first);
  capture.frames = 4;
  core::writeSequence(makeCapture(capture), second);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(first);
  reader->Update();
  reader->Update();
  reader->UpdateInformation();
  EXPECT_EQ(reader->GetReadCount(), 1);
  EXPECT_EQ(reader->GetExecutionCount(), 1);

  reader->SetFileName(first);  // the same name: nothing changes
  reader->Update();
  EXPECT_EQ(reader->GetReadCount(), 1);

  reader->Modified();
  reader->Update();
  EXPECT_EQ(reader->GetReadCount(), 2);
  EXPECT_EQ(reader->GetExecutionCount(), 2);

  reader->SetFileName(second);
  reader->Update();
  EXPECT_EQ(reader->GetReadCount(), 3);
  EXPECT_EQ(reader->GetOutput()->GetDimensions()[1], 4);
}

TEST(SequenceReader, MissingFileFailsThroughTheExecutiveAndNamesTheFile) {
  CapturedVtkOutput messages;
  TempDir dir;
  const std::string path = dir.file("absent.igs.mha");
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  EXPECT_NO_THROW(reader->Update());
  EXPECT_EQ(reader->GetExecutive()->Update(), 0);
  EXPECT_NE(reader->GetLastError().find(path), std::string::npos) << reader->GetLastError();
  EXPECT_NE(messages.text().find(path), std::string::npos) << messages.text();
  EXPECT_EQ(reader->GetOutput()->GetNumberOfPoints(), 0);
  EXPECT_EQ(reader->GetExecutionCount(), 0);
}

TEST(SequenceReader, DirectoryAndCorruptFilesFailAndNameTheFile) {
  CapturedVtkOutput messages;
  TempDir dir;
  const std::string folder = dir.file("folder.igs.mha");
  std::filesystem::create_directories(folder);
  const std::string corrupt = dir.file("corrupt.igs.mha");
  std::ofstream(corrupt) << "ObjectType = Image\nNDims = banana\nElementDataFile = LOCAL\n";
  const std::string truncated = dir.file("truncated.igs.nrrd");
  std::ofstream(truncated) << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100 1 10\n"
                              "encoding: raw\n\nshort";

  for (const std::string& path : {folder, corrupt, truncated}) {
    vtkNew<vtkEchoregSequenceReader> reader;
    reader->SetFileName(path);
    EXPECT_EQ(reader->GetExecutive()->Update(), 0) << path;
    EXPECT_NE(reader->GetLastError().find(path), std::string::npos) << reader->GetLastError();
    EXPECT_EQ(reader->GetOutput()->GetNumberOfPoints(), 0);
  }
}

TEST(SequenceReader, RecoversAfterAFailureAndClearsTheError) {
  CapturedVtkOutput messages;
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 2;
  capture.samples = 64;
  capture.firstEchoSample = 30.0;
  const std::string good = dir.file("good.igs.mha");
  core::writeSequence(makeCapture(capture), good);

  vtkNew<vtkEchoregSequenceReader> reader;
  EXPECT_EQ(reader->GetExecutive()->Update(), 0) << "no file name";
  EXPECT_NE(reader->GetLastError().find("file name"), std::string::npos);
  reader->SetFileName(dir.file("absent.mha"));
  EXPECT_EQ(reader->GetExecutive()->Update(), 0);
  reader->SetFileName(good);
  EXPECT_EQ(reader->GetExecutive()->Update(), 1);
  EXPECT_EQ(reader->GetLastError(), "");
  EXPECT_EQ(reader->GetOutput()->GetNumberOfPoints(), 128);

  // A failure after a success leaves no stale image behind.
  reader->SetFileName(dir.file("absent.mha"));
  EXPECT_EQ(reader->GetExecutive()->Update(), 0);
  EXPECT_EQ(reader->GetOutput()->GetNumberOfPoints(), 0);
  EXPECT_EQ(reader->GetOutput()->GetFieldData()->GetNumberOfArrays(), 0);
}

TEST(SequenceReader, RefusesFramesThatAreImages) {
  CapturedVtkOutput messages;
  TempDir dir;
  core::Sequence sequence;
  sequence.elementType = core::ElementType::UInt8;
  sequence.frameSize = {8, 4};
  sequence.frames.resize(2);
  sequence.pixels.assign(2 * 8 * 4, 0);
  const std::string path = dir.file("images.igs.mha");
  core::writeSequence(sequence, path);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  EXPECT_EQ(reader->GetExecutive()->Update(), 0);
  // The core's sentence (requireSingleALineFrames), as detect and calibrate give it.
  EXPECT_NE(reader->GetLastError().find("its frames hold 4 rows of 8 samples"), std::string::npos)
      << reader->GetLastError();
  EXPECT_NE(reader->GetLastError().find("one A-line per frame"), std::string::npos)
      << reader->GetLastError();
  EXPECT_NE(reader->GetLastError().find(path), std::string::npos) << reader->GetLastError();
}

TEST(SequenceReader, ReadsThePublicAgilentRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  reader->Update();
  ASSERT_EQ(reader->GetLastError(), "");
  vtkImageData* image = reader->GetOutput();
  int dimensions[3];
  image->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], 11350);
  EXPECT_EQ(dimensions[1], 150);
  EXPECT_EQ(dimensions[2], 1);
  ASSERT_NE(image->GetPointData()->GetScalars(), nullptr);
  EXPECT_EQ(image->GetPointData()->GetScalars()->GetDataType(), VTK_SHORT);
  auto* zOffset =
      vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("ZOffsetToTracker"));
  ASSERT_NE(zOffset, nullptr);
  EXPECT_EQ(zOffset->GetNumberOfComponents(), 16);
  EXPECT_EQ(zOffset->GetNumberOfTuples(), 150);
  EXPECT_NE(image->GetFieldData()->GetAbstractArray("ZOffsetToTracker_Valid"), nullptr);
  auto* timestamps =
      vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("Timestamp"));
  ASSERT_NE(timestamps, nullptr);
  EXPECT_EQ(timestamps->GetNumberOfTuples(), 150);
  EXPECT_FALSE(std::isnan(timestamps->GetValue(0)));
}

TEST(SequenceReader, ReadsThePublicTrackerOnlyLandmarkRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(path,
                              "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  reader->Update();
  ASSERT_EQ(reader->GetLastError(), "");
  vtkImageData* image = reader->GetOutput();
  int dimensions[3];
  image->GetDimensions(dimensions);
  EXPECT_EQ(dimensions[0], 0);
  EXPECT_EQ(dimensions[1], 1000);
  EXPECT_EQ(image->GetNumberOfPoints(), 0);
  auto* stylus =
      vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("StylusToTracker"));
  ASSERT_NE(stylus, nullptr);
  EXPECT_EQ(stylus->GetNumberOfTuples(), 1000);
  EXPECT_NEAR(stylus->GetComponent(0, 3), 315.55283203125, 1e-9);
  EXPECT_NE(image->GetFieldData()->GetAbstractArray("ReferenceToTracker_Status"), nullptr);
}

TEST(SequenceReader, PrintSelfNamesTheFile) {
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName("/some/where.igs.mha");
  std::ostringstream text;
  reader->Print(text);
  EXPECT_NE(text.str().find("FileName: /some/where.igs.mha"), std::string::npos);
}

}  // namespace
}  // namespace echoreg::test
