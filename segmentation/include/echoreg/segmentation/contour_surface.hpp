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

#include <limits>
#include <vector>

namespace echoreg::segmentation {

/// Index of the LPS axis normal to the plane (sagittal 0, coronal 1, axial 2).
int planeAxis(SlicePlane plane);

/// The closed loops where the plane {p[axis] = positionMm} cuts the closed `mesh`, each a
/// polygon (last point joins the first, not repeated), counter-clockwise in the plane's (u, v)
/// axes (the two other LPS axes in order). Loops shorter than 3 points are dropped.
std::vector<std::vector<Eigen::Vector3d>> planeSections(const core::TriangleMesh& mesh,
                                                        SlicePlane plane, double positionMm);

/// `count` slice positions evenly over the extent of the mesh along the plane's normal (of its
/// vertices within zMinMm <= z <= zMaxMm: the scanned part): the centres of `count` equal bins,
/// so the first and last lie half a bin inside the ends. Throws std::invalid_argument for
/// count < 1 or a mesh with no vertex in the slab.
std::vector<double> evenSlicePositions(const core::TriangleMesh& mesh, SlicePlane plane, int count,
                                       double zMinMm = -std::numeric_limits<double>::infinity(),
                                       double zMaxMm = std::numeric_limits<double>::infinity());

struct AnchorProposalOptions {
  double spacingMm = 12.0;      ///< about one anchor per this much contour
  int minAnchors = 4;           ///< per loop
  double minPerimeterMm = 8.0;  ///< smaller loops (the tip of a condyle) get no anchors
  /// Each anchor moves to the sharpest corner within +-this fraction of the spacing.
  double snapFraction = 0.3;
  /// Turns sharper than this over +-2 mm of contour are always anchors (a corner, e.g. where the
  /// bone meets the end of the scan), degrees.
  double cornerDeg = 50.0;
  /// The slab of LPS z that was scanned (the CT group): loops are clipped to it, so anchors
  /// stay inside the volume and the cut along its end runs straight between two corners.
  double zMinMm = -std::numeric_limits<double>::infinity();
  double zMaxMm = std::numeric_limits<double>::infinity();
};

/// The polygon `loop` clipped to zMin <= z <= zMax (Sutherland-Hodgman against both planes).
std::vector<Eigen::Vector3d> clipLoopZ(const std::vector<Eigen::Vector3d>& loop, double zMinMm,
                                       double zMaxMm);

/// Live-wire between two anchors that both lie on the same end of the scanned slab (within tolMm
/// of zMinMm or zMaxMm) has no edge to follow: replaces that stretch of `contour` (the path of
/// `anchors`, located by contour.anchorIndices) by the straight cut between the two anchors.
/// Contours without anchor indices, or with a count that differs from the anchors', are left
/// alone. Returns the number of stretches replaced.
int straightenAtScanEnds(SliceContour& contour, const AnchorSet& anchors, double zMinMm,
                         double zMaxMm, double tolMm);

/// Anchors on each loop: every corner sharper than cornerDeg, then evenly by arc length between
/// them (no gap longer than spacingMm), each moved to the sharpest turn nearby.
std::vector<Eigen::Vector3d> proposeLoopAnchors(const std::vector<Eigen::Vector3d>& loop,
                                                const AnchorProposalOptions& options = {});

/// Anchor sets for `slices` planes evenly over the surface's extent: one set per loop with a
/// perimeter of at least minPerimeterMm, labelled "<plane><index>-<loop>".
std::vector<AnchorSet> proposeAnchors(const core::TriangleMesh& surface, SlicePlane plane,
                                      int slices, const AnchorProposalOptions& options = {});

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
VoxelMask contoursToMask(const std::vector<SliceContour>& contours, const core::CtImage& grid,
                         const ContourMaskOptions& options = {});

struct SliceCorrectionResult {
  VoxelMask region;
  std::size_t added = 0, removed = 0;  ///< voxels, against the region given
  int slices = 0;                      ///< voxel layers the contours and absent areas lie on
};

/// A few slices corrected by the user (live-wire contours on the slices `--anchors-where
/// uncertain` proposed) put into an automatic `region` (uniform grid, axis-aligned direction):
/// on the voxel layer of each contour (its points' mean along the plane's normal, rounded) the
/// region becomes the contours' even-odd fill; on the layers within `falloffMm` of it the
/// in-plane signed distances of the region and of the contour are blended, the contour's weight
/// falling linearly from 1 toward 0 (each layer takes its nearest corrected layer), so the
/// correction fades into the automatic model instead of leaving a step. `absent` are areas
/// where the bone is not (a curve drawn around what the automatic model wrongly holds, or
/// around the whole section of a slice where the bone should be absent): on their layer the
/// region (or the contours' fill there) loses what they enclose, faded the same way; a layer
/// left empty counts as one layer's spacing outside everywhere, so the bone tapers toward it
/// instead of vanishing on the layers around it. Throws std::invalid_argument for no
/// contour and no absent area, contours of several plane families, or a contour outside the
/// grid.
SliceCorrectionResult correctOnSlices(const VoxelMask& region,
                                      const std::vector<SliceContour>& contours,
                                      double falloffMm = 3.0,
                                      const std::vector<SliceContour>& absent = {});

}  // namespace echoreg::segmentation
