#include "echoreg/simulation/tissue.hpp"

#include <gtest/gtest.h>

namespace echoreg::simulation {
namespace {

TEST(Tissue, WaterSpeedFollowsMarczak) {
  // Reference values for pure water (Del Grosso & Mader 1972; Bilaniuk & Wong 1993): 20 C 1482.3,
  // 37 C 1524.2 m/s. Marczak's fit agrees within 0.05 %.
  EXPECT_NEAR(waterSpeedOfSoundMps(20.0), 1482.3, 0.0005 * 1482.3);
  EXPECT_NEAR(waterSpeedOfSoundMps(37.0), 1524.2, 0.0005 * 1524.2);
  EXPECT_GT(waterSpeedOfSoundMps(30.0), waterSpeedOfSoundMps(20.0));
}

TEST(Tissue, SoftTissueBoneInterfaceReflectsAboutHalf) {
  // Muscle 1.62 MRayl, cortical bone 6.7 MRayl: R = (6.7 - 1.62) / (6.7 + 1.62) ~ 0.61.
  EXPECT_NEAR(reflectionCoefficient(Tissue::Muscle, Tissue::CorticalBone), 0.61, 0.03);
  // Fat to muscle is weak (a fascia-sized echo): about 0.07.
  EXPECT_NEAR(reflectionCoefficient(Tissue::Fat, Tissue::Muscle), 0.07, 0.02);
  // Water to air reflects everything with inverted phase.
  EXPECT_LT(reflectionCoefficient(Tissue::Water, Tissue::Air), -0.999);
}

}  // namespace
}  // namespace echoreg::simulation
