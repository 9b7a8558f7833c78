// vtkEchoregPivotCalibrationFilter: the core's pivotCalibration on the valid poses of a capture
// read through the pipeline; a change of the reader's file re-runs it, a change downstream does
// not; errors through the executive.
#include "echoreg/core/fits.hpp"
#include "echoreg/filters/vtkEchoregPivotCalibrationFilter.h"
#include "echoreg/filters/vtkEchoregSequenceReader.h"
#include "filter_test_helpers.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkTable.h>

#include <Eigen/Geometry>

#include <random>
#include <sstream>

namespace echoreg::test {
namespace {

// A stylus whose tip (tipInStylus) pivots about pivotInTracker, with `noiseMm` of tracking noise
// and one stray pose; frame `invalidFrame` is marked INVALID.
core::Sequence pivotCapture(const Eigen::Vector3d& tipInStylus,
                            const Eigen::Vector3d& pivotInTracker, double noiseMm, int frames,
                            int invalidFrame) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> angle(-0.5, 0.5);
  std::normal_distribution<double> noise(0.0, noiseMm);
  core::Sequence sequence;
  sequence.frames.resize(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const Eigen::Matrix3d rotation = (Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitX()) *
                                      Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitZ()))
                                         .toRotationMatrix();
    core::TrackedTransform pose;
    pose.matrix.block<3, 3>(0, 0) = rotation;
    pose.matrix.block<3, 1>(0, 3) = pivotInTracker - rotation * tipInStylus +
                                    Eigen::Vector3d(noise(random), noise(random), noise(random));
    if (f == 5)
      pose.matrix(0, 3) += 8.0;  // a stray pose the robust rounds must drop
    if (f == invalidFrame)
      pose.status = "INVALID";
    sequence.frames[static_cast<std::size_t>(f)].transforms["StylusToTracker"] = pose;
    sequence.frames[static_cast<std::size_t>(f)].timestampS = 0.05 * f;
  }
  return sequence;
}

TEST(PivotCalibrationFilter, GivesTheCoresPivotOnTheValidPoses) {
  TempDir dir;
  const Eigen::Vector3d tip(3.0, -2.0, 160.0), pivot(100.0, 50.0, -900.0);
  const core::Sequence sequence = pivotCapture(tip, pivot, 0.1, 60, 9);
  const std::string path = dir.file("pivot.igs.mha");
  core::writeSequence(sequence, path);

  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  vtkNew<vtkEchoregPivotCalibrationFilter> filter;
  filter->SetInputConnection(reader->GetOutputPort());
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");

  std::vector<Eigen::Isometry3d> poses;
  const core::Sequence read = core::readSequence(path);
  for (const core::SequenceFrame& frame : read.frames) {
    const core::TrackedTransform& pose = frame.transforms.at("StylusToTracker");
    if (!pose.valid())
      continue;
    Eigen::Isometry3d isometry;
    isometry.matrix() = pose.matrix;
    poses.push_back(isometry);
  }
  const core::PivotResult expected = core::pivotCalibration(poses);
  const auto& result = filter->GetLastResult();
  EXPECT_EQ(result.pivot.pointInMarker, expected.pointInMarker);
  EXPECT_EQ(result.pivot.pointInTracker, expected.pointInTracker);
  EXPECT_EQ(result.pivot.rmsMm, expected.rmsMm);
  EXPECT_EQ(result.pivot.inliers, expected.inliers);
  EXPECT_LT((result.pivot.pointInMarker - tip).norm(), 0.2);
  EXPECT_LT((result.pivot.pointInTracker - pivot).norm(), 0.2);

  vtkTable* table = filter->GetOutput();
  ASSERT_EQ(table->GetNumberOfRows(), 59) << "the invalid frame is not a pose";
  EXPECT_EQ(table->GetValueByName(9, "frame").ToInt(), 10);
  EXPECT_EQ(table->GetValueByName(5, "inlier").ToInt(), 0) << "the stray pose";
  auto* tipArray = vtkDoubleArray::SafeDownCast(table->GetFieldData()->GetArray("PointInMarkerMm"));
  ASSERT_NE(tipArray, nullptr);
  EXPECT_EQ(tipArray->GetComponent(0, 2), expected.pointInMarker.z());

  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 1) << "no change, no re-run";
  filter->SetMinRotationSpreadDeg(15.0);  // the default: no change
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 1);
  core::writeSequence(pivotCapture(tip, pivot + Eigen::Vector3d(0, 0, 10), 0.1, 60, 9),
                      dir.file("pivot2.igs.mha"));
  reader->SetFileName(dir.file("pivot2.igs.mha"));
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 2);
  EXPECT_LT((filter->GetLastResult().pivot.pointInTracker - pivot).norm() - 10.0, 0.3);
}

TEST(PivotCalibrationFilter, BadInputFailsThroughTheExecutive) {
  CapturedVtkOutput messages;
  TempDir dir;
  const std::string path = dir.file("pivot.igs.mha");
  core::writeSequence(pivotCapture({0, 0, 150}, {0, 0, 0}, 0.1, 30, -1), path);
  vtkNew<vtkEchoregSequenceReader> reader;
  reader->SetFileName(path);
  vtkNew<vtkEchoregPivotCalibrationFilter> filter;
  filter->SetInputConnection(reader->GetOutputPort());

  filter->SetMarkerTransformName("FemurToTracker");
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("(it has: StylusToTracker)"), std::string::npos)
      << filter->GetLastError();

  filter->SetMarkerTransformName("StylusToTracker");
  filter->SetMinRotationSpreadDeg(80.0);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("pivot calibration failed"), std::string::npos);
  EXPECT_NE(messages.text().find("pivot calibration failed"), std::string::npos);

  filter->SetMinRotationSpreadDeg(15.0);
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetLastError(), "");
}

TEST(PivotCalibrationFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregPivotCalibrationFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"MarkerTransformName", "OutlierSigmas", "MinOutlierMm", "MaxRounds",
                           "MinRotationSpreadDeg", "LastResult", "ExecutionCount"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
