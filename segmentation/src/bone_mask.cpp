#include "echoreg/segmentation/bone_mask.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace echoreg::segmentation {

namespace {

bool sameGrid(const core::CtImage& a, const core::CtImage& b) {
  return a.dimensions == b.dimensions && a.slicePositionsMm == b.slicePositionsMm &&
         (a.originMm - b.originMm).norm() < 1e-9 &&
         (a.pixelSpacingMm - b.pixelSpacingMm).norm() < 1e-12;
}

core::CtImage geometryOf(const core::CtImage& image) {
  core::CtImage g = image;
  g.hu.clear();
  g.hu.shrink_to_fit();
  return g;
}

std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

// 1D squared Euclidean distance transform (Felzenszwalb & Huttenlocher 2012) of f (n samples
// `step` mm apart), in place, with scratch buffers.
void edt1d(std::vector<double>& f, std::size_t n, double step, std::vector<double>& d,
           std::vector<int>& v, std::vector<double>& z) {
  const double inf = std::numeric_limits<double>::infinity();
  d.assign(n, inf);
  v.assign(n, 0);
  z.assign(n + 1, 0.0);
  int k = -1;
  for (std::size_t qi = 0; qi < n; ++qi) {
    if (!std::isfinite(f[qi]))
      continue;
    const double q = static_cast<double>(qi) * step;
    double s = 0.0;
    while (k >= 0) {
      const double p = v[sz(k)] * step;
      s = ((f[qi] + q * q) - (f[sz(v[sz(k)])] + p * p)) / (2.0 * (q - p));
      if (s <= z[sz(k)]) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    v[sz(k)] = static_cast<int>(qi);
    z[sz(k)] = k == 0 ? -inf : s;
    z[sz(k) + 1] = inf;
  }
  if (k < 0)
    return;  // no finite sample: all stay infinite
  int j = 0;
  for (std::size_t qi = 0; qi < n; ++qi) {
    const double q = static_cast<double>(qi) * step;
    while (z[sz(j) + 1] < q)
      ++j;
    const double p = v[sz(j)] * step;
    d[qi] = (q - p) * (q - p) + f[sz(v[sz(j)])];
  }
  for (std::size_t i = 0; i < n; ++i)
    f[i] = d[i];
}

// Squared distance (mm^2) from every voxel to the nearest foreground (toForeground) or background
// voxel; float storage (half the memory of a real CT's volume in doubles), double arithmetic.
std::vector<float> squaredDistance(const VoxelMask& mask, bool toForeground) {
  const auto& g = mask.geometry;
  const int nx = g.dimensions[0], ny = g.dimensions[1], nz = g.dimensions[2];
  const Eigen::Vector3d s = g.uniform()
                                ? g.spacingMm()
                                : Eigen::Vector3d(g.pixelSpacingMm.x(), g.pixelSpacingMm.y(), 1.0);
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> dist(mask.voxels.size());
  for (std::size_t i = 0; i < dist.size(); ++i) {
    const bool fg = mask.voxels[i] != 0;
    dist[i] = (fg == toForeground) ? 0.0f : inf;
  }
  std::vector<double> line, d, z;
  std::vector<int> v;
  // along i
  line.resize(sz(nx));
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      const std::size_t base = g.index(0, j, k);
      for (int i = 0; i < nx; ++i)
        line[sz(i)] = dist[base + sz(i)];
      edt1d(line, sz(nx), s.x(), d, v, z);
      for (int i = 0; i < nx; ++i)
        dist[base + sz(i)] = static_cast<float>(line[sz(i)]);
    }
  }
  line.resize(sz(ny));
  for (int k = 0; k < nz; ++k) {
    for (int i = 0; i < nx; ++i) {
      for (int j = 0; j < ny; ++j)
        line[sz(j)] = dist[g.index(i, j, k)];
      edt1d(line, sz(ny), s.y(), d, v, z);
      for (int j = 0; j < ny; ++j)
        dist[g.index(i, j, k)] = static_cast<float>(line[sz(j)]);
    }
  }
  line.resize(sz(nz));
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      for (int k = 0; k < nz; ++k)
        line[sz(k)] = dist[g.index(i, j, k)];
      edt1d(line, sz(nz), s.z(), d, v, z);
      for (int k = 0; k < nz; ++k)
        dist[g.index(i, j, k)] = static_cast<float>(line[sz(k)]);
    }
  }
  return dist;
}

