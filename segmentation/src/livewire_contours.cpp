#include "echoreg/segmentation/livewire_contours.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/markups.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

namespace echoreg::segmentation {

namespace {

constexpr double kPlaneToleranceMm = 0.5;
const char* const kAxisNames[3] = {"x", "y", "z"};

std::string mm(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", v);
  return buffer;
}

std::string pointText(const Eigen::Vector3d& p) {
  return "(" + mm(p.x()) + ", " + mm(p.y()) + ", " + mm(p.z()) + ")";
}

void checkCt(const core::CtImage& ct) {
  if (ct.dimensions[0] < 1 || ct.dimensions[1] < 1 || ct.dimensions[2] < 1 ||
      ct.hu.size() != ct.voxelCount() ||
      ct.slicePositionsMm.size() != static_cast<std::size_t>(ct.dimensions[2]))
    throw std::invalid_argument("live-wire contour: the CT image is empty or inconsistent");
}

// The plane whose normal axis the anchors agree on (all within kPlaneToleranceMm of their mean),
// as the reader's problem text or "" with the plane and position set.
std::string inferPlane(const std::vector<Eigen::Vector3d>& anchors, SlicePlane& plane,
                       double& positionMm) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& a : anchors)
    mean += a;
  mean /= static_cast<double>(anchors.size());
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();
  for (const auto& a : anchors)
    spread = spread.cwiseMax((a - mean).cwiseAbs());
  int agreeing = 0;
  int axis = -1;
  for (int i = 0; i < 3; ++i) {
    if (spread[i] <= kPlaneToleranceMm) {
      ++agreeing;
      axis = i;
    }
  }
  if (agreeing == 0)
    return "anchors are not in one sagittal, coronal or axial plane (they spread +-" +
           mm(spread.x()) + ", +-" + mm(spread.y()) + ", +-" + mm(spread.z()) +
           " mm along x, y, z; at most +-0.5 mm along the slice normal)";
  if (agreeing > 1)
    return "anchors lie on a line";
  plane = axis == 0 ? SlicePlane::Sagittal : axis == 1 ? SlicePlane::Coronal : SlicePlane::Axial;
  positionMm = mean[axis];
  return "";
}

void finishSet(const std::string& path, AnchorSet& set, const std::string& planeInFile) {
  const std::string where = "contour \"" + set.label + "\"";
  if (set.anchorsLps.size() < 3)
    throw core::FileError(path, where + ": " + std::to_string(set.anchorsLps.size()) +
                                    " anchors (at least 3 needed)");
  const std::string problem = inferPlane(set.anchorsLps, set.plane, set.positionMm);
  if (!problem.empty())
    throw core::FileError(path, where + ": " + problem);
  if (!planeInFile.empty() && planeInFile != slicePlaneName(set.plane))
    throw core::FileError(path, where + ": anchors lie in a " + slicePlaneName(set.plane) +
                                    " plane, the file says \"" + planeInFile + "\"");
}

std::vector<AnchorSet> readEchoregAnchors(const std::string& path, const nlohmann::json& doc) {
  std::string plane;
  if (doc.contains("plane")) {
    if (!doc["plane"].is_string())
      throw core::FileError(path, "\"plane\" is not a string");
    plane = doc["plane"].get<std::string>();
    try {
      parseSlicePlane(plane);
    } catch (const std::invalid_argument&) {
      throw core::FileError(path, "plane \"" + plane + "\" (expected sagittal, coronal or axial)");
    }
  }
  const auto& contours = doc["contours"];
  if (!contours.is_array())
    throw core::FileError(path, "\"contours\" is not an array");
  std::vector<AnchorSet> sets;
  for (std::size_t c = 0; c < contours.size(); ++c) {
    const auto& contour = contours[c];
    AnchorSet set;
    set.label = "contour " + std::to_string(c + 1);
    if (!contour.is_object())
      throw core::FileError(path, set.label + " is not an object");
    if (contour.contains("label")) {
      if (!contour["label"].is_string())
        throw core::FileError(path, set.label + ": label is not a string");
      set.label = contour["label"].get<std::string>();
    }
    const std::string where = "contour \"" + set.label + "\"";
    if (!contour.contains("anchors") || !contour["anchors"].is_array())
      throw core::FileError(path, where + ": no \"anchors\" array");
    for (std::size_t a = 0; a < contour["anchors"].size(); ++a) {
      const auto& anchor = contour["anchors"][a];
      const std::string which = where + ", anchor " + std::to_string(a + 1);
      if (!anchor.is_array() || anchor.size() != 3)
        throw core::FileError(path, which + ": not 3 numbers [x, y, z]");
      Eigen::Vector3d p;
      for (std::size_t i = 0; i < 3; ++i) {
        if (!anchor[i].is_number())
          throw core::FileError(path, which + ": not 3 numbers [x, y, z]");
        p[static_cast<Eigen::Index>(i)] = anchor[i].get<double>();
      }
      if (!p.allFinite())
        throw core::FileError(path, which + ": not finite");
      set.anchorsLps.push_back(p);
    }
    finishSet(path, set, plane);
    sets.push_back(std::move(set));
  }
  return sets;
}

