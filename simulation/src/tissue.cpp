#include "echoreg/simulation/tissue.hpp"

#include <array>
#include <cstddef>

namespace echoreg::simulation {

namespace {

// name, density, speed, attenuation a, power n, HU, HU spread, backscatter.
// Sources in docs/simulation.md (Duck 1990; Mast 2000; Goss et al. 1978/1980; ICRU 61; Schneider
// et al. 2000; Marczak 1997; Sawbones and Aquaflex data sheets).
constexpr std::array<TissueProperties, static_cast<std::size_t>(Tissue::Count)> kTable{{
    {"air", 1.2, 343.0, 0.0, 2.0, -1000.0, 5.0, 0.0},
    {"water", 998.0, 1482.0, 0.0022, 2.0, 0.0, 3.0, 0.0},
    {"gel pad", 1020.0, 1540.0, 0.25, 1.0, 10.0, 5.0, 0.05},
    {"skin", 1090.0, 1615.0, 2.0, 1.0, 45.0, 15.0, 1.6},
    {"fat", 950.0, 1478.0, 0.6, 1.0, -100.0, 15.0, 0.5},
    {"muscle", 1050.0, 1547.0, 1.1, 1.0, 45.0, 12.0, 1.0},
    {"cortical bone", 1908.0, 3500.0, 15.0, 1.0, 1500.0, 150.0, 0.0},
    {"cancellous bone", 1178.0, 1800.0, 10.0, 1.0, 300.0, 80.0, 0.0},
    {"yellow marrow", 980.0, 1435.0, 0.5, 1.0, -60.0, 20.0, 0.0},
    {"sawbones shell", 1640.0, 2900.0, 5.0, 1.0, 900.0, 60.0, 0.0},
    {"sawbones foam", 320.0, 1900.0, 8.0, 1.0, -650.0, 40.0, 0.0},
    {"steel", 7850.0, 5900.0, 0.0, 1.0, 3071.0, 0.0, 0.0},
}};

}  // namespace

const TissueProperties& properties(Tissue tissue) {
  return kTable[static_cast<std::size_t>(tissue)];
}

double waterSpeedOfSoundMps(double t) {
  // Marczak (1997), fifth-order polynomial in degrees Celsius.
  return 1402.385 + 5.038813 * t - 5.799136e-2 * t * t + 3.287156e-4 * t * t * t -
         1.398845e-6 * t * t * t * t + 2.787860e-9 * t * t * t * t * t;
}

double reflectionCoefficient(Tissue from, Tissue to) {
  const double z1 = properties(from).impedanceMRayl();
  const double z2 = properties(to).impedanceMRayl();
  return (z2 - z1) / (z2 + z1);
}

}  // namespace echoreg::simulation
