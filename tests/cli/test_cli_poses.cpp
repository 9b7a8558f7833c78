// Issue 15, item 2: one rule for tracked poses in every command that uses them as rigid
// transforms. Shown here on `echoreg pivot` (the register and calibrate cases are in the study
// tests, the real PLUS recording in test_cli_landmarks.cpp).
#include "cli_test_support.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <functional>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

const Eigen::Vector3d kTip(2.0, -1.0, 150.0);    // StylusTip in Stylus
const Eigen::Vector3d kPivot(10.0, 20.0, 30.0);  // the divot in Tracker

// A stylus pivoting about its tip in a divot, swept about two axes.
core::Sequence pivotCapture() {
  core::Sequence s;
  for (int f = 0; f < 40; ++f) {
    const double a = 0.5 * std::sin(0.3 * f), b = 0.5 * std::cos(0.21 * f);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = (Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(b, Eigen::Vector3d::UnitY()))
                        .toRotationMatrix();
    pose.translation() = kPivot - pose.linear() * kTip;
    core::SequenceFrame frame;
    frame.timestampS = 0.05 * f;
    frame.transforms["StylusToTracker"] = {pose.matrix(), "OK"};
    s.frames.push_back(frame);
  }
  return s;
}

class CliPoses : public ::testing::Test {
 protected:
  std::string write(const core::Sequence& s, const std::string& name) {
    const std::string path = dir_.file(name);
    core::writeSequence(s, path);
    return path;
  }
  test::CommandResult pivot(const std::string& capture) {
    return runEchoreg({"pivot", "--capture", capture, "--out", out_, "--json"});
  }
  test::TempDir dir_;
  std::string out_ = dir_.file("tip.json");
};

TEST_F(CliPoses, PivotRefusesPosesThatAreNotRigidNamingFrameAndTransform) {
  const std::vector<std::pair<std::string, std::function<void(Eigen::Matrix4d&)>>> cases{
      {"a scale, shear or reflection", [](Eigen::Matrix4d& m) { m.topLeftCorner<3, 3>() *= 2.0; }},
      {"a scale, shear or reflection", [](Eigen::Matrix4d& m) { m.topLeftCorner<3, 3>() *= 1.01; }},
      {"a scale, shear or reflection", [](Eigen::Matrix4d& m) { m(0, 1) += 0.3; }},
      {"not 0 0 0 1", [](Eigen::Matrix4d& m) { m(3, 0) = 0.01; }},
      // Was accepted and written as 300-digit coordinates (issue 15, item 8).
      {"its translation is 1e+308 mm from the tracker's origin",
       [](Eigen::Matrix4d& m) { m(1, 3) = 1e308; }}};
  for (const auto& [phrase, spoil] : cases) {
    core::Sequence s = pivotCapture();
    spoil(s.frames[7].transforms["StylusToTracker"].matrix);
    const std::string capture = write(s, "spoiled.igs.mha");
    const auto r = pivot(capture);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find(capture + ": frame 7: its StylusToTrackerTransform is not a rigid pose"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find(phrase), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out_));
    EXPECT_FALSE(fs::exists(dir_.file("tip.tfm")));
  }
}

TEST_F(CliPoses, PivotReorthonormalisesTrackerRoundingAndSaysHowMany) {
  const auto exact = pivot(write(pivotCapture(), "exact.igs.mha"));
  ASSERT_EQ(exact.exitCode, 0) << exact.err;
  EXPECT_EQ(nlohmann::json::parse(exact.out)["poses_reorthonormalised"], 0);
  EXPECT_EQ(exact.err.find("re-orthonormalised"), std::string::npos) << exact.err;
  const Eigen::Vector3d exactTip = core::readTransformFile(out_).matrix.topRightCorner<3, 1>();
  EXPECT_LT((exactTip - kTip).norm(), 1e-6);

  // Every third pose rounded as a real tracker writes it (off orthonormal by ~5e-4).
  core::Sequence s = pivotCapture();
  for (std::size_t f = 0; f < s.frames.size(); f += 3) {
    s.frames[f].transforms["StylusToTracker"].matrix.topLeftCorner<3, 3>() *= 1.00025;
  }
  const std::string capture = write(s, "rounded.igs.mha");
  const auto r = pivot(capture);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["poses_reorthonormalised"], 14);
  EXPECT_NE(r.err.find("echoreg pivot: note: " + capture +
                       ": 14 of 40 StylusToTracker poses re-orthonormalised"),
            std::string::npos)
      << r.err;
  const Eigen::Vector3d tip = core::readTransformFile(out_).matrix.topRightCorner<3, 1>();
  EXPECT_LT((tip - kTip).norm(), 0.2);
}

}  // namespace
}  // namespace echoreg::cli