// Flood fill from `starts` through voxels where `pass` is true; 6- or 26-connected.
template <class Pass>
std::vector<std::uint8_t> flood(const core::CtImage& g, const std::vector<std::size_t>& starts,
                                Pass pass, bool connect26) {
  const int nx = g.dimensions[0], ny = g.dimensions[1], nz = g.dimensions[2];
  std::vector<std::uint8_t> reached(g.voxelCount(), 0);
  std::vector<std::size_t> stack;
  for (std::size_t s : starts) {
    if (!reached[s] && pass(s)) {
      reached[s] = 1;
      stack.push_back(s);
    }
  }
  const std::size_t plane = sz(nx) * sz(ny);
  while (!stack.empty()) {
    const std::size_t idx = stack.back();
    stack.pop_back();
    const int k = static_cast<int>(idx / plane);
    const int j = static_cast<int>((idx % plane) / sz(nx));
    const int i = static_cast<int>(idx % sz(nx));
    for (int dk = -1; dk <= 1; ++dk) {
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int manhattan = std::abs(di) + std::abs(dj) + std::abs(dk);
          if (manhattan == 0 || (!connect26 && manhattan > 1))
            continue;
          const int a = i + di, b = j + dj, c = k + dk;
          if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz)
            continue;
          const std::size_t n = g.index(a, b, c);
          if (reached[n] || !pass(n))
            continue;
          reached[n] = 1;
          stack.push_back(n);
        }
      }
    }
  }
  return reached;
}

void report(const GrowOptions& o, double f, const std::string& stage) {
  if (o.progress)
    o.progress(f, stage);
}

}  // namespace

std::size_t VoxelMask::count() const {
  return static_cast<std::size_t>(std::count(voxels.begin(), voxels.end(), std::uint8_t{1}));
}

VoxelMask emptyMask(const core::CtImage& image) {
  VoxelMask m;
  m.geometry = geometryOf(image);
  const std::size_t n = image.voxelCount();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // A mask of a whole large CT is hundreds of MB, and the kernel's fault of each fresh 4 kB page
  // cost more than the work on it (the 1000-slice benchmark's 512 x 512 masks: about a million
  // faults, half its time). Asked for as transparent huge pages (2 MB) it faults 512 times less
  // often; where the kernel does not give them, the advice is ignored and nothing changes.
  if (n >= (std::size_t{32} << 20)) {
    m.voxels.reserve(n);
    const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    const auto first = reinterpret_cast<std::uintptr_t>(m.voxels.data());
    const std::uintptr_t begin = (first + page - 1) / page * page;
    if (page > 0 && first + n > begin)
      madvise(reinterpret_cast<void*>(begin), first + n - begin, MADV_HUGEPAGE);
  }
#endif
  m.voxels.assign(n, 0);
  return m;
}

