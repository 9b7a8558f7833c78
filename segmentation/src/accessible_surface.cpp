#include "echoreg/segmentation/accessible_surface.hpp"

#include "echoreg/core/markups.hpp"
#include "echoreg/core/mesh_locator.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace echoreg::segmentation {

AccessibleSurface accessibleSurface(const core::TriangleMesh& surface,
                                    const AccessibleSurfaceOptions& options) {
  if (surface.empty())
    throw std::invalid_argument("the surface is empty");
  if (!(options.maxAngleDeg > 0.0 && options.maxAngleDeg <= 90.0)) {
    throw std::invalid_argument(
        fmt::format("the beam angle must be in (0, 90] degrees, got {}", options.maxAngleDeg));
  }
  std::vector<Eigen::Vector3d> views;
  for (const Eigen::Vector3d& v : options.viewDirections) {
    if (!(v.norm() > 1e-12) || !v.allFinite())
      throw std::invalid_argument("a view direction is zero or not finite");
    views.push_back(v.normalized());
  }
  for (const SurfaceRegion& r : options.regions) {
    if (!(r.radiusMm > 0.0)) {
      throw std::invalid_argument(
          fmt::format("region '{}' has radius {} mm (must be > 0)", r.label, r.radiusMm));
    }
  }
  const double cosMax = std::cos(options.maxAngleDeg * M_PI / 180.0);
  std::unique_ptr<core::MeshLocator> locator;
  if (!views.empty())
    locator = std::make_unique<core::MeshLocator>(surface);
  AccessibleSurface out;
  double total = 0.0;
  std::vector<int> newIndex(surface.vertices.size(), -1);
  for (std::size_t t = 0; t < surface.triangles.size(); ++t) {
    const auto& tri = surface.triangles[t];
    const Eigen::Vector3d& a = surface.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d& b = surface.vertices[static_cast<std::size_t>(tri[1])];
    const Eigen::Vector3d& c = surface.vertices[static_cast<std::size_t>(tri[2])];
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    total += area;
    if (area <= 0.0)
      continue;
    const Eigen::Vector3d centroid = (a + b + c) / 3.0;
    const Eigen::Vector3d normal = cross.normalized();
    bool keep = options.regions.empty();
    for (const SurfaceRegion& r : options.regions) {
      if ((centroid - r.centreLps).norm() <= r.radiusMm) {
        keep = true;
        break;
      }
    }
    if (keep && !views.empty()) {
      keep = false;
      for (const Eigen::Vector3d& v : views) {
        if (normal.dot(v) < cosMax)
          continue;
        // Nothing of the surface in front of the triangle along v (a ray from just above it).
        if (!locator->firstHit(centroid + 1e-3 * v, v)) {
          keep = true;
          break;
        }
      }
    }
    if (!keep)
      continue;
    std::array<int, 3> nt{};
    for (int k = 0; k < 3; ++k) {
      const int vtx = tri[static_cast<std::size_t>(k)];
      if (newIndex[static_cast<std::size_t>(vtx)] < 0) {
        newIndex[static_cast<std::size_t>(vtx)] = static_cast<int>(out.mesh.vertices.size());
        out.mesh.vertices.push_back(surface.vertices[static_cast<std::size_t>(vtx)]);
      }
      nt[static_cast<std::size_t>(k)] = newIndex[static_cast<std::size_t>(vtx)];
    }
    out.mesh.triangles.push_back(nt);
    out.keptTriangles.push_back(static_cast<int>(t));
    out.areaMm2 += area;
  }
  if (out.mesh.empty()) {
    throw std::invalid_argument(
        "no triangle of the surface lies in the given regions and faces the given directions");
  }
  out.fractionOfArea = total > 0.0 ? out.areaMm2 / total : 0.0;
  return out;
}

std::vector<SurfaceRegion> readSurfaceRegions(const std::string& path, double radiusMm) {
  std::vector<SurfaceRegion> regions;
  for (const core::MarkupPoint& p : core::readMarkupPoints(path)) {
    regions.push_back({p.label, p.positionLps, radiusMm});
  }
  return regions;
}

}  // namespace echoreg::segmentation
