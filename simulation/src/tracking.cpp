#include "echoreg/simulation/tracking.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>

namespace echoreg::simulation {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

MarkerGeometry probeMarker() {
  return {"Probe", {{0, 0, 0}, {0, 30, 50}, {0, -25, 95}, {0, 20, 135}}, -Eigen::Vector3d::UnitX()};
}

MarkerGeometry stylusMarker() {
  return {
      "Stylus", {{0, 0, 0}, {0, -30, 45}, {0, 25, 80}, {0, -20, 110}}, -Eigen::Vector3d::UnitX()};
}

MarkerGeometry boneMarker(const std::string& name) {
  return {name, {{0, 0, 0}, {-40, 28, 0}, {20, 60, 0}, {45, -5, 0}}, Eigen::Vector3d::UnitZ()};
}

bool OpticalTracker::visible(const Eigen::Isometry3d& markerToTracker,
                             const MarkerGeometry& marker) const {
  const Eigen::Vector3d position = markerToTracker.translation();
  const double distance = position.norm();
  if (distance < noise_.minDistanceMm || distance > noise_.maxDistanceMm)
    return false;
  const Eigen::Vector3d normal = markerToTracker.linear() * marker.faceNormal;
  const Eigen::Vector3d towardCamera = -position / distance;
  const double angle = std::acos(std::clamp(normal.dot(towardCamera), -1.0, 1.0));
  return angle <= noise_.maxViewAngleDeg * kPi / 180.0;
}

OpticalTracker::OpticalTracker(TrackerNoise noise, std::uint64_t seed) : noise_(noise) {
  // The bias: a sum of plane waves with random directions and phases, scaled to the RMS asked
  // (a sinusoid of amplitude A has variance A^2 / 2).
  core::Rng rng = core::Rng::derive(seed, "camera-bias");
  constexpr int kWaves = 6;
  const double perWave = std::sqrt(2.0 / kWaves);
  for (int i = 0; i < kWaves; ++i) {
    Wave wave;
    Eigen::Vector3d direction(rng.normal(), rng.normal(), rng.normal());
    direction.normalize();
    const double wavelength = noise_.biasWavelengthMm * rng.uniform(0.6, 1.6);
    wave.wavevector = direction * (2.0 * kPi / wavelength);
    wave.amplitude =
        Eigen::Vector3d(noise_.biasLateralMm, noise_.biasLateralMm, noise_.biasDepthMm) * perWave *
        rng.uniform(0.7, 1.3);
    wave.phase = rng.uniform(0.0, 2.0 * kPi);
    waves_.push_back(wave);
  }
}

Eigen::Vector3d OpticalTracker::bias(const Eigen::Vector3d& p) const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < waves_.size(); ++i) {
    // Each axis its own phase offset, so the three components are independent.
    for (int axis = 0; axis < 3; ++axis) {
      sum[axis] += waves_[i].amplitude[axis] *
                   std::sin(waves_[i].wavevector.dot(p) + waves_[i].phase + 2.1 * axis);
    }
  }
  return sum;
}

Measurement OpticalTracker::measure(const Eigen::Isometry3d& truth, const MarkerGeometry& marker,
                                    core::Rng& rng, bool noisy) const {
  Measurement result;
  result.valid = visible(truth, marker);
  // Draw the noise whatever the visibility, so that one frame's visibility does not shift the
  // random stream of the next.
  const std::size_t count = marker.fiducialsMm.size();
  Eigen::Matrix3Xd model(3, static_cast<Eigen::Index>(count));
  Eigen::Matrix3Xd seen(3, static_cast<Eigen::Index>(count));
  bool occluded = false;
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Index c = static_cast<Eigen::Index>(i);
    model.col(c) = marker.fiducialsMm[i];
    Eigen::Vector3d p = truth * marker.fiducialsMm[i];
    // The camera's depth axis is along the line of sight to the fiducial; across it is lateral.
    const Eigen::Vector3d sight = p.normalized();
    const Eigen::Vector3d across1 = Eigen::Vector3d::UnitY().cross(sight).normalized();
    const Eigen::Vector3d across2 = sight.cross(across1);
    const Eigen::Vector3d b = bias(p);
    const double a1 = b.x() + rng.normal() * noise_.jitterLateralMm;
    const double a2 = b.y() + rng.normal() * noise_.jitterLateralMm;
    const double d = b.z() + rng.normal() * noise_.jitterDepthMm;
    if (noisy)
      p += a1 * across1 + a2 * across2 + d * sight;
    seen.col(c) = p;
    if (rng.chance(noise_.dropoutProbability))
      occluded = true;
  }
  if (noisy && occluded)
    result.valid = false;
  if (!noisy) {
    result.markerToTracker = truth;
    return result;
  }
  const Eigen::Matrix4d fit = Eigen::umeyama(model, seen, false);
  result.markerToTracker.matrix() = fit;
  return result;
}

SmoothNoise::SmoothNoise(core::Rng& rng, double rms, double minFrequencyHz, double maxFrequencyHz,
                         int components) {
  // Each component contributes rms^2 / components per axis (a sinusoid of amplitude A has
  // variance A^2 / 2).
  const double amplitude = rms * std::sqrt(2.0 / std::max(1, components));
  for (int i = 0; i < components; ++i) {
    Wave wave;
    wave.frequencyHz = rng.uniform(minFrequencyHz, maxFrequencyHz);
    for (int axis = 0; axis < 3; ++axis) {
      wave.amplitude[axis] = amplitude * rng.uniform(0.7, 1.3);
      wave.phase[axis] = rng.uniform(0.0, 2.0 * kPi);
    }
    waves_.push_back(wave);
  }
}

Eigen::Vector3d SmoothNoise::at(double timeS) const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Wave& wave : waves_) {
    for (int axis = 0; axis < 3; ++axis) {
      sum[axis] +=
          wave.amplitude[axis] * std::sin(2.0 * kPi * wave.frequencyHz * timeS + wave.phase[axis]);
    }
  }
  return sum;
}

Eigen::Matrix3d tiltAbout(const Eigen::Vector3d& axis, double angleRad, double azimuthRad) {
  const Eigen::Vector3d u = axis.unitOrthogonal();
  const Eigen::Vector3d v = axis.cross(u);
  const Eigen::Vector3d tiltAxis = std::cos(azimuthRad) * u + std::sin(azimuthRad) * v;
  return Eigen::AngleAxisd(angleRad, tiltAxis).toRotationMatrix();
}

Eigen::Matrix3d frameAlong(const Eigen::Vector3d& direction, double rollRad) {
  const Eigen::Vector3d z = direction.normalized();
  const Eigen::Vector3d x0 = z.unitOrthogonal();
  const Eigen::Vector3d y0 = z.cross(x0);
  const Eigen::Vector3d x = std::cos(rollRad) * x0 + std::sin(rollRad) * y0;
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return r;
}

}  // namespace echoreg::simulation
