// Sample index to depth along the beam: d = (i / fs + delay) * c / 2 (Eq. 3.2 and 4.1).
#pragma once

#include <tuple>

namespace echoreg {

/// Converts between A-line sample indices and depths in the Beam frame (mm along +z).
struct DepthConversion {
  double samplingFrequencyHz = 50e6;  ///< digitiser rate (the dissertation's AlazarTech: 50 MHz)
  double delayS = 0.0;                ///< acquisition delay between the pulse and sample 0
  double speedOfSoundMps = 1540.0;    ///< assumed speed of sound (tissue 1540, water ~1480)

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

}  // namespace echoreg
