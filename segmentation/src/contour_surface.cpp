#include "echoreg/segmentation/contour_surface.hpp"

#include "echoreg/segmentation/section_closing.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

namespace echoreg::segmentation {

namespace {

std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

// The two in-plane LPS axes of a plane whose normal is `axis`.
std::pair<int, int> inPlaneAxes(int axis) {
  if (axis == 0)
    return {1, 2};
  if (axis == 1)
    return {0, 2};
  return {0, 1};
}

double signedArea2d(const std::vector<Eigen::Vector3d>& loop, int u, int v) {
  double a = 0.0;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const Eigen::Vector3d& p = loop[i];
    const Eigen::Vector3d& q = loop[(i + 1) % loop.size()];
    a += p[u] * q[v] - q[u] * p[v];
  }
  return 0.5 * a;
}

// 1D squared distance transform (Felzenszwalb & Huttenlocher) of f with sample step `step`.
void edt1d(std::vector<double>& f, double step) {
  const std::size_t n = f.size();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> d(n, inf), z(n + 1, 0.0);
  std::vector<std::size_t> v(n, 0);
  long k = -1;
  for (std::size_t q = 0; q < n; ++q) {
    if (!std::isfinite(f[q]))
      continue;
    const double qq = static_cast<double>(q) * step;
    double s = 0.0;
    while (k >= 0) {
      const double pp = static_cast<double>(v[static_cast<std::size_t>(k)]) * step;
      s = ((f[q] + qq * qq) - (f[v[static_cast<std::size_t>(k)]] + pp * pp)) / (2.0 * (qq - pp));
      if (s <= z[static_cast<std::size_t>(k)]) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    v[static_cast<std::size_t>(k)] = q;
    z[static_cast<std::size_t>(k)] = k == 0 ? -inf : s;
    z[static_cast<std::size_t>(k) + 1] = inf;
  }
  if (k < 0)
    return;
  std::size_t j = 0;
  for (std::size_t q = 0; q < n; ++q) {
    const double qq = static_cast<double>(q) * step;
    while (z[j + 1] < qq)
      ++j;
    const double pp = static_cast<double>(v[j]) * step;
    d[q] = (qq - pp) * (qq - pp) + f[v[j]];
  }
  f = d;
}

// A signed distance map of one slice's loops on a raster (negative inside).
struct SliceDistance {
  double positionMm = 0.0;
  double u0 = 0.0, v0 = 0.0, step = 0.25;
  int nu = 0, nv = 0;
  std::vector<float> d;

  double sample(double u, double v) const {
    const double fu = (u - u0) / step, fv = (v - v0) / step;
    if (fu < 0.0 || fv < 0.0 || fu > nu - 1 || fv > nv - 1) {
      // Outside the raster (which has a margin around every loop): far outside.
      const double du = std::max({u0 - u, u - (u0 + (nu - 1) * step), 0.0});
      const double dv = std::max({v0 - v, v - (v0 + (nv - 1) * step), 0.0});
      return std::hypot(du, dv) + 1.0;
    }
    const int a = std::min(static_cast<int>(fu), nu - 2),
              b = std::min(static_cast<int>(fv), nv - 2);
    const double tu = fu - a, tv = fv - b;
    auto at = [&](int i, int j) { return static_cast<double>(d[sz(j) * sz(nu) + sz(i)]); };
    return (1 - tu) * (1 - tv) * at(a, b) + tu * (1 - tv) * at(a + 1, b) +
           (1 - tu) * tv * at(a, b + 1) + tu * tv * at(a + 1, b + 1);
  }
};

SliceDistance sliceDistance(const std::vector<const SliceContour*>& loops, int u, int v,
                            double lo_u, double lo_v, double hi_u, double hi_v, double step) {
  SliceDistance s;
  s.step = step;
  s.u0 = lo_u;
  s.v0 = lo_v;
  s.nu = static_cast<int>(std::ceil((hi_u - lo_u) / step)) + 1;
  s.nv = static_cast<int>(std::ceil((hi_v - lo_v) / step)) + 1;
  const std::size_t n = sz(s.nu) * sz(s.nv);
  std::vector<std::uint8_t> inside(n, 0);
  // Even-odd scanline fill at raster centres.
  std::vector<double> crossings;
  for (int j = 0; j < s.nv; ++j) {
    const double y = s.v0 + j * step;
    crossings.clear();
    for (const SliceContour* c : loops) {
      const auto& pts = c->pointsLps;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        const Eigen::Vector3d& p = pts[i];
        const Eigen::Vector3d& q = pts[(i + 1) % pts.size()];
        if ((p[v] <= y) == (q[v] <= y))
          continue;
        const double t = (y - p[v]) / (q[v] - p[v]);
        crossings.push_back(p[u] + t * (q[u] - p[u]));
      }
    }
    std::sort(crossings.begin(), crossings.end());
    for (std::size_t c = 0; c + 1 < crossings.size(); c += 2) {
      const int i0 = std::max(0, static_cast<int>(std::ceil((crossings[c] - s.u0) / step)));
      const int i1 =
          std::min(s.nu - 1, static_cast<int>(std::floor((crossings[c + 1] - s.u0) / step)));
      for (int i = i0; i <= i1; ++i)
        inside[sz(j) * sz(s.nu) + sz(i)] = 1;
    }
  }
  // Distances to the nearest raster point of the other kind, then signed (half a step off the
  // boundary on each side).
  auto distanceTo = [&](bool toInside) {
    std::vector<double> f(n);
    for (std::size_t i = 0; i < n; ++i)
      f[i] = (inside[i] != 0) == toInside ? 0.0 : std::numeric_limits<double>::infinity();
    std::vector<double> line(sz(s.nu));
    for (int j = 0; j < s.nv; ++j) {
      for (int i = 0; i < s.nu; ++i)
        line[sz(i)] = f[sz(j) * sz(s.nu) + sz(i)];
      edt1d(line, step);
      for (int i = 0; i < s.nu; ++i)
        f[sz(j) * sz(s.nu) + sz(i)] = line[sz(i)];
    }
    line.resize(sz(s.nv));
    for (int i = 0; i < s.nu; ++i) {
      for (int j = 0; j < s.nv; ++j)
        line[sz(j)] = f[sz(j) * sz(s.nu) + sz(i)];
      edt1d(line, step);
      for (int j = 0; j < s.nv; ++j)
        f[sz(j) * sz(s.nu) + sz(i)] = line[sz(j)];
    }
    return f;
  };
  const auto toIn = distanceTo(true);
  const auto toOut = distanceTo(false);
  s.d.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double dist =
        inside[i] ? -(std::sqrt(toOut[i]) - 0.5 * step) : std::sqrt(toIn[i]) - 0.5 * step;
    s.d[i] = static_cast<float>(std::isfinite(dist) ? dist : 1e6);
  }
  return s;
}

}  // namespace

