#include "mesh_test_support.hpp"

#include "echoreg/core/mesh_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <utility>
#include <vector>

namespace echoreg::test {

namespace {

const Eigen::Vector3d& corner(const core::TriangleMesh& mesh, const std::array<int, 3>& tri,
                              int k) {
  return mesh.vertices[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])];
}

double segmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                       const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double s = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

}  // namespace

core::TriangleMesh icosphere(double radiusMm, int subdivisions, const Eigen::Vector3d& centre) {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> unit = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                                       {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                                       {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  for (auto& v : unit)
    v.normalize();
  std::vector<std::array<int, 3>> faces = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<int, int>, int> midpoints;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto found = midpoints.find(key);
      if (found != midpoints.end())
        return found->second;
      // Normalising a + b keeps antipodal symmetry exact: the mirror edge gives -(a + b).
      unit.push_back(
          (unit[static_cast<std::size_t>(a)] + unit[static_cast<std::size_t>(b)]).normalized());
      const int index = static_cast<int>(unit.size()) - 1;
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<int, 3>> finer;
    finer.reserve(faces.size() * 4);
    for (const auto& f : faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }
  core::TriangleMesh mesh;
  mesh.vertices.reserve(unit.size());
  for (const auto& v : unit)
    mesh.vertices.push_back(centre + radiusMm * v);
  mesh.triangles = std::move(faces);
  return mesh;
}

core::TriangleMesh cube(double sizeMm) {
  core::TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back((i & 1) ? sizeMm : 0.0, (i & 2) ? sizeMm : 0.0,
                               (i & 4) ? sizeMm : 0.0);
  }
  // Vertex index = x + 2y + 4z; each quad counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

double bruteClosestDistance(const core::TriangleMesh& mesh, const Eigen::Vector3d& point) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d& a = corner(mesh, tri, 0);
    const Eigen::Vector3d& b = corner(mesh, tri, 1);
    const Eigen::Vector3d& c = corner(mesh, tri, 2);
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.squaredNorm() > 0.0) {
      const Eigen::Vector3d unit = n.normalized();
      const Eigen::Vector3d foot = point - unit.dot(point - a) * unit;
      // Inside when the three sub-triangles have the orientation of the triangle.
      if ((b - a).cross(foot - a).dot(n) >= 0.0 && (c - b).cross(foot - b).dot(n) >= 0.0 &&
          (a - c).cross(foot - c).dot(n) >= 0.0) {
        best = std::min(best, std::abs(unit.dot(point - a)));
        continue;
      }
    }
    best = std::min({best, segmentDistance(point, a, b), segmentDistance(point, b, c),
                     segmentDistance(point, c, a)});
  }
  return best;
}

std::optional<BruteHit> bruteFirstHit(const core::TriangleMesh& mesh, const Eigen::Vector3d& origin,
                                      const Eigen::Vector3d& direction) {
  std::optional<BruteHit> best;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& tri = mesh.triangles[i];
    const Eigen::Vector3d& a = corner(mesh, tri, 0);
    const Eigen::Vector3d& b = corner(mesh, tri, 1);
    const Eigen::Vector3d& c = corner(mesh, tri, 2);
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double along = n.dot(direction);
    if (along == 0.0)
      continue;
    const double t = n.dot(a - origin) / along;
    if (!(t > 0.0))
      continue;
    const Eigen::Vector3d x = origin + t * direction;
    if ((b - a).cross(x - a).dot(n) < 0.0 || (c - b).cross(x - b).dot(n) < 0.0 ||
        (a - c).cross(x - c).dot(n) < 0.0) {
      continue;
    }
    if (!best || t < best->t)
      best = BruteHit{t, static_cast<int>(i)};
  }
  return best;
}

double windingNumber(const core::TriangleMesh& mesh, const Eigen::Vector3d& point) {
  double sum = 0.0;
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = corner(mesh, tri, 0) - point;
    const Eigen::Vector3d b = corner(mesh, tri, 1) - point;
    const Eigen::Vector3d c = corner(mesh, tri, 2) - point;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    sum += 2.0 * std::atan2(numerator, denominator);
  }
  return sum / (4.0 * 3.14159265358979323846);
}

std::optional<Eigen::Vector3d> insidePointNearCentroid(const core::TriangleMesh& mesh, double z,
                                                       double depthMm) {
  const core::MeshLocator locator(mesh);
  const auto b = core::bounds(mesh);
  std::vector<Eigen::Vector3d> inside;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (double y = b[0].y(); y <= b[1].y(); y += 1.0) {
    for (double x = b[0].x(); x <= b[1].x(); x += 1.0) {
      if (locator.signedDistance({x, y, z}) < -depthMm) {
        inside.emplace_back(x, y, z);
        sum += inside.back();
      }
    }
  }
  if (inside.empty())
    return std::nullopt;
  const Eigen::Vector3d c = sum / static_cast<double>(inside.size());
  Eigen::Vector3d best = inside.front();
  for (const auto& p : inside) {
    if ((p - c).norm() < (best - c).norm())
      best = p;
  }
  return best;
}

}  // namespace echoreg::test
