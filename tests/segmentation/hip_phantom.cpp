#include "hip_phantom.hpp"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/filters/mesh_io.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace echoreg::test {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;
constexpr int kTissueCount = static_cast<int>(HipTissue::kCount);

double degrees(double d) {
  return d * kPi / 180.0;
}
double clamp01(double x) {
  return std::min(1.0, std::max(0.0, x));
}
double smoothstep(double e0, double e1, double x) {
  const double t = clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0 - 2.0 * t);
}
// Polynomial smooth minimum (Lipschitz like its arguments; at most k/4 below min).
double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}
double smax(double a, double b, double k) {
  return -smin(-a, -b, k);
}

// ---------------------------------------------------------------------------------------------
// Options

void requireRange(const char* name, double value, double low, double high) {
  if (!std::isfinite(value) || value < low || value > high) {
    std::ostringstream os;
    os << "HipPhantomOptions." << name << " must be in [" << low << ", " << high << "], got "
       << value;
    throw std::invalid_argument(os.str());
  }
}

void validate(const HipPhantomOptions& o) {
  requireRange("sliceMm", o.sliceMm, 1.0, 6.0);
  requireRange("pixelMm", o.pixelMm, 0.3, 2.0);
  requireRange("jointGapMm", o.jointGapMm, 0.0, 4.0);
  requireRange("cancellousHu", o.cancellousHu, 50.0, 1000.0);
  requireRange("cortexHu", o.cortexHu, 300.0, 3000.0);
  requireRange("noiseHu", o.noiseHu, 0.0, 200.0);
  requireRange("zPhaseMm", o.zPhaseMm, 0.0, o.sliceMm);
  requireRange("noiseCorrelationMm", o.noiseCorrelationMm, 0.0, 2.0);
  requireRange("psfSigmaMm", o.psfSigmaMm, 0.0, 2.0);
  if (o.cortexHu < o.cancellousHu + 100.0) {
    std::ostringstream os;
    os << "HipPhantomOptions.cortexHu (" << o.cortexHu << ") must exceed cancellousHu ("
       << o.cancellousHu << ") by at least 100";
    throw std::invalid_argument(os.str());
  }
  if (o.femurMesh.empty())
    throw std::invalid_argument("HipPhantomOptions.femurMesh is empty");
}

// ---------------------------------------------------------------------------------------------
// Femoral head

struct Sphere {
  Vector3d centre = Vector3d::Zero();
  double radius = 0.0;
  double rmsMm = 0.0;
};

// Gauss-Newton on the geometric residuals |p - c| - r, from `start` (or from an algebraic fit
// when `start` has no radius).
Sphere fitSphere(const std::vector<Vector3d>& points, const Sphere& start = Sphere()) {
  Sphere s = start;
  if (points.size() < 4)
    return s;
  if (start.radius <= 0.0) {
    Eigen::Matrix4d ata = Eigen::Matrix4d::Zero();
    Eigen::Vector4d atb = Eigen::Vector4d::Zero();
    for (const auto& p : points) {
      const Eigen::Vector4d row(2.0 * p.x(), 2.0 * p.y(), 2.0 * p.z(), 1.0);
      ata += row * row.transpose();
      atb += row * p.squaredNorm();
    }
    const Eigen::Vector4d x = ata.ldlt().solve(atb);
    s.centre = x.head<3>();
    s.radius = std::sqrt(std::max(0.0, x(3) + s.centre.squaredNorm()));
  }
  for (int iteration = 0; iteration < 30; ++iteration) {
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    for (const auto& p : points) {
      const Vector3d d = p - s.centre;
      const double n = d.norm();
      if (n < 1e-9)
        continue;
      Eigen::Vector4d j;
      j << -d / n, -1.0;
      jtj += j * j.transpose();
      jtr += j * (n - s.radius);
    }
    const Eigen::Vector4d step = jtj.ldlt().solve(-jtr);
    s.centre += step.head<3>();
    s.radius += step(3);
    if (step.norm() < 1e-7)
      break;
  }
  double sum = 0.0;
  for (const auto& p : points) {
    const double e = (p - s.centre).norm() - s.radius;
    sum += e * e;
  }
  s.rmsMm = std::sqrt(sum / static_cast<double>(points.size()));
  return s;
}

struct HeadFit {
  bool ok = false;
  Sphere sphere;
  Vector3d neckAxis = Vector3d::Zero();
  double coverage = 0.0;  // share of the sphere's directions that carry head points
};

Vector3d neckDirection(const core::TriangleMesh& mesh, const Sphere& s) {
  Vector3d sum = Vector3d::Zero();
  int count = 0;
  for (const auto& v : mesh.vertices) {
    const Vector3d d = v - s.centre;
    const double r = d.norm();
    if (r > s.radius + 4.0 && r < s.radius + 14.0) {
      sum += d / r;
      ++count;
    }
  }
  return count >= 10 && sum.norm() > 1e-9 ? Vector3d(sum.normalized()) : Vector3d::Zero();
}