std::vector<AnchorSet> readSlicerAnchors(const std::string& path) {
  std::vector<AnchorSet> sets;
  int curve = 0;
  for (const core::Markup& markup : core::readMarkups(path)) {
    if (markup.type != "ClosedCurve")
      continue;
    ++curve;
    AnchorSet set;
    set.label = markup.name.empty() ? "closed curve " + std::to_string(curve) : markup.name;
    for (const auto& p : markup.points)
      set.anchorsLps.push_back(p.positionLps);
    finishSet(path, set, "");
    sets.push_back(std::move(set));
  }
  return sets;
}

}  // namespace

const char* slicePlaneName(SlicePlane plane) {
  switch (plane) {
    case SlicePlane::Sagittal:
      return "sagittal";
    case SlicePlane::Coronal:
      return "coronal";
    case SlicePlane::Axial:
      return "axial";
  }
  return "sagittal";
}

SlicePlane parseSlicePlane(const std::string& name) {
  if (name == "sagittal")
    return SlicePlane::Sagittal;
  if (name == "coronal")
    return SlicePlane::Coronal;
  if (name == "axial")
    return SlicePlane::Axial;
  throw std::invalid_argument("slice plane \"" + name + "\" (expected sagittal, coronal or axial)");
}

SlicePlaneAxes slicePlaneAxes(SlicePlane plane) {
  switch (plane) {
    case SlicePlane::Sagittal:
      return {0, 1, 2};
    case SlicePlane::Coronal:
      return {1, 0, 2};
    case SlicePlane::Axial:
      return {2, 0, 1};
  }
  return {0, 1, 2};
}

Eigen::Vector3d CtSlice::lps(double col, double row) const {
  const SlicePlaneAxes axes = slicePlaneAxes(plane);
  Eigen::Vector3d p;
  p[axes.normal] = positionMm;
  p[axes.u] = originUvMm.x() + col * spacingMm;
  p[axes.v] = originUvMm.y() + row * spacingMm;
  return p;
}

Eigen::Vector2d CtSlice::pixel(const Eigen::Vector3d& point) const {
  const SlicePlaneAxes axes = slicePlaneAxes(plane);
  return {(point[axes.u] - originUvMm.x()) / spacingMm,
          (point[axes.v] - originUvMm.y()) / spacingMm};
}

double sampleCt(const core::CtImage& ct, const Eigen::Vector3d& lps) {
  checkCt(ct);
  const Eigen::Vector3d ijk = ct.lpsToVoxel(lps);
  int i0[3];
  int i1[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    const double last = ct.dimensions[static_cast<std::size_t>(a)] - 1;
    const double v = std::clamp(ijk[a], 0.0, last);
    i0[a] = static_cast<int>(std::floor(v));
    i1[a] = std::min(i0[a] + 1, static_cast<int>(last));
    f[a] = v - i0[a];
  }
  double result = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const int ci = corner & 1 ? i1[0] : i0[0];
    const int cj = corner & 2 ? i1[1] : i0[1];
    const int ck = corner & 4 ? i1[2] : i0[2];
    const double w = (corner & 1 ? f[0] : 1.0 - f[0]) * (corner & 2 ? f[1] : 1.0 - f[1]) *
                     (corner & 4 ? f[2] : 1.0 - f[2]);
    if (w != 0.0)
      result += w * ct.at(ci, cj, ck);
  }
  return result;
}

