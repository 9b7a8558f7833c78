// Live-Wire (intelligent scissors, Mortensen & Barrett 1995) on CT slices in any of the three
// planes of the CT's patient axes: a slice is resampled from the volume, the core's live-wire
// (core/livewire.hpp, plain arrays) finds the optimal path from each anchor to the next, and the
// closed contour comes back in CT patient coordinates (LPS, mm). Anchors come from a file: an
// echoreg anchors JSON or 3D Slicer .mrk.json closed curves.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/core/livewire.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace echoreg::segmentation {

/// Slice planes named from the CT's patient axes: sagittal slices are normal to x (L), coronal
/// to y (P), axial to z (S).
enum class SlicePlane { Sagittal, Coronal, Axial };

/// "sagittal", "coronal", "axial"; parseSlicePlane throws std::invalid_argument on other names.
const char* slicePlaneName(SlicePlane plane);
SlicePlane parseSlicePlane(const std::string& name);

/// The anchors of one closed contour, in order, all in one slice plane.
struct AnchorSet {
  SlicePlane plane = SlicePlane::Sagittal;
  double positionMm = 0.0;  ///< the slice's coordinate along the plane's normal axis
  std::vector<Eigen::Vector3d> anchorsLps;  ///< at least 3
  std::string label;                        ///< e.g. the curve's name, for messages
};

/// A closed contour on one slice (the last point joins the first; it is not repeated).
struct SliceContour {
  SlicePlane plane = SlicePlane::Sagittal;
  double positionMm = 0.0;
  std::vector<Eigen::Vector3d> pointsLps;
  double cost = 0.0;                       ///< total live-wire cost of the path (for diagnostics)
  std::vector<std::size_t> anchorIndices;  ///< index in pointsLps of each anchor's point
  double sampleSpacingMm = 0.0;            ///< of the resliced slice the path was found on
};

/// Reads anchors: either echoreg's JSON
///   {"plane": "sagittal", "contours": [{"label": "s12", "anchors": [[x, y, z], ...]}, ...]}
/// or a 3D Slicer .mrk.json whose ClosedCurve markups are the contours (their control points the
/// anchors, LPS). The plane of each contour is the CT axis along which its anchors agree (within
/// 0.5 mm); `plane` in the JSON, when present, must agree. Throws FileError naming the file and
/// the contour: not readable, fewer than 3 anchors, anchors not in one axis plane, no contour.
std::vector<AnchorSet> readAnchors(const std::string& path);

/// Writes anchors as a 3D Slicer .mrk.json of ClosedCurve markups (one per set), atomically.
void writeAnchors(const std::string& path, const std::vector<AnchorSet>& anchors);

struct LiveWireContourOptions {
  /// In-plane sampling of the resliced slice, mm; 0 uses the CT's smallest pixel spacing.
  double sampleSpacingMm = 0.0;
  /// Move each path point to the sub-pixel edge along the contour's normal, so the contour is not
  /// bound to the pixel grid: on the CT's trilinear profile along the normal, the crossing of the
  /// level half-way between the darkest and brightest values within +-3 samples (the surface of a
  /// partial-volume step), nearest the path point and at most 1.5 samples away.
  bool subpixelRefine = true;
  /// Extra margin around the anchors' bounding box for the resliced region, mm.
  double marginMm = 15.0;
  /// The core's cost weights and smoothing (core/livewire.hpp).
  core::LiveWireOptions liveWire;
};

/// The closed live-wire contour through `anchors` (in order) on their slice of `ct`. Throws
/// std::invalid_argument when an anchor lies outside the volume or off the set's plane.
SliceContour liveWireContour(const core::CtImage& ct, const AnchorSet& anchors,
                             const LiveWireContourOptions& options = {});

// --- Reslicing (used by liveWireContour; public for the segmentation pipeline and tests) ---

/// The CT patient axes (0 = x/L, 1 = y/P, 2 = z/S) of a plane: its normal and its in-plane u
/// (columns) and v (rows) axes. Sagittal: normal x, u = y, v = z; coronal: normal y, u = x,
/// v = z; axial: normal z, u = x, v = y.
struct SlicePlaneAxes {
  int normal = 0;
  int u = 1;
  int v = 2;
};
SlicePlaneAxes slicePlaneAxes(SlicePlane plane);

/// A square-sampled slice of the CT in one patient-axis plane: pixel (col, row) is the LPS point
/// with coordinate positionMm along the normal, originUvMm.x() + col * spacingMm along u and
/// originUvMm.y() + row * spacingMm along v.
struct CtSlice {
  SlicePlane plane = SlicePlane::Sagittal;
  double positionMm = 0.0;
  Eigen::Vector2d originUvMm = Eigen::Vector2d::Zero();
  double spacingMm = 1.0;
  int width = 0;
  int height = 0;
  std::vector<float> hu;  ///< row-major (col fastest), trilinear from the CT

  Eigen::Vector3d lps(double col, double row) const;
  /// (col, row) of an LPS point (its coordinate along the normal is ignored).
  Eigen::Vector2d pixel(const Eigen::Vector3d& lps) const;
};

/// Trilinear interpolation of the CT's Hounsfield units at an LPS point (uneven slices
/// honoured: k comes from the slice positions). Outside the volume the nearest edge voxel's value
/// (clamped indices). Throws std::invalid_argument for an empty CT.
double sampleCt(const core::CtImage& ct, const Eigen::Vector3d& lps);

/// Samples the CT on `plane` at `positionMm` over the rectangle [minUvMm, maxUvMm] (u, v in mm)
/// intersected with the box of the CT's voxel centres, `spacingMm` apart. Throws
/// std::invalid_argument for an empty CT, spacingMm <= 0, or a rectangle that misses the volume or
/// is smaller than 2 x 2 samples, or larger than 4096 x 4096.
CtSlice resliceCt(const core::CtImage& ct, SlicePlane plane, double positionMm,
                  const Eigen::Vector2d& minUvMm, const Eigen::Vector2d& maxUvMm, double spacingMm);

}  // namespace echoreg::segmentation