int planeAxis(SlicePlane plane) {
  switch (plane) {
    case SlicePlane::Sagittal:
      return 0;
    case SlicePlane::Coronal:
      return 1;
    case SlicePlane::Axial:
      return 2;
  }
  return 0;
}

std::vector<std::vector<Eigen::Vector3d>> planeSections(const core::TriangleMesh& mesh,
                                                        SlicePlane plane, double positionMm) {
  const int axis = planeAxis(plane);
  const auto [u, v] = inPlaneAxes(axis);
  // A vertex exactly on the plane counts as above it, so every crossing is on an edge.
  auto side = [&](int vertex) { return mesh.vertices[sz(vertex)][axis] >= positionMm; };
  std::map<std::pair<int, int>, int> pointOfEdge;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 2>> neighbours;
  auto edgePoint = [&](int a, int b) {
    const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
    const auto it = pointOfEdge.find(key);
    if (it != pointOfEdge.end())
      return it->second;
    const Eigen::Vector3d& p = mesh.vertices[sz(key.first)];
    const Eigen::Vector3d& q = mesh.vertices[sz(key.second)];
    const double t = (positionMm - p[axis]) / (q[axis] - p[axis]);
    Eigen::Vector3d x = p + t * (q - p);
    x[axis] = positionMm;
    const int id = static_cast<int>(points.size());
    points.push_back(x);
    neighbours.push_back({-1, -1});
    pointOfEdge.emplace(key, id);
    return id;
  };
  auto link = [&](int a, int b) {
    for (int n : {0, 1}) {
      if (neighbours[sz(a)][sz(n)] < 0) {
        neighbours[sz(a)][sz(n)] = b;
        break;
      }
    }
    for (int n : {0, 1}) {
      if (neighbours[sz(b)][sz(n)] < 0) {
        neighbours[sz(b)][sz(n)] = a;
        break;
      }
    }
  };
  for (const auto& t : mesh.triangles) {
    std::vector<int> crossing;
    for (int e = 0; e < 3; ++e) {
      const int a = t[sz(e)], b = t[sz((e + 1) % 3)];
      if (side(a) != side(b))
        crossing.push_back(edgePoint(a, b));
    }
    if (crossing.size() == 2)
      link(crossing[0], crossing[1]);
  }
  std::vector<std::vector<Eigen::Vector3d>> loops;
  std::vector<std::uint8_t> used(points.size(), 0);
  for (std::size_t start = 0; start < points.size(); ++start) {
    if (used[start])
      continue;
    std::vector<Eigen::Vector3d> loop;
    int previous = -1;
    int current = static_cast<int>(start);
    while (current >= 0 && !used[sz(current)]) {
      used[sz(current)] = 1;
      loop.push_back(points[sz(current)]);
      const auto& nb = neighbours[sz(current)];
      const int next = nb[0] != previous && nb[0] >= 0 && !used[sz(nb[0])] ? nb[0] : nb[1];
      previous = current;
      current = next >= 0 && !used[sz(next)] ? next : -1;
    }
    if (loop.size() < 3)
      continue;
    if (signedArea2d(loop, u, v) < 0.0)
      std::reverse(loop.begin(), loop.end());
    loops.push_back(std::move(loop));
  }
  return loops;
}