// The head at the end of `mesh` toward `up`: a sphere fitted to the end cap, then refitted to
// the vertices within a narrowing band about it, away from the neck.
HeadFit fitHeadAtEnd(const core::TriangleMesh& mesh, const Vector3d& up) {
  HeadFit fit;
  double top = -std::numeric_limits<double>::infinity();
  for (const auto& v : mesh.vertices)
    top = std::max(top, v.dot(up));
  // Start: a sphere of a typical head's radius (22 mm) under the end, fitted to the end's cap.
  std::vector<Vector3d> points;
  Vector3d tip = Vector3d::Zero();
  for (const auto& v : mesh.vertices)
    if (v.dot(up) > top - 15.0) {
      points.push_back(v);
      tip += v;
    }
  if (points.size() < 20)
    return fit;
  tip /= static_cast<double>(points.size());
  Sphere start;
  start.radius = 22.0;
  start.centre = tip - (22.0 - 7.5) * up;
  Sphere s = fitSphere(points, start);
  Vector3d neck = Vector3d::Zero();
  const double cosNeck = std::cos(degrees(60.0));
  for (int iteration = 0; iteration < 30; ++iteration) {
    if (!(s.radius > 5.0 && s.radius < 60.0))
      return fit;
    neck = neckDirection(mesh, s);
    const double band = std::max(2.0, 6.0 - 0.5 * iteration);
    points.clear();
    for (const auto& v : mesh.vertices) {
      const Vector3d d = v - s.centre;
      const double r = d.norm();
      if (std::abs(r - s.radius) < band && (neck.isZero() || d.dot(neck) < cosNeck * r))
        points.push_back(v);
    }
    if (points.size() < 30)
      return fit;
    s = fitSphere(points);
  }
  neck = neckDirection(mesh, s);
  // Coverage: Fibonacci directions that have a band point within 12 degrees.
  const int directions = 200;
  const double cosNear = std::cos(degrees(12.0));
  int covered = 0;
  std::vector<Vector3d> unit;
  unit.reserve(points.size());
  for (const auto& p : points)
    unit.push_back((p - s.centre).normalized());
  for (int i = 0; i < directions; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / directions;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = i * kPi * (3.0 - std::sqrt(5.0));
    const Vector3d d(rho * std::cos(phi), rho * std::sin(phi), z);
    for (const auto& u : unit)
      if (u.dot(d) > cosNear) {
        ++covered;
        break;
      }
  }
  fit.sphere = s;
  fit.neckAxis = neck;
  fit.coverage = static_cast<double>(covered) / directions;
  fit.ok = s.radius >= 15.0 && s.radius <= 35.0 && s.rmsMm < 2.5 && !neck.isZero();
  return fit;
}

// ---------------------------------------------------------------------------------------------
// The hip bone: an implicit solid in a local frame q at the head centre (q.x lateral, q.y
// posterior, q.z superior; mirrored for a right hip), negative inside, roughly a signed distance.

struct RoundCone {
  Vector3d a, b;
  double ra, rb;
  double sdf(const Vector3d& p) const {
    const Vector3d ab = b - a;
    const double t = clamp01((p - a).dot(ab) / ab.squaredNorm());
    return (p - (a + t * ab)).norm() - (ra + t * (rb - ra));
  }
};

class HipBone {
 public:
  HipBone(const Vector3d& centre, int lateralSign, double cupRadius)
      : centre_(centre), lateral_(lateralSign), cupRadius_(cupRadius) {
    // Acetabular axis out of the cup: radiographic inclination 45 deg, anteversion 17 deg.
    const double inclination = degrees(45.0), anteversion = degrees(17.0);
    axisQ_ = Vector3d(std::cos(anteversion) * std::sin(inclination), -std::sin(anteversion),
                      -std::cos(anteversion) * std::cos(inclination));
    rimOffset_ = -cupRadius_ * std::cos(degrees(kCoverageHalfAngleDeg));
    outerCentreQ_ = Vector3d(2.5, 0.0, 3.5);  // wall: roof ~14 mm, medial ~8 mm, else ~10 mm
    outerRadius_ = cupRadius_ + 10.5;
    const double a = degrees(30.0);
    wingNormal_ = Vector2d(-std::cos(a), -std::sin(a));  // toward the iliac fossa
    // Posterior column down to the ischial tuberosity and the ischial ramus; superior pubic ramus.
    rods_ = {RoundCone{{-12, 22, 22}, {-18, 30, -18}, 13, 12},
             RoundCone{{-18, 30, -18}, {-28, 30, -50}, 12, 14},
             RoundCone{{-28, 30, -50}, {-48, 8, -68}, 14, 8},
             RoundCone{{-18, -14, -6}, {-55, -26, -16}, 12, 9},
             RoundCone{{-55, -26, -16}, {-85, -30, -22}, 9, 9},
             RoundCone{{-48, 8, -68}, {-80, -24, -34}, 8, 9}};  // inferior ramus: obturator ring
  }

  static constexpr double kCoverageHalfAngleDeg = 88.0;

  Vector3d toQ(const Vector3d& p) const {
    return {lateral_ * (p.x() - centre_.x()), p.y() - centre_.y(), p.z() - centre_.z()};
  }
  Vector3d fromQ(const Vector3d& q) const {
    return {centre_.x() + lateral_ * q.x(), centre_.y() + q.y(), centre_.z() + q.z()};
  }
  Vector3d axisLps() const { return {lateral_ * axisQ_.x(), axisQ_.y(), axisQ_.z()}; }
  double cupRadius() const { return cupRadius_; }

  double sdf(const Vector3d& p) const { return sdfQ(toQ(p)); }

  double sdfQ(const Vector3d& q) const {
    const double r = q.norm();
    // Cup: a spherical shell cut by the rim plane (rounded rim).
    const double shell = std::max(cupRadius_ - r, (q - outerCentreQ_).norm() - outerRadius_);
    const double cup = smax(shell, q.dot(axisQ_) - rimOffset_, 3.0);
    double f = smin(cup, ilium(q), 8.0);
    for (const auto& rod : rods_)
      f = smin(f, rod.sdf(q), 8.0);
    // Nothing of the hip bone inside the articular sphere.
    return std::max(f, cupRadius_ - r);
  }

  // Inside the cup's coverage (not beyond the rim plane).
  bool coveredQ(const Vector3d& q) const { return q.dot(axisQ_) < rimOffset_ + 1.0; }
  double rimOffset() const { return rimOffset_; }
  const Vector3d& axisQ() const { return axisQ_; }

  // Bounds of the solid (generous), LPS.
  std::array<Vector3d, 2> boundsLps() const {
    Vector3d lo(-110, -75, -90), hi(75, 80, 105);  // q frame, covers every primitive + blends
    Vector3d a = fromQ(lo), b = fromQ(hi);
    return {a.cwiseMin(b), a.cwiseMax(b)};
  }

