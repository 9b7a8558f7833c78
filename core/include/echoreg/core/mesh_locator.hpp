// Exact ray and closest-point queries on a triangle mesh, through a bounding volume hierarchy
// built once per mesh. Used by the simulator (beams against bones, CT voxelisation) and by the
// registration (closest points on the triangles, Eq. 4.4). Queries are const and thread-safe.
//
// The hierarchy is a binned-SAH bounding volume hierarchy over the triangles (leaves of at most
// 4), built once in one flat node array; the same mesh always gives the same tree, and every
// answer is independent of the tree (ties go to the lowest triangle index). Ray tests are
// Moller-Trumbore in double with both sides counting; a ray through a shared edge or vertex is
// one crossing (hits within 1e-9 mm on triangles sharing a vertex are merged), and a ray that
// only touches the surface there (a silhouette edge or vertex: the triangles disagree on the
// side) is no crossing. A ray lying in a triangle's plane does not hit that triangle.
#pragma once

#include "echoreg/core/mesh.hpp"

#include <memory>
#include <optional>
#include <vector>

namespace echoreg::core {

struct RayHit {
  double t = 0.0;          ///< distance along the ray (the direction is unit), mm
  Eigen::Vector3d point;   ///< origin + t * direction
  Eigen::Vector3d normal;  ///< the triangle's unit outward normal
  int triangle = -1;
  bool entering = false;  ///< the ray goes from outside to inside here (dot(dir, normal) < 0)
};

struct ClosestPoint {
  Eigen::Vector3d point;  ///< nearest point on the triangles
  double distance = 0.0;  ///< unsigned, mm
  int triangle = -1;
  /// Barycentric coordinates of `point` in `triangle` (weights of its three vertices).
  Eigen::Vector3d barycentric;
};

class MeshLocator {
 public:
  /// Builds the hierarchy (the mesh is copied). Deterministic: same mesh, same tree. Zero-area
  /// triangles are kept for closest() but never hit. Throws std::invalid_argument naming the
  /// triangle or vertex when an index is outside the vertex list or a vertex is not finite.
  explicit MeshLocator(TriangleMesh mesh);
  ~MeshLocator();
  MeshLocator(MeshLocator&&) noexcept;
  MeshLocator& operator=(MeshLocator&&) noexcept;
  MeshLocator(const MeshLocator&) = delete;
  MeshLocator& operator=(const MeshLocator&) = delete;

  const TriangleMesh& mesh() const;

  /// First intersection with t in (tMin, tMax]; `direction` must be unit length (within 1e-6,
  /// else std::invalid_argument). Equals allHits(...).front().
  std::optional<RayHit> firstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                 double tMax = 1e30, double tMin = 0.0) const;
  /// Every intersection with t in (tMin, tMax], sorted by t.
  std::vector<RayHit> allHits(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                              double tMax = 1e30, double tMin = 0.0) const;

  /// Nearest point on the surface. `maxDistance` prunes the search: when nothing lies within it,
  /// the result has triangle == -1 and distance == maxDistance.
  ClosestPoint closest(const Eigen::Vector3d& point, double maxDistance = 1e30) const;

  /// Inside the closed surface: the majority of the crossing parities along three fixed
  /// directions (none along an axis), so one ray grazing an edge cannot flip the answer.
  bool inside(const Eigen::Vector3d& point) const;

  /// Distance to the surface, negative inside (closed meshes only): closest() and inside().
  double signedDistance(const Eigen::Vector3d& point) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace echoreg::core