std::vector<double> evenSlicePositions(const core::TriangleMesh& mesh, SlicePlane plane, int count,
                                       double zMinMm, double zMaxMm) {
  if (count < 1)
    throw std::invalid_argument(fmt::format("the number of slices must be >= 1, got {}", count));
  const int axis = planeAxis(plane);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& v : mesh.vertices) {
    if (v.z() < zMinMm || v.z() > zMaxMm)
      continue;
    lo = std::min(lo, v[axis]);
    hi = std::max(hi, v[axis]);
  }
  if (!(hi >= lo))
    throw std::invalid_argument(
        "evenSlicePositions: the surface has no vertex in the scanned slab");
  const double width = hi - lo;
  std::vector<double> positions;
  for (int i = 0; i < count; ++i)
    positions.push_back(lo + (i + 0.5) * width / count);
  return positions;
}

std::vector<Eigen::Vector3d> proposeLoopAnchors(const std::vector<Eigen::Vector3d>& loop,
                                                const AnchorProposalOptions& options) {
  const std::size_t n = loop.size();
  if (n < 3)
    return {};
  std::vector<double> arc(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    arc[i + 1] = arc[i] + (loop[(i + 1) % n] - loop[i]).norm();
  const double perimeter = arc[n];
  if (perimeter < options.minPerimeterMm)
    return {};
  auto pointAt = [&](double s) {
    s = std::fmod(std::fmod(s, perimeter) + perimeter, perimeter);
    const std::size_t i =
        static_cast<std::size_t>(std::upper_bound(arc.begin(), arc.end(), s) - arc.begin()) - 1;
    const double len = arc[i + 1] - arc[i];
    const double t = len > 0.0 ? (s - arc[i]) / len : 0.0;
    return Eigen::Vector3d(loop[i] + t * (loop[(i + 1) % n] - loop[i]));
  };
  // Turning angle at each point, over +-2 mm of contour.
  std::vector<double> turn(n, 0.0);
  const double window = std::min(2.0, perimeter / 8.0);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = (loop[i] - pointAt(arc[i] - window)).normalized();
    const Eigen::Vector3d b = (pointAt(arc[i] + window) - loop[i]).normalized();
    turn[i] = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
  }
  // Corners: local maxima of the turn above cornerDeg, at least a window apart.
  const double cornerRad = options.cornerDeg * M_PI / 180.0;
  std::vector<double> fixed;  // arc positions of the anchors so far
  for (std::size_t i = 0; i < n; ++i) {
    if (turn[i] < cornerRad)
      continue;
    bool isMax = true;
    for (std::size_t j = 0; j < n && isMax; ++j) {
      double ds = std::abs(arc[j] - arc[i]);
      ds = std::min(ds, perimeter - ds);
      if (j != i && ds <= window && (turn[j] > turn[i] || (turn[j] == turn[i] && j < i)))
        isMax = false;
    }
    if (isMax)
      fixed.push_back(arc[i]);
  }
  const double reach = options.snapFraction * options.spacingMm;
  auto snapped = [&](double target) {
    std::size_t best = n;
    double bestTurn = 15.0 * M_PI / 180.0;  // only a clear bend moves an anchor
    for (std::size_t i = 0; i < n; ++i) {
      double ds = std::abs(arc[i] - target);
      ds = std::min(ds, perimeter - ds);
      if (ds <= reach && turn[i] > bestTurn + 1e-9) {
        bestTurn = turn[i];
        best = i;
      }
    }
    return best < n ? arc[best] : target;
  };
  if (fixed.empty()) {
    const int count =
        std::max(options.minAnchors, static_cast<int>(std::lround(perimeter / options.spacingMm)));
    std::vector<Eigen::Vector3d> anchors;
    for (int k = 0; k < count; ++k)
      anchors.push_back(pointAt(snapped(k * perimeter / count)));
    return anchors;
  }
  // Fill each gap between consecutive corners evenly.
  std::vector<double> positions;
  for (std::size_t c = 0; c < fixed.size(); ++c) {
    const double from = fixed[c];
    double to = fixed[(c + 1) % fixed.size()];
    if (to <= from)
      to += perimeter;
    positions.push_back(from);
    const int pieces = static_cast<int>(std::ceil((to - from) / options.spacingMm - 1e-9));
    for (int k = 1; k < pieces; ++k)
      positions.push_back(from + k * (to - from) / pieces);
  }
  // At least minAnchors: split the longest gaps.
  while (static_cast<int>(positions.size()) < options.minAnchors) {
    std::size_t longest = 0;
    double gap = -1.0;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      double g = (i + 1 < positions.size() ? positions[i + 1] : positions.front() + perimeter) -
                 positions[i];
      if (g > gap) {
        gap = g;
        longest = i;
      }
    }
    positions.insert(positions.begin() + static_cast<std::ptrdiff_t>(longest) + 1,
                     positions[longest] + 0.5 * gap);
  }
  std::vector<Eigen::Vector3d> anchors;
  for (double s : positions)
    anchors.push_back(pointAt(s));
  return anchors;
}