 private:
  // Ilium: a curved plate (an arc band in each axial plane) rising from the acetabular roof,
  // thick above the cup, thinning into the wing, flaring laterally and posteriorly.
  double ilium(const Vector3d& q) const {
    const double h = q.z();
    const double above = std::max(0.0, h - 35.0);
    const Vector2d mid(-4.0 + 0.45 * above, 6.0 + 0.15 * above);
    const double rho = 80.0;
    const Vector2d arcCentre = mid + rho * wingNormal_;
    const double thickness =
        22.0 - 17.5 * smoothstep(35.0, 58.0, h) + 5.0 * smoothstep(kTop - 35.0, kTop - 10.0, h);
    const double sPost = -(22.0 + 1.1 * std::max(0.0, h - 15.0));
    const double sAnt = 20.0 + 0.6 * std::max(0.0, h - 20.0);
    const Vector2d v = Vector2d(q.x(), q.y()) - arcCentre;
    const Vector2d outward = -wingNormal_;  // from the arc centre to `mid`
    const double cross = outward.x() * v.y() - outward.y() * v.x();
    const double s = -rho * std::atan2(cross, outward.dot(v));
    double d2;
    if (s >= sPost && s <= sAnt) {
      d2 = std::abs(v.norm() - rho) - 0.5 * thickness;
    } else {
      const double sEnd = s < sPost ? sPost : sAnt;
      const double angle = -sEnd / rho;  // back to the rotation used for s
      const Vector2d end =
          arcCentre + rho * Vector2d(outward.x() * std::cos(angle) - outward.y() * std::sin(angle),
                                     outward.x() * std::sin(angle) + outward.y() * std::cos(angle));
      d2 = (Vector2d(q.x(), q.y()) - end).norm() - 0.5 * thickness;
    }
    // The crest: highest over the middle of the wing.
    const double along = (s + 20.0) / 85.0;
    const double crest = kTop - 22.0 * std::min(1.5, along * along);
    return smax(smax(d2, h - crest, 8.0), kBottom - h, 6.0);
  }

  static constexpr double kTop = 96.0;     // iliac crest (its highest point) above the head centre
  static constexpr double kBottom = 12.0;  // the plate's lower end, inside the acetabular roof

  Vector3d centre_;
  double lateral_;
  double cupRadius_;
  Vector3d axisQ_;
  double rimOffset_;
  Vector3d outerCentreQ_;
  double outerRadius_;
  Vector2d wingNormal_;  // the wing runs along (sin a, -cos a): anterior-lateral
  std::vector<RoundCone> rods_;
};

// ---------------------------------------------------------------------------------------------
// Marching tetrahedra (Kuhn subdivision of a 0.5 mm grid) over the implicit, evaluated only in
// coarse blocks near its zero set: a closed, consistently wound, manifold surface.

struct Extraction {
  core::TriangleMesh mesh;
  Vector3d deepestLps = Vector3d::Zero();  // a coarse node of largest depth within `seedBox`
  double deepestDepth = -1.0;
};