core::CtImage extractGroup(const core::CtImage& image, std::size_t group) {
  if (group >= image.groups.size()) {
    throw std::invalid_argument(
        fmt::format("the CT has {} slice groups, no group {}", image.groups.size(), group));
  }
  const core::CtSliceGroup& gr = image.groups[group];
  core::CtImage out;
  out.dimensions = {image.dimensions[0], image.dimensions[1], gr.count};
  out.direction = image.direction;
  out.pixelSpacingMm = image.pixelSpacingMm;
  out.seriesInstanceUid = image.seriesInstanceUid;
  out.folder = image.folder;
  const double z0 = image.slicePositionsMm[sz(gr.firstSlice)];
  out.originMm = image.originMm + image.direction.col(2) * z0;
  for (int k = 0; k < gr.count; ++k)
    out.slicePositionsMm.push_back(image.slicePositionsMm[sz(gr.firstSlice + k)] - z0);
  out.groups = {core::CtSliceGroup{0, gr.count, gr.count > 1 ? gr.spacingMm : 0.0}};
  const std::size_t plane = sz(image.dimensions[0]) * sz(image.dimensions[1]);
  if (!image.hu.empty()) {
    out.hu.assign(
        image.hu.begin() + static_cast<std::ptrdiff_t>(plane * sz(gr.firstSlice)),
        image.hu.begin() + static_cast<std::ptrdiff_t>(plane * sz(gr.firstSlice + gr.count)));
  }
  return out;
}

int groupContaining(const core::CtImage& image, const Eigen::Vector3d& pointLps) {
  if (image.voxelCount() == 0 || image.slicePositionsMm.empty())
    return -1;
  const Eigen::Vector3d local = image.direction.transpose() * (pointLps - image.originMm);
  const double i = local.x() / image.pixelSpacingMm.x(), j = local.y() / image.pixelSpacingMm.y();
  if (i < -0.5 || j < -0.5 || i > image.dimensions[0] - 0.5 || j > image.dimensions[1] - 0.5)
    return -1;
  // Along k in mm: within half the group's own spacing of its end slices (0.5 mm for one slice).
  for (std::size_t g = 0; g < image.groups.size(); ++g) {
    const core::CtSliceGroup& gr = image.groups[g];
    const double first = image.slicePositionsMm[sz(gr.firstSlice)];
    const double last = image.slicePositionsMm[sz(gr.firstSlice + gr.count - 1)];
    const double half = gr.count > 1 ? 0.5 * gr.spacingMm : 0.5;
    if (local.z() >= first - half && local.z() <= last + half)
      return static_cast<int>(g);
  }
  return -1;
}

VoxelMask thresholdBone(const core::CtImage& image, const BoneThreshold& threshold) {
  if (image.voxelCount() == 0 || image.hu.size() != image.voxelCount()) {
    throw std::invalid_argument("thresholdBone: the CT image is empty");
  }
  if (threshold.weakHu > threshold.strongHu) {
    throw std::invalid_argument(
        fmt::format("bone threshold: weak {} HU must not exceed strong {} HU", threshold.weakHu,
                    threshold.strongHu));
  }
  std::vector<std::size_t> strong;
  for (std::size_t i = 0; i < image.hu.size(); ++i) {
    if (image.hu[i] >= threshold.strongHu)
      strong.push_back(i);
  }
  VoxelMask m;
  m.geometry = geometryOf(image);
  m.voxels = flood(
      image, strong, [&](std::size_t n) { return image.hu[n] >= threshold.weakHu; }, true);
  return m;
}

VoxelMask unite(const VoxelMask& a, const VoxelMask& b) {
  if (!sameGrid(a.geometry, b.geometry))
    throw std::invalid_argument("unite: the masks lie on different grids");
  VoxelMask out = a;
  for (std::size_t i = 0; i < out.voxels.size(); ++i)
    out.voxels[i] = (a.voxels[i] | b.voxels[i]) ? 1 : 0;
  return out;
}

VoxelMask dilate(const VoxelMask& mask, double radiusMm) {
  if (radiusMm <= 0.0)
    return mask;
  const std::vector<float> d = squaredDistance(mask, true);
  VoxelMask out = mask;
  const double r2 = radiusMm * radiusMm * (1.0 + 1e-6);  // float distances: exact radii count
  for (std::size_t i = 0; i < d.size(); ++i)
    out.voxels[i] = d[i] <= r2 ? 1 : 0;
  return out;
}

