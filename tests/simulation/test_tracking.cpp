#include "echoreg/simulation/tracking.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace echoreg::simulation {
namespace {

Eigen::Isometry3d facingCamera(const Eigen::Vector3d& position) {
  // Marker +z toward the camera at the origin.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d z = -position.normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  pose.linear().col(0) = x;
  pose.linear().col(1) = z.cross(x);
  pose.linear().col(2) = z;
  pose.translation() = position;
  return pose;
}

TEST(OpticalTracker, JitterAndBiasHaveTheSpecifiedSizes) {
  const OpticalTracker tracker(TrackerNoise{}, 5);
  const MarkerGeometry marker = boneMarker("Femur");
  const Eigen::Isometry3d truth = facingCamera({40.0, -30.0, 1500.0});
  core::Rng rng(1);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d meanSquare = Eigen::Vector3d::Zero();
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const Measurement m = tracker.measure(truth, marker, rng);
    const Eigen::Vector3d e = m.markerToTracker.translation() - truth.translation();
    mean += e / n;
    meanSquare += e.cwiseProduct(e) / n;
  }
  const Eigen::Vector3d sigma = (meanSquare - mean.cwiseProduct(mean)).cwiseSqrt();
  // Four fiducials: the origin's jitter is about the fiducial jitter / sqrt(4), larger along the
  // line of sight (camera z here) than across.
  EXPECT_LT(sigma.x(), 0.03);
  EXPECT_LT(sigma.y(), 0.03);
  EXPECT_GT(sigma.z(), 0.02);
  EXPECT_LT(sigma.z(), 0.08);
  EXPECT_GT(sigma.z(), sigma.x());
  // A static bias that does not average away, within the accuracy specification.
  EXPECT_GT(mean.norm(), 0.005);
  EXPECT_LT(mean.norm(), 0.75);
  // Noise-free measurements are the truth.
  const Measurement exact = tracker.measure(truth, marker, rng, false);
  EXPECT_TRUE(exact.markerToTracker.isApprox(truth, 1e-12));
}

TEST(OpticalTracker, BiasVariesOverTheVolumeAndWithTheCamera) {
  const MarkerGeometry marker = boneMarker("Tibia");
  auto meanError = [&](const OpticalTracker& tracker, const Eigen::Vector3d& where) {
    core::Rng rng(2);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i = 0; i < 400; ++i) {
      mean += (tracker.measure(facingCamera(where), marker, rng).markerToTracker.translation() -
               where) /
              400.0;
    }
    return mean;
  };
  const OpticalTracker a(TrackerNoise{}, 1), b(TrackerNoise{}, 2);
  const Eigen::Vector3d here(0, 0, 1400), there(250, 150, 1900);
  EXPECT_GT((meanError(a, here) - meanError(a, there)).norm(), 0.02);
  EXPECT_GT((meanError(a, here) - meanError(b, here)).norm(), 0.02);
}

TEST(OpticalTracker, MarkersOutOfViewAreInvalid) {
  const OpticalTracker tracker;
  const MarkerGeometry marker = stylusMarker();
  core::Rng rng(3);
  // The stylus' spheres face its -x axis: turned toward the camera it is seen, away it is not.
  Eigen::Isometry3d seen = Eigen::Isometry3d::Identity();
  seen.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  seen.translation() = Eigen::Vector3d(0, 0, 1500);
  EXPECT_NEAR((seen.linear() * marker.faceNormal).dot(Eigen::Vector3d(0, 0, -1)), 1.0, 1e-12);
  EXPECT_TRUE(tracker.visible(seen, marker));
  Eigen::Isometry3d away = seen;
  away.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_FALSE(tracker.visible(away, marker));
  EXPECT_FALSE(tracker.measure(away, marker, rng).valid);
  Eigen::Isometry3d far = seen;
  far.translation() = Eigen::Vector3d(0, 0, 3000);
  EXPECT_FALSE(tracker.visible(far, marker));
}

TEST(SmoothNoise, HasTheAskedRmsAndBand) {
  core::Rng rng(4);
  const SmoothNoise noise(rng, 0.3, 6.0, 12.0, 4);
  double sum = 0.0, sumSquare = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double v = noise.at(i * 0.001).x();
    sum += v;
    sumSquare += v * v;
  }
  const double rms = std::sqrt(sumSquare / n - (sum / n) * (sum / n));
  EXPECT_NEAR(rms, 0.3, 0.12);
  // Band limited: 10 ms apart, values are correlated but not equal.
  EXPECT_NE(noise.at(0.0).x(), noise.at(0.01).x());
}

}  // namespace
}  // namespace echoreg::simulation
