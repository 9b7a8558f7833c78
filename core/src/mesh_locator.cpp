#include "echoreg/core/mesh_locator.hpp"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace echoreg::core {

namespace {

constexpr int kLeafSize = 4;      // triangles per leaf (at most)
constexpr int kBins = 16;         // SAH bins per axis
constexpr int kMaxSahDepth = 40;  // deeper nodes split at the median, so depth stays bounded
constexpr int kStackSize = 128;   // > kMaxSahDepth + log2(2^31 / kLeafSize) + 1
constexpr double kBaryTolerance =
    1e-12;                           // edges widened by this (relative) so no ray slips through
constexpr double kSameHitMm = 1e-9;  // hits this close on adjacent triangles are one crossing
constexpr double kFirstHitWindowMm = 1e-6;  // firstHit gathers hits this far past the nearest

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Three fixed directions, none along an axis or a diagonal, for the parity votes of inside().
const std::array<Eigen::Vector3d, 3>& parityDirections() {
  static const std::array<Eigen::Vector3d, 3> directions = {
      Eigen::Vector3d(0.5381, 0.2947, 0.7897).normalized(),
      Eigen::Vector3d(-0.7132, 0.6183, 0.3301).normalized(),
      Eigen::Vector3d(0.1739, -0.8216, -0.5429).normalized()};
  return directions;
}

struct Box {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(kInfinity);
  Eigen::Vector3d high = Eigen::Vector3d::Constant(-kInfinity);

  void grow(const Eigen::Vector3d& p) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  void grow(const Box& other) {
    low = low.cwiseMin(other.low);
    high = high.cwiseMax(other.high);
  }
  bool empty() const { return low.x() > high.x(); }
  // Half the surface area (the SAH only compares areas).
  double halfArea() const {
    if (empty())
      return 0.0;
    const Eigen::Vector3d d = high - low;
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  }
};

// One node of the flat hierarchy. An inner node's left child follows it; `first` is its right
// child. A leaf holds triangles [first, first + count) of the reordered triangle array.
struct Node {
  double low[3];
  double high[3];
  int first = 0;
  int count = 0;  // > 0 for leaves
};

// A triangle in leaf order with its own copy of the corners (the queries read nothing else).
struct Triangle {
  Eigen::Vector3d a, b, c;
  double doubleAreaMm2 = 0.0;  // |(b - a) x (c - a)|
  int index = 0;               // in the mesh
  bool degenerate = false;
};

// A ray-triangle intersection before edge and vertex duplicates are merged.
struct RawHit {
  double t;
  int triangle;  // mesh index
  bool entering;
};

bool rawLess(const RawHit& x, const RawHit& y) {
  return x.t < y.t || (x.t == y.t && x.triangle < y.triangle);
}

// Squared distance from p to the box (zero inside).
inline double boxDistance2(const Node& node, const Eigen::Vector3d& p) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double below = node.low[k] - p[k];
    const double above = p[k] - node.high[k];
    const double d = std::max({below, above, 0.0});
    sum += d * d;
  }
  return sum;
}

// Entry parameter of the ray into the box, or +inf when it misses it within [tMin, tMax]. An axis
// with a zero direction and the origin on a slab plane gives NaN, which std::min/std::max below
// ignore (the origin is then inside that slab).
inline double boxEntry(const Node& node, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& inverse, double tMin, double tMax) {
  double enter = tMin, leave = tMax;
  for (int k = 0; k < 3; ++k) {
    const double t0 = (node.low[k] - origin[k]) * inverse[k];
    const double t1 = (node.high[k] - origin[k]) * inverse[k];
    enter = std::max(enter, std::min(t0, t1));
    leave = std::min(leave, std::max(t0, t1));
  }
  return enter <= leave ? enter : kInfinity;
}