std::vector<Eigen::Vector3d> clipLoopZ(const std::vector<Eigen::Vector3d>& loop, double zMinMm,
                                       double zMaxMm) {
  auto clip = [](const std::vector<Eigen::Vector3d>& in, double limit, bool keepBelow) {
    std::vector<Eigen::Vector3d> out;
    const std::size_t n = in.size();
    auto inside = [&](const Eigen::Vector3d& p) {
      return keepBelow ? p.z() <= limit : p.z() >= limit;
    };
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d& a = in[i];
      const Eigen::Vector3d& b = in[(i + 1) % n];
      const bool ia = inside(a), ib = inside(b);
      if (ia)
        out.push_back(a);
      if (ia != ib) {
        const double t = (limit - a.z()) / (b.z() - a.z());
        Eigen::Vector3d x = a + t * (b - a);
        x.z() = limit;
        out.push_back(x);
      }
    }
    return out;
  };
  std::vector<Eigen::Vector3d> out = loop;
  if (std::isfinite(zMaxMm))
    out = clip(out, zMaxMm, true);
  if (std::isfinite(zMinMm) && !out.empty())
    out = clip(out, zMinMm, false);
  return out;
}

int straightenAtScanEnds(SliceContour& contour, const AnchorSet& anchors, double zMinMm,
                         double zMaxMm, double tolMm) {
  const auto& idx = contour.anchorIndices;
  const auto& pts = contour.pointsLps;
  const auto& at = anchors.anchorsLps;
  if (idx.size() < 2 || idx.size() != at.size() || pts.size() < 3)
    return 0;
  for (std::size_t i : idx) {
    if (i >= pts.size())
      return 0;
  }
  auto near = [&](const Eigen::Vector3d& p, double z) { return std::abs(p.z() - z) <= tolMm; };
  std::vector<std::uint8_t> drop(pts.size(), 0);
  std::vector<Eigen::Vector3d> moved = pts;
  int replaced = 0;
  for (std::size_t a = 0; a < idx.size(); ++a) {
    const std::size_t b = (a + 1) % idx.size();
    const bool low = near(at[a], zMinMm) && near(at[b], zMinMm);
    const bool high = near(at[a], zMaxMm) && near(at[b], zMaxMm);
    if (!low && !high)
      continue;
    const std::size_t from = idx[a], to = idx[b];
    for (std::size_t i = (from + 1) % pts.size(); i != to; i = (i + 1) % pts.size())
      drop[i] = 1;
    moved[from] = at[a];
    moved[to] = at[b];
    ++replaced;
  }
  if (replaced == 0)
    return 0;
  std::vector<Eigen::Vector3d> kept;
  std::vector<std::size_t> newIndex(pts.size(), 0);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    newIndex[i] = kept.size();
    if (!drop[i])
      kept.push_back(moved[i]);
  }
  for (std::size_t& i : contour.anchorIndices)
    i = newIndex[i];
  contour.pointsLps = std::move(kept);
  return replaced;
}

