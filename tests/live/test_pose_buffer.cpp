// Poses looked up at an A-line's time as PLUS does: interpolated between the two nearest (linear
// translation, SLERP rotation; checked against the rotation of half the relative angle), exact
// when a pose has the A-line's time, and refused with the reason when stale or INVALID.
#include "echoreg/live/pose_buffer.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace echoreg::live {
namespace {

Eigen::Matrix4d pose(double angleRad, const Eigen::Vector3d& translation) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(angleRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

TEST(PoseBuffer, InterpolatesTranslationLinearlyAndRotationAlongTheArc) {
  PoseBuffer buffer(0.1);
  buffer.add("ProbeToTracker", {1.00, pose(0.0, {0, 0, 0}), "OK"});
  buffer.add("ProbeToTracker", {1.02, pose(0.4, {10, -4, 2}), "OK"});
  const PoseLookup quarter = buffer.at("ProbeToTracker", 1.005);
  ASSERT_TRUE(quarter.matrix) << quarter.refusal;
  // Oracle: a quarter of the way, a quarter of the angle about the same axis.
  EXPECT_LT((*quarter.matrix - pose(0.1, {2.5, -1, 0.5})).cwiseAbs().maxCoeff(), 1e-9);
  const PoseLookup exact = buffer.at("ProbeToTracker", 1.02);
  ASSERT_TRUE(exact.matrix);
  EXPECT_EQ(*exact.matrix, pose(0.4, {10, -4, 2}));
}

TEST(PoseBuffer, OutOfOrderPosesAreSortedByTime) {
  PoseBuffer buffer(0.1);
  buffer.add("P", {2.0, pose(0.0, {2, 0, 0}), "OK"});
  buffer.add("P", {1.0, pose(0.0, {0, 0, 0}), "OK"});
  const PoseLookup half = buffer.at("P", 1.5);
  EXPECT_FALSE(half.matrix);  // 1 s apart: more than twice the tolerance
  buffer.add("P", {1.55, pose(0.0, {1.55, 0, 0}), "OK"});
  buffer.add("P", {1.45, pose(0.0, {1.45, 0, 0}), "OK"});
  const PoseLookup between = buffer.at("P", 1.5);
  ASSERT_TRUE(between.matrix) << between.refusal;
  EXPECT_NEAR((*between.matrix)(0, 3), 1.5, 1e-12);
}

TEST(PoseBuffer, StaleInvalidAndMissingPosesAreRefusedWithTheReason) {
  PoseBuffer buffer(0.1);
  EXPECT_EQ(buffer.at("ProbeToTracker", 1.0).refusal, "no ProbeToTracker received yet");
  buffer.add("ProbeToTracker", {1.0, pose(0.0, {0, 0, 0}), "OK"});
  // The tracker lags a little: the newest pose is held within the tolerance.
  EXPECT_TRUE(buffer.at("ProbeToTracker", 1.05).matrix);
  const PoseLookup stale = buffer.at("ProbeToTracker", 1.35);
  EXPECT_FALSE(stale.matrix);
  EXPECT_EQ(stale.refusal,
            "stale pose: the newest ProbeToTracker is 0.350 s older than the A-line (tolerance "
            "0.100 s)");
  buffer.add("ProbeToTracker", {1.02, Eigen::Matrix4d::Identity(), "INVALID"});
  const PoseLookup invalid = buffer.at("ProbeToTracker", 1.01);
  EXPECT_FALSE(invalid.matrix);
  EXPECT_EQ(invalid.refusal, "ProbeToTracker is INVALID at 1.0200 s");
  EXPECT_FALSE(buffer.at("ProbeToTracker", 1.02).matrix);
}

TEST(PoseBuffer, KeepsOnlyItsCapacity) {
  PoseBuffer buffer(0.1, 10);
  for (int i = 0; i < 100; ++i)
    buffer.add("P", {i * 0.01, pose(0.0, {double(i), 0, 0}), "OK"});
  EXPECT_FALSE(buffer.at("P", 0.0).matrix);  // dropped long ago
  EXPECT_TRUE(buffer.at("P", 0.955).matrix);
}

}  // namespace
}  // namespace echoreg::live
