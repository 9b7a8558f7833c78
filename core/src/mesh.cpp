#include "echoreg/core/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace echoreg::core {

std::string MeshCheck::describe() const {
  if (triangles == 0)
    return "has no triangles";
  std::ostringstream text;
  std::vector<std::string> parts;
  auto add = [&parts](std::size_t count, const char* what) {
    if (count > 0)
      parts.push_back(std::to_string(count) + " " + what);
  };
  add(badIndices, "triangle indices outside the vertex list");
  add(boundaryEdges, "boundary edges (holes)");
  add(nonManifoldEdges, "non-manifold edges");
  add(inconsistentEdges, "edges with inconsistent winding");
  add(degenerateTriangles, "degenerate triangles");
  if (closed()) {
    text << "closed surface of " << triangles << " triangles";
    if (!parts.empty())
      text << " (with " << parts.front() << ")";
    return text.str();
  }
  text << "not a closed surface: ";
  for (std::size_t i = 0; i < parts.size(); ++i)
    text << (i > 0 ? ", " : "") << parts[i];
  return text.str();
}

MeshCheck checkMesh(const TriangleMesh& mesh) {
  MeshCheck check;
  check.vertices = mesh.vertices.size();
  check.triangles = mesh.triangles.size();
  const int vertexCount = static_cast<int>(mesh.vertices.size());
  // Directed edge (a, b) -> number of triangles traversing it that way.
  std::map<std::pair<int, int>, int> directed;
  for (const auto& tri : mesh.triangles) {
    if (std::any_of(tri.begin(), tri.end(), [&](int i) { return i < 0 || i >= vertexCount; })) {
      ++check.badIndices;
      continue;
    }
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(tri[2])];
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || cross.norm() == 0.0) {
      ++check.degenerateTriangles;
    }
    check.areaMm2 += 0.5 * cross.norm();
    check.volumeMm3 += a.dot(b.cross(c)) / 6.0;
    for (int k = 0; k < 3; ++k)
      ++directed[{tri[static_cast<std::size_t>(k)], tri[static_cast<std::size_t>((k + 1) % 3)]}];
  }
  for (const auto& [edge, count] : directed) {
    const auto [a, b] = edge;
    if (a > b && directed.count({b, a}) > 0)
      continue;  // counted from the other direction
    const auto reverse = directed.find({b, a});
    const int back = reverse == directed.end() ? 0 : reverse->second;
    const int total = count + back;
    if (total == 1) {
      ++check.boundaryEdges;
    } else if (total > 2) {
      ++check.nonManifoldEdges;
    } else if (count == 2 || back == 2) {
      ++check.inconsistentEdges;
    }
  }
  return check;
}

TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Isometry3d& transform) {
  TriangleMesh out;
  out.triangles = mesh.triangles;
  out.vertices.reserve(mesh.vertices.size());
  for (const Eigen::Vector3d& v : mesh.vertices)
    out.vertices.push_back(transform * v);
  return out;
}

void flipWinding(TriangleMesh& mesh) {
  for (auto& tri : mesh.triangles)
    std::swap(tri[1], tri[2]);
}

std::array<Eigen::Vector3d, 2> bounds(const TriangleMesh& mesh) {
  if (mesh.vertices.empty())
    return {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d low = mesh.vertices.front();
  Eigen::Vector3d high = low;
  for (const Eigen::Vector3d& v : mesh.vertices) {
    low = low.cwiseMin(v);
    high = high.cwiseMax(v);
  }
  return {low, high};
}

Eigen::Vector3d triangleNormal(const TriangleMesh& mesh, int index) {
  const auto& tri = mesh.triangles[static_cast<std::size_t>(index)];
  const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
  const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(tri[1])];
  const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(tri[2])];
  return (b - a).cross(c - a).normalized();
}

TriangleMesh uvSphere(const Eigen::Vector3d& centre, double radius, int rings, int segments) {
  if (!(radius > 0.0) || rings < 2 || segments < 3) {
    throw std::invalid_argument("uvSphere: needs radius > 0, rings >= 2 and segments >= 3");
  }
  constexpr double kPi = 3.14159265358979323846;
  TriangleMesh mesh;
  mesh.vertices.push_back(centre + Eigen::Vector3d(0, 0, radius));
  for (int r = 1; r < rings; ++r) {
    const double theta = kPi * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2.0 * kPi * s / segments;
      mesh.vertices.push_back(centre + radius * Eigen::Vector3d(std::sin(theta) * std::cos(phi),
                                                                std::sin(theta) * std::sin(phi),
                                                                std::cos(theta)));
    }
  }
  mesh.vertices.push_back(centre - Eigen::Vector3d(0, 0, radius));
  const int south = static_cast<int>(mesh.vertices.size()) - 1;
  const auto at = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s)
    mesh.triangles.push_back({0, at(1, s), at(1, s + 1)});
  for (int r = 1; r < rings - 1; ++r) {
    for (int s = 0; s < segments; ++s) {
      mesh.triangles.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      mesh.triangles.push_back({at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s) {
    mesh.triangles.push_back({south, at(rings - 1, s + 1), at(rings - 1, s)});
  }
  return mesh;
}

}  // namespace echoreg::core
