// vtkEchoregInterSignalFilter: the verdicts of the core's applyInterSignal on the points of the
// beam points filter, in both temporal modes, tracked or not, with errors through the executive.
#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"
#include "echoreg/filters/vtkEchoregInterSignalFilter.h"
#include "filter_test_helpers.hpp"
#include "peak_table_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkExecutive.h>
#include <vtkFieldData.h>

#include <cmath>
#include <map>
#include <sstream>

namespace echoreg::test {
namespace {

// Beam points (untracked, or through `pose`) followed by the inter-signal filter.
struct Chain {
  vtkNew<vtkEchoregBeamPointsFilter> beamPoints;
  vtkNew<vtkEchoregInterSignalFilter> interSignal;
  explicit Chain(vtkTable* peaks, const std::string& pose = "") {
    beamPoints->SetInputData(peaks);
    beamPoints->SetPoseTransformName(pose);
    interSignal->SetInputConnection(beamPoints->GetOutputPort());
  }
  vtkTable* output() { return interSignal->GetOutput(); }
};

TEST(InterSignalFilter, StatusFollowsTheVerdictsAndColumnsAreKept) {
  Chain chain(peakTable({12.0, kNaN, 13.5}, {"", "no-peak", ""}));
  chain.interSignal->SetHistory(1);
  chain.interSignal->Update();
  ASSERT_EQ(chain.interSignal->GetLastError(), "");
  vtkTable* output = chain.output();
  ASSERT_EQ(output->GetNumberOfRows(), 3);
  EXPECT_EQ(statusAt(output, 0), "accepted");
  EXPECT_EQ(statusAt(output, 1), "rejected");
  EXPECT_EQ(reasonAt(output, 1), "no-peak");
  EXPECT_EQ(pointAt(output, 2), Eigen::Vector3d(0.0, 0.0, 13.5));
  EXPECT_NE(output->GetColumnByName("threshold"), nullptr) << "input columns are kept";
  EXPECT_EQ(chain.interSignal->GetLastResult().echoes, 2);
  EXPECT_EQ(chain.interSignal->GetLastResult().accepted, 2);
  EXPECT_FALSE(chain.interSignal->GetLastResult().tracked);
}

TEST(InterSignalFilter, InvalidPoseRejectsTheFrameAndBreaksTheRun) {
  // All points agree (same depth, probe steps 0.1 mm) so only the invalid pose breaks the run.
  core::Sequence poses = probePoses(6, {2});
  for (auto& frame : poses.frames)
    frame.transforms["ProbeToTracker"].matrix(0, 3) *= 0.01;
  Chain chain(peakTable({20, 20, 20, 20, 20, 20}, {"", "", "", "", "", ""}, poses),
              "ProbeToTracker");
  chain.interSignal->SetHistory(2);
  chain.interSignal->SetConsistencyMm(0.5);
  chain.interSignal->SetMinSpreadMm(0.0);
  chain.interSignal->Update();
  vtkTable* output = chain.output();
  const std::vector<std::string> expected = {"inconsistent", "", "invalid-pose",
                                             "inconsistent", "", ""};
  for (int row = 0; row < 6; ++row)
    EXPECT_EQ(reasonAt(output, row), expected[row]) << row;
  EXPECT_TRUE(std::isnan(pointAt(output, 2).x())) << "an invalid pose gives no point";
  EXPECT_FALSE(std::isnan(pointAt(output, 3).x())) << "inter-signal rejects keep their point";

  const std::map<std::string, int>& counts = chain.interSignal->GetReasonCounts();
  EXPECT_EQ(counts.at("accepted"), 3);
  EXPECT_EQ(counts.at("inconsistent"), 2);
  EXPECT_EQ(counts.at("invalid-pose"), 1);
  EXPECT_EQ(counts.at("no-peak"), 0);
  EXPECT_EQ(counts.at("in-ring-down"), 0);
  auto* countArray =
      vtkIntArray::SafeDownCast(output->GetFieldData()->GetAbstractArray("Count_invalid-pose"));
  ASSERT_NE(countArray, nullptr);
  EXPECT_EQ(countArray->GetValue(0), 1);
  auto* echoes = vtkIntArray::SafeDownCast(
      output->GetFieldData()->GetAbstractArray("EchoesBeforeInterSignal"));
  ASSERT_NE(echoes, nullptr);
  EXPECT_EQ(echoes->GetValue(0), 5);
  EXPECT_NE(output->GetFieldData()->GetAbstractArray("ProbeToTracker"), nullptr)
      << "poses pass through";
  EXPECT_TRUE(chain.interSignal->GetLastResult().tracked);
}

// The adapter's verdicts against applyInterSignal on the same frames, in every mode.
struct Case {
  core::TemporalMode temporal;
  bool tracked;
};

class InterSignalAgainstCore : public ::testing::TestWithParam<Case> {};

TEST_P(InterSignalAgainstCore, GivesApplyInterSignalsVerdicts) {
  // Depths that wander, jump and return, with a gap: the adapter must give the core's verdicts.
  const std::vector<double> depths = {20.0, 20.1, 20.2, 20.25, 25.0, 25.1, 25.1, 25.2,
                                      20.3, 20.3, 20.4, 21.6,  21.7, 21.8, 30.0};
  std::vector<std::string> reasons(depths.size());
  reasons[9] = "no-peak";
  core::InterSignalParams params;
  params.temporal = GetParam().temporal;
  params.history = 3;
  params.consistencyMm = 0.3;
  params.minSpreadMm = 0.15;
  params.maxDepthRateMmPerS = 2.0;

  // Tracked: an identity probe pose, so the points are (0, 0, depth) in Tracker and the spatial
  // filter runs; untracked it must not.
  core::Sequence poses;
  poses.frames.resize(depths.size());
  for (std::size_t frame = 0; frame < depths.size(); ++frame) {
    // 30 ms apart, not the 20 ms the filter assumes without timestamps: the column is read.
    poses.frames[frame].timestampS = 0.03 * static_cast<double>(frame);
    poses.frames[frame].transforms["ProbeToTracker"] = core::TrackedTransform();
  }
  vtkSmartPointer<vtkTable> peaks = peakTable(depths, reasons, poses);
  vtkNew<vtkDoubleArray> timestamps;
  timestamps->SetName("timestamp_s");
  for (const core::SequenceFrame& frame : poses.frames)
    timestamps->InsertNextValue(*frame.timestampS);
  peaks->AddColumn(timestamps);
  Chain chain(peaks, GetParam().tracked ? "ProbeToTracker" : "");
  chain.interSignal->SetInterSignalParams(params);
  chain.interSignal->Update();
  ASSERT_EQ(chain.interSignal->GetLastError(), "");

  std::vector<core::InterSignalInput> inputs(depths.size());
  for (std::size_t row = 0; row < depths.size(); ++row) {
    inputs[row].detected = reasons[row].empty();
    inputs[row].depthMm = depths[row];
    inputs[row].pointMm = Eigen::Vector3d(0.0, 0.0, depths[row]);
    inputs[row].timestampS = poses.frames[row].timestampS;
  }
  const std::vector<core::RejectReason> verdicts =
      core::applyInterSignal(params, inputs, GetParam().tracked);
  int rejectedHere = 0;
  for (std::size_t row = 0; row < depths.size(); ++row) {
    const std::string expected =
        inputs[row].detected ? std::string(core::rejectReasonName(verdicts[row])) : reasons[row];
    EXPECT_EQ(reasonAt(chain.output(), static_cast<vtkIdType>(row)), expected) << row;
    if (inputs[row].detected && verdicts[row] != core::RejectReason::None)
      ++rejectedHere;
  }
  EXPECT_GT(rejectedHere, 0) << "the track must give the filter something to reject";
  EXPECT_EQ(chain.interSignal->GetLastResult().tracked, GetParam().tracked);
}

INSTANTIATE_TEST_SUITE_P(Modes, InterSignalAgainstCore,
                         ::testing::Values(Case{core::TemporalMode::Run, false},
                                           Case{core::TemporalMode::Run, true},
                                           Case{core::TemporalMode::Neighbours, false},
                                           Case{core::TemporalMode::Neighbours, true}));

TEST(InterSignalFilter, TheSpatialFilterRunsOnlyOnTrackedPoints) {
  // The same depth again and again: tracked, only the first survives the 1 mm spread; on the
  // beam of a transducer that does not move, the spread says nothing and all are kept.
  const std::vector<double> depths(5, 20.0);
  const std::vector<std::string> reasons(5);
  core::Sequence poses;
  poses.frames.resize(5);
  for (auto& frame : poses.frames)
    frame.transforms["ProbeToTracker"] = core::TrackedTransform();
  for (const bool tracked : {false, true}) {
    Chain chain(peakTable(depths, reasons, poses), tracked ? "ProbeToTracker" : "");
    chain.interSignal->SetHistory(1);
    chain.interSignal->SetMinSpreadMm(1.0);
    chain.interSignal->Update();
    EXPECT_EQ(chain.interSignal->GetReasonCounts().at("accepted"), tracked ? 1 : 5) << tracked;
    EXPECT_EQ(chain.interSignal->GetReasonCounts().at("too-close"), tracked ? 4 : 0) << tracked;
  }
}

TEST(InterSignalFilter, BadSettingsFailThroughTheExecutive) {
  CapturedVtkOutput messages;
  Chain chain(peakTable({20.0}, {""}));
  chain.interSignal->SetHistory(0);
  EXPECT_EQ(chain.interSignal->GetExecutive()->Update(), 0);
  EXPECT_NE(chain.interSignal->GetLastError().find("history"), std::string::npos)
      << chain.interSignal->GetLastError();

  chain.interSignal->SetHistory(1);
  chain.interSignal->SetMaxGapS(0.0);
  EXPECT_EQ(chain.interSignal->GetExecutive()->Update(), 0);
  EXPECT_NE(chain.interSignal->GetLastError().find("gap"), std::string::npos);
  chain.interSignal->SetMaxGapS(0.1);
  EXPECT_EQ(chain.interSignal->GetExecutive()->Update(), 1);
  EXPECT_EQ(chain.interSignal->GetLastError(), "");

  vtkNew<vtkEchoregInterSignalFilter> alone;
  alone->SetInputData(peakTable({20.0}, {""}));
  EXPECT_EQ(alone->GetExecutive()->Update(), 0);
  EXPECT_NE(alone->GetLastError().find("x_mm"), std::string::npos) << "points are needed";
}

TEST(InterSignalFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregInterSignalFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"TemporalMode", "History", "ConsistencyMm", "MaxDepthRateMmPerS",
                           "MaxGapS", "FrameRateHz", "MinSpreadMm"}) {
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace echoreg::test
