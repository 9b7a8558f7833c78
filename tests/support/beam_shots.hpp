// Simulated calibration shots for the beam calibration's tests and benchmark: a sphere of known
// centre and radius, a probe aiming at it from a cone of directions (head-on and off its centre)
// at a range of depths, and the depths the transducer would measure with an assumed speed of
// sound, with optional tracking and depth noise. Written from the geometry (a beam line meeting a
// sphere), independently of core/src/beam_calibration.cpp.
#pragma once

#include "echoreg/core/beam_calibration.hpp"
#include "echoreg/core/random.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace echoreg::test {

/// What to simulate. Tracker coordinates are the camera's, mm.
struct BeamShotsSpec {
  std::size_t shots = 100;
  /// The true BeamToProbe: the beam leaves its origin along its +z axis.
  Eigen::Isometry3d beamToProbe = Eigen::Isometry3d::Identity();
  Eigen::Vector3d sphereCentreTracker = Eigen::Vector3d(120.0, -40.0, -1500.0);
  double sphereRadiusMm = 25.4;
  /// The probe sits on this side of the sphere (unit vector from the centre), within the cone.
  Eigen::Vector3d coneAxis = Eigen::Vector3d(0.0, 0.0, 1.0);
  double coneHalfAngleDeg = 50.0;
  /// The beam passes the centre at up to this fraction of the radius (0: every shot head-on).
  double maxOffCentre = 0.5;
  double minDepthMm = 20.0;  ///< true distance from the beam origin to the surface
  double maxDepthMm = 60.0;
  double trueSpeedOfSoundMps = 1450.0;
  double assumedSpeedOfSoundMps = 1450.0;
  /// Tracking noise of the probe's pose (per axis, applied in the probe's frame).
  double trackingRotationSigmaDeg = 0.0;
  double trackingTranslationSigmaMm = 0.0;
  double depthSigmaMm = 0.0;  ///< noise of the measured depth
  std::uint64_t seed = 1;
};

/// A unit vector perpendicular to `u`.
inline Eigen::Vector3d anyPerpendicular(const Eigen::Vector3d& u) {
  const Eigen::Vector3d helper =
      std::abs(u.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return u.cross(helper).normalized();
}

/// The shots, each from its own random stream (seed, "beam-shot", index).
inline std::vector<core::BeamShot> makeBeamShots(const BeamShotsSpec& spec) {
  constexpr double kPi = 3.14159265358979323846;
  const double radians = kPi / 180.0;
  const Eigen::Vector3d axis = spec.coneAxis.normalized();
  const Eigen::Vector3d a1 = anyPerpendicular(axis);
  const Eigen::Vector3d a2 = axis.cross(a1);
  const double r = spec.sphereRadiusMm;
  std::vector<core::BeamShot> shots;
  shots.reserve(spec.shots);
  for (std::size_t i = 0; i < spec.shots; ++i) {
    core::Rng rng = core::Rng::derive(spec.seed, "beam-shot", i);
    // Probe side u, uniform over the cone's cap.
    const double cosTheta = rng.uniform(std::cos(spec.coneHalfAngleDeg * radians), 1.0);
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    const double phi = rng.uniform(0.0, 2.0 * kPi);
    const Eigen::Vector3d u =
        (cosTheta * axis + sinTheta * (std::cos(phi) * a1 + std::sin(phi) * a2)).normalized();
    const Eigen::Vector3d e1 = anyPerpendicular(u);
    const Eigen::Vector3d e2 = u.cross(e1);
    // The beam line runs along -u, passing the centre at distance rho (uniform over a disc).
    const double rho = spec.maxOffCentre * r * std::sqrt(rng.uniform());
    const double psi = rng.uniform(0.0, 2.0 * kPi);
    const Eigen::Vector3d lateral = rho * (std::cos(psi) * e1 + std::sin(psi) * e2);
    const Eigen::Vector3d hit =
        spec.sphereCentreTracker + lateral + u * std::sqrt(r * r - rho * rho);
    const double depthMm = rng.uniform(spec.minDepthMm, spec.maxDepthMm);
    // BeamToTracker: origin depthMm before the hit, z along -u, a random roll about the beam.
    const double roll = rng.uniform(0.0, 2.0 * kPi);
    Eigen::Isometry3d beamToTracker = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d z = -u;
    const Eigen::Vector3d x = std::cos(roll) * e1 + std::sin(roll) * e2;
    beamToTracker.linear().col(0) = x;
    beamToTracker.linear().col(1) = z.cross(x);
    beamToTracker.linear().col(2) = z;
    beamToTracker.translation() = hit + u * depthMm;
    core::BeamShot shot;
    shot.probeToTracker = beamToTracker * spec.beamToProbe.inverse();
    if (spec.trackingRotationSigmaDeg > 0.0 || spec.trackingTranslationSigmaMm > 0.0) {
      const Eigen::Vector3d w(rng.normal(), rng.normal(), rng.normal());
      const Eigen::Vector3d dt(rng.normal(), rng.normal(), rng.normal());
      Eigen::Isometry3d error = Eigen::Isometry3d::Identity();
      const double angle = spec.trackingRotationSigmaDeg * radians * w.norm();
      if (angle > 0.0)
        error.linear() = Eigen::AngleAxisd(angle, w.normalized()).toRotationMatrix();
      error.translation() = spec.trackingTranslationSigmaMm * dt;
      shot.probeToTracker = shot.probeToTracker * error;
    }
    // Time of flight at the true speed, converted to distance with the assumed one.
    shot.depthMm = depthMm * spec.assumedSpeedOfSoundMps / spec.trueSpeedOfSoundMps +
                   spec.depthSigmaMm * rng.normal();
    shots.push_back(shot);
  }
  return shots;
}

/// The calibration options that match a spec (sphere, assumed speed), with `initial` as guess.
inline core::BeamCalibrationOptions beamOptionsFor(const BeamShotsSpec& spec,
                                                   const Eigen::Isometry3d& initial) {
  core::BeamCalibrationOptions options;
  options.sphereCentreTracker = spec.sphereCentreTracker;
  options.sphereRadiusMm = spec.sphereRadiusMm;
  options.assumedSpeedOfSoundMps = spec.assumedSpeedOfSoundMps;
  options.initialBeamToProbe = initial;
  return options;
}

}  // namespace echoreg::test
