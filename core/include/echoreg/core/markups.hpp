// 3D Slicer markups files (.mrk.json): named points (Fiducial), open and closed curves. Read in
// LPS whatever the file's coordinate system (RAS files are converted), written in LPS. Used for
// CT landmarks, live-wire anchors (closed curves) and registration targets.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace echoreg::core {

struct MarkupPoint {
  std::string label;
  Eigen::Vector3d positionLps = Eigen::Vector3d::Zero();  ///< mm
};

struct Markup {
  std::string type = "Fiducial";  ///< "Fiducial", "Curve", "ClosedCurve", ...
  std::string name;               ///< the markup's "name" when the file gives one
  std::vector<MarkupPoint> points;
};

/// Every markup in the file, in order. Throws FileError naming `path` when it cannot be read, is
/// not JSON, has no "markups" array, a control point without a 3-number position, a
/// non-finite coordinate, or a coordinate system other than LPS/RAS. Control points whose
/// positionStatus is "undefined" are skipped.
std::vector<Markup> readMarkups(const std::string& path);

/// The points of all Fiducial markups of the file, in order (a landmark list). Throws FileError
/// when the file holds no point at all.
std::vector<MarkupPoint> readMarkupPoints(const std::string& path);

/// Writes `markups` (LPS, mm) atomically; Slicer 5 opens the file. Throws FileError.
void writeMarkups(const std::string& path, const std::vector<Markup>& markups);

/// Convenience: one Fiducial markup of named points.
void writeMarkupPoints(const std::string& path, const std::vector<MarkupPoint>& points);

}  // namespace echoreg::core
