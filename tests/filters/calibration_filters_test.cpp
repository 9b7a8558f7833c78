// The calibration chain as pipeline algorithms: stylus capture -> vtkEchoregSphereFitFilter
// -> (input 1) vtkEchoregBeamCalibrationFilter (input 0: the shots' detection table). Each equals
// its core function on the same data and recovers the simulated truth; a change on one side
// re-runs only what is downstream of it; errors go through the executive.
#include "echoreg/core/beam_calibration.hpp"
#include "echoreg/core/detection.hpp"
#include "echoreg/core/fits.hpp"
#include "echoreg/filters/sequence_field_data.h"
#include "echoreg/filters/vtkEchoregBeamCalibrationFilter.h"
#include "echoreg/filters/vtkEchoregSphereFitFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTrivialProducer.h>

#include <Eigen/Geometry>

#include <random>
#include <sstream>

namespace echoreg::test {
namespace {

const Eigen::Vector3d kCentre(10.0, 20.0, -800.0);
constexpr double kBallRadius = 12.7;
constexpr double kTipRadius = 1.5;
const Eigen::Vector3d kTipInStylus(1.0, -2.0, 150.0);
const Eigen::Vector3d kBeamOrigin(26.5, 0.8, 196.6);  // BeamToProbe's translation (truth)

Eigen::Matrix3d randomRotation(std::mt19937& random, double maxRad) {
  std::uniform_real_distribution<double> angle(-maxRad, maxRad);
  return (Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(angle(random), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

// A unit vector on the hemisphere facing -`towards`, at least 30 degrees in from its rim.
Eigen::Vector3d facing(std::mt19937& random, const Eigen::Vector3d& towards) {
  std::normal_distribution<double> normal;
  for (;;) {
    const Eigen::Vector3d n =
        Eigen::Vector3d(normal(random), normal(random), normal(random)).normalized();
    if (n.dot(towards) < -0.5)
      return n;
  }
}

// The stylus touching the sphere from above (tips on the sphere of radius ball + tip), as the
// field data of a tracker-only capture.
vtkSmartPointer<vtkImageData> stylusCapture(int poses, double noiseMm) {
  std::mt19937 random(5);
  std::normal_distribution<double> noise(0.0, noiseMm);
  core::Sequence sequence;
  sequence.frames.resize(static_cast<std::size_t>(poses));
  for (int f = 0; f < poses; ++f) {
    const Eigen::Vector3d n = facing(random, Eigen::Vector3d(0, 0, -1));
    const Eigen::Vector3d tip = kCentre + (kBallRadius + kTipRadius) * n +
                                Eigen::Vector3d(noise(random), noise(random), noise(random));
    const Eigen::Matrix3d rotation = randomRotation(random, 0.6);
    core::TrackedTransform pose;
    pose.matrix.block<3, 3>(0, 0) = rotation;
    pose.matrix.block<3, 1>(0, 3) = tip - rotation * kTipInStylus;
    if (f == 3)
      pose.status = "INVALID";
    sequence.frames[static_cast<std::size_t>(f)].transforms["StylusToTracker"] = pose;
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetExtent(0, -1, 0, poses - 1, 0, 0);
  filters::SequenceFieldData::write(sequence, image->GetFieldData());
  return image;
}

// Shots at the sphere: each beam (BeamToProbe = translation kBeamOrigin) enters the ball at a
// point facing the probe, at 15-30 mm; a detection table as the inter-signal filter writes it
// (every 7th frame rejected), with the poses in its field data.
vtkSmartPointer<vtkTable> shotsTable(int shots) {
  std::mt19937 random(9);
  std::uniform_real_distribution<double> depth(15.0, 30.0);
  core::Sequence sequence;
  sequence.frames.resize(static_cast<std::size_t>(shots));
  sequence.acquisition.speedOfSoundMps = 1450.0;
  vtkNew<vtkIntArray> frames;
  frames->SetName("frame");
  vtkNew<vtkDoubleArray> depths;
  depths->SetName("depth_mm");
  vtkNew<vtkStringArray> statuses;
  statuses->SetName("status");
  for (int f = 0; f < shots; ++f) {
    const Eigen::Matrix3d rotation = randomRotation(random, 0.5);
    const Eigen::Vector3d beam = rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d hit = kCentre + kBallRadius * facing(random, beam);
    const double d = depth(random);
    const Eigen::Vector3d origin = hit - d * beam;
    core::TrackedTransform pose;
    pose.matrix.block<3, 3>(0, 0) = rotation;
    pose.matrix.block<3, 1>(0, 3) = origin - rotation * kBeamOrigin;
    sequence.frames[static_cast<std::size_t>(f)].transforms["ProbeToTracker"] = pose;
    frames->InsertNextValue(f);
    depths->InsertNextValue(f % 7 == 6 ? std::numeric_limits<double>::quiet_NaN() : d);
    statuses->InsertNextValue(f % 7 == 6 ? "rejected" : "accepted");
  }
  auto table = vtkSmartPointer<vtkTable>::New();
  table->AddColumn(frames);
  table->AddColumn(depths);
  table->AddColumn(statuses);
  filters::SequenceFieldData::write(sequence, table->GetFieldData());
  return table;
}

struct CalibrationPipeline {
  vtkNew<vtkTrivialProducer> stylus;
  vtkNew<vtkTrivialProducer> shots;
  vtkNew<vtkEchoregSphereFitFilter> sphere;
  vtkNew<vtkEchoregBeamCalibrationFilter> beam;
  CalibrationPipeline() {
    stylus->SetOutput(stylusCapture(80, 0.05));
    shots->SetOutput(shotsTable(70));
    sphere->SetInputConnection(stylus->GetOutputPort());
    sphere->SetTipInStylusMm(kTipInStylus.x(), kTipInStylus.y(), kTipInStylus.z());
    sphere->SetTipRadiusMm(kTipRadius);
    sphere->SetBallRadiusMm(kBallRadius);
    beam->SetInputConnection(0, shots->GetOutputPort());
    beam->SetSphereConnection(sphere->GetOutputPort());
    const double initial[16] = {1, 0, 0, 25, 0, 1, 0, 0, 0, 0, 1, 195, 0, 0, 0, 1};
    beam->SetInitialBeamToProbe(initial);
  }
};

TEST(SphereFitFilter, EqualsFitSphereOnTheValidTipsAndFindsTheBall) {
  CalibrationPipeline pipeline;
  pipeline.sphere->Update();
  ASSERT_EQ(pipeline.sphere->GetLastError(), "");
  vtkTable* table = pipeline.sphere->GetOutput();
  ASSERT_EQ(table->GetNumberOfRows(), 79) << "the invalid pose is left out";
  std::vector<Eigen::Vector3d> tips;
  for (vtkIdType row = 0; row < table->GetNumberOfRows(); ++row) {
    tips.emplace_back(table->GetValueByName(row, "x_mm").ToDouble(),
                      table->GetValueByName(row, "y_mm").ToDouble(),
                      table->GetValueByName(row, "z_mm").ToDouble());
  }
  core::SphereFitOptions options;
  options.radiusMm = kBallRadius + kTipRadius;
  const core::SphereFit expected = core::fitSphere(tips, options);
  EXPECT_EQ(pipeline.sphere->GetLastResult().centre, expected.centre);
  EXPECT_EQ(pipeline.sphere->GetLastResult().rmsMm, expected.rmsMm);
  EXPECT_LT((expected.centre - kCentre).norm(), 0.05);
  auto* radius = vtkDoubleArray::SafeDownCast(table->GetFieldData()->GetArray("SphereRadiusMm"));
  ASSERT_NE(radius, nullptr);
  EXPECT_DOUBLE_EQ(radius->GetValue(0), kBallRadius) << "the ball's own radius";

  pipeline.sphere->SetBallRadiusMm(std::numeric_limits<double>::quiet_NaN());
  pipeline.sphere->Update();
  EXPECT_NEAR(pipeline.sphere->GetLastResult().radiusMm, kBallRadius + kTipRadius, 0.05)
      << "a free radius";
}

TEST(BeamCalibrationFilter, EqualsCalibrateBeamAndRecoversTheBeamOrigin) {
  CalibrationPipeline pipeline;
  pipeline.beam->Update();
  ASSERT_EQ(pipeline.beam->GetLastError(), "");
  const core::BeamCalibrationResult& result = pipeline.beam->GetLastResult();
  EXPECT_LT((result.beamToProbe.translation() - kBeamOrigin).norm(), 0.1)
      << result.beamToProbe.translation().transpose();
  EXPECT_LT(result.rmsMm, 0.1);

  // The same shots and sphere straight into the core.
  vtkTable* shots = vtkTable::SafeDownCast(pipeline.shots->GetOutputDataObject(0));
  const filters::SequenceFieldData poses(shots->GetFieldData());
  std::vector<core::BeamShot> coreShots;
  for (vtkIdType row = 0; row < shots->GetNumberOfRows(); ++row) {
    if (shots->GetValueByName(row, "status").ToString() != "accepted")
      continue;
    core::BeamShot shot;
    shot.probeToTracker.matrix() = *poses.validMatrix("ProbeToTracker", row);
    shot.depthMm = shots->GetValueByName(row, "depth_mm").ToDouble();
    coreShots.push_back(shot);
  }
  core::BeamCalibrationOptions options;
  options.assumedSpeedOfSoundMps = 1450.0;
  options.sphereCentreTracker = pipeline.sphere->GetLastResult().centre;
  options.sphereRadiusMm = kBallRadius;
  options.initialBeamToProbe.translation() = Eigen::Vector3d(25, 0, 195);
  const core::BeamCalibrationResult expected = core::calibrateBeam(coreShots, options);
  EXPECT_TRUE(result.beamToProbe.matrix() == expected.beamToProbe.matrix());
  EXPECT_EQ(result.rmsMm, expected.rmsMm);
  EXPECT_EQ(pipeline.beam->GetOutput()->GetNumberOfRows(),
            static_cast<vtkIdType>(coreShots.size()));
  auto* matrix = vtkDoubleArray::SafeDownCast(
      pipeline.beam->GetOutput()->GetFieldData()->GetArray("BeamToProbe"));
  ASSERT_NE(matrix, nullptr);
  EXPECT_EQ(matrix->GetComponent(0, 3), expected.beamToProbe.translation().x()) << "row-major";
}

// The speed the shots' depths were measured with: the one set, else the capture header's, else
// the calibration preset's (as echoreg calibrate assumes); the result reports the one used.
TEST(BeamCalibrationFilter, AssumedSpeedIsTheSetOneElseTheHeadersElseTheCalibrationPresets) {
  CalibrationPipeline pipeline;
  pipeline.beam->Update();
  ASSERT_EQ(pipeline.beam->GetLastError(), "");
  EXPECT_EQ(pipeline.beam->GetLastResult().speedOfSoundMps, 1450.0) << "the header's";
  pipeline.beam->SetAssumedSpeedOfSoundMps(1500.0);
  pipeline.beam->Update();
  EXPECT_EQ(pipeline.beam->GetLastResult().speedOfSoundMps, 1500.0) << "the one set";
  pipeline.beam->SetAssumedSpeedOfSoundMps(std::numeric_limits<double>::quiet_NaN());
  vtkTable* shots = vtkTable::SafeDownCast(pipeline.shots->GetOutputDataObject(0));
  ASSERT_NE(shots->GetFieldData()->GetArray("SpeedOfSoundMps"), nullptr);
  shots->GetFieldData()->RemoveArray("SpeedOfSoundMps");
  shots->Modified();
  pipeline.beam->Update();
  ASSERT_EQ(pipeline.beam->GetLastError(), "");
  EXPECT_EQ(pipeline.beam->GetLastResult().speedOfSoundMps,
            core::detectionPreset("calibration").depth.speedOfSoundMps)
      << "without a header: the calibration preset's";
  EXPECT_EQ(pipeline.beam->GetLastResult().speedOfSoundMps, core::kWaterSpeedOfSoundMps);
}

TEST(CalibrationPipeline, AChangeReRunsOnlyWhatIsDownstream) {
  CalibrationPipeline pipeline;
  pipeline.beam->Update();
  EXPECT_EQ(pipeline.sphere->GetExecutionCount(), 1);
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 1);

  pipeline.beam->Update();
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 1) << "nothing changed";

  pipeline.beam->SetMode(core::BeamCalibrationMode::Beam);
  pipeline.beam->Update();
  EXPECT_EQ(pipeline.sphere->GetExecutionCount(), 1) << "a solver setting: the sphere stays";
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 2);

  pipeline.sphere->SetTipRadiusMm(1.0);
  pipeline.beam->Update();
  EXPECT_EQ(pipeline.sphere->GetExecutionCount(), 2) << "a stylus setting: both run";
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 3);

  pipeline.shots->SetOutput(shotsTable(60));
  pipeline.beam->Update();
  EXPECT_EQ(pipeline.sphere->GetExecutionCount(), 2) << "new shots: the sphere stays";
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 4);
}

TEST(CalibrationFilters, BadInputFailsThroughTheExecutive) {
  CapturedVtkOutput messages;
  CalibrationPipeline pipeline;
  pipeline.sphere->SetStylusTransformName("PointerToTracker");
  EXPECT_EQ(pipeline.beam->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.sphere->GetLastError().find("(it has: StylusToTracker)"), std::string::npos)
      << pipeline.sphere->GetLastError();
  EXPECT_EQ(pipeline.beam->GetExecutionCount(), 0) << "nothing runs below a failure";

  pipeline.sphere->SetStylusTransformName("StylusToTracker");
  pipeline.sphere->SetTipRadiusMm(-1.0);
  EXPECT_EQ(pipeline.sphere->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.sphere->GetLastError().find("TipRadiusMm"), std::string::npos);
  pipeline.sphere->SetTipRadiusMm(kTipRadius);

  pipeline.shots->SetOutput(shotsTable(3));
  EXPECT_EQ(pipeline.beam->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.beam->GetLastError().find("sphere echoes"), std::string::npos)
      << pipeline.beam->GetLastError();

  vtkNew<vtkTable> noSphere;
  pipeline.beam->SetInputData(1, noSphere);
  pipeline.shots->SetOutput(shotsTable(70));
  EXPECT_EQ(pipeline.beam->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.beam->GetLastError().find("SphereCentreMm"), std::string::npos);
}

TEST(CalibrationFilters, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregSphereFitFilter> sphere;
  vtkNew<vtkEchoregBeamCalibrationFilter> beam;
  std::ostringstream text;
  sphere->Print(text);
  beam->Print(text);
  for (const char* name : {"StylusTransformName", "TipInStylusMm", "TipRadiusMm", "BallRadiusMm",
                           "Mode", "FitSpeedOfSound", "AssumedSpeedOfSoundMps",
                           "InitialBeamToProbe", "MaxConditionNumber", "PoseTransformName"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
