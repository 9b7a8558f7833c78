// Signed distance primitives and their smooth combinations (after Inigo Quilez's distance-function
// notes), and the mesher that turns an implicit surface into a closed triangle mesh: the
// procedural bones are built from these. Negative inside, positive outside, in mm.
#pragma once

#include "echoreg/core/mesh.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <string>

namespace echoreg::simulation::sdf {

/// An implicit surface: signed distance (or a close bound of it) at a point, mm.
using Field = std::function<double(const Eigen::Vector3d&)>;

/// Sphere of `radiusMm` about `centre`.
inline double sphere(const Eigen::Vector3d& p, const Eigen::Vector3d& centre, double radiusMm) {
  return (p - centre).norm() - radiusMm;
}

/// Capsule: the points within `radiusMm` of the segment a-b.
inline double capsule(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      double radiusMm) {
  const Eigen::Vector3d ab = b - a;
  const double h = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - a - h * ab).norm() - radiusMm;
}

/// Tapered capsule ("round cone"): spheres of radius ra at a and rb at b and the cone tangent to
/// both. Exact distance (Quilez's sdRoundCone with arbitrary end points).
inline double roundCone(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b, double ra, double rb) {
  const Eigen::Vector3d ba = b - a;
  const double l2 = ba.squaredNorm();
  const double rr = ra - rb;
  const double a2 = l2 - rr * rr;
  const double il2 = 1.0 / l2;
  const Eigen::Vector3d pa = p - a;
  const double y = pa.dot(ba);
  const double z = y - l2;
  const double x2 = (pa * l2 - ba * y).squaredNorm();
  const double y2 = y * y * l2;
  const double z2 = z * z * l2;
  const double k = (rr > 0.0 ? 1.0 : (rr < 0.0 ? -1.0 : 0.0)) * rr * rr * x2;
  if ((z > 0.0 ? 1.0 : -1.0) * a2 * z2 > k)
    return std::sqrt(x2 + z2) * il2 - rb;
  if ((y > 0.0 ? 1.0 : -1.0) * a2 * y2 < k)
    return std::sqrt(x2 + y2) * il2 - ra;
  return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - ra;
}

/// Ellipsoid with semi-axes `radiiMm` along the columns of `axes` (a rotation), about `centre`.
/// Quilez's bound: exact on the surface, a close under-estimate elsewhere.
inline double ellipsoid(const Eigen::Vector3d& p, const Eigen::Vector3d& centre,
                        const Eigen::Matrix3d& axes, const Eigen::Vector3d& radiiMm) {
  const Eigen::Vector3d q = axes.transpose() * (p - centre);
  const double k0 = q.cwiseQuotient(radiiMm).norm();
  const double k1 = q.cwiseQuotient(radiiMm.cwiseProduct(radiiMm)).norm();
  if (k1 == 0.0)
    return -radiiMm.minCoeff();
  return k0 * (k0 - 1.0) / k1;
}

/// Axis-aligned ellipsoid.
inline double ellipsoid(const Eigen::Vector3d& p, const Eigen::Vector3d& centre,
                        const Eigen::Vector3d& radiiMm) {
  return ellipsoid(p, centre, Eigen::Matrix3d::Identity(), radiiMm);
}

/// Half-space below the plane through `point` with outward unit normal `normal`.
inline double halfSpace(const Eigen::Vector3d& p, const Eigen::Vector3d& point,
                        const Eigen::Vector3d& normal) {
  return (p - point).dot(normal);
}

/// Polynomial smooth minimum (union) with blend width `k` mm; k <= 0 is the plain minimum.
inline double smoothUnion(double a, double b, double k) {
  if (k <= 0.0)
    return std::min(a, b);
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

/// Smooth maximum (intersection) with blend width `k` mm.
inline double smoothIntersection(double a, double b, double k) {
  return -smoothUnion(-a, -b, k);
}

/// Smooth subtraction of b from a with blend width `k` mm.
inline double smoothSubtraction(double a, double b, double k) {
  return smoothIntersection(a, -b, k);
}

/// Central-difference gradient of `field` at p with step `stepMm`.
Eigen::Vector3d gradient(const Field& field, const Eigen::Vector3d& p, double stepMm);

/// The surface point where the ray from `inside` (a point with field < 0) along `direction`
/// leaves the surface (first sign change, refined by bisection to 1e-6 mm). Throws
/// std::invalid_argument when `inside` is not inside or the ray does not leave within
/// `maxDistanceMm`.
Eigen::Vector3d rayExit(const Field& field, const Eigen::Vector3d& inside,
                        const Eigen::Vector3d& direction, double maxDistanceMm = 300.0);

/// Meshes the zero level of `field` inside `box` (which must contain the whole solid with a
/// margin: the field must be positive on the box's faces, else std::invalid_argument):
/// samples on a grid of `spacingMm`, contours with vtkFlyingEdges3D, then moves every vertex onto
/// the zero level by `newtonSteps` Newton steps along the gradient so that the surface follows
/// the field and not the grid. A surface of more than `maxTriangles` (0: no limit) is first
/// decimated to about that many (vtkQuadricDecimation) and projected the same way. The result is
/// closed, wound outward (positive volume); throws std::runtime_error naming `what` otherwise.
/// Deterministic: same inputs, same bytes.
core::TriangleMesh meshField(const Field& field, const Eigen::AlignedBox3d& box, double spacingMm,
                             const std::string& what, std::size_t maxTriangles = 300000,
                             int newtonSteps = 4);

/// Tight bounds of {field < 0} inside `searchBox`, from a coarse grid of `stepMm` and padded by
/// `padMm` (plus a grid cell) so that the result can be given to meshField.
Eigen::AlignedBox3d solidBounds(const Field& field, const Eigen::AlignedBox3d& searchBox,
                                double stepMm, double padMm);

}  // namespace echoreg::simulation::sdf