// Ericson, Real-Time Collision Detection, 5.1.5; `weights` gets the barycentric coordinates.
Eigen::Vector3d closestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                  const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                  Eigen::Vector3d& weights) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    weights = {1.0, 0.0, 0.0};
    return a;
  }
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    weights = {0.0, 1.0, 0.0};
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    weights = {1.0 - v, v, 0.0};
    return a + v * ab;
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    weights = {0.0, 0.0, 1.0};
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    weights = {1.0 - w, 0.0, w};
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    weights = {0.0, 1.0 - w, w};
    return b + w * (c - b);
  }
  const double denominator = 1.0 / (va + vb + vc);
  const double v = vb * denominator, w = vc * denominator;
  weights = {1.0 - v - w, v, w};
  return a + v * ab + w * ac;
}

// Closest point on a zero-area triangle: the nearest of its three edges.
Eigen::Vector3d closestOnDegenerate(const Eigen::Vector3d& p, const Triangle& tri,
                                    Eigen::Vector3d& weights) {
  const Eigen::Vector3d* corners[3] = {&tri.a, &tri.b, &tri.c};
  double best = kInfinity;
  Eigen::Vector3d bestPoint = tri.a;
  for (int e = 0; e < 3; ++e) {
    const Eigen::Vector3d& from = *corners[e];
    const Eigen::Vector3d& to = *corners[(e + 1) % 3];
    const Eigen::Vector3d edge = to - from;
    const double length2 = edge.squaredNorm();
    const double s = length2 > 0.0 ? std::clamp((p - from).dot(edge) / length2, 0.0, 1.0) : 0.0;
    const Eigen::Vector3d q = from + s * edge;
    const double d2 = (q - p).squaredNorm();
    if (d2 < best) {
      best = d2;
      bestPoint = q;
      weights = Eigen::Vector3d::Zero();
      weights[e] = 1.0 - s;
      weights[(e + 1) % 3] = s;
    }
  }
  return bestPoint;
}

inline Eigen::Vector3d closestOn(const Triangle& tri, const Eigen::Vector3d& p,
                                 Eigen::Vector3d& weights) {
  return tri.degenerate ? closestOnDegenerate(p, tri, weights)
                        : closestOnTriangle(p, tri.a, tri.b, tri.c, weights);
}

// Möller-Trumbore in double; both sides count. Edges are widened by kBaryTolerance so that a ray
// through a shared edge or vertex hits at least one of the triangles there.
inline bool intersect(const Triangle& tri, const Eigen::Vector3d& origin,
                      const Eigen::Vector3d& direction, double& t, bool& entering) {
  if (tri.degenerate)
    return false;
  const Eigen::Vector3d e1 = tri.b - tri.a, e2 = tri.c - tri.a;
  const Eigen::Vector3d p = direction.cross(e2);
  const double det = e1.dot(p);  // = -dot(direction, e1 x e2)
  // Parallel to the plane (to 1e-13 rad): no crossing.
  if (std::abs(det) <= 1e-13 * tri.doubleAreaMm2)
    return false;
  const double inverse = 1.0 / det;
  const Eigen::Vector3d s = origin - tri.a;
  const double u = s.dot(p) * inverse;
  if (u < -kBaryTolerance || u > 1.0 + kBaryTolerance)
    return false;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = direction.dot(q) * inverse;
  if (v < -kBaryTolerance || u + v > 1.0 + kBaryTolerance)
    return false;
  t = e2.dot(q) * inverse;
  entering = det > 0.0;
  return true;
}

// Throws std::invalid_argument with message() (built only on failure: queries call this).
template <typename Message>
void require(bool condition, Message&& message) {
  if (!condition)
    throw std::invalid_argument(message());
}

std::string text(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

std::string text(const Eigen::Vector3d& v) {
  return "(" + text(v.x()) + ", " + text(v.y()) + ", " + text(v.z()) + ")";
}

void requireRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double tMax,
                double tMin) {
  require(origin.allFinite(),
          [&] { return "MeshLocator: ray origin " + text(origin) + " is not finite"; });
  require(direction.allFinite() && std::abs(direction.squaredNorm() - 1.0) <= 1e-6, [&] {
    return "MeshLocator: ray direction " + text(direction) + " is not of unit length";
  });
  require(!std::isnan(tMax) && !std::isnan(tMin), [&] {
    return "MeshLocator: ray interval (" + text(tMin) + ", " + text(tMax) + "] is not a number";
  });
}

}  // namespace

