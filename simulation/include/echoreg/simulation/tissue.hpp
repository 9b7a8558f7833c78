// Materials of the simulated specimens with the physical values the CT and the A-line models use.
// Every value and its source is in docs/simulation.md; change both together.
#pragma once

#include <cstdint>
#include <string_view>

namespace echoreg::simulation {

enum class Tissue : std::uint8_t {
  Air,
  Water,   ///< bath or standoff (glove finger); speed from the temperature
  GelPad,  ///< Aquaflex-like hydrogel standoff
  Skin,
  Fat,
  Muscle,
  CorticalBone,
  CancellousBone,
  Marrow,         ///< yellow (fatty) marrow of the shaft
  SawbonesShell,  ///< composite "cortical" shell of a sawbones phantom
  SawbonesFoam,   ///< rigid polyurethane foam interior of a sawbones phantom
  Steel,          ///< the calibration sphere
  Count
};

struct TissueProperties {
  std::string_view name;
  double densityKgM3;
  double speedMps;               ///< longitudinal speed of sound at body temperature
  double attenuationDbPerCmMHz;  ///< amplitude attenuation coefficient a in a * f^n
  double attenuationPower;       ///< n (1 for soft tissue, 2 for water)
  double hounsfield;             ///< mean CT number at 120 kVp
  double hounsfieldSigma;        ///< spread within the tissue (texture), before scanner noise
  double backscatter;            ///< relative speckle strength (muscle = 1)

  /// Characteristic acoustic impedance Z = rho * c in MRayl.
  double impedanceMRayl() const { return densityKgM3 * speedMps * 1e-6; }
};

const TissueProperties& properties(Tissue tissue);

/// Speed of sound in pure water at `celsius` (Marczak 1997, 0-95 degrees C), m/s.
double waterSpeedOfSoundMps(double celsius);

/// Pressure reflection coefficient (Z2 - Z1) / (Z2 + Z1) at normal incidence.
double reflectionCoefficient(Tissue from, Tissue to);

}  // namespace echoreg::simulation
