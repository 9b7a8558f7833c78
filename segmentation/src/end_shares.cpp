#include "echoreg/segmentation/end_shares.hpp"

#include "echoreg/segmentation/section_closing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace echoreg::segmentation {

namespace {

std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

// One slice's section: its in-plane signed distance on the box (mm, negative inside) and its
// deepest inside distance.
struct Section {
  bool present = false;
  std::vector<float> distanceMm;
  double deepestMm = 0.0;
};

constexpr int kSamplesPerSlab = 40;

}  // namespace

std::vector<VoxelShare> zEndShares(const VoxelMask& region, const VoxelMask* exclude,
                                   const EndShareOptions& options, const VoxelMask* sectionRegion) {
  const core::CtImage& g = region.geometry;
  if (!g.uniform())
    throw std::invalid_argument("zEndShares needs a CT of one slice group");
  const std::size_t n = g.voxelCount();
  if (region.voxels.size() != n || (exclude != nullptr && exclude->voxels.size() != n) ||
      (sectionRegion != nullptr && sectionRegion->voxels.size() != n))
    throw std::invalid_argument("zEndShares: the masks lie on different grids");
  const VoxelMask& sectioned = sectionRegion != nullptr ? *sectionRegion : region;
  const auto& d = g.dimensions;
  const Eigen::Vector3d spacing = g.spacingMm();
  const double h = spacing.z();
  const double closingMm =
      sectionClosingMm(h, options.sectionOffsetSlices * h, options.closingReachSlices);
  // The region's box in plane, with one pixel of margin outside it all round.
  int i0 = d[0], i1 = -1, j0 = d[1], j1 = -1;
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        if (sectioned.at(i, j, k)) {
          i0 = std::min(i0, i);
          i1 = std::max(i1, i);
          j0 = std::min(j0, j);
          j1 = std::max(j1, j);
        }
      }
    }
  }
  std::vector<VoxelShare> out;
  if (i1 < 0)
    return out;
  --i0;
  --j0;
  ++i1;
  ++j1;
  const int nu = i1 - i0 + 1, nv = j1 - j0 + 1;
  core::CtImage plane;
  plane.dimensions = {nu, nv, 1};
  plane.pixelSpacingMm = g.pixelSpacingMm;
  plane.slicePositionsMm = {0.0};
  // A pixel's centre lies half a pixel inside (or outside) the section's edge next to it.
  const double halfPixelMm = 0.5 * std::min(spacing.x(), spacing.y());
  std::vector<std::optional<Section>> sections(sz(d[2]));
  auto section = [&](int k) -> const Section& {
    std::optional<Section>& s = sections[sz(k)];
    if (s)
      return *s;
    s.emplace();
    VoxelMask layer;
    layer.geometry = plane;
    layer.voxels.assign(sz(nu) * sz(nv), 0);
    for (int b = 0; b < nv; ++b) {
      for (int a = 0; a < nu; ++a) {
        const int i = i0 + a, j = j0 + b;
        if (i >= 0 && j >= 0 && i < d[0] && j < d[1] && sectioned.at(i, j, k)) {
          layer.voxels[sz(b) * sz(nu) + sz(a)] = 1;
          s->present = true;
        }
      }
    }
    if (!s->present)
      return *s;
    const std::vector<float> toInside = squaredDistanceMm2(layer, true);
    const std::vector<float> toOutside = squaredDistanceMm2(layer, false);
    s->distanceMm.resize(layer.voxels.size());
    for (std::size_t p = 0; p < layer.voxels.size(); ++p) {
      const double dist = layer.voxels[p] ? halfPixelMm - std::sqrt(toOutside[p])
                                          : std::sqrt(toInside[p]) - halfPixelMm;
      s->distanceMm[p] = static_cast<float>(dist);
      s->deepestMm = std::max(s->deepestMm, -dist);
    }
    return *s;
  };
  auto pixel = [&](int i, int j) { return sz(j - j0) * sz(nu) + sz(i - i0); };
  // The interpolated signed distance at column (i, j) and continuous slice index z (sections at
  // the slices' centres; beyond the scan the end slice's section continues).
  auto distanceAt = [&](int i, int j, double z) {
    const std::size_t p = pixel(i, j);
    const int ka = std::clamp(static_cast<int>(std::floor(z)), 0, d[2] - 1);
    const int kb = std::min(ka + 1, d[2] - 1);
    const double t = std::clamp(z - ka, 0.0, 1.0);
    const Section& a = section(ka);
    const Section& b = section(kb);
    if (a.present && b.present)
      return (1.0 - t) * a.distanceMm[p] + t * b.distanceMm[p];
    if (a.present)
      return closedSectionDistanceMm(a.distanceMm[p], a.deepestMm, closingMm, t * h);
    if (b.present)
      return closedSectionDistanceMm(b.distanceMm[p], b.deepestMm, closingMm, (1.0 - t) * h);
    return std::numeric_limits<double>::infinity();
  };
  // The part of slab k's column (i, j) inside the solid whose sections lie `offset` slices
  // from the slices' centres.
  auto shareOf = [&](int i, int j, int k, double offset) {
    int inside = 0;
    for (int m = 0; m < kSamplesPerSlab; ++m) {
      const double z = k + (m + 0.5) / kSamplesPerSlab - 0.5;
      if (distanceAt(i, j, z - offset) < 0.0)
        ++inside;
    }
    return static_cast<double>(inside) / kSamplesPerSlab;
  };
  for (int k = 0; k < d[2]; ++k) {
    for (int j = std::max(j0, 1); j <= std::min(j1, d[1] - 2); ++j) {
      for (int i = std::max(i0, 1); i <= std::min(i1, d[0] - 2); ++i) {
        if (!region.at(i, j, k))
          continue;
        bool facesZ = true;
        for (int b = -1; b <= 1 && facesZ; ++b) {
          for (int a = -1; a <= 1 && facesZ; ++a)
            facesZ = region.at(i + a, j + b, k);
        }
        if (!facesZ)
          continue;
        for (int step : {-1, 1}) {
          const int beyond = k + step, inner = k - step;
          if (beyond < 0 || beyond >= d[2] || region.at(i, j, beyond))
            continue;
          // A gap of one slice in the region is not an end (the bone goes on beyond it).
          const int further = beyond + step;
          if (further >= 0 && further < d[2] && region.at(i, j, further))
            continue;
          // The sections lie towards the bone's inside: against `step`.
          const double offset = -step * options.sectionOffsetSlices;
          bool flat = false;
          if (inner >= 0 && inner < d[2] && section(inner).present) {
            const double shrinkMm =
                section(k).distanceMm[pixel(i, j)] - section(inner).distanceMm[pixel(i, j)];
            flat = shrinkMm < options.flatShrinkSlices * h;
          }
          out.push_back({g.index(i, j, k), shareOf(i, j, k, offset), flat});
          const std::size_t b = g.index(i, j, beyond);
          if (exclude == nullptr || !exclude->voxels[b])
            out.push_back({b, shareOf(i, j, beyond, offset), flat});
        }
      }
    }
  }
  return out;
}

double zEndFieldValue(double share) {
  share = std::clamp(share, 0.0, 1.0);
  // Between the inside neighbour (1) and the voxel (f): 0.5 at 1/2 / (1 - f) slabs from the
  // neighbour, which is to be 1/2 + s; between the voxel (f) and the one beyond (0): 0.5 at
  // (f - 1/2) / f slabs from the voxel, which is to be s - 1/2.
  return share < 0.5 ? 1.0 - 1.0 / (1.0 + 2.0 * share) : 1.0 / (3.0 - 2.0 * share);
}

}  // namespace echoreg::segmentation