struct MeshLocator::Impl {
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> normals;  // unit, per mesh triangle (zero when degenerate)
  std::vector<Triangle> triangles;       // leaf order
  std::vector<Node> nodes;               // depth-first; nodes[0] is the root

  // Build scratch: one record per triangle, moved around as the tree splits (so each split
  // reads its triangles contiguously).
  struct Item {
    Box box;
    Eigen::Vector3d centroid;
    int index;
  };
  std::vector<Item> items;

  explicit Impl(TriangleMesh input) : mesh(std::move(input)) {
    validate();
    const std::size_t count = mesh.triangles.size();
    normals.resize(count, Eigen::Vector3d::Zero());
    items.resize(count);
    double scale = 1.0;
    for (const Eigen::Vector3d& v : mesh.vertices)
      scale = std::max(scale, v.cwiseAbs().maxCoeff());
    for (std::size_t i = 0; i < count; ++i) {
      const auto& tri = mesh.triangles[i];
      Item& item = items[i];
      for (int k = 0; k < 3; ++k)
        item.box.grow(vertex(tri, k));
      item.centroid = (vertex(tri, 0) + vertex(tri, 1) + vertex(tri, 2)) / 3.0;
      item.index = static_cast<int>(i);
    }
    if (count > 0) {
      nodes.reserve(2 * count / kLeafSize + 1);
      build(0, static_cast<int>(count), 0);
    }
    // Pad every box a little so that rays accepted through the widened edges and rounding in
    // the slab test never skip a box.
    const double pad = 1e-10 * scale;
    for (Node& node : nodes) {
      for (int k = 0; k < 3; ++k) {
        node.low[k] -= pad;
        node.high[k] += pad;
      }
    }
    triangles.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      const int index = items[i].index;
      const auto& tri = mesh.triangles[static_cast<std::size_t>(index)];
      Triangle& out = triangles[i];
      out.a = vertex(tri, 0);
      out.b = vertex(tri, 1);
      out.c = vertex(tri, 2);
      const Eigen::Vector3d cross = (out.b - out.a).cross(out.c - out.a);
      out.doubleAreaMm2 = cross.norm();
      out.index = index;
      out.degenerate =
          !(out.doubleAreaMm2 > 0.0) || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
      if (!out.degenerate)
        normals[static_cast<std::size_t>(index)] = cross / out.doubleAreaMm2;
    }
    items = {};
  }

  const Eigen::Vector3d& vertex(const std::array<int, 3>& tri, int k) const {
    return mesh.vertices[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])];
  }

  void validate() const {
    const std::size_t vertexCount = mesh.vertices.size();
    for (std::size_t v = 0; v < vertexCount; ++v) {
      require(mesh.vertices[v].allFinite(), [&] {
        return "MeshLocator: vertex " + std::to_string(v) + " " + text(mesh.vertices[v]) +
               " is not finite";
      });
    }
    require(mesh.triangles.size() < static_cast<std::size_t>(INT_MAX / 2), [&] {
      return "MeshLocator: " + std::to_string(mesh.triangles.size()) + " triangles are too many";
    });
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int index : mesh.triangles[t]) {
        require(index >= 0 && static_cast<std::size_t>(index) < vertexCount, [&] {
          return "MeshLocator: triangle " + std::to_string(t) + " has vertex index " +
                 std::to_string(index) + " outside 0.." + std::to_string(vertexCount) +
                 " (exclusive)";
        });
      }
    }
  }

  // Builds the subtree of items[begin, end) and returns its node index.
  int build(int begin, int end, int depth) {
    const int nodeIndex = static_cast<int>(nodes.size());
    nodes.emplace_back();
    Box box, centroidBox;
    for (int i = begin; i < end; ++i) {
      const Item& item = items[static_cast<std::size_t>(i)];
      box.grow(item.box);
      centroidBox.grow(item.centroid);
    }
    Node& node = nodes.back();
    for (int k = 0; k < 3; ++k) {
      node.low[k] = box.low[k];
      node.high[k] = box.high[k];
    }
    if (end - begin <= kLeafSize) {
      node.first = begin;
      node.count = end - begin;
      return nodeIndex;
    }
    int middle = depth < kMaxSahDepth ? sahSplit(begin, end, centroidBox) : begin;
    if (middle <= begin || middle >= end)
      middle = medianSplit(begin, end, centroidBox);
    build(begin, middle, depth + 1);
    const int right = build(middle, end, depth + 1);
    nodes[static_cast<std::size_t>(nodeIndex)].first = right;  // `node` may have moved
    nodes[static_cast<std::size_t>(nodeIndex)].count = 0;
    return nodeIndex;
  }

  // Binned surface area heuristic over the three axes (one pass bins all three); returns the
  // partition point, or `begin` when the centroids cannot be separated.
  int sahSplit(int begin, int end, const Box& centroidBox) {
    const Eigen::Vector3d low = centroidBox.low;
    const Eigen::Vector3d extent = centroidBox.high - centroidBox.low;
    Eigen::Vector3d scale;
    for (int axis = 0; axis < 3; ++axis)
      scale[axis] = extent[axis] > 0.0 ? kBins / extent[axis] : 0.0;
    std::array<std::array<Box, kBins>, 3> boxes;
    std::array<std::array<int, kBins>, 3> counts{};
    for (int i = begin; i < end; ++i) {
      const Item& item = items[static_cast<std::size_t>(i)];
      for (std::size_t axis = 0; axis < 3; ++axis) {
        const auto bin =
            static_cast<std::size_t>(binOf(item.centroid, low, scale, static_cast<int>(axis)));
        ++counts[axis][bin];
        boxes[axis][bin].grow(item.box);
      }
    }
    double bestCost = kInfinity;
    int bestAxis = -1, bestBin = 0;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      if (!(extent[static_cast<int>(axis)] > 0.0))
        continue;
      // Areas and counts to the right of each split plane.
      std::array<double, kBins> rightArea{};
      std::array<int, kBins> rightCount{};
      Box right;
      int rightSum = 0;
      for (std::size_t b = kBins - 1; b > 0; --b) {
        right.grow(boxes[axis][b]);
        rightSum += counts[axis][b];
        rightArea[b] = right.halfArea();
        rightCount[b] = rightSum;
      }
      Box left;
      int leftSum = 0;
      for (std::size_t b = 1; b < kBins; ++b) {  // split between bin b - 1 and bin b
        left.grow(boxes[axis][b - 1]);
        leftSum += counts[axis][b - 1];
        if (leftSum == 0 || rightCount[b] == 0)
          continue;
        const double cost = left.halfArea() * leftSum + rightArea[b] * rightCount[b];
        if (cost < bestCost) {
          bestCost = cost;
          bestAxis = static_cast<int>(axis);
          bestBin = static_cast<int>(b);
        }
      }
    }
    if (bestAxis < 0)
      return begin;
    const auto first = items.begin() + begin, last = items.begin() + end;
    const auto split = std::partition(first, last, [&](const Item& item) {
      return binOf(item.centroid, low, scale, bestAxis) < bestBin;
    });
    return begin + static_cast<int>(split - first);
  }

  static int binOf(const Eigen::Vector3d& centroid, const Eigen::Vector3d& low,
                   const Eigen::Vector3d& scale, int axis) {
    const auto bin = static_cast<int>((centroid[axis] - low[axis]) * scale[axis]);
    return std::clamp(bin, 0, kBins - 1);
  }

  // Splits at the median centroid along the widest axis (ties by triangle index: deterministic).
  int medianSplit(int begin, int end, const Box& centroidBox) {
    const Eigen::Vector3d extent = centroidBox.high - centroidBox.low;
    int axis = 0;
    if (extent.y() > extent[axis])
      axis = 1;
    if (extent.z() > extent[axis])
      axis = 2;
    const int middle = begin + (end - begin) / 2;
    std::nth_element(items.begin() + begin, items.begin() + middle, items.begin() + end,
                     [axis](const Item& x, const Item& y) {
                       const double cx = x.centroid[axis], cy = y.centroid[axis];
                       return cx < cy || (cx == cy && x.index < y.index);
                     });
    return middle;
  }

  // Every raw intersection with t in (tMin, tMax], in traversal order. With `firstOnly`, boxes
  // farther than kFirstHitWindowMm past the nearest hit so far are skipped.
  template <typename Hits>
  void collect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double tMax,
               double tMin, bool firstOnly, Hits& hits) const {
    if (nodes.empty())
      return;
    const Eigen::Vector3d inverse = direction.cwiseInverse();
    double limit = tMax;
    std::array<int, kStackSize> stack;
    int top = 0;
    if (boxEntry(nodes[0], origin, inverse, tMin, limit) == kInfinity)
      return;
    stack[static_cast<std::size_t>(top++)] = 0;
    while (top > 0) {
      const Node& node = nodes[static_cast<std::size_t>(stack[static_cast<std::size_t>(--top)])];
      if (node.count > 0) {
        for (int i = node.first; i < node.first + node.count; ++i) {
          const Triangle& tri = triangles[static_cast<std::size_t>(i)];
          double t = 0.0;
          bool entering = false;
          if (!intersect(tri, origin, direction, t, entering) || !(t > tMin) || !(t <= tMax)) {
            continue;
          }
          hits.push_back(RawHit{t, tri.index, entering});
          if (firstOnly)
            limit = std::min(limit, t + kFirstHitWindowMm);
        }
        continue;
      }
      const int leftIndex = static_cast<int>(&node - nodes.data()) + 1;
      const int rightIndex = node.first;
      const double leftEntry =
          boxEntry(nodes[static_cast<std::size_t>(leftIndex)], origin, inverse, tMin, limit);
      const double rightEntry =
          boxEntry(nodes[static_cast<std::size_t>(rightIndex)], origin, inverse, tMin, limit);
      // Push the farther child first so that the nearer one is searched first.
      if (leftEntry <= rightEntry) {
        if (rightEntry != kInfinity)
          stack[static_cast<std::size_t>(top++)] = rightIndex;
        if (leftEntry != kInfinity)
          stack[static_cast<std::size_t>(top++)] = leftIndex;
      } else {
        if (leftEntry != kInfinity)
          stack[static_cast<std::size_t>(top++)] = leftIndex;
        stack[static_cast<std::size_t>(top++)] = rightIndex;
      }
    }
  }

  // Triangles that share a vertex (by index or by exact position).
  bool adjacent(int x, int y) const {
    const auto& tx = mesh.triangles[static_cast<std::size_t>(x)];
    const auto& ty = mesh.triangles[static_cast<std::size_t>(y)];
    for (int i : tx) {
      for (int j : ty) {
        if (i == j || mesh.vertices[static_cast<std::size_t>(i)] ==
                          mesh.vertices[static_cast<std::size_t>(j)]) {
          return true;
        }
      }
    }
    return false;
  }

  // Merges sorted raw hits into crossings and calls emit(rawHit) for each, in order of t. Hits
  // within kSameHitMm of each other on adjacent triangles (a ray through a shared edge or
  // vertex) are one crossing when they agree on the side they enter from; when they disagree the
  // ray only touches the surface there (a silhouette edge or vertex) and nothing is emitted.
  template <typename Emit>
  void merge(const RawHit* hits, std::size_t count, Emit&& emit) const {
    std::size_t i = 0;
    while (i < count) {
      std::size_t j = i + 1;
      while (j < count && hits[j].t - hits[j - 1].t <= kSameHitMm)
        ++j;
      if (j - i == 1) {
        emit(hits[i]);
        i = j;
        continue;
      }
      // Connected components of the run by adjacency (runs are a handful of hits).
      const std::size_t n = j - i;
      std::array<int, 64> labelStorage;
      std::vector<int> labelOverflow;
      int* label = labelStorage.data();
      if (n > labelStorage.size()) {
        labelOverflow.resize(n);
        label = labelOverflow.data();
      }
      std::fill(label, label + n, -1);
      for (std::size_t k = 0; k < n; ++k) {
        if (label[k] >= 0)
          continue;
        const int component = static_cast<int>(k);
        label[k] = component;
        for (bool grew = true; grew;) {
          grew = false;
          for (std::size_t m = k + 1; m < n; ++m) {
            if (label[m] >= 0)
              continue;
            for (std::size_t r = k; r < n; ++r) {
              if (label[r] == component && adjacent(hits[i + m].triangle, hits[i + r].triangle)) {
                label[m] = component;
                grew = true;
                break;
              }
            }
          }
        }
        bool enters = false, leaves = false;
        for (std::size_t m = k; m < n; ++m) {
          if (label[m] != component)
            continue;
          (hits[i + m].entering ? enters : leaves) = true;
        }
        if (!(enters && leaves))
          emit(hits[i + k]);
      }
      i = j;
    }
  }

  RayHit toHit(const RawHit& raw, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction) const {
    RayHit hit;
    hit.t = raw.t;
    hit.point = origin + raw.t * direction;
    hit.normal = normals[static_cast<std::size_t>(raw.triangle)];
    hit.triangle = raw.triangle;
    hit.entering = raw.entering;
    return hit;
  }

  // Number of crossings of the ray from `origin` (t > 0).
  int crossings(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                std::vector<RawHit>& scratch) const {
    scratch.clear();
    collect(origin, direction, kInfinity, 0.0, false, scratch);
    std::sort(scratch.begin(), scratch.end(), rawLess);
    int count = 0;
    merge(scratch.data(), scratch.size(), [&count](const RawHit&) { ++count; });
    return count;
  }
};

