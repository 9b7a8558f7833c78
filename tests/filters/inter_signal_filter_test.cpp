#include "echoreg/filters/SequenceFieldData.h"
#include "echoreg/filters/vtkEchoregInterSignalFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkIntArray.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>

namespace echoreg::test {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A peak table as vtkEchoregPeakFilter makes it: one row per frame; a non-empty reason means the
// single-signal detection rejected the frame (its depth is then NaN).
vtkSmartPointer<vtkTable> peakTable(const std::vector<double>& depthsMm,
                                    const std::vector<std::string>& reasons,
                                    const Sequence& poses = Sequence()) {
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkIntArray> frames;
  frames->SetName("frame");
  vtkNew<vtkDoubleArray> depths;
  depths->SetName("depth_mm");
  vtkNew<vtkStringArray> reasonColumn;
  reasonColumn->SetName("reason");
  vtkNew<vtkDoubleArray> thresholds;
  thresholds->SetName("threshold");
  for (std::size_t row = 0; row < depthsMm.size(); ++row) {
    frames->InsertNextValue(static_cast<int>(row));
    depths->InsertNextValue(reasons[row].empty() ? depthsMm[row] : kNaN);
    reasonColumn->InsertNextValue(reasons[row]);
    thresholds->InsertNextValue(7.0);
  }
  table->AddColumn(frames);
  table->AddColumn(depths);
  table->AddColumn(reasonColumn);
  table->AddColumn(thresholds);
  filters::SequenceFieldData::write(poses, table->GetFieldData());
  return table;
}

Sequence probePoses(int frames, const std::vector<int>& invalidFrames = {}) {
  Sequence sequence;
  sequence.frames.resize(static_cast<std::size_t>(frames));
  for (int frame = 0; frame < frames; ++frame) {
    TrackedTransform probe;
    probe.matrix = Eigen::Matrix4d::Identity();
    probe.matrix(0, 3) = 10.0 * frame;
    probe.matrix(2, 3) = 100.0;
    if (std::find(invalidFrames.begin(), invalidFrames.end(), frame) != invalidFrames.end()) {
      probe.status = "INVALID";
    }
    sequence.frames[static_cast<std::size_t>(frame)].transforms["ProbeToTracker"] = probe;
    TrackedTransform femur;
    femur.matrix = Eigen::Matrix4d::Identity();
    femur.matrix.block<3, 3>(0, 0) =
        Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    femur.matrix.block<3, 1>(0, 3) = Eigen::Vector3d(1.0, 2.0, 3.0);
    sequence.frames[static_cast<std::size_t>(frame)].transforms["FemurToTracker"] = femur;
  }
  return sequence;
}

std::string reasonAt(vtkTable* table, vtkIdType row) {
  return vtkStringArray::SafeDownCast(table->GetColumnByName("reason"))->GetValue(row);
}
std::string statusAt(vtkTable* table, vtkIdType row) {
  return vtkStringArray::SafeDownCast(table->GetColumnByName("status"))->GetValue(row);
}
Eigen::Vector3d pointAt(vtkTable* table, vtkIdType row) {
  return {table->GetValueByName(row, "x_mm").ToDouble(),
          table->GetValueByName(row, "y_mm").ToDouble(),
          table->GetValueByName(row, "z_mm").ToDouble()};
}

TEST(InterSignalFilter, WithoutPosesPointsLieOnTheBeam) {
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetHistory(1);
  filter->SetMinSpreadMm(0.0);
  filter->SetInputData(peakTable({12.0, kNaN, 13.5}, {"", "no-peak", ""}));
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");
  vtkTable* output = filter->GetOutput();
  ASSERT_EQ(output->GetNumberOfRows(), 3);
  EXPECT_TRUE(pointAt(output, 0).isApprox(Eigen::Vector3d(0.0, 0.0, 12.0)));
  EXPECT_TRUE(pointAt(output, 2).isApprox(Eigen::Vector3d(0.0, 0.0, 13.5)));
  EXPECT_TRUE(std::isnan(pointAt(output, 1).x()));
  EXPECT_EQ(statusAt(output, 0), "accepted");
  EXPECT_EQ(statusAt(output, 1), "rejected");
  EXPECT_EQ(reasonAt(output, 1), "no-peak");
  EXPECT_NE(output->GetColumnByName("threshold"), nullptr) << "input columns are kept";
}

TEST(InterSignalFilter, PosesAndBeamToProbePlaceThePointInTracker) {
  const Sequence poses = probePoses(2);
  // Beam +z along Probe +x, beam origin 5 mm along Probe y.
  const double beamToProbe[16] = {0,  0, 1, 0,  //
                                  0,  1, 0, 5,  //
                                  -1, 0, 0, 0,  //
                                  0,  0, 0, 1};
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetHistory(1);
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

TEST(InterSignalFilter, ReferenceTransformExpressesPointsInTheBone) {
  const Sequence poses = probePoses(2);
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetHistory(1);
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetReferenceTransformName("FemurToTracker");
  filter->SetInputData(peakTable({20.0, 30.0}, {"", ""}, poses));
  filter->Update();
  for (int frame = 0; frame < 2; ++frame) {
    const auto& transforms = poses.frames[static_cast<std::size_t>(frame)].transforms;
    const Eigen::Vector4d beam(0.0, 0.0, frame == 0 ? 20.0 : 30.0, 1.0);
    const Eigen::Vector4d expected = transforms.at("FemurToTracker").matrix.inverse() *
                                     transforms.at("ProbeToTracker").matrix * beam;
    EXPECT_TRUE(pointAt(filter->GetOutput(), frame).isApprox(expected.head<3>()));
  }
}

TEST(InterSignalFilter, InvalidPoseRejectsTheFrameAndBreaksTheRun) {
  // All points agree (same depth, probe steps 0.1 mm) so only the invalid pose breaks the run.
  Sequence poses = probePoses(6, {2});
  for (auto& frame : poses.frames)
    frame.transforms["ProbeToTracker"].matrix(0, 3) *= 0.01;
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetHistory(2);
  filter->SetConsistencyMm(0.5);
  filter->SetMinSpreadMm(0.0);
  filter->SetPoseTransformName("ProbeToTracker");
  filter->SetInputData(peakTable({20, 20, 20, 20, 20, 20}, {"", "", "", "", "", ""}, poses));
  filter->Update();
  vtkTable* output = filter->GetOutput();
  const std::vector<std::string> expected = {"inconsistent", "", "invalid-pose",
                                             "inconsistent", "", ""};
  for (int row = 0; row < 6; ++row)
    EXPECT_EQ(reasonAt(output, row), expected[row]) << row;
  EXPECT_TRUE(std::isnan(pointAt(output, 2).x())) << "an invalid pose gives no point";
  EXPECT_FALSE(std::isnan(pointAt(output, 3).x())) << "inter-signal rejects keep their point";

  const std::map<std::string, int>& counts = filter->GetReasonCounts();
  EXPECT_EQ(counts.at("accepted"), 3);
  EXPECT_EQ(counts.at("inconsistent"), 2);
  EXPECT_EQ(counts.at("invalid-pose"), 1);
  EXPECT_EQ(counts.at("no-peak"), 0);
  auto* countArray =
      vtkIntArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("Count_invalid-pose"));
  ASSERT_NE(countArray, nullptr);
  EXPECT_EQ(countArray->GetValue(0), 1);
  EXPECT_NE(output->GetFieldData()->GetAbstractArray("ProbeToTracker"), nullptr)
      << "poses pass through";
}

TEST(InterSignalFilter, UnknownTransformNameFailsAndListsTheKnownOnes) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetHistory(1);
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

TEST(InterSignalFilter, AgreesWithTheCoreFilterOnAWanderingTrack) {
  // Depths that wander, jump and return: the adapter must give the core's verdicts in order.
  const std::vector<double> depths = {20.0, 20.1, 20.2, 20.25, 25.0, 25.1, 25.1, 25.2,
                                      20.3, 20.3, 20.4, 21.6,  21.7, 21.8, 30.0};
  std::vector<std::string> reasons(depths.size());
  reasons[9] = "no-peak";
  InterSignalParams params;
  params.history = 3;
  params.consistencyMm = 0.3;
  params.minSpreadMm = 0.15;

  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetInterSignalParams(params);
  filter->SetInputData(peakTable(depths, reasons));
  filter->Update();

  InterSignalFilter oracle(params);
  for (std::size_t row = 0; row < depths.size(); ++row) {
    std::string expected = reasons[row];
    if (expected.empty()) {
      expected = rejectReasonName(oracle.judge(Eigen::Vector3d(0.0, 0.0, depths[row])));
    } else {
      oracle.breakRun();
    }
    EXPECT_EQ(reasonAt(filter->GetOutput(), static_cast<vtkIdType>(row)), expected) << row;
  }
}

TEST(InterSignalFilter, BadSettingsFailThroughTheExecutive) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregInterSignalFilter> filter;
  filter->SetInputData(peakTable({20.0}, {""}));
  filter->SetHistory(0);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("history"), std::string::npos) << filter->GetLastError();

  filter->SetHistory(1);
  filter->SetReferenceTransformName("FemurToTracker");
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("PoseTransformName"), std::string::npos);

  filter->SetReferenceTransformName("");
  vtkNew<vtkTable> notPeaks;
  filter->SetInputData(notPeaks);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("depth_mm"), std::string::npos);
}

TEST(InterSignalFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregInterSignalFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"History", "ConsistencyMm", "MinSpreadMm", "PoseTransformName",
                           "ReferenceTransformName", "BeamToProbe"}) {
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace echoreg::test
