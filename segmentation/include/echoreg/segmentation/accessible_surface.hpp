// The part of a bone surface that a registration may use: the regions the user marks (points
// with radii, e.g. from a 3D Slicer .mrk.json: the epicondyles, the anterior tibia), and/or the
// triangles a tracked probe can reach from given directions (nothing of the bone in front of
// them, and facing the probe within an angle). The registration then matches points only to this
// part, as the dissertation restricted the third femur to the epicondyles (section 6.3.3).
#pragma once

#include "echoreg/core/mesh.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace echoreg::segmentation {

/// A ball of the surface to keep.
struct SurfaceRegion {
  std::string label;
  Eigen::Vector3d centreLps = Eigen::Vector3d::Zero();
  double radiusMm = 20.0;
};

struct AccessibleSurfaceOptions {
  /// Keep triangles whose centroid lies in one of these balls (empty: no restriction).
  std::vector<SurfaceRegion> regions;
  /// Directions from the bone toward where the probe stands (unit after normalisation; empty: no
  /// restriction). A triangle is reachable along v when its outward normal is within
  /// maxAngleDeg of v and the ray from outside travelling along -v meets it first (nothing of
  /// the surface lies in front of it along +v).
  std::vector<Eigen::Vector3d> viewDirections;
  double maxAngleDeg = 60.0;
};

struct AccessibleSurface {
  core::TriangleMesh mesh;         ///< the kept triangles (an open surface), vertices compacted
  std::vector<int> keptTriangles;  ///< their indices in the input mesh
  double areaMm2 = 0.0;
  double fractionOfArea = 0.0;  ///< kept area / whole area
};

/// The kept part of `surface` (both restrictions apply when both are given). Throws
/// std::invalid_argument for an empty surface, a zero direction, a non-positive radius or an
/// angle outside (0, 90], or when nothing is kept.
AccessibleSurface accessibleSurface(const core::TriangleMesh& surface,
                                    const AccessibleSurfaceOptions& options);

/// Regions from a 3D Slicer markups file: every control point of its Fiducial markups, with
/// `radiusMm` each. Throws FileError naming the file (see core::readMarkupPoints).
std::vector<SurfaceRegion> readSurfaceRegions(const std::string& path, double radiusMm);

}  // namespace echoreg::segmentation