MeshLocator::MeshLocator(TriangleMesh mesh) : impl_(std::make_unique<Impl>(std::move(mesh))) {}
MeshLocator::~MeshLocator() = default;
MeshLocator::MeshLocator(MeshLocator&&) noexcept = default;
MeshLocator& MeshLocator::operator=(MeshLocator&&) noexcept = default;

const TriangleMesh& MeshLocator::mesh() const {
  return impl_->mesh;
}

std::optional<RayHit> MeshLocator::firstHit(const Eigen::Vector3d& origin,
                                            const Eigen::Vector3d& direction, double tMax,
                                            double tMin) const {
  requireRay(origin, direction, tMax, tMin);
  thread_local std::vector<RawHit> scratch;
  double from = tMin;
  for (;;) {
    scratch.clear();
    impl_->collect(origin, direction, tMax, from, true, scratch);
    if (scratch.empty())
      return std::nullopt;
    std::sort(scratch.begin(), scratch.end(), rawLess);
    // Only the hits near the nearest one are complete (farther boxes were skipped).
    const double nearest = scratch.front().t;
    const auto complete = static_cast<std::size_t>(
        std::upper_bound(scratch.begin(), scratch.end(), nearest + 0.5 * kFirstHitWindowMm,
                         [](double t, const RawHit& hit) { return t < hit.t; }) -
        scratch.begin());
    std::optional<RawHit> first;
    impl_->merge(scratch.data(), complete, [&first](const RawHit& hit) {
      if (!first)
        first = hit;
    });
    if (first)
      return impl_->toHit(*first, origin, direction);
    // The ray only touched the surface there: search on past it.
    from = scratch[complete - 1].t;
  }
}

