#include "echoreg/segmentation/surface_metrics.hpp"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace echoreg::segmentation {

namespace {

// `count` points on `mesh` uniformly by area, inside the slab.
std::vector<Eigen::Vector3d> samplePoints(const core::TriangleMesh& mesh, int count, double zMin,
                                          double zMax, core::Rng& rng) {
  std::vector<double> cumulative;
  std::vector<int> triangles;
  double total = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(tri[2])];
    const double lo = std::min({a.z(), b.z(), c.z()}), hi = std::max({a.z(), b.z(), c.z()});
    if (hi < zMin || lo > zMax)
      continue;
    total += 0.5 * (b - a).cross(c - a).norm();
    cumulative.push_back(total);
    triangles.push_back(static_cast<int>(t));
  }
  std::vector<Eigen::Vector3d> points;
  if (total <= 0.0)
    return points;
  int attempts = 0;
  while (static_cast<int>(points.size()) < count && attempts < 20 * count) {
    ++attempts;
    const double r = rng.uniform() * total;
    const std::size_t pick = static_cast<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), r) - cumulative.begin());
    const auto& tri =
        mesh.triangles[static_cast<std::size_t>(triangles[std::min(pick, triangles.size() - 1)])];
    double u = rng.uniform(), v = rng.uniform();
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d p = a + u * (mesh.vertices[static_cast<std::size_t>(tri[1])] - a) +
                              v * (mesh.vertices[static_cast<std::size_t>(tri[2])] - a);
    if (p.z() < zMin || p.z() > zMax)
      continue;
    points.push_back(p);
  }
  return points;
}

// Length of the solid along the ray (x, y) inside [zMin, zMax], as intervals.
std::vector<std::pair<double, double>> insideIntervals(const core::MeshLocator& locator, double x,
                                                       double y, double zStart, double zMin,
                                                       double zMax) {
  const Eigen::Vector3d origin(x, y, zStart);
  const auto hits = locator.allHits(origin, Eigen::Vector3d::UnitZ());
  std::vector<std::pair<double, double>> intervals;
  for (std::size_t h = 0; h + 1 < hits.size(); h += 2) {
    const double a = std::max(zStart + hits[h].t, zMin);
    const double b = std::min(zStart + hits[h + 1].t, zMax);
    if (b > a)
      intervals.emplace_back(a, b);
  }
  return intervals;
}

double overlap(const std::vector<std::pair<double, double>>& a,
               const std::vector<std::pair<double, double>>& b) {
  double total = 0.0;
  for (const auto& p : a) {
    for (const auto& q : b)
      total += std::max(0.0, std::min(p.second, q.second) - std::max(p.first, q.first));
  }
  return total;
}

double length(const std::vector<std::pair<double, double>>& a) {
  double total = 0.0;
  for (const auto& p : a)
    total += p.second - p.first;
  return total;
}

}  // namespace

SurfaceComparison compareSurfaces(const core::TriangleMesh& estimate,
                                  const core::TriangleMesh& truth,
                                  const SurfaceComparisonOptions& options) {
  if (estimate.empty() || truth.empty())
    throw std::invalid_argument("compareSurfaces: a mesh is empty");
  const core::MeshLocator estimateLocator(estimate);
  const core::MeshLocator truthLocator(truth);
  core::Rng rng = core::Rng::derive(options.seed, "surface-comparison");
  const auto onEstimate =
      samplePoints(estimate, options.samplesPerSurface, options.zMinMm, options.zMaxMm, rng);
  const auto onTruth =
      samplePoints(truth, options.samplesPerSurface, options.zMinMm, options.zMaxMm, rng);
  if (onEstimate.empty() || onTruth.empty()) {
    throw std::invalid_argument("compareSurfaces: a surface has nothing inside the z slab");
  }
  SurfaceComparison c;
  std::vector<double> all;
  double sumA = 0.0, sumB = 0.0;
  for (const auto& p : onEstimate) {
    const double d = truthLocator.closest(p).distance;
    sumA += d;
    all.push_back(d);
  }
  for (const auto& p : onTruth) {
    const double d = estimateLocator.closest(p).distance;
    sumB += d;
    all.push_back(d);
  }
  c.meanEstimateToTruthMm = sumA / static_cast<double>(onEstimate.size());
  c.meanTruthToEstimateMm = sumB / static_cast<double>(onTruth.size());
  c.meanMm = (sumA + sumB) / static_cast<double>(all.size());
  std::sort(all.begin(), all.end());
  c.p95Mm = all[std::min(all.size() - 1,
                         static_cast<std::size_t>(0.95 * static_cast<double>(all.size())))];
  c.maxMm = all.back();

  // Dice along rays parallel to z on a grid over both meshes' bounds (offset so that rays do not
  // run through grid-aligned vertices).
  const auto be = core::bounds(estimate);
  const auto bt = core::bounds(truth);
  const Eigen::Vector3d lo = be[0].cwiseMin(bt[0]), hi = be[1].cwiseMax(bt[1]);
  const double step = options.diceStepMm;
  const double zStart = lo.z() - 1.0;
  const double zMin = std::max(options.zMinMm, lo.z() - 1.0),
               zMax = std::min(options.zMaxMm, hi.z() + 1.0);
  double both = 0.0, sumE = 0.0, sumT = 0.0;
  for (double y = lo.y() + 0.3183 * step; y < hi.y(); y += step) {
    for (double x = lo.x() + 0.2719 * step; x < hi.x(); x += step) {
      const auto a = insideIntervals(estimateLocator, x, y, zStart, zMin, zMax);
      const auto b = insideIntervals(truthLocator, x, y, zStart, zMin, zMax);
      sumE += length(a);
      sumT += length(b);
      both += overlap(a, b);
    }
  }
  c.volumeEstimateMm3 = sumE * step * step;
  c.volumeTruthMm3 = sumT * step * step;
  c.dice = sumE + sumT > 0.0 ? 2.0 * both / (sumE + sumT) : 0.0;
  return c;
}

}  // namespace echoreg::segmentation