std::vector<AnchorSet> proposeAnchors(const core::TriangleMesh& surface, SlicePlane plane,
                                      int slices, const AnchorProposalOptions& options) {
  std::vector<AnchorSet> sets;
  const auto positions = evenSlicePositions(surface, plane, slices, options.zMinMm, options.zMaxMm);
  const char* prefix = plane == SlicePlane::Sagittal  ? "s"
                       : plane == SlicePlane::Coronal ? "c"
                                                      : "a";
  for (std::size_t s = 0; s < positions.size(); ++s) {
    const auto loops = planeSections(surface, plane, positions[s]);
    for (std::size_t l = 0; l < loops.size(); ++l) {
      AnchorSet set;
      set.plane = plane;
      set.positionMm = positions[s];
      const auto clipped = clipLoopZ(loops[l], options.zMinMm, options.zMaxMm);
      if (clipped.size() < 3)
        continue;
      set.anchorsLps = proposeLoopAnchors(clipped, options);
      if (set.anchorsLps.size() < 3)
        continue;
      set.label = fmt::format("{}{:02d}-{}", prefix, s, l);
      sets.push_back(std::move(set));
    }
  }
  return sets;
}

VoxelMask contoursToMask(const std::vector<SliceContour>& contours, const core::CtImage& grid,
                         const ContourMaskOptions& options) {
  if (contours.empty())
    throw std::invalid_argument("no contour to fill");
  if (grid.voxelCount() == 0)
    throw std::invalid_argument("contoursToMask: the grid is empty");
  const SlicePlane plane = contours.front().plane;
  for (const SliceContour& c : contours) {
    if (c.plane != plane)
      throw std::invalid_argument("the contours lie in different plane families");
    if (c.pointsLps.size() < 3)
      throw std::invalid_argument("a contour has fewer than 3 points");
  }
  const int axis = planeAxis(plane);
  const auto [u, v] = inPlaneAxes(axis);
  // Bounds of every contour, with a margin.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const SliceContour& c : contours) {
    for (const auto& p : c.pointsLps) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const double margin = 3.0;
  // Slices: contours grouped by position.
  std::vector<const SliceContour*> sorted;
  for (const SliceContour& c : contours)
    sorted.push_back(&c);
  std::sort(sorted.begin(), sorted.end(), [](const SliceContour* a, const SliceContour* b) {
    return a->positionMm < b->positionMm;
  });
  std::vector<SliceDistance> slices;
  for (std::size_t i = 0; i < sorted.size();) {
    std::vector<const SliceContour*> group{sorted[i]};
    std::size_t j = i + 1;
    while (j < sorted.size() &&
           sorted[j]->positionMm - sorted[i]->positionMm < options.sliceToleranceMm)
      group.push_back(sorted[j++]);
    SliceDistance s = sliceDistance(group, u, v, lo[u] - margin, lo[v] - margin, hi[u] + margin,
                                    hi[v] + margin, options.rasterMm);
    s.positionMm = sorted[i]->positionMm;
    slices.push_back(std::move(s));
    i = j;
  }
  VoxelMask mask = emptyMask(grid);
  const auto& d = grid.dimensions;
  const double first = slices.front().positionMm, last = slices.back().positionMm;
  // Beyond an end slice the solid closes (section_closing.hpp) within half the spacing to its
  // neighbour (a lone contour within 1 mm).
  auto deepest = [](const SliceDistance& s) {
    float low = 0.0f;
    for (float x : s.d)
      low = std::min(low, x);
    return -static_cast<double>(low);
  };
  const double closingFirst =
      slices.size() > 1 ? sectionClosingMm(slices[1].positionMm - first) : 1.0;
  const double closingLast =
      slices.size() > 1 ? sectionClosingMm(last - slices[slices.size() - 2].positionMm) : 1.0;
  const double depthFirst = deepest(slices.front()), depthLast = deepest(slices.back());
  // Voxels whose centres lie within the contours' bounds (the taper reaches at most the largest
  // in-plane extent beyond the end slices; it is bounded by the bounds' margin here).
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        const Eigen::Vector3d p = grid.voxelToLps(Eigen::Vector3d(i, j, k));
        if (p[u] < lo[u] - margin || p[u] > hi[u] + margin || p[v] < lo[v] - margin ||
            p[v] > hi[v] + margin || p[axis] < first - margin || p[axis] > last + margin) {
          continue;
        }
        const double w = p[axis];
        double dist = 0.0;
        if (w <= first) {
          dist = closedSectionDistanceMm(slices.front().sample(p[u], p[v]), depthFirst,
                                         closingFirst, first - w);
        } else if (w >= last) {
          dist = closedSectionDistanceMm(slices.back().sample(p[u], p[v]), depthLast, closingLast,
                                         w - last);
        } else {
          const auto it =
              std::upper_bound(slices.begin(), slices.end(), w,
                               [](double x, const SliceDistance& s) { return x < s.positionMm; });
          const SliceDistance& b = *it;
          const SliceDistance& a = *(it - 1);
          const double t = (w - a.positionMm) / (b.positionMm - a.positionMm);
          dist = (1.0 - t) * a.sample(p[u], p[v]) + t * b.sample(p[u], p[v]);
        }
        if (dist < 0.0)
          mask.voxels[grid.index(i, j, k)] = 1;
      }
    }
  }
  return mask;
}

