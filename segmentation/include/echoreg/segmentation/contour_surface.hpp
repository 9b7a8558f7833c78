// Slice contours and bone masks, both ways: the closed sections of a surface by axis planes (to
// propose live-wire anchors on a new specimen, and to simulate a user in tests), anchors chosen
// on those sections (few, at the corners), and the solid that a stack of contours encloses
// (shape-based interpolation: the in-plane signed distance of each contour, interpolated
// linearly between contoured slices) as a mask on the CT's grid.
#pragma once

#include "echoreg/core/mesh.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"

#include <Eigen/Core>

#include <vector>

namespace echoreg::segmentation {

/// Index of the LPS axis normal to the plane (sagittal 0, coronal 1, axial 2).
int planeAxis(SlicePlane plane);

/// The closed loops where the plane {p[axis] = positionMm} cuts the closed `mesh`, each a
/// polygon (last point joins the first, not repeated), counter-clockwise in the plane's (u, v)
/// axes (the two other LPS axes in order). Loops shorter than 3 points are dropped.
std::vector<std::vector<Eigen::Vector3d>> planeSections(const core::TriangleMesh& mesh, SlicePlane plane,
                                                        double positionMm);

/// `count` slice positions evenly over the extent of the mesh along the plane's normal: the
/// centres of `count` equal bins, so the first and last lie half a bin inside the ends.
/// Throws std::invalid_argument for count < 1 or an empty mesh.
std::vector<double> evenSlicePositions(const core::TriangleMesh& mesh, SlicePlane plane, int count);

struct AnchorProposalOptions {
  double spacingMm = 12.0;      ///< about one anchor per this much contour
  int minAnchors = 4;           ///< per loop
  double minPerimeterMm = 8.0;  ///< smaller loops (the tip of a condyle) get no anchors
  /// Each anchor moves to the sharpest corner within +-this fraction of the spacing.
  double snapFraction = 0.3;
};

/// Anchors on each loop: evenly by arc length, each moved to the sharpest turn nearby.
std::vector<Eigen::Vector3d> proposeLoopAnchors(const std::vector<Eigen::Vector3d>& loop,
                                                const AnchorProposalOptions& options = {});

/// Anchor sets for `slices` planes evenly over the surface's extent: one set per loop with a
/// perimeter of at least minPerimeterMm, labelled "<plane><index>-<loop>".
std::vector<AnchorSet> proposeAnchors(const core::TriangleMesh& surface, SlicePlane plane, int slices,
                                      const AnchorProposalOptions& options = {});

struct ContourMaskOptions {
  /// Raster of the in-plane signed distance maps, mm.
  double rasterMm = 0.25;
  /// Contours whose positions differ by less than this are one slice (their union), mm.
  double sliceToleranceMm = 0.25;
};

/// The solid enclosed by `contours` (all in one plane family) on the grid of `grid` (uniform):
/// in each contoured slice the signed distance to its loops (even-odd inside); between slices
/// the linear interpolation of the two; beyond the first and last slice the end slice's
/// distance grows so that the solid closes within half the spacing to the neighbouring slice
/// (1 mm for a single slice). Throws std::invalid_argument when
/// there is no contour, the contours lie in different plane families, or the grid is empty.
VoxelMask contoursToMask(const std::vector<SliceContour>& contours, const CtImage& grid,
                         const ContourMaskOptions& options = {});

}  // namespace echoreg::segmentation