CtSlice resliceCt(const core::CtImage& ct, SlicePlane plane, double positionMm,
                  const Eigen::Vector2d& minUvMm, const Eigen::Vector2d& maxUvMm,
                  double spacingMm) {
  checkCt(ct);
  if (!std::isfinite(spacingMm) || spacingMm <= 0.0)
    throw std::invalid_argument("reslice: the sample spacing must be positive");
  const SlicePlaneAxes axes = slicePlaneAxes(plane);
  // The box of the CT's voxel centres in LPS.
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d ijk(corner & 1 ? ct.dimensions[0] - 1 : 0,
                              corner & 2 ? ct.dimensions[1] - 1 : 0,
                              corner & 4 ? ct.dimensions[2] - 1 : 0);
    const Eigen::Vector3d p = ct.voxelToLps(ijk);
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  const Eigen::Vector2d boxLow(low[axes.u], low[axes.v]);
  const Eigen::Vector2d boxHigh(high[axes.u], high[axes.v]);
  const Eigen::Vector2d from = minUvMm.cwiseMax(boxLow);
  const Eigen::Vector2d to = maxUvMm.cwiseMin(boxHigh);
  if (!(from.allFinite() && to.allFinite()) || positionMm < low[axes.normal] ||
      positionMm > high[axes.normal] || (to - from).minCoeff() < spacingMm)
    throw std::invalid_argument(std::string("reslice: the ") + slicePlaneName(plane) +
                                " rectangle at " + kAxisNames[axes.normal] + " = " +
                                mm(positionMm) +
                                " mm misses the CT volume or is smaller than 2 x 2 samples");
  CtSlice slice;
  slice.plane = plane;
  slice.positionMm = positionMm;
  slice.originUvMm = from;
  slice.spacingMm = spacingMm;
  const Eigen::Vector2d extent = (to - from) / spacingMm;
  if (extent.maxCoeff() > 4095.0)
    throw std::invalid_argument("reslice: more than 4096 samples along a side; raise the spacing");
  slice.width = static_cast<int>(std::floor(extent.x() + 1e-9)) + 1;
  slice.height = static_cast<int>(std::floor(extent.y() + 1e-9)) + 1;
  slice.hu.resize(static_cast<std::size_t>(slice.width) * static_cast<std::size_t>(slice.height));
  std::size_t index = 0;
  for (int row = 0; row < slice.height; ++row)
    for (int col = 0; col < slice.width; ++col)
      slice.hu[index++] = static_cast<float>(sampleCt(ct, slice.lps(col, row)));
  return slice;
}

std::vector<AnchorSet> readAnchors(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw core::FileError(path, "cannot open the anchors file");
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw core::FileError(path, std::string("not a JSON anchors file: ") + e.what());
  }
  std::vector<AnchorSet> sets;
  if (doc.is_object() && doc.contains("markups")) {
    sets = readSlicerAnchors(path);
    if (sets.empty())
      throw core::FileError(path, "no contour (no ClosedCurve markup)");
  } else if (doc.is_object() && doc.contains("contours")) {
    sets = readEchoregAnchors(path, doc);
    if (sets.empty())
      throw core::FileError(path, "no contour (\"contours\" is empty)");
  } else {
    throw core::FileError(path,
                          "neither echoreg anchors (\"contours\") nor a 3D Slicer .mrk.json "
                          "(\"markups\")");
  }
  return sets;
}

void writeAnchors(const std::string& path, const std::vector<AnchorSet>& anchors) {
  std::vector<core::Markup> markups;
  for (std::size_t s = 0; s < anchors.size(); ++s) {
    const AnchorSet& set = anchors[s];
    const std::string name = set.label.empty() ? "contour " + std::to_string(s + 1) : set.label;
    if (set.anchorsLps.size() < 3)
      throw core::FileError(path, "contour \"" + name +
                                      "\": " + std::to_string(set.anchorsLps.size()) +
                                      " anchors (at least 3 needed); nothing written");
    core::Markup markup;
    markup.type = "ClosedCurve";
    markup.name = name;
    for (std::size_t i = 0; i < set.anchorsLps.size(); ++i)
      markup.points.push_back({name + "-" + std::to_string(i + 1), set.anchorsLps[i]});
    markups.push_back(std::move(markup));
  }
  if (markups.empty())
    throw core::FileError(path, "no contour to write; nothing written");
  core::writeMarkups(path, markups);
}