SliceCorrectionResult correctOnSlices(const VoxelMask& region,
                                      const std::vector<SliceContour>& contours, double falloffMm,
                                      const std::vector<SliceContour>& absent) {
  if (contours.empty() && absent.empty())
    throw std::invalid_argument("no corrected contour");
  const core::CtImage& g = region.geometry;
  if (!g.uniform() || region.voxels.size() != g.voxelCount() || g.voxelCount() == 0)
    throw std::invalid_argument("correctOnSlices: the region is empty or not on a uniform grid");
  const SlicePlane plane = contours.empty() ? absent.front().plane : contours.front().plane;
  for (const auto* list : {&contours, &absent}) {
    for (const auto& c : *list) {
      if (c.plane != plane)
        throw std::invalid_argument("the corrected contours lie in several plane families");
    }
  }
  const int a = planeAxis(plane);
  const int ua = a == 0 ? 1 : 0, va = a == 2 ? 1 : 2;  // the in-plane voxel axes
  const auto& d = g.dimensions;
  const Eigen::Vector3d spacing = g.spacingMm();
  const int nu = d[sz(ua)], nv = d[sz(va)], nl = d[sz(a)];
  // Each contour's layer and its loop in voxel coordinates (u, v).
  using Loops = std::map<int, std::vector<std::vector<Eigen::Vector2d>>>;
  Loops loops, absentLoops;
  auto addLoop = [&](const SliceContour& c, Loops& into) {
    if (c.pointsLps.size() < 3)
      throw std::invalid_argument("a corrected contour has fewer than 3 points");
    double along = 0.0;
    std::vector<Eigen::Vector2d> loop;
    for (const auto& p : c.pointsLps) {
      const Eigen::Vector3d v = g.lpsToVoxel(p);
      along += v[a];
      loop.emplace_back(v[ua], v[va]);
    }
    const int layer =
        static_cast<int>(std::lround(along / static_cast<double>(c.pointsLps.size())));
    if (layer < 0 || layer >= nl) {
      throw std::invalid_argument(
          fmt::format("a corrected {} contour at {:.1f} mm lies outside "
                      "the CT's slices",
                      slicePlaneName(plane), c.positionMm));
    }
    into[layer].push_back(std::move(loop));
  };
  for (const auto& c : contours)
    addLoop(c, loops);
  for (const auto& c : absent)
    addLoop(c, absentLoops);
  auto index = [&](int l, int u, int v) {
    int ijk[3];
    ijk[a] = l;
    ijk[ua] = u;
    ijk[va] = v;
    return g.index(ijk[0], ijk[1], ijk[2]);
  };
  // In-plane signed distance (mm, negative inside) of a u x v mask, capped (an empty layer is
  // far outside everywhere).
  core::CtImage plane2;
  plane2.dimensions = {nu, nv, 1};
  plane2.pixelSpacingMm = {spacing[ua], spacing[va]};
  plane2.slicePositionsMm = {0.0};
  auto signedDistance = [&](const std::vector<std::uint8_t>& m) {
    VoxelMask mask;
    mask.geometry = plane2;
    mask.voxels = m;
    const std::vector<float> out = squaredDistanceMm2(mask, true);
    const std::vector<float> in = squaredDistanceMm2(mask, false);
    std::vector<float> sd(m.size());
    for (std::size_t i = 0; i < m.size(); ++i)
      sd[i] = std::min(1e6f, m[i] ? -std::sqrt(in[i]) : std::sqrt(out[i]));
    return sd;
  };
  // The even-odd fill of a layer's loops.
  auto fillOf = [&](const std::vector<std::vector<Eigen::Vector2d>>& polys) {
    std::vector<std::uint8_t> fill(sz(nu) * sz(nv), 0);
    for (int v = 0; v < nv; ++v) {
      for (int u = 0; u < nu; ++u) {
        bool inside = false;
        for (const auto& poly : polys) {
          for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
            const Eigen::Vector2d& p = poly[i];
            const Eigen::Vector2d& q = poly[j];
            if ((p.y() > v) != (q.y() > v) &&
                u < (q.x() - p.x()) * (v - p.y()) / (q.y() - p.y()) + p.x())
              inside = !inside;
          }
        }
        fill[sz(v) * sz(nu) + sz(u)] = inside ? 1 : 0;
      }
    }
    return fill;
  };
  std::set<int> layers;
  for (const auto* list : {&loops, &absentLoops}) {
    for (const auto& entry : *list)
      layers.insert(entry.first);
  }
  std::map<int, std::vector<float>> corrected;
  for (int layer : layers) {
    std::vector<std::uint8_t> fill(sz(nu) * sz(nv), 0);
    const auto drawn = loops.find(layer);
    if (drawn != loops.end()) {
      fill = fillOf(drawn->second);
    } else {
      for (int v = 0; v < nv; ++v)
        for (int u = 0; u < nu; ++u)
          fill[sz(v) * sz(nu) + sz(u)] = region.voxels[index(layer, u, v)];
    }
    const auto gone = absentLoops.find(layer);
    if (gone != absentLoops.end()) {
      const std::vector<std::uint8_t> out = fillOf(gone->second);
      for (std::size_t p = 0; p < fill.size(); ++p)
        fill[p] = static_cast<std::uint8_t>(fill[p] && !out[p]);
    }
    std::vector<float> sd = signedDistance(fill);
    if (std::none_of(fill.begin(), fill.end(), [](std::uint8_t f) { return f != 0; }))
      std::fill(sd.begin(), sd.end(), static_cast<float>(spacing[a]));
    corrected[layer] = std::move(sd);
  }
  SliceCorrectionResult result;
  result.region = region;
  result.slices = static_cast<int>(corrected.size());
  const int reach = std::max(0, static_cast<int>(std::floor(falloffMm / spacing[a])));
  for (int l = 0; l < nl; ++l) {
    int best = -1;  // the nearest corrected layer within reach
    for (const auto& entry : corrected) {
      const int layer = entry.first;
      if (std::abs(layer - l) <= reach && (best < 0 || std::abs(layer - l) < std::abs(best - l)))
        best = layer;
    }
    if (best < 0)
      continue;
    const double w = 1.0 - std::abs(best - l) / static_cast<double>(reach + 1);
    std::vector<std::uint8_t> mine(sz(nu) * sz(nv));
    for (int v = 0; v < nv; ++v)
      for (int u = 0; u < nu; ++u)
        mine[sz(v) * sz(nu) + sz(u)] = region.voxels[index(l, u, v)];
    const std::vector<float> own = signedDistance(mine);
    const std::vector<float>& want = corrected[best];
    for (int v = 0; v < nv; ++v) {
      for (int u = 0; u < nu; ++u) {
        const std::size_t p = sz(v) * sz(nu) + sz(u);
        const double blended = l == best ? want[p] : (1.0 - w) * own[p] + w * want[p];
        const std::uint8_t now = blended < 0.0 ? 1 : 0;
        std::uint8_t& out = result.region.voxels[index(l, u, v)];
        result.added += now && !out ? 1u : 0u;
        result.removed += !now && out ? 1u : 0u;
        out = now;
      }
    }
  }
  return result;
}

}  // namespace echoreg::segmentation
