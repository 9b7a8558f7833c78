// Triangle meshes without VTK: the bone surfaces that the simulator, the closest-point search and
// the registration share. Vertices in mm; triangles wound counter-clockwise seen from outside
// (normals point out of a closed surface).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <string>
#include <vector>

namespace echoreg::core {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;

  bool empty() const { return triangles.empty(); }
};

/// What checkMesh found. A closed, consistently oriented 2-manifold has zero boundary and
/// non-manifold edges, no flipped edge pairs, no degenerate triangles and positive volume.
struct MeshCheck {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t boundaryEdges = 0;        ///< edges used by one triangle (holes)
  std::size_t nonManifoldEdges = 0;     ///< edges used by three or more triangles
  std::size_t inconsistentEdges = 0;    ///< edges whose two triangles traverse them the same way
  std::size_t degenerateTriangles = 0;  ///< zero area or repeated vertex indices
  std::size_t badIndices = 0;           ///< triangle indices outside the vertex list
  double volumeMm3 = 0.0;               ///< signed volume (divergence theorem)
  double areaMm2 = 0.0;

  bool closed() const {
    return badIndices == 0 && boundaryEdges == 0 && nonManifoldEdges == 0 &&
           inconsistentEdges == 0 && triangles > 0;
  }
  /// One sentence for an error message, e.g. "not closed: 12 boundary edges, 2 non-manifold edges".
  std::string describe() const;
};

MeshCheck checkMesh(const TriangleMesh& mesh);

/// The mesh with every vertex mapped by `transform` (winding kept: rigid transforms only).
TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Isometry3d& transform);

/// Reverses every triangle's winding (for meshes whose volume comes out negative).
void flipWinding(TriangleMesh& mesh);

/// Axis-aligned bounds {min, max}; both zero for an empty mesh.
std::array<Eigen::Vector3d, 2> bounds(const TriangleMesh& mesh);

/// Unit normal of triangle `index` (from its winding).
Eigen::Vector3d triangleNormal(const TriangleMesh& mesh, int index);

/// A closed latitude-longitude sphere wound outward (the calibration sphere in figures, test
/// shapes): `rings` >= 2 bands from pole to pole, `segments` >= 3 around. Throws
/// std::invalid_argument for a radius <= 0 or too few rings or segments.
TriangleMesh uvSphere(const Eigen::Vector3d& centre, double radius, int rings = 36,
                      int segments = 72);

}  // namespace echoreg::core
