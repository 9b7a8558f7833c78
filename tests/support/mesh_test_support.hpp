// Meshes and brute-force references for the mesh locator's tests and benchmark: an icosphere, a
// cube, and closest-point, ray and inside tests over every triangle, written independently of
// core/src/mesh_locator.cpp (other formulas, no hierarchy).
#pragma once

#include "echoreg/core/mesh.hpp"

#include <optional>

namespace echoreg::test {

/// Icosahedron subdivided `subdivisions` times (20 * 4^n triangles), vertices on the sphere of
/// `radiusMm` about `centre`, wound outward. Antipodal vertices are exact negatives of each other.
core::TriangleMesh icosphere(double radiusMm, int subdivisions,
                             const Eigen::Vector3d& centre = Eigen::Vector3d::Zero());

/// The cube [0, sizeMm]^3: 8 vertices, 12 triangles (each face split along one diagonal).
core::TriangleMesh cube(double sizeMm);

/// Brute-force closest distance: the foot on the triangle's plane when it lies inside the
/// triangle (by signed areas), else the nearest point on the three edges.
double bruteClosestDistance(const core::TriangleMesh& mesh, const Eigen::Vector3d& point);

/// A brute-force ray hit: the smallest t > 0 over all triangles (plane intersection, then the
/// point-in-triangle test by the signs of the edge cross products).
struct BruteHit {
  double t = 0.0;
  int triangle = -1;
};
std::optional<BruteHit> bruteFirstHit(const core::TriangleMesh& mesh, const Eigen::Vector3d& origin,
                                      const Eigen::Vector3d& direction);

/// Generalised winding number (sum of solid angles / 4 pi, Van Oosterom and Strackee): about 1
/// inside a closed outward-wound surface, about 0 outside.
double windingNumber(const core::TriangleMesh& mesh, const Eigen::Vector3d& point);

/// A seed inside a closed mesh: on a 1 mm grid of its section at height z, the point at least
/// `depthMm` inside that lies nearest the centroid of all such points; nullopt when none is.
std::optional<Eigen::Vector3d> insidePointNearCentroid(const core::TriangleMesh& mesh, double z,
                                                       double depthMm = 3.0);

}  // namespace echoreg::test
