// Sample index to depth along the beam: d = (i / fs + delay) * c / 2 (Eq. 3.2 and 4.1).
#pragma once

#include <tuple>

namespace echoreg::core {

// The speeds of sound echoreg assumes, m/s: every default in the code is one of these, and the one
// resolver of the detection's parameters (cli/src/detection_params.hpp: preset, then the capture's
// header, then --params, then the flags) is where a capture's speed is decided.
/// Soft tissue (the dissertation's 1540 m/s for human tissue): DepthConversion's default and so
/// every detection preset's but calibration's.
inline constexpr double kTissueSpeedOfSoundMps = 1540.0;
/// Water at room temperature: the calibration preset's (a sphere in a bath, section 4.2.2).
inline constexpr double kWaterSpeedOfSoundMps = 1480.0;
/// What a capture's header or a command's --speed-of-sound flag may say (water and soft tissue lie
/// well inside; 0 or a speed in mm/s is refused where it is given, not deep in the detector).
inline constexpr double kMinSpeedOfSoundMps = 1000.0;
inline constexpr double kMaxSpeedOfSoundMps = 2000.0;

/// Converts between A-line sample indices and depths in the Beam frame (mm along +z).
struct DepthConversion {
  double samplingFrequencyHz = 50e6;  ///< digitiser rate (the dissertation's AlazarTech: 50 MHz)
  double delayS = 0.0;                ///< acquisition delay between the pulse and sample 0
  double speedOfSoundMps = kTissueSpeedOfSoundMps;  ///< assumed speed of sound

  /// Depth in mm of (possibly fractional) sample index `sampleIndex`.
  double depthMm(double sampleIndex) const {
    return (sampleIndex / samplingFrequencyHz + delayS) * speedOfSoundMps * 1000.0 / 2.0;
  }
  /// Fractional sample index of depth `depthMm` (the inverse of depthMm).
  double sampleIndex(double depthMm) const {
    return (depthMm * 2.0 / (speedOfSoundMps * 1000.0) - delayS) * samplingFrequencyHz;
  }
  /// Millimetres per sample.
  double mmPerSample() const { return speedOfSoundMps * 1000.0 / (2.0 * samplingFrequencyHz); }
};

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const DepthConversion& a, const DepthConversion& b) {
  const auto& [samplingA, delayA, speedA] = a;
  const auto& [samplingB, delayB, speedB] = b;
  return std::tie(samplingA, delayA, speedA) == std::tie(samplingB, delayB, speedB);
}
inline bool operator!=(const DepthConversion& a, const DepthConversion& b) {
  return !(a == b);
}

}  // namespace echoreg::core
