// An optical tracker's measurements of rigid markers, and the hand's motion, for simulated
// captures. Noise is made where a real camera makes it: on each retro-reflective fiducial, more
// along the camera's viewing axis than across it (Wiles et al. 2004, NDI Polaris: 0.25 mm RMS over
// the volume), and the marker's pose is fitted to the noisy fiducials (Umeyama 1991), so the
// pose error grows with the lever arm exactly as it does on a real probe or stylus tip.
#pragma once

#include "echoreg/core/random.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::simulation {

/// A passive marker: its fiducials (sphere centres) in the marker's own frame, mm, and the side
/// they are seen from (`faceNormal`, unit, marker frame).
struct MarkerGeometry {
  std::string name;
  std::vector<Eigen::Vector3d> fiducialsMm;
  Eigen::Vector3d faceNormal = Eigen::Vector3d::UnitZ();
};

/// Four-sphere markers with NDI-like spacings (50-135 mm between spheres). The probe's and the
/// stylus' spheres lie in their y-z plane (the long axis is z, toward the transducer or the tip)
/// and face -x; the bone markers' lie in their x-y plane and face +z.
MarkerGeometry probeMarker();
MarkerGeometry stylusMarker();
MarkerGeometry boneMarker(const std::string& name);

/// Optical tracker errors per fiducial, split as cameras show them: a frame-to-frame jitter
/// (precision) and a bias that varies smoothly over the measurement volume (the calibration error
/// of the camera: accuracy), both larger along the line of sight than across it. Totals match
/// NDI's Polaris specification of 0.25 mm RMS over the volume.
struct TrackerNoise {
  double jitterLateralMm = 0.03;    ///< across the camera's view, per fiducial per frame (1 sigma)
  double jitterDepthMm = 0.08;      ///< along the line of sight
  double biasLateralMm = 0.09;      ///< RMS of the smooth volumetric bias, across
  double biasDepthMm = 0.23;        ///< along the line of sight
  double biasWavelengthMm = 400.0;  ///< spatial scale of the bias
  double maxViewAngleDeg = 75.0;    ///< marker normal versus the line of sight: INVALID beyond
  double minDistanceMm = 950.0;     ///< Polaris Vicra/Spectra pyramid volume, near end
  double maxDistanceMm = 2400.0;    ///< far end
  double dropoutProbability = 0.002;  ///< a sphere occluded by a hand for a frame
};

/// A measured pose: the transform and whether the camera could see the marker.
struct Measurement {
  Eigen::Isometry3d markerToTracker = Eigen::Isometry3d::Identity();
  bool valid = true;
};

/// The camera. Its frame is the `Tracker` frame: origin at the camera, +z its viewing axis.
class OpticalTracker {
 public:
  /// `seed` draws this camera's volumetric bias.
  explicit OpticalTracker(TrackerNoise noise = {}, std::uint64_t seed = 1);

  /// What the camera reports for a marker at `trueMarkerToTracker`. With `noisy` false, the true
  /// pose (still INVALID when out of view), for the noise-free truth captures.
  Measurement measure(const Eigen::Isometry3d& trueMarkerToTracker, const MarkerGeometry& marker,
                      core::Rng& rng, bool noisy = true) const;

  /// Whether a marker at this pose is visible (angle and distance limits).
  bool visible(const Eigen::Isometry3d& markerToTracker, const MarkerGeometry& marker) const;

  const TrackerNoise& noise() const { return noise_; }

 private:
  Eigen::Vector3d bias(const Eigen::Vector3d& pointMm) const;  // in (across1, across2, depth)

  TrackerNoise noise_;
  struct Wave {
    Eigen::Vector3d wavevector;
    Eigen::Vector3d amplitude;
    double phase;
  };
  std::vector<Wave> waves_;
};

/// Smooth random motion: a sum of a few sinusoids per axis with random phases (seeded), band
/// limited to `maxFrequencyHz`, with the given RMS. Used for hand tremor (8-12 Hz, ~0.1 mm),
/// slow drift of a held probe and the sway of a cadaver leg.
class SmoothNoise {
 public:
  SmoothNoise() = default;
  SmoothNoise(core::Rng& rng, double rms, double minFrequencyHz, double maxFrequencyHz,
              int components = 4);
  Eigen::Vector3d at(double timeS) const;

 private:
  struct Wave {
    Eigen::Vector3d amplitude;
    Eigen::Vector3d phase;
    double frequencyHz;
  };
  std::vector<Wave> waves_;
};

/// A rotation of `angleRad` about a random axis perpendicular to `axis` (unit): a tilt.
Eigen::Matrix3d tiltAbout(const Eigen::Vector3d& axis, double angleRad, double azimuthRad);

/// A rotation taking +z to `direction` (unit), with the given roll about it.
Eigen::Matrix3d frameAlong(const Eigen::Vector3d& direction, double rollRad);

}  // namespace echoreg::simulation