VoxelMask erode(const VoxelMask& mask, double radiusMm) {
  if (radiusMm <= 0.0)
    return mask;
  const std::vector<float> d = squaredDistance(mask, false);
  VoxelMask out = mask;
  const double r2 = radiusMm * radiusMm * (1.0 + 1e-6);  // float distances: exact radii count
  for (std::size_t i = 0; i < d.size(); ++i)
    out.voxels[i] = d[i] > r2 ? 1 : 0;
  return out;
}

std::vector<float> squaredDistanceMm2(const VoxelMask& mask, bool toForeground) {
  return squaredDistance(mask, toForeground);
}

void fillHoles(VoxelMask& mask, double maxSliceHoleMm2, bool closedScanEnds) {
  const core::CtImage& g = mask.geometry;
  const int nx = g.dimensions[0], ny = g.dimensions[1], nz = g.dimensions[2];
  std::vector<std::size_t> border;
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const bool end = !closedScanEnds && (k == 0 || k == nz - 1);
        if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1 || end)
          border.push_back(g.index(i, j, k));
      }
    }
  }
  const auto outside = flood(
      g, border, [&](std::size_t n) { return mask.voxels[n] == 0; }, false);
  for (std::size_t i = 0; i < mask.voxels.size(); ++i) {
    if (!outside[i])
      mask.voxels[i] = 1;
  }
  if (!(maxSliceHoleMm2 > 0.0))
    return;
  // Per axial slice: label the background regions (4-connected); fill those that do not touch
  // the slice's border and are small enough.
  const double pixelMm2 = g.pixelSpacingMm.x() * g.pixelSpacingMm.y();
  std::vector<int> label(sz(nx) * sz(ny));
  std::vector<int> stack, region;
  for (int k = 0; k < nz; ++k) {
    std::uint8_t* slice = mask.voxels.data() + g.index(0, 0, k);
    std::fill(label.begin(), label.end(), 0);
    for (std::size_t startPixel = 0; startPixel < label.size(); ++startPixel) {
      if (slice[startPixel] || label[startPixel])
        continue;
      region.clear();
      bool touchesBorder = false;
      label[startPixel] = 1;
      stack.push_back(static_cast<int>(startPixel));
      while (!stack.empty()) {
        const int p = stack.back();
        stack.pop_back();
        region.push_back(p);
        const int i = p % nx, j = p / nx;
        if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1)
          touchesBorder = true;
        const int next[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
        for (const auto& q : next) {
          if (q[0] < 0 || q[1] < 0 || q[0] >= nx || q[1] >= ny)
            continue;
          const std::size_t n = sz(q[1]) * sz(nx) + sz(q[0]);
          if (slice[n] || label[n])
            continue;
          label[n] = 1;
          stack.push_back(static_cast<int>(n));
        }
      }
      if (!touchesBorder && static_cast<double>(region.size()) * pixelMm2 <= maxSliceHoleMm2) {
        for (int p : region)
          slice[sz(p)] = 1;
      }
    }
  }
}

VoxelMask connectedComponent(const VoxelMask& mask, const Eigen::Vector3i& seed) {
  VoxelMask out = mask;
  const core::CtImage& g = mask.geometry;
  if (seed.x() < 0 || seed.y() < 0 || seed.z() < 0 || seed.x() >= g.dimensions[0] ||
      seed.y() >= g.dimensions[1] || seed.z() >= g.dimensions[2] ||
      !mask.at(seed.x(), seed.y(), seed.z())) {
    std::fill(out.voxels.begin(), out.voxels.end(), std::uint8_t{0});
    return out;
  }
  out.voxels = flood(
      g, {g.index(seed.x(), seed.y(), seed.z())},
      [&](std::size_t n) { return mask.voxels[n] != 0; }, true);
  return out;
}

