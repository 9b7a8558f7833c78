// How a solid known by its sections closes beyond its last one: the one rule of the two
// shape-based interpolations, the --anchors contours' filling (contoursToMask) and the z ends'
// shares on thick slices (zEndShares), so they cannot disagree. Each section is an in-plane
// signed distance d(u, v) (mm, negative inside) at a position along the stacking axis;
// between two sections it is interpolated linearly. Beyond the last section the solid closes
// as a cone over the section: at `beyondMm` past it
//
//   d(u, v, beyond) = d(u, v) + max(1, D / c) * beyond,
//
// D the section's deepest inside distance (mm) and c the closing distance (mm): the deepest
// point reaches the surface c past the section (a thin section closes at 45 degrees, sooner).
// c is where the solid ends, `reachSlices` of the spacing beyond the last slice that holds it:
// half (0.5, the default) when the slices are points that see the solid or not (contours drawn
// at slice positions: the unknown end lies between that slice and the next, half way on
// average); zEndShares' region holds a slab when the slab has bone enough to show, so its
// solid may reach a little into the next slab (EndShareOptions::closingReachSlices).
#pragma once

#include <algorithm>

namespace echoreg::segmentation {

/// The closing distance c (mm) of a solid whose last section lies `sectionInsideMm` inside
/// the last slice that holds it (0: on that slice; zEndShares places its sections inside
/// their slices), with slices `spacingMm` apart: the solid ends `reachSlices` of the spacing
/// beyond that slice.
inline double sectionClosingMm(double spacingMm, double sectionInsideMm = 0.0,
                               double reachSlices = 0.5) {
  return reachSlices * spacingMm + sectionInsideMm;
}

/// The signed distance (mm, negative inside) `beyondMm` (>= 0) past the last section, at a
/// point whose distance on the section is `sectionDistanceMm`; `depthMm` is the section's
/// deepest inside distance (>= 0) and `closingMm` (> 0) sectionClosingMm's.
inline double closedSectionDistanceMm(double sectionDistanceMm, double depthMm, double closingMm,
                                      double beyondMm) {
  return sectionDistanceMm + std::max(1.0, depthMm / closingMm) * beyondMm;
}

}  // namespace echoreg::segmentation
