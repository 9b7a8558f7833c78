// vtkEchoregSequenceWriter: reader -> writer gives back the file's A-lines, timestamps, poses with
// their statuses and acquisition settings, as echoreg::core::readSequence reads them; errors
// through the executive leave no file.
#include "echoreg/filters/vtkEchoregSequenceReader.h"
#include "echoreg/filters/vtkEchoregSequenceWriter.h"
#include "filter_test_helpers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <filesystem>
#include <sstream>

namespace echoreg::test {
namespace {

void expectSameSequence(const core::Sequence& actual, const core::Sequence& expected) {
  EXPECT_EQ(actual.elementType, expected.elementType);
  EXPECT_EQ(actual.frameSize, expected.frameSize);
  EXPECT_EQ(actual.pixels, expected.pixels);
  ASSERT_EQ(actual.frames.size(), expected.frames.size());
  for (std::size_t f = 0; f < expected.frames.size(); ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    EXPECT_EQ(actual.frames[f].timestampS, expected.frames[f].timestampS);
    ASSERT_EQ(actual.frames[f].transforms.size(), expected.frames[f].transforms.size());
    for (const auto& [name, transform] : expected.frames[f].transforms) {
      const core::TrackedTransform& written = actual.frames[f].transforms.at(name);
      EXPECT_EQ(written.status, transform.status) << name;
      EXPECT_TRUE(written.matrix.isApprox(transform.matrix, 1e-12)) << name;
    }
  }
  EXPECT_EQ(actual.acquisition.samplingFrequencyHz, expected.acquisition.samplingFrequencyHz);
  EXPECT_EQ(actual.acquisition.speedOfSoundMps, expected.acquisition.speedOfSoundMps);
  EXPECT_EQ(actual.acquisition.delayS, expected.acquisition.delayS);
}

TEST(SequenceWriter, ReaderToWriterGivesTheCaptureBack) {
  TempDir dir;
  SyntheticCapture capture;
  capture.frames = 16;
  capture.invalidProbeFrames = {3};
  capture.withFemur = true;
  const core::Sequence sequence = makeCapture(capture);
  const std::string path = dir.file("capture.igs.mha");
  core::writeSequence(sequence, path);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  vtkNew<vtkEchoregSequenceWriter> writer;
  writer->SetInputConnection(reader->GetOutputPort());
  for (const std::string name : {"copy.igs.mha", "copy.igs.nrrd", "copy.mhd"}) {
    SCOPED_TRACE(name);
    writer->SetFileName(dir.file(name));
    ASSERT_EQ(writer->Write(), 1) << writer->GetLastError();
    expectSameSequence(core::readSequence(dir.file(name)), core::readSequence(path));
  }
  EXPECT_EQ(writer->GetExecutionCount(), 3);
  EXPECT_EQ(reader->GetExecutionCount(), 1) << "the reader's output is reused";

  writer->CompressOff();
  writer->SetFileName(dir.file("raw.igs.mha"));
  ASSERT_EQ(writer->Write(), 1);
  expectSameSequence(core::readSequence(dir.file("raw.igs.mha")), core::readSequence(path));
  EXPECT_GT(std::filesystem::file_size(dir.file("raw.igs.mha")),
            std::filesystem::file_size(dir.file("copy.igs.mha")))
      << "compressed by default";
}

TEST(SequenceWriter, TrackerOnlyCaptureKeepsItsPoses) {
  CapturedVtkOutput messages;
  TempDir dir;
  core::Sequence stylus;
  stylus.frames.resize(5);
  for (std::size_t f = 0; f < stylus.frames.size(); ++f) {
    core::TrackedTransform pose;
    pose.matrix(0, 3) = 2.0 * static_cast<double>(f);
    if (f == 2)
      pose.status = "INVALID";
    stylus.frames[f].transforms["StylusToTracker"] = pose;
    stylus.frames[f].timestampS = 0.1 * static_cast<double>(f);
  }
  const std::string path = dir.file("stylus.igs.mha");
  core::writeSequence(stylus, path);
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  vtkNew<vtkEchoregSequenceWriter> writer;
  writer->SetInputConnection(reader->GetOutputPort());
  writer->SetFileName(dir.file("copy.igs.mha"));
  ASSERT_EQ(writer->Write(), 1) << writer->GetLastError();
  expectSameSequence(core::readSequence(dir.file("copy.igs.mha")), core::readSequence(path));
}

TEST(SequenceWriter, RoundTripsThePublicAgilentRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  TempDir dir;
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  vtkNew<vtkEchoregSequenceWriter> writer;
  writer->SetInputConnection(reader->GetOutputPort());
  writer->SetFileName(dir.file("agilent.igs.nrrd"));
  ASSERT_EQ(writer->Write(), 1) << writer->GetLastError();
  expectSameSequence(core::readSequence(dir.file("agilent.igs.nrrd")), core::readSequence(path));
}

TEST(SequenceWriter, BadInputFailsThroughTheExecutiveAndWritesNothing) {
  CapturedVtkOutput messages;
  TempDir dir;
  vtkNew<vtkEchoregSequenceWriter> writer;

  vtkNew<vtkImageData> volume;
  volume->SetDimensions(8, 4, 3);
  volume->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  writer->SetInputData(volume);
  writer->SetFileName(dir.file("volume.igs.mha"));
  EXPECT_EQ(writer->Write(), 0);
  EXPECT_NE(writer->GetLastError().find("3 slices"), std::string::npos) << writer->GetLastError();
  EXPECT_NE(writer->GetLastError().find("volume.igs.mha"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.file("volume.igs.mha")));

  vtkNew<vtkImageData> doubles;
  doubles->SetDimensions(8, 4, 1);
  doubles->AllocateScalars(VTK_DOUBLE, 1);
  writer->SetInputData(doubles);
  EXPECT_EQ(writer->Write(), 0);
  EXPECT_NE(writer->GetLastError().find("double"), std::string::npos) << writer->GetLastError();

  vtkNew<vtkImageData> alines;
  alines->SetDimensions(8, 4, 1);
  alines->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  writer->SetInputData(alines);
  writer->SetFileName(dir.file("missing-folder/capture.igs.mha"));
  EXPECT_EQ(writer->Write(), 0);
  EXPECT_NE(writer->GetLastError().find("missing-folder"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.file("missing-folder")));

  writer->SetFileName("");
  EXPECT_EQ(writer->Write(), 0);
  EXPECT_NE(writer->GetLastError().find("no file name"), std::string::npos);

  writer->SetFileName(dir.file("alines.igs.mha"));
  EXPECT_EQ(writer->Write(), 1) << writer->GetLastError();
  EXPECT_EQ(writer->GetLastError(), "");
  EXPECT_EQ(core::readSequence(dir.file("alines.igs.mha")).frameCount(), 4U);
}

TEST(SequenceWriter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregSequenceWriter> writer;
  std::ostringstream text;
  writer->Print(text);
  for (const char* name : {"FileName", "Compress", "LastError", "ExecutionCount"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
