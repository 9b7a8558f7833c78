// A simulated knee CT in memory for the segmentation tests: the procedural knee of the simulator
// (seed 3, 1.2 mm bone meshes as in a small study) in a cadaver leg, imaged with the small
// protocol's pixels and knee group only (144 x 144 pixels of 0.8 mm centred on the knee, 1 mm
// slices over +-32 mm). Built once per test program and shared; the CT (seconds to synthesise)
// is cached in the tests' temporary folder under a checksum of the bones.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/simulation/anatomy.hpp"
#include "echoreg/simulation/ct.hpp"

#include <Eigen/Core>

#include <optional>
#include <string>

namespace echoreg::test {

struct SimulatedKnee {
  simulation::Knee knee;
  core::CtImage ct;                           ///< knee group only (uniform)
  double kneeZMinMm = 0.0, kneeZMaxMm = 0.0;  ///< the first and last slice centres
};

/// A knee other than the shared one: a narrowed joint, a patella on the femur, faint bone,
/// osteophytes, thick slices.
struct KneeVariant {
  double tibiofemoralGapMm = -1.0;  ///< simulation::KneeOptions (negative: healthy, ~3 mm)
  double patellofemoralGapMm = 4.0;
  double cancellousHu = 300.0;  ///< the simulator's tissue table's
  double halfRangeMm = 32.0;    ///< slices over the knee centre +- this
  double sliceMm = 1.0;         ///< slice spacing (and thickness): 3 mm, or the hip's 5 mm
  double osteophyteMm = 0.0;    ///< simulation::KneeOptions (marginal osteophytes; 0: none)
  /// The simulator's seed (bones, soft tissue and CT noise): 3 is the shared knee's; others are
  /// knees not used to choose a method.
  int seed = 3;
  /// A femur surface to use instead of the simulator's (simulation::KneeOptions::meshFiles):
  /// e.g. ../shared/data/meshes/femur.stl, a real femur's shape; empty: the simulator's.
  std::string femurMesh;
  /// Pixels per row and column (0.8 mm): 144 holds the simulator's knee; a larger femur pushes the
  /// patella out of that field of view.
  int columns = 144;
};

/// The shared knee (built on first use).
const SimulatedKnee& simulatedKnee();
/// A variant (built on first use, kept for the program's life).
const SimulatedKnee& simulatedKnee(const KneeVariant& variant);

/// The inside point of `bone` at height z nearest the centroid of its points 3 mm or more deep;
/// none when the section holds no such point.
std::optional<Eigen::Vector3d> insidePoint(const simulation::Bone& bone, double z);

/// A seed for `id` on a section at least 6 mm inside the scan and the bone, away from the joints
/// (femur and patella from the top down, tibia and fibula from the bottom up): the point 3 mm or
/// more deep nearest the centroid of such points; none when no section has one.
std::optional<Eigen::Vector3d> seedPoint(const SimulatedKnee& sim, simulation::BoneId id);

}  // namespace echoreg::test