VoxelMask otherBones(const VoxelMask& threshold, const VoxelMask& region, double bandMm) {
  if (!sameGrid(threshold.geometry, region.geometry))
    throw std::invalid_argument("otherBones: the masks lie on different grids");
  const VoxelMask band = dilate(region, bandMm);
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < region.voxels.size(); ++i) {
    if (region.voxels[i] && threshold.voxels[i])
      starts.push_back(i);
  }
  const auto ours = flood(
      threshold.geometry, starts,
      [&](std::size_t n) { return threshold.voxels[n] != 0 && band.voxels[n] != 0; }, true);
  VoxelMask out = threshold;
  for (std::size_t i = 0; i < out.voxels.size(); ++i)
    out.voxels[i] = (threshold.voxels[i] && !ours[i]) ? 1 : 0;
  return out;
}

GrowResult growBone(const core::CtImage& image, const Eigen::Vector3d& seedLps,
                    const GrowOptions& options) {
  if (image.voxelCount() == 0 || image.hu.size() != image.voxelCount()) {
    throw std::invalid_argument("the CT image is empty");
  }
  if (!image.uniform()) {
    throw std::invalid_argument("growBone needs one slice group (extract the seed's group first)");
  }
  const Eigen::Vector3d v = image.lpsToVoxel(seedLps);
  const Eigen::Vector3i seed(static_cast<int>(std::lround(v.x())),
                             static_cast<int>(std::lround(v.y())),
                             static_cast<int>(std::lround(v.z())));
  const auto& dims = image.dimensions;
  if (seed.x() < 0 || seed.y() < 0 || seed.z() < 0 || seed.x() >= dims[0] || seed.y() >= dims[1] ||
      seed.z() >= dims[2]) {
    const Eigen::Vector3d lo = image.voxelToLps(Eigen::Vector3d(-0.5, -0.5, -0.5));
    const Eigen::Vector3d hi =
        image.voxelToLps(Eigen::Vector3d(dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5));
    throw std::invalid_argument(
        fmt::format("the seed ({:.1f}, {:.1f}, {:.1f}) mm lies outside the CT volume, which spans "
                    "x {:.1f}..{:.1f}, "
                    "y {:.1f}..{:.1f}, z {:.1f}..{:.1f} mm (LPS)",
                    seedLps.x(), seedLps.y(), seedLps.z(), std::min(lo.x(), hi.x()),
                    std::max(lo.x(), hi.x()), std::min(lo.y(), hi.y()), std::max(lo.y(), hi.y()),
                    std::min(lo.z(), hi.z()), std::max(lo.z(), hi.z())));
  }
  GrowResult result;
  result.seedVoxel = seed;
  result.seedHu = image.at(seed.x(), seed.y(), seed.z());
  report(options, 0.0, "threshold");
  result.threshold = thresholdBone(image, options.threshold);
  const Eigen::Vector3d spacing = image.spacingMm();
  const double voxelMm3 = spacing.prod();

  // Solid bones: the threshold with the marrow (enclosed background) filled.
  report(options, 0.2, "fill");
  VoxelMask solid = result.threshold;
  fillHoles(solid, options.maxSliceHoleMm2);
  const std::size_t seedIndex = image.index(seed.x(), seed.y(), seed.z());
  if (!solid.voxels[seedIndex]) {
    throw std::invalid_argument(fmt::format(
        "the seed ({:.1f}, {:.1f}, {:.1f}) mm is not in bone: {} HU there (bone is >= {} HU, or "
        "enclosed by it)",
        seedLps.x(), seedLps.y(), seedLps.z(), result.seedHu, options.threshold.weakHu));
  }

  // Separation: the components of the eroded solid are the bones; each solid voxel goes to the
  // nearest one.
  report(options, 0.4, "separate");
  const double step = std::max(spacing.x(), spacing.y());
  const double radiusMm =
      options.separationRadiusMm > 0.0
          ? std::max(options.separationRadiusMm, options.separationVoxels * spacing.maxCoeff())
          : 0.0;
  VoxelMask grown;
  if (radiusMm > 0.0) {
    const VoxelMask core = erode(solid, radiusMm);
    // The core voxel nearest the seed (the seed itself when it is in the core), within the
    // radius plus 1.5 voxels.
    Eigen::Vector3i start(-1, -1, -1);
    const double reach = radiusMm + 1.5 * step;
    double best = std::numeric_limits<double>::infinity();
    const Eigen::Vector3i r =
        (Eigen::Vector3d::Constant(reach).cwiseQuotient(spacing)).array().ceil().cast<int>();
    for (int k = std::max(0, seed.z() - r.z()); k <= std::min(dims[2] - 1, seed.z() + r.z()); ++k) {
      for (int j = std::max(0, seed.y() - r.y()); j <= std::min(dims[1] - 1, seed.y() + r.y());
           ++j) {
        for (int i = std::max(0, seed.x() - r.x()); i <= std::min(dims[0] - 1, seed.x() + r.x());
             ++i) {
          if (!core.at(i, j, k))
            continue;
          const double d =
              Eigen::Vector3d((i - seed.x()) * spacing.x(), (j - seed.y()) * spacing.y(),
                              (k - seed.z()) * spacing.z())
                  .norm();
          if (d < best) {
            best = d;
            start = Eigen::Vector3i(i, j, k);
          }
        }
      }
    }
    if (start.x() < 0) {
      // A thin bone (thinner than the erosion): grow it without separation.
      grown = connectedComponent(solid, seed);
    } else {
      const VoxelMask own = connectedComponent(core, start);
      VoxelMask rest = core;
      for (std::size_t i = 0; i < rest.voxels.size(); ++i)
        rest.voxels[i] = core.voxels[i] && !own.voxels[i] ? 1 : 0;
      report(options, 0.6, "separate");
      const std::vector<float> dOwn = squaredDistance(own, true);
      const std::vector<float> dRest = squaredDistance(rest, true);
      const double reach2 = reach * reach;
      grown = solid;
      result.others = solid;
      for (std::size_t i = 0; i < solid.voxels.size(); ++i) {
        const bool bone = solid.voxels[i] != 0;
        result.others.voxels[i] = bone && dRest[i] < dOwn[i] && dRest[i] <= reach2 ? 1 : 0;
        grown.voxels[i] = bone && !result.others.voxels[i] ? 1 : 0;
      }
      grown = connectedComponent(grown, grown.voxels[seedIndex] ? seed : start);
    }
  } else {
    grown = connectedComponent(solid, seed);
  }
  if (result.others.voxels.empty()) {
    result.others = solid;
    for (std::size_t i = 0; i < solid.voxels.size(); ++i)
      result.others.voxels[i] = solid.voxels[i] && !grown.voxels[i] ? 1 : 0;
  }
  report(options, 0.9, "fill");
  fillHoles(grown, options.maxSliceHoleMm2);
  if (!grown.voxels[seedIndex]) {
    throw std::invalid_argument(
        fmt::format("the seed ({:.1f}, {:.1f}, {:.1f}) mm lies on the bridge between two bones at "
                    "a joint ({} HU); "
                    "move it into the bone",
                    seedLps.x(), seedLps.y(), seedLps.z(), result.seedHu));
  }
  result.volumeMm3 = static_cast<double>(grown.count()) * voxelMm3;
  if (result.volumeMm3 < options.minVolumeMm3) {
    throw std::invalid_argument(
        fmt::format("the bone grown from the seed ({:.1f}, {:.1f}, {:.1f}) mm has only {:.0f} mm^3 "
                    "(at least {:.0f} "
                    "expected): a speck of bone or calcification, not a bone",
                    seedLps.x(), seedLps.y(), seedLps.z(), result.volumeMm3, options.minVolumeMm3));
  }
  result.mask = std::move(grown);
  report(options, 1.0, "grow");
  return result;
}

}  // namespace echoreg::segmentation