template <class Field, class Allowed>
Extraction extractSurface(const Field& field, const std::array<Vector3d, 2>& box, double h,
                          const std::array<Vector3d, 2>& seedBox, const Allowed& seedAllowed) {
  constexpr int kBlock = 4;                                           // fine cells per coarse cell
  constexpr double kLipschitz = 2.5;                                  // safety bound of |grad f|
  const Vector3d origin = box[0] - Vector3d(0.0613, 0.0419, 0.0287);  // off the CT's columns
  std::array<int, 3> coarse{};
  for (int a = 0; a < 3; ++a)
    coarse[a] = static_cast<int>(std::ceil((box[1][a] - origin[a]) / (h * kBlock))) + 1;
  const int nx = coarse[0] * kBlock + 1, ny = coarse[1] * kBlock + 1;
  auto fine = [&](int i, int j, int k) -> Vector3d { return origin + h * Vector3d(i, j, k); };
  auto clampValue = [](double v) { return std::abs(v) < 1e-3 ? (v < 0.0 ? -1e-3 : 1e-3) : v; };

  Extraction out;
  // Coarse node values.
  const int cx = coarse[0] + 1, cy = coarse[1] + 1, cz = coarse[2] + 1;
  std::vector<float> cv(static_cast<std::size_t>(cx) * cy * cz);
  for (int k = 0; k < cz; ++k)
    for (int j = 0; j < cy; ++j)
      for (int i = 0; i < cx; ++i) {
        const Vector3d p = fine(i * kBlock, j * kBlock, k * kBlock);
        const double v = field(p);
        cv[(static_cast<std::size_t>(k) * cy + j) * cx + i] = static_cast<float>(v);
        if ((i == 0 || j == 0 || k == 0 || i == cx - 1 || j == cy - 1 || k == cz - 1) && v <= 0.0)
          throw std::logic_error("hip phantom: hip bone reaches its extraction box");
        if (-v > out.deepestDepth && (p.array() >= seedBox[0].array()).all() &&
            (p.array() <= seedBox[1].array()).all() && seedAllowed(p)) {
          out.deepestDepth = -v;
          out.deepestLps = p;
        }
      }
  auto coarseValue = [&](int i, int j, int k) {
    return cv[(static_cast<std::size_t>(k) * cy + j) * cx + i];
  };
  const double threshold = kLipschitz * 0.5 * std::sqrt(3.0) * h * kBlock;

  // Kuhn tetrahedra: corner bit 1 = +x, 2 = +y, 4 = +z; six paths from 0 to 7.
  static const int kPaths[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                   {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  std::unordered_map<std::uint64_t, int> edgeVertex;
  edgeVertex.reserve(1 << 20);
  auto nodeId = [&](int i, int j, int k) {
    return (static_cast<std::uint64_t>(k) * ny + j) * nx + i;
  };

  std::vector<float> layer(static_cast<std::size_t>(kBlock + 1) * ny * nx);
  std::vector<unsigned char> known(layer.size());
  std::vector<char> active(static_cast<std::size_t>(coarse[0]) * coarse[1]);
  for (int kc = 0; kc < coarse[2]; ++kc) {
    std::fill(known.begin(), known.end(), 0);
    bool any = false;
    for (int jc = 0; jc < coarse[1]; ++jc)
      for (int ic = 0; ic < coarse[0]; ++ic) {
        float m = std::numeric_limits<float>::infinity();
        for (int c = 0; c < 8; ++c)
          m = std::min(
              m, std::abs(coarseValue(ic + (c & 1), jc + ((c >> 1) & 1), kc + ((c >> 2) & 1))));
        const bool on = m <= threshold;
        active[static_cast<std::size_t>(jc) * coarse[0] + ic] = on;
        any = any || on;
      }
    if (!any)
      continue;
    auto value = [&](int i, int j, int kl) {
      const std::size_t index = (static_cast<std::size_t>(kl) * ny + j) * nx + i;
      if (!known[index]) {
        layer[index] = static_cast<float>(clampValue(field(fine(i, j, kc * kBlock + kl))));
        known[index] = 1;
      }
      return static_cast<double>(layer[index]);
    };
    for (int jc = 0; jc < coarse[1]; ++jc)
      for (int ic = 0; ic < coarse[0]; ++ic) {
        if (!active[static_cast<std::size_t>(jc) * coarse[0] + ic])
          continue;
        for (int kl = 0; kl < kBlock; ++kl)
          for (int jf = 0; jf < kBlock; ++jf)
            for (int iff = 0; iff < kBlock; ++iff) {
              const int i0 = ic * kBlock + iff, j0 = jc * kBlock + jf, k0 = kc * kBlock + kl;
              std::array<double, 8> val;
              bool inside = false, outside = false;
              for (int c = 0; c < 8; ++c) {
                val[c] = value(i0 + (c & 1), j0 + ((c >> 1) & 1), kl + ((c >> 2) & 1));
                (val[c] < 0.0 ? inside : outside) = true;
              }
              if (!inside || !outside)
                continue;
              auto vertexOn = [&](int ca, int cb) {
                // Kuhn edges join a corner to one with a superset of its bits.
                if ((ca & cb) != ca)
                  std::swap(ca, cb);
                const std::uint64_t key =
                    nodeId(i0 + (ca & 1), j0 + ((ca >> 1) & 1), k0 + ((ca >> 2) & 1)) * 8 +
                    static_cast<std::uint64_t>(cb & ~ca);
                auto found = edgeVertex.find(key);
                if (found != edgeVertex.end())
                  return found->second;
                const Vector3d pa = fine(i0 + (ca & 1), j0 + ((ca >> 1) & 1), k0 + ((ca >> 2) & 1));
                const Vector3d pb = fine(i0 + (cb & 1), j0 + ((cb >> 1) & 1), k0 + ((cb >> 2) & 1));
                const double t = val[ca] / (val[ca] - val[cb]);
                const int id = static_cast<int>(out.mesh.vertices.size());
                out.mesh.vertices.push_back(pa + t * (pb - pa));
                edgeVertex.emplace(key, id);
                return id;
              };
              auto corner = [&](int c) -> Vector3d {
                return fine(i0 + (c & 1), j0 + ((c >> 1) & 1), k0 + ((c >> 2) & 1));
              };
              auto emit = [&](int a, int b, int c, int cornerIn, int cornerOut) {
                const auto& va = out.mesh.vertices[a];
                const Vector3d n = (out.mesh.vertices[b] - va).cross(out.mesh.vertices[c] - va);
                if (n.dot(corner(cornerOut) - corner(cornerIn)) < 0.0)
                  std::swap(b, c);
                out.mesh.triangles.push_back({a, b, c});
              };
              for (const auto& path : kPaths) {
                int in[4], outs[4], nin = 0, nout = 0;
                for (int v = 0; v < 4; ++v)
                  (val[path[v]] < 0.0 ? in[nin++] : outs[nout++]) = path[v];
                if (nin == 0 || nout == 0)
                  continue;
                if (nin == 1) {
                  emit(vertexOn(in[0], outs[0]), vertexOn(in[0], outs[1]), vertexOn(in[0], outs[2]),
                       in[0], outs[0]);
                } else if (nout == 1) {
                  emit(vertexOn(in[0], outs[0]), vertexOn(in[1], outs[0]), vertexOn(in[2], outs[0]),
                       in[0], outs[0]);
                } else {
                  const int e00 = vertexOn(in[0], outs[0]), e01 = vertexOn(in[0], outs[1]);
                  const int e11 = vertexOn(in[1], outs[1]), e10 = vertexOn(in[1], outs[0]);
                  emit(e00, e01, e11, in[0], outs[0]);
                  emit(e00, e11, e10, in[0], outs[0]);
                }
              }
            }
      }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Ray casting along +z: inside intervals of a closed mesh over one column.

struct Intervals {
  bool ok = true;
  std::vector<std::pair<double, double>> spans;  // [enter z, exit z], increasing
};

Intervals columnIntervals(const core::MeshLocator& locator, double x, double y, double zFrom,
                          double zTo) {
  Intervals out;
  const Vector3d dir(0.0, 0.0, 1.0);
  for (int attempt = 0; attempt < 3; ++attempt) {
    const double dx = attempt * 1.37e-5, dy = attempt * 0.91e-5;
    const Vector3d origin(x + dx, y + dy, zFrom);
    const auto hits = locator.allHits(origin, dir, zTo - zFrom);
    out.spans.clear();
    out.ok = hits.size() % 2 == 0;
    for (std::size_t h = 0; out.ok && h + 1 < hits.size(); h += 2) {
      if (!hits[h].entering || hits[h + 1].entering)
        out.ok = false;
      else
        out.spans.emplace_back(zFrom + hits[h].t, zFrom + hits[h + 1].t);
    }
    if (out.ok)
      return out;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Signed depth of the femur (positive inside) on a 1 mm grid near its surface.

class DepthGrid {
 public:
  DepthGrid(const core::MeshLocator& locator, const Vector3d& lo, const Vector3d& hi,
            double spacing, double band)
      : origin_(lo), spacing_(spacing) {
    for (int a = 0; a < 3; ++a)
      n_[a] = std::max(2, static_cast<int>(std::ceil((hi[a] - lo[a]) / spacing)) + 1);
    const std::size_t count = static_cast<std::size_t>(n_[0]) * n_[1] * n_[2];
    std::vector<char> inside(count, 0);
    const double zFrom = core::bounds(locator.mesh())[0].z() - 1.0;
    const double zTo = origin_.z() + (n_[2] - 1) * spacing + 1.0;
    for (int j = 0; j < n_[1]; ++j)
      for (int i = 0; i < n_[0]; ++i) {
        const double x = origin_.x() + i * spacing, y = origin_.y() + j * spacing;
        const Intervals iv = columnIntervals(locator, x, y, zFrom, zTo);
        for (int k = 0; k < n_[2]; ++k) {
          const Vector3d p = origin_ + spacing * Vector3d(i, j, k);
          bool in = false;
          if (iv.ok) {
            for (const auto& s : iv.spans)
              in = in || (p.z() > s.first && p.z() < s.second);
          } else {
            in = locator.inside(p);
          }
          inside[index(i, j, k)] = in;
        }
      }
    depth_.assign(count, static_cast<float>(-band));
    for (int k = 0; k < n_[2]; ++k)
      for (int j = 0; j < n_[1]; ++j)
        for (int i = 0; i < n_[0]; ++i) {
          const bool in = inside[index(i, j, k)];
          bool needed = in;
          for (int dk = -1; !needed && dk <= 1; ++dk)
            for (int dj = -1; !needed && dj <= 1; ++dj)
              for (int di = -1; !needed && di <= 1; ++di) {
                const int a = i + di, b = j + dj, c = k + dk;
                if (a >= 0 && b >= 0 && c >= 0 && a < n_[0] && b < n_[1] && c < n_[2] &&
                    inside[index(a, b, c)])
                  needed = true;
              }
          if (!needed)
            continue;
          const Vector3d p = origin_ + spacing * Vector3d(i, j, k);
          const double d = locator.closest(p, band).distance;
          depth_[index(i, j, k)] = static_cast<float>(in ? d : -d);
        }
  }

  // Trilinear depth (clamped to the grid), mm.
  double depth(const Vector3d& p) const {
    const Vector3d g = (p - origin_) / spacing_;
    int c[3];
    double w[3];
    for (int a = 0; a < 3; ++a) {
      const double x = std::min(std::max(g[a], 0.0), n_[a] - 1.000001);
      c[a] = static_cast<int>(x);
      w[a] = x - c[a];
    }
    double v = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
      const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
      const double weight =
          (dx ? w[0] : 1 - w[0]) * (dy ? w[1] : 1 - w[1]) * (dz ? w[2] : 1 - w[2]);
      v += weight * depth_[index(c[0] + dx, c[1] + dy, c[2] + dz)];
    }
    return v;
  }

 private:
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i;
  }
  Vector3d origin_;
  double spacing_;
  int n_[3];
  std::vector<float> depth_;
};

// ---------------------------------------------------------------------------------------------
// In-plane Gaussian filtering of one slice (separable, edges replicated).

std::vector<double> gaussianKernel(double sigmaPx) {
  if (sigmaPx <= 1e-6)
    return {1.0};
  const int radius = std::max(1, static_cast<int>(std::ceil(3.5 * sigmaPx)));
  std::vector<double> k(2 * radius + 1);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    k[i + radius] = std::exp(-0.5 * (i / sigmaPx) * (i / sigmaPx));
    sum += k[i + radius];
  }
  for (auto& w : k)
    w /= sum;
  return k;
}

void filterSlice(float* slice, int nx, int ny, const std::vector<double>& kernel,
                 std::vector<float>& scratch) {
  const int radius = static_cast<int>(kernel.size()) / 2;
  if (radius == 0)
    return;
  scratch.resize(static_cast<std::size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      double s = 0.0;
      for (int d = -radius; d <= radius; ++d)
        s += kernel[d + radius] *
             slice[static_cast<std::size_t>(j) * nx + std::min(nx - 1, std::max(0, i + d))];
      scratch[static_cast<std::size_t>(j) * nx + i] = static_cast<float>(s);
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      double s = 0.0;
      for (int d = -radius; d <= radius; ++d)
        s += kernel[d + radius] *
             scratch[static_cast<std::size_t>(std::min(ny - 1, std::max(0, j + d))) * nx + i];
      slice[static_cast<std::size_t>(j) * nx + i] = static_cast<float>(s);
    }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

const char* hipTissueName(HipTissue tissue) {
  switch (tissue) {
    case HipTissue::kAir:
      return "air";
    case HipTissue::kFat:
      return "fat";
    case HipTissue::kMuscle:
      return "muscle";
    case HipTissue::kJoint:
      return "joint space";
    case HipTissue::kMarrow:
      return "marrow";
    case HipTissue::kFemurCancellous:
      return "femur cancellous";
    case HipTissue::kFemurCortex:
      return "femur cortex";
    case HipTissue::kFemurSubchondral:
      return "femur subchondral";
    case HipTissue::kHipCancellous:
      return "hip cancellous";
    case HipTissue::kHipCortex:
      return "hip cortex";
    case HipTissue::kHipSubchondral:
      return "hip subchondral";
    default:
      return "?";
  }
}

double hipTissueHu(HipTissue tissue, const HipPhantomOptions& o) {
  switch (tissue) {
    case HipTissue::kAir:
      return -1000.0;
    case HipTissue::kFat:
      return -100.0;
    case HipTissue::kMuscle:
      return 50.0;
    case HipTissue::kJoint:
      return 80.0;
    case HipTissue::kMarrow:
      return -20.0;
    case HipTissue::kFemurCancellous:
    case HipTissue::kHipCancellous:
      return o.cancellousHu;
    case HipTissue::kFemurCortex:
    case HipTissue::kHipCortex:
      return o.cortexHu;
    case HipTissue::kFemurSubchondral:
    case HipTissue::kHipSubchondral:
      return 0.5 * (o.cancellousHu + o.cortexHu);
    default:
      return 0.0;
  }
}

HipPhantom makeHipPhantom(const HipPhantomOptions& options) {
  validate(options);
  const HipPhantomOptions& o = options;

  // --- The femur: read, orient (head superior), place.
  core::TriangleMesh raw;
  try {
    raw = filters::readMesh(o.femurMesh);
  } catch (const std::exception& e) {
    throw std::invalid_argument("HipPhantomOptions.femurMesh: cannot read '" + o.femurMesh +
                                "': " + e.what());
  }
  {
    const core::MeshCheck check = core::checkMesh(raw);
    if (!check.closed())
      throw std::invalid_argument("HipPhantomOptions.femurMesh: '" + o.femurMesh +
                                  "' is not a closed surface: " + check.describe());
    if (check.volumeMm3 < 0.0)
      core::flipWinding(raw);
  }
  Vector3d mean = Vector3d::Zero();
  for (const auto& v : raw.vertices)
    mean += v;
  mean /= static_cast<double>(raw.vertices.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& v : raw.vertices)
    cov += (v - mean) * (v - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(cov);
  Vector3d longAxis = eigen.eigenvectors().col(2);
  if (longAxis.z() < 0.0)
    longAxis = -longAxis;
  const HeadFit endA = fitHeadAtEnd(raw, longAxis), endB = fitHeadAtEnd(raw, -longAxis);
  if (!endA.ok && !endB.ok)
    throw std::invalid_argument(
        "HipPhantomOptions.femurMesh: no femoral head (a sphere of "
        "radius 15-35 mm at an end) found in '" +
        o.femurMesh + "'");
  const bool useA = endA.ok && (!endB.ok || endA.coverage >= endB.coverage);
  const HeadFit& head = useA ? endA : endB;
  const Vector3d proximal = useA ? longAxis : Vector3d(-longAxis);

  // Rotation: the long axis kept when within 20 degrees of +z (its natural tilt), else turned
  // onto +z (a head-down mesh first turned 180 degrees about y).
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  if (proximal.z() < std::cos(degrees(20.0))) {
    if (proximal.z() < 0.0)
      rotation = Eigen::AngleAxisd(kPi, Vector3d::UnitY()).toRotationMatrix();
    const Vector3d turned = rotation * proximal;
    if (turned.z() < std::cos(degrees(20.0)))
      rotation = Eigen::Quaterniond::FromTwoVectors(turned, Vector3d::UnitZ()).toRotationMatrix() *
                 rotation;
  }
  const Vector3d neckAxis = (rotation * head.neckAxis).normalized();
  const int lateral = neckAxis.x() >= 0.0 ? 1 : -1;
  // Head centre: a left hip at x = +92 mm (LPS), a right one at -92.
  const Vector3d headCentre(lateral * 92.0, 8.0, -150.0);
  Eigen::Isometry3d place = Eigen::Isometry3d::Identity();
  place.linear() = rotation;
  place.translation() = headCentre - rotation * head.sphere.centre;

  HipPhantom phantom;
  phantom.femur = core::transformed(raw, place);
  phantom.headCentreLps = headCentre;
  phantom.headRadiusMm = head.sphere.radius;
  phantom.headFitRmsMm = head.sphere.rmsMm;
  phantom.neckAxisLps = neckAxis;
  phantom.shaftAxisLps = (rotation * proximal).normalized();
  phantom.lateralSign = lateral;
  const double headRadius = head.sphere.radius;
  const Vector3d shaftAxis = phantom.shaftAxisLps;

  // --- The cup radius: the head's farthest vertex within (and 12 degrees beyond) the cup's
  // coverage, plus the joint gap (plus 0.02 mm for the truth surface's chords).
  HipBone probe(headCentre, lateral, headRadius);
  const Vector3d cupAxis = probe.axisLps();
  double farthest = 0.0;
  {
    const double cosLimit = std::cos(degrees(HipBone::kCoverageHalfAngleDeg + 12.0));
    for (const auto& v : phantom.femur.vertices) {
      const Vector3d d = v - headCentre;
      const double r = d.norm();
      if (r < headRadius + 6.0 && -d.dot(cupAxis) > cosLimit * r)
        farthest = std::max(farthest, r);
    }
  }
  const double cupRadius = farthest + o.jointGapMm + 0.02;
  const HipBone hip(headCentre, lateral, cupRadius);
  phantom.cupRadiusMm = cupRadius;
  phantom.cupAxisLps = cupAxis;

  // --- Field of view: head, neck, trochanters and cup with >= 15 mm margin; z +-60 mm.
  const double zLow = headCentre.z() - 60.0, zHigh = headCentre.z() + 60.0;
  Vector3d lo = headCentre - Vector3d::Constant(cupRadius + 15.0);
  Vector3d hi = headCentre + Vector3d::Constant(cupRadius + 15.0);
  for (const auto& v : phantom.femur.vertices)
    if (v.z() >= zLow && v.z() <= zHigh) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  const double margin = 15.0;
  const double side = std::max(160.0, std::max(hi.x() - lo.x(), hi.y() - lo.y()) + 2.0 * margin);
  const int columns = static_cast<int>(std::ceil(side / o.pixelMm));
  const Vector2d fovCentre(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()));
  const Vector2d firstPixel(fovCentre.x() - 0.5 * (columns - 1) * o.pixelMm,
                            fovCentre.y() - 0.5 * (columns - 1) * o.pixelMm);
  const int slices = static_cast<int>(std::floor((zHigh - zLow) / o.sliceMm + 1e-9));
  const double slabBottom = zLow + o.zPhaseMm;
  const double slabTop = slabBottom + slices * o.sliceMm;

  core::CtImage& ct = phantom.ct;
  ct.dimensions = {columns, columns, slices};
  ct.originMm = Vector3d(firstPixel.x(), firstPixel.y(), slabBottom + 0.5 * o.sliceMm);
  ct.direction = Eigen::Matrix3d::Identity();
  ct.pixelSpacingMm = Vector2d(o.pixelMm, o.pixelMm);
  ct.slicePositionsMm.resize(slices);
  for (int k = 0; k < slices; ++k)
    ct.slicePositionsMm[k] = k * o.sliceMm;
  ct.groups = {core::CtSliceGroup{0, slices, o.sliceMm}};

  // --- The hip bone's truth surface (and its deepest point in the field of view: the seed).
  const Vector3d fovLo(firstPixel.x() - 0.5 * o.pixelMm, firstPixel.y() - 0.5 * o.pixelMm,
                       slabBottom);
  const Vector3d fovHi(fovLo.x() + columns * o.pixelMm, fovLo.y() + columns * o.pixelMm, slabTop);
  const std::array<Vector3d, 2> seedBox{fovLo + Vector3d(12, 12, 12), fovHi - Vector3d(12, 12, 12)};
  auto hipField = [&hip](const Vector3d& p) { return hip.sdf(p); };
  auto seedAllowed = [&hip, cupRadius](const Vector3d& p) {
    return (p - hip.fromQ(Vector3d::Zero())).norm() > cupRadius + 8.0;
  };
  Extraction extraction = extractSurface(hipField, hip.boundsLps(), 0.5, seedBox, seedAllowed);
  phantom.hip = std::move(extraction.mesh);
  {
    const core::MeshCheck check = core::checkMesh(phantom.hip);
    if (!check.closed() || check.volumeMm3 <= 0.0)
      throw std::logic_error("hip phantom: the hip surface is not closed: " + check.describe());
  }
  if (extraction.deepestDepth < 6.0)
    throw std::logic_error("hip phantom: no hip seed 6 mm deep in the field of view");
  phantom.hipSeedLps = extraction.deepestLps;
  phantom.femurSeedLps = headCentre;

  // Clearance of the femur from the hip bone, as the implicit sees it.
  {
    double m = std::numeric_limits<double>::infinity();
    const auto hb = hip.boundsLps();
    for (const auto& v : phantom.femur.vertices)
      if ((v.array() >= hb[0].array() - 1.0).all() && (v.array() <= hb[1].array() + 1.0).all())
        m = std::min(m, hip.sdf(v));
    phantom.minFemurToHipMm = m;
    if (m < o.jointGapMm - 0.05) {
      std::ostringstream os;
      os << "hip phantom: the hip bone comes within " << m << " mm of the femur (gap "
         << o.jointGapMm << ")";
      throw std::logic_error(os.str());
    }
  }

  // --- Locators, femur depth.
  const core::MeshLocator femurLocator(phantom.femur);
  const core::MeshLocator hipLocator(phantom.hip);
  const auto femurBounds = core::bounds(phantom.femur);
  const auto hipBounds = core::bounds(phantom.hip);
  const double band = 9.0;
  const DepthGrid femurDepth(femurLocator,
                             Vector3d(std::max(femurBounds[0].x(), fovLo.x()) - 2.0,
                                      std::max(femurBounds[0].y(), fovLo.y()) - 2.0,
                                      std::max(femurBounds[0].z(), fovLo.z()) - 2.0),
                             Vector3d(std::min(femurBounds[1].x(), fovHi.x()) + 2.0,
                                      std::min(femurBounds[1].y(), fovHi.y()) + 2.0,
                                      std::min(femurBounds[1].z(), fovHi.z()) + 2.0),
                             1.0, band);

  // --- Tissues.
  std::array<double, kTissueCount> tissueHu{};
  for (int t = 0; t < kTissueCount; ++t)
    tissueHu[t] = hipTissueHu(static_cast<HipTissue>(t), o);
  const double cosHeadZone = std::cos(degrees(48.0));
  auto femurTissue = [&](const Vector3d& p) {
    const double depth = std::max(0.0, femurDepth.depth(p));
    const Vector3d d = p - headCentre;
    const double r = d.norm();
    if (r > headRadius - 6.0 && d.dot(neckAxis) < cosHeadZone * r) {  // under the head's surface
      if (depth < 1.0)
        return HipTissue::kFemurCortex;
      return depth < 3.0 ? HipTissue::kFemurSubchondral : HipTissue::kFemurCancellous;
    }
    const double s = d.dot(shaftAxis);  // along the shaft, from the head centre
    const double cortex = 1.3 + 3.7 * clamp01((-38.0 - s) / 27.0);
    if (depth < cortex)
      return HipTissue::kFemurCortex;
    const double lining = 1.5 + 2.5 * std::max(0.0, s + 52.0);  // cancellous above the canal
    return depth > cortex + lining ? HipTissue::kMarrow : HipTissue::kFemurCancellous;
  };
  auto hipTissue = [&](const Vector3d& p) {
    const Vector3d q = hip.toQ(p);
    const double depth = std::max(0.0, -hip.sdfQ(q));
    const double articular = q.norm() - cupRadius;
    if (articular < 3.5 && hip.coveredQ(q))  // subchondral plate lining the cup
      return articular < 1.8 || depth < 1.3 ? HipTissue::kHipCortex : HipTissue::kHipSubchondral;
    return depth < 1.3 ? HipTissue::kHipCortex : HipTissue::kHipCancellous;
  };
  // Soft tissue outside the bones: the joint (cartilage, fluid, labrum) about the head, else
  // the body's column class.
  const double cartilageRadius = farthest + 1.5;
  const double labrumWidth = 5.0;
  auto jointTissue = [&](const Vector3d& p) {
    const Vector3d q = hip.toQ(p);
    const double r = q.norm();
    if (r < cupRadius && hip.coveredQ(q))
      return true;
    if (r < cartilageRadius && (p - headCentre).dot(neckAxis) < cosHeadZone * r)
      return true;
    // Labrum: a triangular ring on the rim.
    const double beyond = q.dot(hip.axisQ()) - hip.rimOffset();
    return r >= cupRadius - 1.0 && r < cupRadius + labrumWidth && beyond >= -1.0 &&
           beyond < labrumWidth - (r - cupRadius);
  };
  const double midline = headCentre.x() - lateral * 92.0;
  const Vector2d bodyCentre(midline, headCentre.y() + 5.0);
  auto bodyTissue = [&](double x, double y) {
    const double u = (x - bodyCentre.x()), v = (y - bodyCentre.y());
    const double skin = std::hypot(u / 180.0, v / 120.0);
    if (skin >= 1.0)
      return HipTissue::kAir;
    return std::hypot(u / 165.0, v / 105.0) >= 1.0 ? HipTissue::kFat : HipTissue::kMuscle;
  };

  // --- Partial volume: 3 x 3 columns per pixel, samples <= 0.5 mm apart through each slab.
  const int perSlab = static_cast<int>(std::ceil(o.sliceMm / 0.5 - 1e-9));
  const int samples = slices * perSlab;
  std::vector<double> zSample(samples);
  for (int k = 0; k < slices; ++k)
    for (int m = 0; m < perSlab; ++m)
      zSample[k * perSlab + m] = slabBottom + k * o.sliceMm + (m + 0.5) * o.sliceMm / perSlab;
  const std::size_t voxels = ct.voxelCount();
  std::vector<float> volume(voxels);
  phantom.tissue.assign(voxels, 0);
  phantom.purity.assign(voxels, 0);
  std::vector<std::uint16_t> counts(static_cast<std::size_t>(slices) * kTissueCount);
  std::vector<std::uint8_t> label(samples);
  const double jointReach = cupRadius + labrumWidth + 2.0;
  const double perVoxel = 9.0 * perSlab;

  for (int j = 0; j < columns; ++j)
    for (int i = 0; i < columns; ++i) {
      std::fill(counts.begin(), counts.end(), 0);
      for (int sj = -1; sj <= 1; ++sj)
        for (int si = -1; si <= 1; ++si) {
          const double x = firstPixel.x() + (i + si / 3.0) * o.pixelMm;
          const double y = firstPixel.y() + (j + sj / 3.0) * o.pixelMm;
          const HipTissue body = bodyTissue(x, y);
          std::fill(label.begin(), label.end(), static_cast<std::uint8_t>(body));
          const bool nearJoint = std::hypot(x - headCentre.x(), y - headCentre.y()) < jointReach;
          if (nearJoint)
            for (int g = 0; g < samples; ++g)
              if (std::abs(zSample[g] - headCentre.z()) < jointReach &&
                  jointTissue(Vector3d(x, y, zSample[g])))
                label[g] = static_cast<std::uint8_t>(HipTissue::kJoint);
          auto paint = [&](const core::MeshLocator& locator, const std::array<Vector3d, 2>& mb,
                           auto&& tissueAt, auto&& insideAt) {
            if (x < mb[0].x() || x > mb[1].x() || y < mb[0].y() || y > mb[1].y())
              return;
            const Intervals iv = columnIntervals(locator, x, y, mb[0].z() - 1.0, slabTop + 1.0);
            if (iv.ok) {
              std::size_t g = 0;
              for (const auto& span : iv.spans) {
                while (g < zSample.size() && zSample[g] <= span.first)
                  ++g;
                for (; g < zSample.size() && zSample[g] < span.second; ++g)
                  label[g] = static_cast<std::uint8_t>(tissueAt(Vector3d(x, y, zSample[g])));
              }
            } else {
              for (int g = 0; g < samples; ++g) {
                const Vector3d p(x, y, zSample[g]);
                if (insideAt(p))
                  label[g] = static_cast<std::uint8_t>(tissueAt(p));
              }
            }
          };
          paint(hipLocator, hipBounds, hipTissue,
                [&](const Vector3d& p) { return hip.sdf(p) < 0.0; });
          paint(femurLocator, femurBounds, femurTissue,
                [&](const Vector3d& p) { return femurLocator.inside(p); });
          for (int g = 0; g < samples; ++g)
            ++counts[static_cast<std::size_t>(g / perSlab) * kTissueCount + label[g]];
        }
      for (int k = 0; k < slices; ++k) {
        const std::uint16_t* c = &counts[static_cast<std::size_t>(k) * kTissueCount];
        double sum = 0.0;
        int best = 0;
        for (int t = 0; t < kTissueCount; ++t) {
          sum += c[t] * tissueHu[t];
          if (c[t] > c[best])
            best = t;
        }
        const std::size_t index = ct.index(i, j, k);
        volume[index] = static_cast<float>(sum / perVoxel);
        phantom.tissue[index] = static_cast<std::uint8_t>(best);
        phantom.purity[index] = static_cast<std::uint8_t>(std::lround(100.0 * c[best] / perVoxel));
      }
    }

  // --- Point spread, noise, int16.
  const std::vector<double> psf = gaussianKernel(o.psfSigmaMm / o.pixelMm);
  const std::vector<double> noiseKernel = gaussianKernel(o.noiseCorrelationMm / o.pixelMm);
  double energy = 0.0;
  for (double w : noiseKernel)
    energy += w * w;
  const double noiseScale = o.noiseHu / energy;  // 2-D kernel energy = energy^2
  const std::size_t perSlice = static_cast<std::size_t>(columns) * columns;
  std::vector<float> scratch, noise(perSlice);
  ct.hu.resize(voxels);
  for (int k = 0; k < slices; ++k) {
    float* slice = &volume[static_cast<std::size_t>(k) * perSlice];
    filterSlice(slice, columns, columns, psf, scratch);
    core::Rng rng = core::Rng::derive(o.seed, "hip-phantom-noise", static_cast<std::uint64_t>(k));
    for (auto& n : noise)
      n = static_cast<float>(rng.normal());
    filterSlice(noise.data(), columns, columns, noiseKernel, scratch);
    for (std::size_t v = 0; v < perSlice; ++v) {
      const double hu = slice[v] + noiseScale * noise[v];
      ct.hu[static_cast<std::size_t>(k) * perSlice + v] =
          static_cast<std::int16_t>(std::lround(std::min(3071.0, std::max(-1024.0, hu))));
    }
  }
  return phantom;
}

}  // namespace echoreg::test
