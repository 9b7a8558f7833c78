// The registration error decomposition: known compositions of rotations about the CT axes and
// translations come back as they were built, target distances, the mean of absolute values.
#include "echoreg/core/rigid_error.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace echoreg::core {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Eigen::Isometry3d femurToCt() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotationFromAnglesZyxDeg(Eigen::Vector3d(80.0, -20.0, 135.0));
  t.translation() = Eigen::Vector3d(-95.0, 20.0, -480.0);
  return t;
}

TEST(RigidError, AnglesRoundTripAndFollowRzRyRx) {
  const Eigen::Vector3d angles(12.5, -33.0, 71.0);
  const Eigen::Matrix3d r = rotationFromAnglesZyxDeg(angles);
  const Eigen::Matrix3d byHand =
      Eigen::AngleAxisd(71.0 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      Eigen::AngleAxisd(-33.0 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix() *
      Eigen::AngleAxisd(12.5 * kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_LT((r - byHand).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((rotationAnglesZyxDeg(r) - angles).cwiseAbs().maxCoeff(), 1e-10);
  // Gimbal lock (ry = 90): the matrix is still reproduced.
  const Eigen::Matrix3d locked = rotationFromAnglesZyxDeg(Eigen::Vector3d(20.0, 90.0, 0.0));
  EXPECT_LT((rotationFromAnglesZyxDeg(rotationAnglesZyxDeg(locked)) - locked).cwiseAbs().maxCoeff(),
            1e-9);
  Eigen::Matrix3d notRotation = Eigen::Matrix3d::Identity();
  notRotation(0, 0) = -1.0;
  EXPECT_THROW(rotationAnglesZyxDeg(notRotation), std::invalid_argument);
}

TEST(RigidError, RecoversAKnownErrorAppliedInCtSpace) {
  const Eigen::Isometry3d reference = femurToCt();
  Eigen::Isometry3d error = Eigen::Isometry3d::Identity();
  error.linear() = rotationFromAnglesZyxDeg(Eigen::Vector3d(1.5, -0.7, 2.2));
  error.translation() = Eigen::Vector3d(0.8, -1.9, 2.6);
  const Eigen::Isometry3d estimate = error * reference;
  const Eigen::Vector3d target(-95.0, 20.0, -26.0);  // the hip
  const RigidError e = rigidError(reference, estimate, {target, Eigen::Vector3d::Zero()});
  EXPECT_LT((e.translationMm - Eigen::Vector3d(0.8, -1.9, 2.6)).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((e.rotationDeg - Eigen::Vector3d(1.5, -0.7, 2.2)).cwiseAbs().maxCoeff(), 1e-10);
  ASSERT_EQ(e.targetErrorsMm.size(), 2u);
  EXPECT_NEAR(e.targetErrorsMm[0], (error * target - target).norm(), 1e-10);
  EXPECT_NEAR(e.targetErrorsMm[1], error.translation().norm(), 1e-10);
  // About a centre: a pure rotation about the knee moves the knee by nothing.
  Eigen::Isometry3d aboutKnee = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d knee(-95.0, 20.0, -480.0);
  aboutKnee.linear() = rotationFromAnglesZyxDeg(Eigen::Vector3d(0.0, 0.0, 3.0));
  aboutKnee.translation() = knee - aboutKnee.linear() * knee;
  const RigidError k = rigidError(reference, aboutKnee * reference, {}, knee);
  EXPECT_LT(k.translationMm.norm(), 1e-10);
  EXPECT_NEAR(k.rotationDeg.z(), 3.0, 1e-10);
  // ... but the CT origin, 97 mm from the knee's axis, by a chord of 3 degrees.
  EXPECT_NEAR(rigidError(reference, aboutKnee * reference).translationMm.norm(),
              2.0 * std::hypot(95.0, 20.0) * std::sin(1.5 * kDeg), 1e-9);
  // Identity when the estimate is the reference.
  const RigidError none = rigidError(reference, reference, {target});
  EXPECT_LT(none.translationMm.norm() + none.rotationDeg.norm() + none.targetErrorsMm[0], 1e-10);
}

TEST(RigidError, MeanOfAbsoluteValuesAndRefusals) {
  RigidError a, b;
  a.translationMm = Eigen::Vector3d(1.0, -2.0, 0.5);
  b.translationMm = Eigen::Vector3d(-3.0, 2.0, 0.5);
  a.rotationDeg = Eigen::Vector3d(-1.0, 0.0, 4.0);
  b.rotationDeg = Eigen::Vector3d(1.0, 2.0, -2.0);
  a.targetErrorsMm = {1.0};
  b.targetErrorsMm = {3.0};
  const RigidError m = meanAbsoluteError({a, b});
  EXPECT_LT((m.translationMm - Eigen::Vector3d(2.0, 2.0, 0.5)).norm(), 1e-12);
  EXPECT_LT((m.rotationDeg - Eigen::Vector3d(1.0, 1.0, 3.0)).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(m.targetErrorsMm[0], 2.0);
  b.targetErrorsMm.clear();
  EXPECT_THROW(meanAbsoluteError({a, b}), std::invalid_argument);
  EXPECT_THROW(meanAbsoluteError({}), std::invalid_argument);
  Eigen::Isometry3d bad = femurToCt();
  bad.matrix()(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(rigidError(femurToCt(), bad), std::invalid_argument);
}

}  // namespace
}  // namespace echoreg::core
