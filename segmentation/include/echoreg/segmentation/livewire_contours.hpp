// Live-Wire (intelligent scissors, Mortensen & Barrett 1995) on CT slices in any of the three
// planes of the CT's patient axes: a slice is resampled from the volume, the core's live-wire
// (core/livewire.hpp, plain arrays) finds the optimal path from each anchor to the next, and the
// closed contour comes back in CT patient coordinates (LPS, mm). Anchors come from a file: an
// echoreg anchors JSON or 3D Slicer .mrk.json closed curves.
#pragma once

#include "echoreg/segmentation/ct_image.hpp"

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
  double positionMm = 0.0;               ///< the slice's coordinate along the plane's normal axis
  std::vector<Eigen::Vector3d> anchorsLps;  ///< at least 3
  std::string label;                     ///< e.g. the curve's name, for messages
};

/// A closed contour on one slice (the last point joins the first; it is not repeated).
struct SliceContour {
  SlicePlane plane = SlicePlane::Sagittal;
  double positionMm = 0.0;
  std::vector<Eigen::Vector3d> pointsLps;
  double cost = 0.0;  ///< total live-wire cost of the path (for diagnostics)
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
  /// Move each path point to the sub-pixel edge along the contour's normal (the maximum of the
  /// gradient magnitude within +-1 sample), so the contour is not bound to the pixel grid.
  bool subpixelRefine = true;
  /// Extra margin around the anchors' bounding box for the resliced region, mm.
  double marginMm = 15.0;
};

/// The closed live-wire contour through `anchors` (in order) on their slice of `ct`. Throws
/// std::invalid_argument when an anchor lies outside the volume or off the set's plane.
SliceContour liveWireContour(const CtImage& ct, const AnchorSet& anchors,
                             const LiveWireContourOptions& options = {});

}  // namespace echoreg::segmentation
