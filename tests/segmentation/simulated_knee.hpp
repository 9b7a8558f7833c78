// A simulated knee CT in memory for the segmentation tests: the procedural knee of the simulator
// (seed 3, 1.2 mm bone meshes as in a small study) in a cadaver leg, imaged with the small
// protocol's pixels and knee group only (144 x 144 pixels of 0.8 mm centred on the knee, 1 mm
// slices over +-32 mm). Built once per test program and shared; the CT (seconds to synthesise)
// is cached in the tests' temporary folder under a checksum of the bones.
#pragma once

#include "echoreg/segmentation/ct_image.hpp"
#include "echoreg/simulation/anatomy.hpp"
#include "echoreg/simulation/ct.hpp"

namespace echoreg::test {

struct SimulatedKnee {
  simulation::Knee knee;
  segmentation::CtImage ct;                   ///< knee group only (uniform)
  double kneeZMinMm = 0.0, kneeZMaxMm = 0.0;  ///< the first and last slice centres
};

/// The simulated CT as a CtImage (axial, identity direction, groups from the slice spacing).
segmentation::CtImage toCtImage(const simulation::CtVolume& volume);

/// A knee other than the shared one: a narrowed joint, a patella on the femur, faint bone.
struct KneeVariant {
  double tibiofemoralGapMm = -1.0;  ///< simulation::KneeOptions (negative: healthy, ~3 mm)
  double patellofemoralGapMm = 4.0;
  double cancellousHu = 300.0;  ///< the simulator's tissue table's
  double halfRangeMm = 32.0;    ///< slices over the knee centre +- this
  double sliceMm = 1.0;         ///< slice spacing (and thickness): 3 mm, or the hip's 5 mm
};

/// The shared knee (built on first use).
const SimulatedKnee& simulatedKnee();
/// A variant (built on first use, kept for the program's life).
const SimulatedKnee& simulatedKnee(const KneeVariant& variant);

}  // namespace echoreg::test
