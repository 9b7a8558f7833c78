// vtkEchoregBeamPointsFilter: depths become points in Beam, Tracker or a reference frame, exactly
// as the core's beamPoint, with invalid poses rejected and errors through the executive.
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"
#include "filter_test_helpers.hpp"
#include "peak_table_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkMatrix4x4.h>
#include <vtkTrivialProducer.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace echoreg::test {
namespace {

std::string pointFrameOf(vtkTable* table) {
  auto* array = vtkStringArray::SafeDownCast(table->GetFieldData()->GetAbstractArray("PointFrame"));
  return array == nullptr ? std::string("(none)") : array->GetValue(0);
}

TEST(BeamPointsFilter, WithoutPosesPointsLieOnTheBeam) {
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetInputData(peakTable({12.0, kNaN, 13.5}, {"", "no-peak", ""}));
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");
  vtkTable* output = filter->GetOutput();
  ASSERT_EQ(output->GetNumberOfRows(), 3);
  EXPECT_EQ(pointAt(output, 0), Eigen::Vector3d(0.0, 0.0, 12.0));
  EXPECT_EQ(pointAt(output, 2), Eigen::Vector3d(0.0, 0.0, 13.5));
  EXPECT_TRUE(std::isnan(pointAt(output, 1).x()));
  EXPECT_EQ(reasonAt(output, 1), "no-peak");
  EXPECT_EQ(reasonAt(output, 0), "");
  EXPECT_NE(output->GetColumnByName("threshold"), nullptr) << "input columns are kept";
  EXPECT_EQ(pointFrameOf(output), "Beam");
  EXPECT_EQ(filter->GetLastResult().placed, 2);
  EXPECT_EQ(filter->GetLastResult().invalidPose, 0);
}

TEST(BeamPointsFilter, PosesAndBeamToProbePlaceThePointInTracker) {
  const core::Sequence poses = probePoses(2);
  // Beam +z along Probe +x, beam origin 5 mm along Probe y.
  const double beamToProbe[16] = {0,  0, 1, 0,  //
                                  0,  1, 0, 5,  //
                                  -1, 0, 0, 0,  //
                                  0,  0, 0, 1};
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetBeamToProbe(beamToProbe);
  filter->SetInputData(peakTable({20.0, 30.0}, {"", ""}, poses));
  filter->Update();
  vtkTable* output = filter->GetOutput();
  for (int frame = 0; frame < 2; ++frame) {
    const double depth = frame == 0 ? 20.0 : 30.0;
    const Eigen::Vector3d expected(10.0 * frame + depth, 5.0, 100.0);
    EXPECT_TRUE(pointAt(output, frame).isApprox(expected))
        << pointAt(output, frame).transpose() << " vs " << expected.transpose();
  }
  EXPECT_EQ(pointFrameOf(output), "Tracker");

  // The same calibration through a vtkMatrix4x4 is the same parameter: no Modified().
  vtkNew<vtkMatrix4x4> matrix;
  matrix->DeepCopy(beamToProbe);
  const vtkMTimeType before = filter->GetMTime();
  filter->SetBeamToProbe(matrix);
  EXPECT_EQ(filter->GetMTime(), before);
  double back[16];
  filter->GetBeamToProbe(back);
  EXPECT_DOUBLE_EQ(back[3], 0.0);
  EXPECT_DOUBLE_EQ(back[7], 5.0);
}

TEST(BeamPointsFilter, ReferenceTransformExpressesPointsInTheBoneAsTheCoreDoes) {
  const core::Sequence poses = probePoses(2);
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetReferenceTransformName("FemurToTracker");
  const double beamToProbe[16] = {1, 0, 0, 1.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  filter->SetBeamToProbe(beamToProbe);
  filter->SetInputData(peakTable({20.0, 30.0}, {"", ""}, poses));
  filter->Update();
  core::PointFrameOptions options;
  options.poseTransform = "ProbeToTracker";
  options.referenceTransform = "FemurToTracker";
  options.beamToProbe(0, 3) = 1.5;
  for (int frame = 0; frame < 2; ++frame) {
    const auto& transforms = poses.frames[static_cast<std::size_t>(frame)].transforms;
    const Eigen::Vector4d beam(1.5, 0.0, frame == 0 ? 20.0 : 30.0, 1.0);
    const Eigen::Vector4d expected = transforms.at("FemurToTracker").matrix.inverse() *
                                     transforms.at("ProbeToTracker").matrix * beam;
    EXPECT_TRUE(pointAt(filter->GetOutput(), frame).isApprox(expected.head<3>()));
    // The adapter's numbers are the core's, bit for bit.
    const auto core =
        core::beamPoint(frame == 0 ? 20.0 : 30.0, options, &transforms.at("ProbeToTracker").matrix,
                        &transforms.at("FemurToTracker").matrix);
    ASSERT_TRUE(core.has_value());
    EXPECT_EQ(pointAt(filter->GetOutput(), frame), *core);
  }
  EXPECT_EQ(pointFrameOf(filter->GetOutput()), "Femur");
}

TEST(BeamPointsFilter, ACalibrationInputWinsOverTheParameterAndReRunsIt) {
  const core::Sequence poses = probePoses(2);
  const double beamToProbe[16] = {0, 0, 1, 0, 0, 1, 0, 5, -1, 0, 0, 0, 0, 0, 0, 1};
  vtkNew<vtkEchoregBeamPointsFilter> byParameter;
  byParameter->SetPoseTransformName("ProbeToTracker");
  byParameter->SetBeamToProbe(beamToProbe);
  byParameter->SetInputData(peakTable({20.0, 30.0}, {"", ""}, poses));
  byParameter->Update();

  const auto calibration = [&](const double* matrix) {
    auto table = vtkSmartPointer<vtkTable>::New();
    vtkNew<vtkDoubleArray> array;
    array->SetName("BeamToProbe");
    array->SetNumberOfComponents(16);
    array->InsertNextTuple(matrix);
    table->GetFieldData()->AddArray(array);
    return table;
  };
  vtkNew<vtkTrivialProducer> calibrationSource;
  calibrationSource->SetOutput(calibration(beamToProbe));
  vtkNew<vtkEchoregBeamPointsFilter> byInput;
  byInput->SetPoseTransformName("ProbeToTracker");
  byInput->SetInputData(peakTable({20.0, 30.0}, {"", ""}, poses));
  byInput->SetCalibrationConnection(calibrationSource->GetOutputPort());
  byInput->Update();
  for (int frame = 0; frame < 2; ++frame)
    EXPECT_EQ(pointAt(byInput->GetOutput(), frame), pointAt(byParameter->GetOutput(), frame));

  double moved[16];
  std::copy(beamToProbe, beamToProbe + 16, moved);
  moved[7] = 7.0;  // the beam origin 2 mm further along Probe y
  calibrationSource->SetOutput(calibration(moved));
  byInput->Update();
  EXPECT_EQ(byInput->GetExecutionCount(), 2) << "a new calibration upstream re-runs it";
  EXPECT_NEAR(pointAt(byInput->GetOutput(), 0).y(), pointAt(byParameter->GetOutput(), 0).y() + 2.0,
              1e-12);

  CapturedVtkOutput messages;
  calibrationSource->SetOutput(vtkSmartPointer<vtkTable>::New());
  EXPECT_EQ(byInput->GetExecutive()->Update(), 0);
  EXPECT_NE(byInput->GetLastError().find("BeamToProbe"), std::string::npos);
}

TEST(BeamPointsFilter, InvalidPoseRejectsTheFrame) {
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetInputData(peakTable({20, 20, 20, kNaN}, {"", "", "", "no-peak"}, probePoses(4, {1})));
  filter->Update();
  vtkTable* output = filter->GetOutput();
  EXPECT_EQ(reasonAt(output, 0), "");
  EXPECT_EQ(reasonAt(output, 1), "invalid-pose");
  EXPECT_EQ(reasonAt(output, 3), "no-peak") << "an earlier verdict is kept";
  EXPECT_TRUE(std::isnan(pointAt(output, 1).x()));
  EXPECT_EQ(filter->GetLastResult().placed, 2);
  EXPECT_EQ(filter->GetLastResult().invalidPose, 1);
  auto* invalid =
      vtkIntArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("PointsInvalidPose"));
  ASSERT_NE(invalid, nullptr);
  EXPECT_EQ(invalid->GetValue(0), 1);
  EXPECT_NE(output->GetFieldData()->GetAbstractArray("ProbeToTracker"), nullptr)
      << "poses pass through";
}

TEST(BeamPointsFilter, ManyRowsInParallelGiveTheSerialAnswer) {
  // Enough rows for vtkSMPTools to split them: every row must still be the core's point.
  const int frames = 5000;
  std::vector<double> depths(frames);
  std::vector<std::string> reasons(frames);
  for (int frame = 0; frame < frames; ++frame) {
    depths[static_cast<std::size_t>(frame)] = 10.0 + 0.001 * frame;
    if (frame % 7 == 0) {
      reasons[static_cast<std::size_t>(frame)] = "no-peak";
      depths[static_cast<std::size_t>(frame)] = kNaN;
    }
  }
  const core::Sequence poses = probePoses(frames, {3, 4000});
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetInputData(peakTable(depths, reasons, poses));
  filter->Update();
  core::PointFrameOptions options;
  options.poseTransform = "ProbeToTracker";
  int invalid = 0;
  for (int frame = 0; frame < frames; ++frame) {
    const auto& probe =
        poses.frames[static_cast<std::size_t>(frame)].transforms.at("ProbeToTracker");
    if (!reasons[static_cast<std::size_t>(frame)].empty())
      continue;
    const auto core = core::beamPoint(depths[static_cast<std::size_t>(frame)], options,
                                      probe.valid() ? &probe.matrix : nullptr, nullptr);
    if (!core) {
      ++invalid;
      EXPECT_EQ(reasonAt(filter->GetOutput(), frame), "invalid-pose") << frame;
    } else {
      EXPECT_EQ(pointAt(filter->GetOutput(), frame), *core) << frame;
    }
  }
  EXPECT_EQ(invalid, 2);
  EXPECT_EQ(filter->GetLastResult().invalidPose, 2);
}

TEST(BeamPointsFilter, UnknownTransformNameFailsAndListsTheKnownOnes) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetReferenceTransformName("TibiaToTracker");
  filter->SetInputData(peakTable({20.0, kNaN}, {"", "no-peak"}, probePoses(2)));
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("TibiaToTracker"), std::string::npos);
  EXPECT_NE(filter->GetLastError().find("FemurToTracker, ProbeToTracker"), std::string::npos)
      << filter->GetLastError();
  EXPECT_NE(messages.text().find("TibiaToTracker"), std::string::npos) << messages.text();

  filter->SetReferenceTransformName("FemurToTracker");
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetLastError(), "");
}

TEST(BeamPointsFilter, BadSettingsAndInputsFailThroughTheExecutive) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  filter->SetInputData(peakTable({20.0}, {""}));
  filter->SetReferenceTransformName("FemurToTracker");
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("PoseTransformName"), std::string::npos);

  filter->SetReferenceTransformName("");
  vtkNew<vtkTable> notPeaks;
  filter->SetInputData(notPeaks);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("depth_mm"), std::string::npos);
}

TEST(BeamPointsFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregBeamPointsFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"PoseTransformName", "ReferenceTransformName", "BeamToProbe",
                           "LastResult", "ExecutionCount"}) {
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace echoreg::test
