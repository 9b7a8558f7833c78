// Accuracy of a segmented surface against a reference surface: the symmetric surface distance
// (points sampled uniformly by area on each surface, exact distances to the other's triangles)
// and the Dice overlap of the two solids (measured along a fine grid of rays, so the solids are
// voxelised exactly along one axis), both optionally restricted to a slab of CT z (the part of
// the bone that was scanned).
#pragma once

#include "echoreg/core/mesh.hpp"

#include <cstdint>
#include <limits>

namespace echoreg::segmentation {

struct SurfaceComparisonOptions {
  /// Only what lies in this slab of LPS z counts (points sampled on either surface, and the
  /// solids' overlap), mm.
  double zMinMm = -std::numeric_limits<double>::infinity();
  double zMaxMm = std::numeric_limits<double>::infinity();
  int samplesPerSurface = 20000;  ///< area-weighted points on each surface (inside the slab)
  double diceStepMm = 0.25;       ///< spacing of the rays (along z) that voxelise the solids
  std::uint64_t seed = 1;         ///< core::Rng seed of the sampling
};

struct SurfaceComparison {
  double meanMm = 0.0;  ///< mean symmetric surface distance (both directions pooled)
  double p95Mm = 0.0;   ///< 95th percentile of the pooled distances
  double maxMm = 0.0;   ///< Hausdorff distance of the samples
  double meanEstimateToTruthMm = 0.0;
  double meanTruthToEstimateMm = 0.0;
  double dice = 0.0;               ///< 2 |A n B| / (|A| + |B|) inside the slab
  double volumeEstimateMm3 = 0.0;  ///< inside the slab
  double volumeTruthMm3 = 0.0;
};

/// Compares `estimate` with `truth` (closed meshes, same frame). Throws std::invalid_argument when
/// a mesh is empty or has no surface inside the slab.
SurfaceComparison compareSurfaces(const core::TriangleMesh& estimate,
                                  const core::TriangleMesh& truth,
                                  const SurfaceComparisonOptions& options = {});

}  // namespace echoreg::segmentation