SliceContour liveWireContour(const core::CtImage& ct, const AnchorSet& anchors,
                             const LiveWireContourOptions& options) {
  checkCt(ct);
  const std::string name = "contour \"" + anchors.label + "\"";
  if (anchors.anchorsLps.size() < 3)
    throw std::invalid_argument(name + ": " + std::to_string(anchors.anchorsLps.size()) +
                                " anchors (at least 3 needed)");
  if (!std::isfinite(options.sampleSpacingMm) || options.sampleSpacingMm < 0.0 ||
      !std::isfinite(options.marginMm) || options.marginMm < 0.0)
    throw std::invalid_argument(name + ": sample spacing and margin must be finite and >= 0");
  const SlicePlaneAxes axes = slicePlaneAxes(anchors.plane);
  Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d high = -low;
  for (std::size_t i = 0; i < anchors.anchorsLps.size(); ++i) {
    const Eigen::Vector3d& a = anchors.anchorsLps[i];
    const std::string which = name + ", anchor " + std::to_string(i + 1) + " " + pointText(a);
    if (!a.allFinite())
      throw std::invalid_argument(which + " is not finite");
    if (std::abs(a[axes.normal] - anchors.positionMm) > kPlaneToleranceMm)
      throw std::invalid_argument(which + " is " +
                                  mm(std::abs(a[axes.normal] - anchors.positionMm)) +
                                  " mm off the " + slicePlaneName(anchors.plane) + " slice at " +
                                  kAxisNames[axes.normal] + " = " + mm(anchors.positionMm) + " mm");
    const Eigen::Vector3d ijk = ct.lpsToVoxel(a);
    for (int k = 0; k < 3; ++k) {
      if (ijk[k] < -0.5 || ijk[k] > ct.dimensions[static_cast<std::size_t>(k)] - 0.5)
        throw std::invalid_argument(which + " lies outside the CT volume");
    }
    low = low.cwiseMin(Eigen::Vector2d(a[axes.u], a[axes.v]));
    high = high.cwiseMax(Eigen::Vector2d(a[axes.u], a[axes.v]));
  }
  const double spacing = options.sampleSpacingMm > 0.0
                             ? options.sampleSpacingMm
                             : std::min(ct.pixelSpacingMm.x(), ct.pixelSpacingMm.y());
  const Eigen::Vector2d margin = Eigen::Vector2d::Constant(options.marginMm + 2.0 * spacing);
  const CtSlice slice =
      resliceCt(ct, anchors.plane, anchors.positionMm, low - margin, high + margin, spacing);

  core::LiveWire wire(slice.hu, slice.width, slice.height, Eigen::Vector2d(spacing, spacing),
                      options.liveWire);
  std::vector<Eigen::Vector2i> pixels;
  for (const auto& a : anchors.anchorsLps) {
    const Eigen::Vector2d p = slice.pixel(a);
    pixels.emplace_back(std::clamp(static_cast<int>(std::lround(p.x())), 0, slice.width - 1),
                        std::clamp(static_cast<int>(std::lround(p.y())), 0, slice.height - 1));
  }
  core::ClosedLiveWire closed;
  try {
    closed = core::closedLiveWire(wire, pixels);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(name + ": " + e.what());
  }

  // Sub-pixel refinement along the path's normal (from its neighbours two points away), on the
  // CT itself (trilinear): the crossing of the level half-way between the darkest and brightest
  // value within +-3 samples, nearest the path point and at most 1.5 samples from it. A line that
  // crosses the edge obliquely still finds a point of the same iso-line, so the coarse normal of
  // a pixel path does no harm.
  const std::size_t n = closed.points.size();
  std::vector<Eigen::Vector2d> refined(n);
  constexpr int kHalf = 12;          // samples each side
  constexpr double kStep = 0.25;     // of the slice's sample spacing
  constexpr double kMaxShift = 1.5;  // samples
  std::vector<double> profile(2 * kHalf + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = closed.points[i].cast<double>();
    refined[i] = p;
    if (!options.subpixelRefine || n < 5)
      continue;
    const Eigen::Vector2d tangent =
        (closed.points[(i + 2) % n] - closed.points[(i + n - 2) % n]).cast<double>();
    if (tangent.norm() == 0.0)
      continue;
    const Eigen::Vector2d normal = Eigen::Vector2d(-tangent.y(), tangent.x()).normalized();
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (int k = -kHalf; k <= kHalf; ++k) {
      const Eigen::Vector2d q = p + (k * kStep) * normal;
      const double v = sampleCt(ct, slice.lps(q.x(), q.y()));
      profile[static_cast<std::size_t>(k + kHalf)] = v;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (!(hi - lo > 1e-6))
      continue;
    const double level = 0.5 * (lo + hi);
    double best = std::numeric_limits<double>::infinity();
    for (int k = -kHalf; k < kHalf; ++k) {
      const double a = profile[static_cast<std::size_t>(k + kHalf)] - level;
      const double b = profile[static_cast<std::size_t>(k + kHalf + 1)] - level;
      if ((a < 0.0) == (b < 0.0))
        continue;
      const double t = (k + a / (a - b)) * kStep;
      if (std::abs(t) < std::abs(best))
        best = t;
    }
    if (std::abs(best) <= kMaxShift)
      refined[i] = p + best * normal;
  }

  SliceContour contour;
  contour.plane = anchors.plane;
  contour.positionMm = anchors.positionMm;
  contour.cost = closed.cost;
  contour.anchorIndices = closed.anchorIndices;
  contour.sampleSpacingMm = spacing;
  contour.pointsLps.reserve(n);
  for (const auto& p : refined)
    contour.pointsLps.push_back(slice.lps(p.x(), p.y()));
  return contour;
}

}  // namespace echoreg::segmentation