std::vector<RayHit> MeshLocator::allHits(const Eigen::Vector3d& origin,
                                         const Eigen::Vector3d& direction, double tMax,
                                         double tMin) const {
  requireRay(origin, direction, tMax, tMin);
  std::vector<RawHit> raw;
  impl_->collect(origin, direction, tMax, tMin, false, raw);
  std::sort(raw.begin(), raw.end(), rawLess);
  std::vector<RayHit> hits;
  hits.reserve(raw.size());
  impl_->merge(raw.data(), raw.size(),
               [&](const RawHit& hit) { hits.push_back(impl_->toHit(hit, origin, direction)); });
  return hits;
}

ClosestPoint MeshLocator::closest(const Eigen::Vector3d& point, double maxDistance) const {
  require(point.allFinite(),
          [&] { return "MeshLocator::closest: point " + text(point) + " is not finite"; });
  require(maxDistance >= 0.0, [&] {
    return "MeshLocator::closest: maxDistance " + text(maxDistance) + " is not >= 0";
  });
  ClosestPoint result;
  result.distance = maxDistance;
  result.point = point;
  result.barycentric = Eigen::Vector3d::Zero();
  const auto& nodes = impl_->nodes;
  if (nodes.empty())
    return result;
  double best2 = maxDistance * maxDistance;
  int bestIndex = INT_MAX;
  int bestSlot = -1;  // position of the best triangle in leaf order

  // Best-first: a heap of boxes by distance; from each box taken off it, walk down to the nearer
  // child and leave the farther one on the heap. The search ends when the nearest box left is
  // farther than the best triangle so far.
  struct Entry {
    double distance2;
    int node;
    bool operator<(const Entry& other) const { return distance2 > other.distance2; }
  };
  thread_local std::vector<Entry> heap;
  heap.clear();
  Eigen::Vector3d weights;
  const double rootDistance2 = boxDistance2(nodes[0], point);
  if (rootDistance2 > best2)
    return result;
  heap.push_back({rootDistance2, 0});
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const Entry entry = heap.back();
    heap.pop_back();
    if (entry.distance2 > best2)
      break;
    int index = entry.node;
    for (;;) {
      const Node& node = nodes[static_cast<std::size_t>(index)];
      if (node.count > 0) {
        for (int i = node.first; i < node.first + node.count; ++i) {
          const Triangle& tri = impl_->triangles[static_cast<std::size_t>(i)];
          const double d2 = (closestOn(tri, point, weights) - point).squaredNorm();
          // Ties go to the lowest triangle index, so the answer does not depend on the tree.
          if (d2 < best2 || (d2 == best2 && tri.index < bestIndex)) {
            best2 = d2;
            bestIndex = tri.index;
            bestSlot = i;
          }
        }
        break;
      }
      const int leftIndex = index + 1;
      const int rightIndex = node.first;
      const double left2 = boxDistance2(nodes[static_cast<std::size_t>(leftIndex)], point);
      const double right2 = boxDistance2(nodes[static_cast<std::size_t>(rightIndex)], point);
      const bool leftFirst = left2 <= right2;
      const double near2 = leftFirst ? left2 : right2, far2 = leftFirst ? right2 : left2;
      if (far2 <= best2) {
        heap.push_back({far2, leftFirst ? rightIndex : leftIndex});
        std::push_heap(heap.begin(), heap.end());
      }
      if (near2 > best2)
        break;
      index = leftFirst ? leftIndex : rightIndex;
    }
  }
  if (bestSlot < 0)
    return result;
  result.point =
      closestOn(impl_->triangles[static_cast<std::size_t>(bestSlot)], point, result.barycentric);
  result.distance = std::sqrt(best2);
  result.triangle = bestIndex;
  return result;
}

bool MeshLocator::inside(const Eigen::Vector3d& point) const {
  require(point.allFinite(),
          [&] { return "MeshLocator::inside: point " + text(point) + " is not finite"; });
  const auto& nodes = impl_->nodes;
  if (nodes.empty())
    return false;
  for (int k = 0; k < 3; ++k) {
    if (point[k] < nodes[0].low[k] || point[k] > nodes[0].high[k])
      return false;
  }
  thread_local std::vector<RawHit> scratch;
  int votes = 0;
  for (std::size_t d = 0; d < 3; ++d) {
    votes += impl_->crossings(point, parityDirections()[d], scratch) % 2;
    // Two votes decide.
    if (votes == 2 || (votes == 0 && d == 1))
      break;
  }
  return votes >= 2;
}

double MeshLocator::signedDistance(const Eigen::Vector3d& point) const {
  const double distance = closest(point).distance;
  return inside(point) ? -distance : distance;
}

}  // namespace echoreg::core
