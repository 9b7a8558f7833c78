// The one rule for tracked poses (issue 15, item 2): near-rotations re-orthonormalised and
// counted, scales, shears, reflections and projective rows refused naming frame and transform.
#include "echoreg/core/error.hpp"
#include "echoreg/core/rigid_pose.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>

namespace echoreg::core {
namespace {

Eigen::Matrix4d pose() {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 3).normalized()).toRotationMatrix();
  m.translation() = Eigen::Vector3d(315.5, 9.8, -36.1);
  return m.matrix();
}

Sequence trackedSequence(int frames) {
  Sequence s;
  for (int f = 0; f < frames; ++f) {
    SequenceFrame frame;
    frame.timestampS = 0.1 * f;
    frame.transforms["ProbeToTracker"] = {pose(), "OK"};
    s.frames.push_back(frame);
  }
  return s;
}

TEST(RigidPose, ExactRotationsAreUsedAsTheyAre) {
  EXPECT_EQ(poseProblem(pose()), "");
  Sequence s = trackedSequence(4);
  const RigidPoseReport report = enforceRigidPoses(s, "c.mha", "ProbeToTracker");
  EXPECT_EQ(report.checked, 4);
  EXPECT_EQ(report.reorthonormalised, 0);
  EXPECT_TRUE(s.frames[2].transforms["ProbeToTracker"].matrix == pose());
  EXPECT_FALSE(rigidPoseNote(report, "c.mha", "ProbeToTracker").has_value());
}

TEST(RigidPose, RealTrackerRoundingIsReorthonormalisedAndCounted) {
  // PLUS's recordings are orthonormal only to 2e-4 .. 5e-4.
  Sequence s = trackedSequence(5);
  Eigen::Matrix4d rounded = pose();
  rounded.topLeftCorner<3, 3>() += 4e-4 * Eigen::Matrix3d::Ones();
  s.frames[1].transforms["ProbeToTracker"].matrix = rounded;
  s.frames[3].transforms["ProbeToTracker"].matrix = rounded;
  s.frames[4].transforms["ProbeToTracker"] = {2.0 * pose(), "INVALID"};  // not used: not checked
  const RigidPoseReport report = enforceRigidPoses(s, "c.mha", "ProbeToTracker");
  EXPECT_EQ(report.checked, 4);
  EXPECT_EQ(report.reorthonormalised, 2);
  EXPECT_GT(report.largestDeviation, 1e-4);
  const Eigen::Matrix4d fixed = s.frames[1].transforms["ProbeToTracker"].matrix;
  EXPECT_LT(poseOrthonormalDeviation(fixed), 1e-12);
  EXPECT_LT((fixed - pose()).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_TRUE((fixed.topRightCorner<3, 1>() == pose().topRightCorner<3, 1>()));
  const auto note = rigidPoseNote(report, "c.mha", "ProbeToTracker");
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("c.mha: 2 of 4 ProbeToTracker poses re-orthonormalised"), std::string::npos)
      << *note;
}

TEST(RigidPose, ScaleShearReflectionAndProjectiveRowsAreRefusedNamingFrameAndTransform) {
  Eigen::Matrix4d scaled = pose();
  scaled.topLeftCorner<3, 3>() *= 2.0;
  Eigen::Matrix4d slightlyScaled = pose();
  slightlyScaled.topLeftCorner<3, 3>() *= 1.01;
  Eigen::Matrix4d sheared = pose();
  sheared(0, 1) += 0.2;
  Eigen::Matrix4d reflected = pose();
  reflected.col(2) = -reflected.col(2);
  Eigen::Matrix4d projective = pose();
  projective(3, 2) = 0.001;
  Eigen::Matrix4d notFinite = pose();
  notFinite(1, 1) = std::numeric_limits<double>::quiet_NaN();
  Eigen::Matrix4d farAway = pose();
  farAway(0, 3) = 1e308;
  Eigen::Matrix4d elevenMetres = pose();
  elevenMetres.topRightCorner<3, 1>() = Eigen::Vector3d(0.0, 6.4e3, 9e3);
  const std::vector<std::pair<Eigen::Matrix4d, std::string>> cases{
      {scaled, "a scale, shear or reflection"},
      {slightlyScaled, "a scale, shear or reflection"},
      {sheared, "a scale, shear or reflection"},
      {reflected, "determinant -1"},
      {projective, "not 0 0 0 1"},
      {notFinite, "not finite"},
      {farAway, "its translation is 1e+308 mm from the tracker's origin, beyond the 1e+04 mm"},
      {elevenMetres, "its translation is 1.1e+04 mm from the tracker's origin"}};
  for (const auto& [matrix, phrase] : cases) {
    Sequence s = trackedSequence(6);
    s.frames[3].transforms["ProbeToTracker"].matrix = matrix;
    try {
      enforceRigidPoses(s, "c.mha", "ProbeToTracker");
      ADD_FAILURE() << "accepted:\n" << matrix;
    } catch (const FileError& e) {
      EXPECT_EQ(e.path(), "c.mha");
      EXPECT_NE(e.problem().find("frame 3: its ProbeToTrackerTransform is not a rigid pose"),
                std::string::npos)
          << e.problem();
      EXPECT_NE(e.problem().find(phrase), std::string::npos) << e.problem();
    }
  }
}

}  // namespace
}  // namespace echoreg::core
