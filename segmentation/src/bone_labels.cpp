#include "echoreg/segmentation/bone_labels.hpp"

#include "echoreg/segmentation/joint_slabs.hpp"

#include <fmt/format.h>
#include <Eigen/LU>
#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <stdexcept>
#include <utility>

namespace echoreg::segmentation {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr double kLevelMm = 0.05;  // quantisation of the distance map
// estimateBoneThreshold's factors (see its comment).
constexpr double kStrongFactor = 0.41;
constexpr double kWeakFactor = 0.29;

std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

void report(const CompetingOptions& o, double f, const std::string& stage) {
  if (o.progress)
    o.progress(f, stage);
}

// The 26 neighbour offsets of a voxel (index deltas and i, j, k steps).
struct Neighbours {
  int di[26], dj[26], dk[26];
  Neighbours() {
    int n = 0;
    for (int k = -1; k <= 1; ++k) {
      for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
          if (i == 0 && j == 0 && k == 0)
            continue;
          di[n] = i;
          dj[n] = j;
          dk[n] = k;
          ++n;
        }
      }
    }
  }
};

// Calls f(neighbourIndex) for every in-grid 26-neighbour of voxel (i, j, k).
template <class F>
void forNeighbours(const core::CtImage& g, int i, int j, int k, F f) {
  static const Neighbours nb;
  const int nx = g.dimensions[0], ny = g.dimensions[1], nz = g.dimensions[2];
  for (int n = 0; n < 26; ++n) {
    const int a = i + nb.di[n], b = j + nb.dj[n], c = k + nb.dk[n];
    if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz)
      continue;
    f(g.index(a, b, c));
  }
}

void ijkOf(const core::CtImage& g, std::size_t idx, int& i, int& j, int& k) {
  const std::size_t plane = sz(g.dimensions[0]) * sz(g.dimensions[1]);
  k = static_cast<int>(idx / plane);
  j = static_cast<int>((idx % plane) / sz(g.dimensions[0]));
  i = static_cast<int>(idx % sz(g.dimensions[0]));
}

// 26-connected components of `mask` (labels 1.., 0 background) and their sizes.
std::vector<std::uint32_t> labelComponents(const core::CtImage& g,
                                           const std::vector<std::uint8_t>& mask,
                                           std::vector<std::size_t>& sizes) {
  std::vector<std::uint32_t> label(mask.size(), 0);
  sizes.assign(1, 0);
  std::vector<std::size_t> stack;
  for (std::size_t s = 0; s < mask.size(); ++s) {
    if (!mask[s] || label[s])
      continue;
    const auto id = static_cast<std::uint32_t>(sizes.size());
    sizes.push_back(0);
    label[s] = id;
    stack.push_back(s);
    while (!stack.empty()) {
      const std::size_t v = stack.back();
      stack.pop_back();
      ++sizes.back();
      int i, j, k;
      ijkOf(g, v, i, j, k);
      forNeighbours(g, i, j, k, [&](std::size_t n) {
        if (mask[n] && !label[n]) {
          label[n] = id;
          stack.push_back(n);
        }
      });
    }
  }
  return label;
}

std::string lpsText(const Eigen::Vector3d& p) {
  return fmt::format("({:.1f}, {:.1f}, {:.1f}) mm", p.x(), p.y(), p.z());
}

// Why the voxel `seed` is not in the filled bone: its HU, the cortex around it, or the
// hysteresis' strong level not reached from its patch.
std::string notInBone(const core::CtImage& image, const VoxelMask& threshold,
                      const Eigen::Vector3i& seed, const Eigen::Vector3d& seedLps,
                      const BoneThreshold& t) {
  const int hu = image.at(seed.x(), seed.y(), seed.z());
  if (hu >= t.weakHu) {
    // The patch of >= weak around the seed (26-connected; it holds no strong voxel, else the
    // seed would be bone): its size and its brightest voxel are the reason.
    std::vector<std::uint8_t> in(image.hu.size(), 0);
    std::vector<std::size_t> stack{image.index(seed.x(), seed.y(), seed.z())};
    in[stack.back()] = 1;
    std::size_t count = 0;
    int brightest = hu;
    const std::size_t limit = 2000000;
    while (!stack.empty() && count < limit) {
      const std::size_t v = stack.back();
      stack.pop_back();
      ++count;
      brightest = std::max(brightest, static_cast<int>(image.hu[v]));
      int i, j, k;
      ijkOf(image, v, i, j, k);
      forNeighbours(image, i, j, k, [&](std::size_t n) {
        if (!in[n] && image.hu[n] >= t.weakHu) {
          in[n] = 1;
          stack.push_back(n);
        }
      });
    }
    return fmt::format(
        "the seed {} is not in bone: {} HU there is above the weak threshold ({:.0f} HU), but "
        "the patch of >= {:.0f} HU around it ({}{:.1f} cm^3) is brightest at {} HU and reaches no "
        "cortex (>= {:.0f} HU, the strong threshold): it is not connected to bone. A seed in "
        "faint bone is accepted when cortex encloses it; move the seed into the bone, or lower "
        "--threshold-hu",
        lpsText(seedLps), hu, t.weakHu, t.weakHu, count >= limit ? "more than " : "",
        static_cast<double>(count) * image.spacingMm().prod() / 1000.0, brightest, t.strongHu);
  }
  // Rays along the six axis directions, up to 40 mm: which of them meet bone.
  const Eigen::Vector3d spacing = image.spacingMm();
  int walls = 0;
  std::vector<std::string> open;
  const char* names[6] = {
      "-i", "+i", "-j", "+j", "-k (scan's first slice)", "+k (scan's last slice)"};
  for (int d = 0; d < 6; ++d) {
    Eigen::Vector3i step = Eigen::Vector3i::Zero();
    step[d / 2] = d % 2 == 0 ? -1 : 1;
    const int reach = static_cast<int>(std::ceil(40.0 / spacing[d / 2]));
    bool wall = false;
    Eigen::Vector3i p = seed;
    for (int r = 0; r < reach && !wall; ++r) {
      p += step;
      if (p.minCoeff() < 0 || p.x() >= image.dimensions[0] || p.y() >= image.dimensions[1] ||
          p.z() >= image.dimensions[2])
        break;
      wall = threshold.at(p.x(), p.y(), p.z());
    }
    if (wall)
      ++walls;
    else
      open.emplace_back(names[d]);
  }
  if (walls == 0 && threshold.count() == 0) {
    return fmt::format(
        "the seed {} is not in bone: {} HU there, and no voxel of the CT is bone by the threshold "
        "(>= {:.0f} HU, and >= {:.0f} HU next to it): lower --threshold-hu",
        lpsText(seedLps), hu, t.strongHu, t.weakHu);
  }
  if (walls == 0) {
    return fmt::format(
        "the seed {} is not in bone: {} HU there (bone is >= {:.0f} HU, or enclosed by it) and no "
        "bone lies within 40 mm along any axis: it is in soft tissue",
        lpsText(seedLps), hu, t.weakHu);
  }
  std::string dirs;
  for (const auto& s : open)
    dirs += (dirs.empty() ? "" : ", ") + s;
  return fmt::format(
      "the seed {} is not in bone: {} HU there (bone is >= {:.0f} HU, or enclosed by it); bone "
      "lies around it on {} of 6 sides but not toward {}: if it is in marrow or faint cancellous "
      "bone, the cortex around it is open there (thinner than the threshold sees); move the seed "
      "or lower --threshold-hu",
      lpsText(seedLps), hu, t.weakHu, walls, dirs);
}

// Joint lines: solid voxels darker by `dip` than bone >= strong on both sides along one of the 13
// directions, within `reachMm`, with bone (solid) for `beyondMm` beyond each side's first bright
// voxel: a joint's plates have bone behind them, a thin wall's cortices soft tissue
// (CompetingOptions::jointBeyondMm). Directions whose step is longer than `beyondMm` are not
// checked beyond; outside the scan counts as bone.
std::vector<std::uint8_t> jointLines(const core::CtImage& image, const VoxelMask& solid,
                                     double strong, double dip, double reachMm, double beyondMm) {
  std::vector<std::uint8_t> out(solid.voxels.size(), 0);
  if (!(dip > 0.0))
    return out;
  const Eigen::Vector3d s = image.spacingMm();
  const int nx = image.dimensions[0], ny = image.dimensions[1], nz = image.dimensions[2];
  struct Dir {
    int di, dj, dk, reach, beyond;
  };
  std::vector<Dir> dirs;
  const std::ptrdiff_t plane = static_cast<std::ptrdiff_t>(nx) * ny;
  std::vector<std::ptrdiff_t> steps;  // each direction's step in the voxel index
  int maxReach = 0;
  for (int k = -1; k <= 1; ++k) {
    for (int j = -1; j <= 1; ++j) {
      for (int i = -1; i <= 1; ++i) {
        // one of each opposite pair
        const int code = (k * 3 + j) * 3 + i;
        if (code <= 0)
          continue;
        const double len = Eigen::Vector3d(i * s.x(), j * s.y(), k * s.z()).norm();
        const int beyond =
            beyondMm > 0.0 && len <= beyondMm ? static_cast<int>(std::lround(beyondMm / len)) : 0;
        dirs.push_back(
            {i, j, k, std::clamp(static_cast<int>(std::lround(reachMm / len)), 1, 3), beyond});
        steps.push_back(k * plane + static_cast<std::ptrdiff_t>(j) * nx + i);
        maxReach = std::max(maxReach, dirs.back().reach);
      }
    }
  }
  const std::int16_t* hu = image.hu.data();
  for (int k = 0; k < nz; ++k) {
    const bool innerK = k >= maxReach && k < nz - maxReach;
    for (int j = 0; j < ny; ++j) {
      const bool innerJK = innerK && j >= maxReach && j < ny - maxReach;
      for (int i = 0; i < nx; ++i) {
        const std::size_t v = image.index(i, j, k);
        if (!solid.voxels[v])
          continue;
        // A side is bright when one of its voxels within reach is at or above `need`: for
        // integer HU, at or above its ceiling.
        const double need = std::max(strong, hu[v] + dip);
        const int needHu = static_cast<int>(std::ceil(std::min(need, 40000.0)));
        const bool inner = innerJK && i >= maxReach && i < nx - maxReach;
        for (std::size_t t = 0; t < dirs.size(); ++t) {
          const Dir& d = dirs[t];
          // The first bright voxel's distance along the side m, 0: none.
          auto bright = [&](int m) {
            if (inner) {
              const std::ptrdiff_t step = m * steps[t];
              const std::int16_t* p = hu + v;
              for (int r = 1; r <= d.reach; ++r) {
                if (p[r * step] >= needHu)
                  return r;
              }
              return 0;
            }
            for (int r = 1; r <= d.reach; ++r) {
              const int a = i + m * r * d.di, b = j + m * r * d.dj, c = k + m * r * d.dk;
              if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz)
                return 0;
              if (image.at(a, b, c) >= needHu)
                return r;
            }
            return 0;
          };
          auto boneBeyond = [&](int m, int r) {
            for (int q = r + 1; q <= r + d.beyond; ++q) {
              const int a = i + m * q * d.di, b = j + m * q * d.dj, c = k + m * q * d.dk;
              if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz)
                return true;
              if (!solid.voxels[image.index(a, b, c)])
                return false;
            }
            return true;
          };
          const int before = bright(-1);
          const int after = before ? bright(1) : 0;
          if (after && boneBeyond(-1, before) && boneBeyond(1, after)) {
            out[v] = 1;
            break;
          }
        }
      }
    }
  }
  return out;
}

// fillHoles (scan ends closed) on the bounding box of the mask grown by one voxel: the same
// result as on the whole grid (the box's rim is background connected all round), in a fraction
// of the time when the bones fill a small part of the field of view.
void fillHolesInBox(VoxelMask& mask, double maxSliceHoleMm2) {
  const auto& d = mask.geometry.dimensions;
  Eigen::Vector3i lo(d[0], d[1], d[2]), hi(-1, -1, -1);
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      const std::uint8_t* row = mask.voxels.data() + mask.geometry.index(0, j, k);
      for (int i = 0; i < d[0]; ++i) {
        if (row[i]) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
        }
      }
    }
  }
  if (hi.x() < 0)
    return;
  lo = (lo.array() - 1).max(0).matrix();
  hi = hi.cwiseMin(Eigen::Vector3i(d[0] - 1, d[1] - 1, d[2] - 1)) + Eigen::Vector3i::Ones();
  hi = hi.cwiseMin(Eigen::Vector3i(d[0] - 1, d[1] - 1, d[2] - 1));
  VoxelMask box;
  box.geometry.dimensions = {hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1};
  box.geometry.pixelSpacingMm = mask.geometry.pixelSpacingMm;
  box.voxels.assign(box.geometry.voxelCount(), 0);
  const auto& b = box.geometry.dimensions;
  for (int k = 0; k < b[2]; ++k) {
    for (int j = 0; j < b[1]; ++j) {
      std::copy_n(mask.voxels.data() + mask.geometry.index(lo.x(), lo.y() + j, lo.z() + k), b[0],
                  box.voxels.data() + box.geometry.index(0, j, k));
    }
  }
  fillHoles(box, maxSliceHoleMm2, true);
  for (int k = 0; k < b[2]; ++k) {
    for (int j = 0; j < b[1]; ++j) {
      std::copy_n(box.voxels.data() + box.geometry.index(0, j, k), b[0],
                  mask.voxels.data() + mask.geometry.index(lo.x(), lo.y() + j, lo.z() + k));
    }
  }
}

struct Component {
  std::uint32_t parent;
  int peakLevel;
  std::uint32_t peakVoxel;
  int bone;  // seed's bone carried (-1 none)
};

}  // namespace

std::string implausibleBone(const std::string& bone, double volumeMm3,
                            const Eigen::Vector3d& extentMm) {
  struct Limit {
    const char* names;
    double maxCm3, maxWidthMm, maxDepthMm, maxLengthMm;
  };
  // Upper bounds of an adult bone (a scan may cut it, so no lower bounds beyond minVolumeMm3):
  // width along i (left-right), depth along j (anterior-posterior), length along k.
  static const Limit limits[] = {
      {"femur", 900.0, 130.0, 110.0, 560.0},   {"tibia", 600.0, 110.0, 90.0, 480.0},
      {"fibula", 80.0, 45.0, 45.0, 460.0},     {"patella", 60.0, 70.0, 45.0, 70.0},
      {"hip", 500.0, 190.0, 230.0, 260.0},     {"ilium", 500.0, 190.0, 230.0, 260.0},
      {"sacrum", 300.0, 150.0, 140.0, 160.0},  {"pelvis", 1300.0, 330.0, 240.0, 260.0},
      {"vertebra", 120.0, 100.0, 110.0, 60.0}, {"humerus", 400.0, 90.0, 80.0, 380.0}};
  std::string name = bone;
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const Limit& l : limits) {
    if (name.find(l.names) == std::string::npos)
      continue;
    std::vector<std::string> why;
    if (volumeMm3 > l.maxCm3 * 1000.0)
      why.push_back(fmt::format("{:.0f} cm^3 (a {} is at most {:.0f})", volumeMm3 / 1000.0, l.names,
                                l.maxCm3));
    const double limit[3] = {l.maxWidthMm, l.maxDepthMm, l.maxLengthMm};
    const char* axis[3] = {"wide (x)", "deep (y)", "long (z)"};
    for (int a = 0; a < 3; ++a) {
      if (extentMm[a] > limit[a])
        why.push_back(fmt::format("{:.0f} mm {} (at most {:.0f})", extentMm[a], axis[a], limit[a]));
    }
    std::string out;
    for (const auto& w : why)
      out += (out.empty() ? "" : ", ") + w;
    return out;
  }
  return {};
}

std::vector<SliceUncertainty> sliceUncertainty(
    const core::CtImage& ct, const VoxelMask& region,
    const std::vector<std::pair<std::string, const VoxelMask*>>& neighbours, SlicePlane plane,
    const std::vector<double>& positionsMm, const UncertaintyOptions& options) {
  if (!ct.uniform() || ct.hu.size() != ct.voxelCount() || region.voxels.size() != ct.voxelCount())
    throw std::invalid_argument("sliceUncertainty: the CT and the region lie on different grids");
  for (const auto& n : neighbours) {
    if (n.second == nullptr || n.second->voxels.size() != ct.voxelCount())
      throw std::invalid_argument("sliceUncertainty: a neighbour's mask lies on another grid");
  }
  const int axis = plane == SlicePlane::Sagittal ? 0 : plane == SlicePlane::Coronal ? 1 : 2;
  std::vector<std::size_t> order(positionsMm.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return positionsMm[a] < positionsMm[b]; });
  const Eigen::Vector3d spacing = ct.spacingMm();
  // The voxel size along the plane's normal (LPS axis).
  double along = 0.0;
  for (int a = 0; a < 3; ++a)
    along += std::abs(ct.direction(axis, a)) * spacing[a];
  std::vector<double> half(positionsMm.size(), options.halfWidthMm);
  for (std::size_t r = 0; r < order.size(); ++r) {
    if (options.halfWidthMm > 0.0)
      continue;
    double gap = std::numeric_limits<double>::infinity();
    if (r > 0)
      gap = std::min(gap, positionsMm[order[r]] - positionsMm[order[r - 1]]);
    if (r + 1 < order.size())
      gap = std::min(gap, positionsMm[order[r + 1]] - positionsMm[order[r]]);
    half[order[r]] = std::max(0.5 * along, std::isfinite(gap) ? 0.5 * gap : 0.5 * along);
  }
  std::vector<SliceUncertainty> out(positionsMm.size());
  std::vector<std::vector<std::size_t>> touched(positionsMm.size(),
                                                std::vector<std::size_t>(neighbours.size(), 0));
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i].positionMm = positionsMm[i];
  const auto& d = ct.dimensions;
  const std::size_t steps[3] = {1, sz(d[0]), sz(d[0]) * sz(d[1])};
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        const std::size_t v = ct.index(i, j, k);
        if (!region.voxels[v])
          continue;
        const int ijk[3] = {i, j, k};
        bool boundary = false, contact = false, low = false;
        std::vector<std::size_t> hits;
        for (int a = 0; a < 3; ++a) {
          for (int sign = -1; sign <= 1; sign += 2) {
            const int c = ijk[a] + sign;
            if (c < 0 || c >= d[sz(a)])
              continue;  // the scan's end or the field of view's edge: not a boundary
            const std::size_t n = sign < 0 ? v - steps[a] : v + steps[a];
            if (region.voxels[n])
              continue;
            boundary = true;
            bool other = false;
            for (std::size_t b = 0; b < neighbours.size(); ++b) {
              if (neighbours[b].second->voxels[n]) {
                other = true;
                hits.push_back(b);
              }
            }
            if (other)
              contact = true;
            else if (ct.hu[v] - ct.hu[n] < options.lowContrastHu)
              low = true;
          }
        }
        if (!boundary)
          continue;
        const double p =
            (ct.originMm + ct.direction * Eigen::Vector3d(i * spacing.x(), j * spacing.y(),
                                                          k * spacing.z()))[axis];
        for (std::size_t s = 0; s < out.size(); ++s) {
          if (std::abs(p - positionsMm[s]) > half[s])
            continue;
          ++out[s].boundaryVoxels;
          out[s].contactVoxels += contact ? 1u : 0u;
          out[s].lowContrastVoxels += !contact && low ? 1u : 0u;
          for (std::size_t b : hits)
            ++touched[s][b];
        }
      }
    }
  }
  for (std::size_t s = 0; s < out.size(); ++s) {
    SliceUncertainty& u = out[s];
    u.share = u.boundaryVoxels == 0 ? 0.0
                                    : static_cast<double>(u.contactVoxels + u.lowContrastVoxels) /
                                          static_cast<double>(u.boundaryVoxels);
    if (u.boundaryVoxels > 0) {
      u.contactShare = static_cast<double>(u.contactVoxels) / static_cast<double>(u.boundaryVoxels);
      u.lowContrastShare =
          static_cast<double>(u.lowContrastVoxels) / static_cast<double>(u.boundaryVoxels);
    }
    u.uncertain = u.boundaryVoxels > 0 && (u.contactShare >= options.minShare ||
                                           u.lowContrastShare >= options.minLowContrastShare);
    std::vector<std::size_t> idx;
    for (std::size_t b = 0; b < neighbours.size(); ++b) {
      if (touched[s][b])
        idx.push_back(b);
    }
    std::stable_sort(idx.begin(), idx.end(),
                     [&](std::size_t a, std::size_t b) { return touched[s][a] > touched[s][b]; });
    for (std::size_t b : idx)
      u.neighbours.push_back(neighbours[b].first);
  }
  return out;
}

// Streaks of the metal piece `label` (voxels of `pieceLabel` == label) on every axial slice it
// crosses (see CompetingOptions::detectStreaks): marks `streak` (1 bright, 2 dark) and counts.
void findStreaks(const core::CtImage& image, const std::vector<std::size_t>& pieceVoxels,
                 const CompetingOptions& o, std::vector<std::uint8_t>& streak, MetalPiece& piece) {
  // streak: 1 bright over soft tissue (the angular median below the weak threshold: left out of
  // the bone), 3 bright over bone (kept), 2 dark.
  const auto& d = image.dimensions;
  const Eigen::Vector3d spacing = image.spacingMm();
  const double step = std::min(spacing.x(), spacing.y());
  // Rays close enough that neighbours are at most a pixel apart at the reach.
  const int angles = std::max(
      180, static_cast<int>(std::ceil(2.0 * 3.14159265358979323846 * o.streakReachMm / step)));
  const int samples = static_cast<int>(std::ceil(o.streakReachMm / step));
  const double degree = angles / 360.0;                                 // rays per degree
  const int halfWindow = static_cast<int>(std::lround(10.0 * degree));  // +-10 degrees
  const int side = static_cast<int>(std::lround(8.0 * degree));         // +-8 degrees
  const int startSamples = static_cast<int>(std::ceil(6.0 / step));
  const int continuation = std::max(2, static_cast<int>(std::ceil(3.0 / step)));
  const int run = std::max(2, static_cast<int>(std::ceil(o.streakRunMm / step)));
  const Eigen::Vector3d centre = image.lpsToVoxel(piece.centreLps);
  std::vector<float> hu(sz(angles) * sz(samples));
  std::vector<std::int64_t> where(hu.size());
  std::vector<std::int8_t> sign(hu.size());
  std::vector<float> base(hu.size());  // the angular median: the tissue under the streak
  std::vector<double> cosines(sz(angles)), sines(sz(angles));
  for (int a = 0; a < angles; ++a) {
    const double t = 2.0 * 3.14159265358979323846 * a / angles;
    cosines[sz(a)] = std::cos(t);
    sines[sz(a)] = std::sin(t);
  }
  // The piece's voxels by slice (pieceVoxels is in index order: slices ascending).
  std::map<int, std::vector<std::pair<int, int>>> bySlice;
  for (std::size_t v : pieceVoxels) {
    int i, j, k;
    ijkOf(image, v, i, j, k);
    bySlice[k].emplace_back(i, j);
  }
  for (const auto& [k, pixels] : bySlice) {
    // The piece's voxels on this slice: their centre and in-plane radius.
    double ci = 0.0, cj = 0.0;
    for (const auto& [i, j] : pixels) {
      ci += i;
      cj += j;
    }
    ci /= static_cast<double>(pixels.size());
    cj /= static_cast<double>(pixels.size());
    double radius = 0.0;
    for (const auto& [i, j] : pixels)
      radius = std::max(radius, std::hypot((i - ci) * spacing.x(), (j - cj) * spacing.y()));
    const double start = radius + 2.0 * step;
    for (int a = 0; a < angles; ++a) {
      const double cx = cosines[sz(a)] / spacing.x(), cy = sines[sz(a)] / spacing.y();
      for (int r = 0; r < samples; ++r) {
        const double rr = start + r * step;
        const int i = static_cast<int>(std::lround(ci + rr * cx));
        const int j = static_cast<int>(std::lround(cj + rr * cy));
        const std::size_t s = sz(a) * sz(samples) + sz(r);
        if (i < 0 || j < 0 || i >= d[0] || j >= d[1]) {
          where[s] = -1;
          hu[s] = std::numeric_limits<float>::quiet_NaN();
          continue;
        }
        where[s] = static_cast<std::int64_t>(image.index(i, j, k));
        hu[s] = image.hu[static_cast<std::size_t>(where[s])];
      }
    }
    // Deviation from the angular median m (the (n/2)-th smallest of the n samples within
    // +-10 degrees at the same radius) by streakHu or more, by counting: m <= x - streakHu iff
    // at least n/2 + 1 samples are <= x - streakHu; m >= x + streakHu iff at least n - n/2 are
    // >= it. The median itself only where it is needed (bright samples: over bone or not).
    std::vector<float> window;
    for (int a = 0; a < angles; ++a) {
      for (int r = 0; r < samples; ++r) {
        const std::size_t s = sz(a) * sz(samples) + sz(r);
        sign[s] = 0;
        if (where[s] < 0)
          continue;
        const float x = hu[s];
        const float lowT = x - static_cast<float>(o.streakHu);
        const float highT = x + static_cast<float>(o.streakHu);
        int n = 0, lows = 0, highs = 0;
        for (int w = -halfWindow; w <= halfWindow; ++w) {
          const int b = (a + w + angles) % angles;
          const float v = hu[sz(b) * sz(samples) + sz(r)];
          if (std::isnan(v))
            continue;
          ++n;
          lows += v <= lowT ? 1 : 0;
          highs += v >= highT ? 1 : 0;
        }
        if (lows >= n / 2 + 1) {
          sign[s] = 1;
          window.clear();
          for (int w = -halfWindow; w <= halfWindow; ++w) {
            const float v = hu[sz((a + w + angles) % angles) * sz(samples) + sz(r)];
            if (!std::isnan(v))
              window.push_back(v);
          }
          auto mid = window.begin() + static_cast<std::ptrdiff_t>(window.size() / 2);
          std::nth_element(window.begin(), mid, window.end());
          base[s] = *mid;
        } else if (highs >= n - n / 2) {
          sign[s] = -1;
        }
      }
    }
    // A streak is narrow: the same sign 8 degrees to either side is a wide feature (a bone's
    // edge seen from the metal), not a streak.
    std::vector<std::int8_t> narrow(sign.size(), 0);
    for (int a = 0; a < angles; ++a) {
      for (int r = 0; r < samples; ++r) {
        const std::int8_t sg = sign[sz(a) * sz(samples) + sz(r)];
        const std::int8_t left = sign[sz((a + angles - side) % angles) * sz(samples) + sz(r)];
        const std::int8_t right = sign[sz((a + side) % angles) * sz(samples) + sz(r)];
        narrow[sz(a) * sz(samples) + sz(r)] = sg != 0 && left != sg && right != sg ? sg : 0;
      }
    }
    sign.swap(narrow);
    // Runs of one sign along each ray, at least streakRunMm long; a streak starts at the metal
    // (its first run within 6 mm of the rim) and may go on beyond a gap (bone it crosses) in
    // runs of 3 mm or more.
    bool any = false;
    for (int a = 0; a < angles; ++a) {
      int r = 0;
      std::int8_t going = 0;  // the sign of the streak this ray carries
      while (r < samples) {
        const std::int8_t sg = sign[sz(a) * sz(samples) + sz(r)];
        if (sg == 0) {
          ++r;
          continue;
        }
        // The run, across gaps of up to 2 samples (a ray grazes a streak one pixel wide).
        int e = r + 1, last = r;
        while (e < samples && e - last <= 3) {
          const std::int8_t g = sign[sz(a) * sz(samples) + sz(e)];
          if (g == -sg)
            break;
          if (g == sg)
            last = e;
          ++e;
        }
        e = last + 1;
        const bool starts = r <= startSamples || going == sg;
        if (e - r >= (going == sg ? continuation : run) && starts) {
          going = sg;
          any = true;
          for (int q = r; q < e; ++q) {
            const std::size_t at = sz(a) * sz(samples) + sz(q);
            if (sign[at] != sg)
              continue;
            const std::size_t v = static_cast<std::size_t>(where[at]);
            if (streak[v] != 0)
              continue;
            const bool overSoft = base[at] < o.threshold.weakHu;
            streak[v] = sg < 0 ? 2 : overSoft ? 1 : 3;
            if (sg > 0)
              ++piece.brightStreakVoxels;
            else
              ++piece.darkStreakVoxels;
            int vi, vj, vk;
            ijkOf(image, v, vi, vj, vk);
            piece.streakReachMm = std::max(
                piece.streakReachMm,
                std::hypot((vi - centre.x()) * spacing.x(), (vj - centre.y()) * spacing.y()));
          }
        }
        r = e;
      }
    }
    piece.streakSlices += any ? 1 : 0;
  }
}

namespace {

// A bone's waist along k (CompetingOptions::waistMinSliceMm): a slice whose area is at most
// kWaistShare of the largest within kWaistReachMm on each side, both at least kWaistMinAreaMm2.
constexpr double kWaistShare = 0.5;
constexpr double kWaistReachMm = 15.0;
constexpr double kWaistMinAreaMm2 = 300.0;

struct Waist {
  int slice = 0;
  double areaMm2 = 0.0, belowMm2 = 0.0, aboveMm2 = 0.0;
};

std::optional<Waist> waistOf(const VoxelMask& mask, const Eigen::Vector3d& spacing) {
  const auto& d = mask.geometry.dimensions;
  const double pixelMm2 = spacing.x() * spacing.y();
  std::vector<double> area(sz(d[2]), 0.0);
  for (int k = 0; k < d[2]; ++k) {
    std::size_t n = 0;
    const std::uint8_t* slice = mask.voxels.data() + mask.geometry.index(0, 0, k);
    for (std::size_t p = 0; p < sz(d[0]) * sz(d[1]); ++p)
      n += slice[p] != 0 ? 1u : 0u;
    area[sz(k)] = static_cast<double>(n) * pixelMm2;
  }
  const int reach = std::max(1, static_cast<int>(std::ceil(kWaistReachMm / spacing.z() - 1e-9)));
  for (int k = 1; k + 1 < d[2]; ++k) {
    double below = 0.0, above = 0.0;
    for (int j = std::max(0, k - reach); j < k; ++j)
      below = std::max(below, area[sz(j)]);
    for (int j = k + 1; j <= std::min(d[2] - 1, k + reach); ++j)
      above = std::max(above, area[sz(j)]);
    const double side = std::min(below, above);
    if (side >= kWaistMinAreaMm2 && area[sz(k)] <= kWaistShare * side)
      return Waist{k, area[sz(k)], below, above};
  }
  return std::nullopt;
}

// Calls f(v, n, axis) for each face between two labelled voxels of different labels (n = v + one
// step along axis), in index order.
template <typename F>
void forEachLabelFace(const core::CtImage& image, const std::vector<std::int16_t>& label, F f) {
  const auto& dims = image.dimensions;
  const std::size_t steps[3] = {1, sz(dims[0]), sz(dims[0]) * sz(dims[1])};
  for (int k = 0; k < dims[2]; ++k) {
    for (int j = 0; j < dims[1]; ++j) {
      for (int i = 0; i < dims[0]; ++i) {
        const std::size_t v = image.index(i, j, k);
        if (label[v] < 0)
          continue;
        const bool more[3] = {i + 1 < dims[0], j + 1 < dims[1], k + 1 < dims[2]};
        for (int a = 0; a < 3; ++a) {
          if (!more[a])
            continue;
          const std::size_t n = v + steps[a];
          if (label[n] >= 0 && label[n] != label[v])
            f(v, n, a);
        }
      }
    }
  }
}

// Two seeded bones refused (checkSeededBoundaries, or their seeds on one hill): the message, and
// the two bones' indices.
class SeededPairRefused : public std::invalid_argument {
 public:
  SeededPairRefused(const std::string& what, int a, int b)
      : std::invalid_argument(what), first(a), second(b) {}
  int first, second;
};

// A ball-and-socket joint's sphere (jointSphereShell): over its cap, at least kBallFilled of the
// voxels inside it are bone (the head), and kSocketLined of those within kSocketWallMm outside
// it (the cup's wall); and its joint-line inliers at least kShellSupport of the shell's voxels
// (the joint shows over much of the cap). Measured on the hip phantom at 5 mm, the spheres that
// separated the bones right: the head 0.99-1.00 bone, the wall 0.69-0.98, the support
// 0.54-0.60; a sphere through a tube's inner dips with seeds on either side of its marrow (two
// seeds in one bone, CliSegment.RefusalsNameTheFileAndWriteNothing): 0.99, 0.61 and 0.08.
constexpr double kSocketWallMm = 4.0;
constexpr double kBallFilled = 0.9;
constexpr double kSocketLined = 0.6;
constexpr double kShellSupport = 0.3;
// A ball fitted to its surface (jointSphereShell's fromSurface, where no joint line shows: the
// head pressed into its socket): the surface voxels count as inliers where the direction into
// the bone is within acos(kFacing) of the centre's, and they make at least kSurfaceSupport of the
// sphere's voxels outside the cap (the head shows where the socket does not cover it). The Hough
// transform's cells, candidates and least vote.
constexpr double kFacing = 0.7;
constexpr double kSurfaceSupport = 0.25;
constexpr double kSurfaceLined = 0.8;
constexpr double kSurfaceOpen = 0.55;
constexpr double kCapBinDegrees = 5.0;
constexpr double kCapMarginDegrees = 10.0;
constexpr double kSameCandidateMm = 1.0;
constexpr double kRingDegrees = 45.0;
constexpr double kRingLined = 0.35;
constexpr double kSurfaceMaxCapDegrees = 135.0;
constexpr double kHoughCellMm = 3.0;
constexpr std::size_t kHoughMaxCells = 32u << 20;
constexpr std::size_t kHoughCandidates = 200;
constexpr int kHoughMinVotes = 5;
// After the second growth the ball and the socket are checked within this of the sphere
// (checkSphereSides).
constexpr double kSidesBandMm = 6.0;
// Slices from which a growth that passed is checked against a joint's sphere too (the hip at the
// dissertation's 5 mm; at 3 mm the joint shows along the slices).
constexpr double kSphereAfterPassSpacingMm = 4.0;

// The index of the bone named `name` in `names` (a JointSphere names its ball and socket).
int boneIndex(const std::vector<std::string>& names, const std::string& name) {
  return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
}

// The sphere through four points, or nothing when they are (nearly) on one plane.
std::optional<std::pair<Eigen::Vector3d, double>> sphereThrough(const Eigen::Vector3d p[4]) {
  // |x|^2 + D x + E y + F z + G = 0 through each point.
  Eigen::Matrix4d a;
  Eigen::Vector4d b;
  for (int r = 0; r < 4; ++r) {
    a.row(r) << p[r].x(), p[r].y(), p[r].z(), 1.0;
    b(r) = -p[r].squaredNorm();
  }
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(a);
  if (!lu.isInvertible())
    return std::nullopt;
  const Eigen::Vector4d x = lu.solve(b);
  const Eigen::Vector3d centre = -0.5 * x.head<3>();
  const double r2 = centre.squaredNorm() - x(3);
  if (!(r2 > 0.0) || !std::isfinite(r2))
    return std::nullopt;
  return std::make_pair(centre, std::sqrt(r2));
}

// The index box of the voxels within `reachMm` of the continuous index `centreVoxel` along each
// axis, clipped to the image.
void sphereBox(const core::CtImage& image, const Eigen::Vector3d& centreVoxel, double reachMm,
               Eigen::Vector3i& lo, Eigen::Vector3i& hi) {
  const Eigen::Vector3d spacing = image.spacingMm();
  for (int a = 0; a < 3; ++a) {
    const double span = reachMm / spacing(a) + 1.0;
    lo(a) = std::max(0, static_cast<int>(std::floor(centreVoxel(a) - span)));
    hi(a) = std::min(image.dimensions[a] - 1, static_cast<int>(std::ceil(centreVoxel(a) + span)));
  }
}

// The nearest and the farthest point of voxel `v`'s box from a sphere's centre at the continuous
// index `centreVoxel`: their distances, mm.
std::pair<double, double> boxDistancesMm(const Eigen::Vector3i& v,
                                         const Eigen::Vector3d& centreVoxel,
                                         const Eigen::Vector3d& spacing) {
  const Eigen::Vector3d delta = (v.cast<double>() - centreVoxel).cwiseAbs().cwiseProduct(spacing);
  return {(delta - 0.5 * spacing).cwiseMax(0.0).norm(), (delta + 0.5 * spacing).norm()};
}

// A ball-and-socket joint whose line shows only where it crosses the slices
// (CompetingOptions::jointFromSphere): a sphere through the joint-line voxels labelled `a` or `b`
// (RANSAC with a fixed seed, then least squares on the inliers), and its shell over the cap the
// inliers span, the voxels whose box the sphere passes through (a surface no 26-path crosses).
// Fills `shell` and `sphere` and returns true where a sphere fits: at least jointSphereMinInliers
// joint-line voxels, one bone's seeds inside and the other's outside, a cap of at least
// jointSphereMinCapDegrees, the centre in the ball where the labels are known.
bool jointSphereShell(const core::CtImage& image, const VoxelMask& solid,
                      const std::vector<std::uint8_t>& joints,
                      const std::vector<std::int16_t>* label, int a, int b,
                      const std::vector<std::string>& names,
                      const std::vector<std::vector<Eigen::Vector3d>>& seedsOf,
                      const CompetingOptions& options, bool fromSurface,
                      std::vector<std::uint8_t>& shell, JointSphere& sphere) {
  // The joint-line voxels the two bones hold; before the flood (two seeds on one hill), those
  // within two of the largest radii of their seeds. From the surface: the bone's voxels next to
  // soft tissue, with the direction into the bone (the CT's gradient).
  std::vector<Eigen::Vector3d> points, inward;
  const double reach = 2.0 * options.jointSphereMaxRadiusMm;
  const Eigen::Vector3d spacing = image.spacingMm();
  const auto& dims = image.dimensions;
  for (std::size_t v = 0; v < joints.size(); ++v) {
    if (label && (*label)[v] != a && (*label)[v] != b)
      continue;
    if (!fromSurface && !joints[v])
      continue;
    int i, j, k;
    ijkOf(image, v, i, j, k);
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    if (fromSurface) {
      if (!solid.voxels[v] || i == 0 || j == 0 || k == 0 || i + 1 == dims[0] || j + 1 == dims[1] ||
          k + 1 == dims[2])
        continue;
      if (solid.at(i - 1, j, k) && solid.at(i + 1, j, k) && solid.at(i, j - 1, k) &&
          solid.at(i, j + 1, k) && solid.at(i, j, k - 1) && solid.at(i, j, k + 1))
        continue;
      gradient =
          Eigen::Vector3d((image.at(i + 1, j, k) - image.at(i - 1, j, k)) / (2.0 * spacing.x()),
                          (image.at(i, j + 1, k) - image.at(i, j - 1, k)) / (2.0 * spacing.y()),
                          (image.at(i, j, k + 1) - image.at(i, j, k - 1)) / (2.0 * spacing.z()));
      if (!(gradient.norm() > 0.0))
        continue;
    }
    const Eigen::Vector3d p = image.voxelToLps(Eigen::Vector3d(i, j, k));
    if (!label) {
      bool near = false;
      for (const int bone : {a, b}) {
        for (const Eigen::Vector3d& q : seedsOf[sz(bone)])
          near = near || (p - q).norm() <= reach;
      }
      if (!near)
        continue;
    }
    if (fromSurface) {
      // The surface lies between the voxel and its soft-tissue neighbour: half a voxel out.
      const Eigen::Vector3d g = gradient.normalized();
      points.push_back(p - 0.5 * spacing.minCoeff() * g);
      inward.push_back(g);
    } else {
      points.push_back(p);
    }
  }
  const int n = static_cast<int>(points.size());
  if (n < options.jointSphereMinInliers)
    return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points)
    mean += p;
  mean /= n;
  for (Eigen::Vector3d& p : points)
    p -= mean;  // centred, for the conditioning of the fits
  const double tolerance = options.jointSphereToleranceMm;
  // From the surface, an inlier's bone lies towards the centre (a ball, not a socket's lining).
  const auto isInlier = [&](std::size_t q, const Eigen::Vector3d& c, double r) {
    const Eigen::Vector3d u = points[q] - c;
    const double d = u.norm();
    return std::fabs(d - r) <= tolerance && (!fromSurface || -inward[q].dot(u) >= kFacing * d);
  };
  const auto inliersOf = [&](const Eigen::Vector3d& c, double r) {
    int count = 0;
    for (std::size_t q = 0; q < points.size(); ++q)
      count += isInlier(q, c, r) ? 1 : 0;
    return count;
  };
  // The label of the voxel holding the (centred) point `c`; -1 outside the image.
  const auto labelAt = [&](const Eigen::Vector3d& c) {
    const Eigen::Vector3d v = image.lpsToVoxel(c + mean);
    const Eigen::Vector3i at(static_cast<int>(std::lround(v.x())),
                             static_cast<int>(std::lround(v.y())),
                             static_cast<int>(std::lround(v.z())));
    if (at.minCoeff() < 0 || at.x() >= image.dimensions[0] || at.y() >= image.dimensions[1] ||
        at.z() >= image.dimensions[2])
      return -1;
    return static_cast<int>((*label)[image.index(at.x(), at.y(), at.z())]);
  };
  // The ball: the bone whose seeds all lie inside the sphere, the other's all outside. Where the
  // labels are known and no seed lies inside (the femur seeded in its neck or shaft), the bone
  // that holds the sphere's centre. -1 when neither.
  const auto ballOf = [&](const Eigen::Vector3d& c, double r) {
    const auto all = [&](int bone, bool in) {
      for (const Eigen::Vector3d& q : seedsOf[sz(bone)]) {
        if (((q - mean - c).norm() < r) != in)
          return false;
      }
      return true;
    };
    if (all(a, true) && all(b, false))
      return a;
    if (all(b, true) && all(a, false))
      return b;
    if (!label || !all(a, false) || !all(b, false))
      return -1;
    const int holder = labelAt(c);
    return holder == a || holder == b ? holder : -1;
  };
  // Least squares on the inliers (a few rounds, while the fit gets denser). Each voxel is taken
  // at its centre: taken as its box (the joint anywhere within a thick slice), the fits on the
  // hip phantom at 5 mm came out a slice off the joint, through the head's inner dips.
  // `anyway`: every round taken while the radius stays in range (a Hough cell's centre and
  // radius are coarse: their first fit can be sparser than the cell).
  const auto refine = [&](Eigen::Vector3d& centre, double& radius, int& count, double& density,
                          bool anyway) {
    for (int round = 0; round < 5; ++round) {
      std::vector<Eigen::Vector3d> on;
      for (std::size_t q = 0; q < points.size(); ++q) {
        if (isInlier(q, centre, radius))
          on.push_back(points[q]);
      }
      if (on.size() < 4)
        break;
      Eigen::MatrixXd m(static_cast<Eigen::Index>(on.size()), 4);
      Eigen::VectorXd rhs(static_cast<Eigen::Index>(on.size()));
      for (std::size_t r = 0; r < on.size(); ++r) {
        m.row(static_cast<Eigen::Index>(r)) << on[r].x(), on[r].y(), on[r].z(), 1.0;
        rhs(static_cast<Eigen::Index>(r)) = -on[r].squaredNorm();
      }
      const Eigen::Vector4d x = m.colPivHouseholderQr().solve(rhs);
      const Eigen::Vector3d c = -0.5 * x.head<3>();
      const double r2 = c.squaredNorm() - x(3);
      if (!(r2 > 0.0))
        break;
      const double r = std::sqrt(r2);
      const int n2 = inliersOf(c, r);
      if (r < options.jointSphereMinRadiusMm || r > options.jointSphereMaxRadiusMm ||
          (!anyway && n2 / (r * r) < density) || ballOf(c, r) < 0)
        break;
      density = n2 / (r * r);
      centre = c;
      radius = r;
      count = n2;
    }
  };
  struct Candidate {
    double density;
    int count;
    Eigen::Vector3d centre;
    double radius;
  };
  std::vector<Candidate> candidates;
  if (!fromSurface) {
    Eigen::Vector3d bestCentre = Eigen::Vector3d::Zero();
    double bestRadius = 0.0;
    int best = 0;
    double bestDensity = 0.0;
    std::mt19937 random(2008);
    for (int trial = 0; trial < 4000; ++trial) {
      Eigen::Vector3d four[4];
      for (auto& q : four)
        q = points[random() % static_cast<std::uint32_t>(n)];
      const auto s = sphereThrough(four);
      if (!s || s->second < options.jointSphereMinRadiusMm ||
          s->second > options.jointSphereMaxRadiusMm)
        continue;
      if (ballOf(s->first, s->second) < 0)
        continue;
      const int count = inliersOf(s->first, s->second);
      // Inliers per area: any sphere through a cloud of joint-line voxels holds more of them
      // the larger it is; the joint's own sphere holds them densest.
      const double density = count / (s->second * s->second);
      if (count >= options.jointSphereMinInliers && density > bestDensity) {
        bestDensity = density;
        best = count;
        bestCentre = s->first;
        bestRadius = s->second;
      }
    }
    if (best < options.jointSphereMinInliers)
      return false;
    refine(bestCentre, bestRadius, best, bestDensity, false);
    candidates.push_back({bestDensity, best, bestCentre, bestRadius});
  } else {
    // Each surface voxel votes for the centres one radius into the bone along its gradient
    // (a Hough transform over centre and radius); the cells with the most votes, refined by
    // least squares, are the candidates. Four points drawn at random (as above) hardly ever
    // all lie on the head: on the hip phantom at 5 mm, 4 % of the surface voxels do.
    const int r0 = static_cast<int>(std::ceil(options.jointSphereMinRadiusMm));
    const int r1 = static_cast<int>(std::floor(options.jointSphereMaxRadiusMm));
    if (r1 < r0)
      return false;
    const std::size_t radii = sz(r1 - r0 + 1);
    Eigen::Vector3d low = points[0], high = points[0];
    for (const Eigen::Vector3d& p : points) {
      low = low.cwiseMin(p);
      high = high.cwiseMax(p);
    }
    double cell = kHoughCellMm;
    Eigen::Vector3i cells;
    for (;;) {
      for (int ax = 0; ax < 3; ++ax)
        cells(ax) = static_cast<int>((high(ax) - low(ax)) / cell) + 1;
      if (sz(cells.x()) * sz(cells.y()) * sz(cells.z()) * radii <= kHoughMaxCells)
        break;
      cell *= 1.25;
    }
    std::vector<std::uint16_t> votes(sz(cells.x()) * sz(cells.y()) * sz(cells.z()) * radii, 0);
    for (std::size_t q = 0; q < points.size(); ++q) {
      for (int r = r0; r <= r1; ++r) {
        const Eigen::Vector3d c = (points[q] + r * inward[q] - low) / cell;
        if (c.minCoeff() < 0.0)
          continue;
        const int x = static_cast<int>(c.x()), y = static_cast<int>(c.y()),
                  z = static_cast<int>(c.z());
        if (x >= cells.x() || y >= cells.y() || z >= cells.z())
          continue;
        std::uint16_t& vote =
            votes[((sz(z) * sz(cells.y()) + sz(y)) * sz(cells.x()) + sz(x)) * radii + sz(r - r0)];
        vote = static_cast<std::uint16_t>(std::min(65535, vote + 1));
      }
    }
    std::vector<std::pair<std::uint16_t, std::size_t>> top;
    for (std::size_t v = 0; v < votes.size(); ++v) {
      if (votes[v] >= kHoughMinVotes)
        top.emplace_back(votes[v], v);
    }
    const std::size_t keep = std::min(top.size(), kHoughCandidates);
    std::partial_sort(top.begin(), top.begin() + static_cast<std::ptrdiff_t>(keep), top.end(),
                      [](const auto& x, const auto& y) {
                        return x.first > y.first || (x.first == y.first && x.second < y.second);
                      });
    for (std::size_t t = 0; t < keep; ++t) {
      const std::size_t v = top[t].second;
      double radius = r0 + static_cast<int>(v % radii);
      const std::size_t c = v / radii;
      Eigen::Vector3d centre =
          low +
          cell * Eigen::Vector3d(static_cast<double>(c % sz(cells.x())) + 0.5,
                                 static_cast<double>((c / sz(cells.x())) % sz(cells.y())) + 0.5,
                                 static_cast<double>(c / sz(cells.x()) / sz(cells.y())) + 0.5);
      int count = inliersOf(centre, radius);
      double density = count / (radius * radius);
      refine(centre, radius, count, density, true);
      if (radius < options.jointSphereMinRadiusMm || radius > options.jointSphereMaxRadiusMm ||
          ballOf(centre, radius) < 0 || count < options.jointSphereMinInliers)
        continue;
      candidates.push_back({density, count, centre, radius});
    }
    // Densest first: of near-copies (kSameCandidateMm) the densest is the one checked.
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& x, const Candidate& y) { return x.density > y.density; });
  }
  // The candidate's cap, its checks and its shell; false where a check fails.
  const auto finish = [&](const Candidate& candidate) -> bool {
    const Eigen::Vector3d& bestCentre = candidate.centre;
    const double bestRadius = candidate.radius;
    const int best = candidate.count;
    // The cap the inliers span: about their mean direction, out to the angle that holds 95 % of
    // them and 10 degrees more, at most a hemisphere (an acetabulum covers the head up to about 90
    // degrees from its pole; wider, the shell cut the pubis from the hip bone on the phantom).
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    double squares = 0.0;
    std::vector<Eigen::Vector3d> directions;
    for (std::size_t q = 0; q < points.size(); ++q) {
      if (!isInlier(q, bestCentre, bestRadius))
        continue;
      const Eigen::Vector3d& p = points[q];
      const double d = (p - bestCentre).norm();
      directions.push_back((p - bestCentre) / std::max(d, 1e-9));
      axis += directions.back();
      squares += (d - bestRadius) * (d - bestRadius);
    }
    if (axis.norm() < 1e-9)
      return false;
    axis.normalize();
    std::vector<double> angles;
    for (const Eigen::Vector3d& u : directions)
      angles.push_back(std::acos(std::clamp(u.dot(axis), -1.0, 1.0)) * 180.0 / M_PI);
    const auto at = angles.begin() + static_cast<std::ptrdiff_t>((angles.size() - 1) * 19 / 20);
    std::nth_element(angles.begin(), at, angles.end());
    const double spread = *at;
    if (spread < options.jointSphereMinCapDegrees)
      return false;
    double capDegrees = std::min(spread + 10.0, 90.0);
    const Eigen::Vector3d centreLps = bestCentre + mean;
    const Eigen::Vector3d centreVoxel = image.lpsToVoxel(centreLps);
    const int ball = ballOf(bestCentre, bestRadius);
    if (label && labelAt(bestCentre) != ball)
      return false;
    if (fromSurface) {
      // The ball's surface shows where no socket covers it: the cap lies the other way. Its
      // axis: from the side opposite the surface, the mean direction of the bone lining the
      // sphere (the band kSocketWallMm outside it) in the hemisphere about it, a few times (the
      // neck's bone, beside the surface, drops out).
      std::vector<std::pair<Eigen::Vector3d, bool>> band;  // direction, bone
      Eigen::Vector3i lo, hi;
      sphereBox(image, centreVoxel, bestRadius + kSocketWallMm, lo, hi);
      for (int k = lo.z(); k <= hi.z(); ++k) {
        for (int j = lo.y(); j <= hi.y(); ++j) {
          for (int i = lo.x(); i <= hi.x(); ++i) {
            const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(i, j, k)) - centreLps;
            const double d = u.norm();
            if (d < bestRadius + tolerance || d > bestRadius + kSocketWallMm)
              continue;
            band.emplace_back(u / d, solid.voxels[image.index(i, j, k)] != 0);
          }
        }
      }
      axis = -axis;
      for (int round = 0; round < 3; ++round) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (const auto& [u, bone] : band)
          sum += bone && u.dot(axis) >= 0.0 ? u : Eigen::Vector3d::Zero();
        if (sum.norm() < 1e-9)
          return false;
        axis = sum.normalized();
      }
      // The cap: out from the axis while the band is mostly bone (kCapBinDegrees wide rings).
      constexpr int bins = static_cast<int>(180.0 / kCapBinDegrees) + 1;
      std::array<std::size_t, bins> all{}, lined{};
      for (const auto& [u, bone] : band) {
        const double angle = std::acos(std::clamp(u.dot(axis), -1.0, 1.0)) * 180.0 / M_PI;
        const auto bin = static_cast<std::size_t>(angle / kCapBinDegrees);
        ++all[bin];
        lined[bin] += bone ? 1u : 0u;
      }
      int edge = 0;
      while (edge < bins && all[sz(edge)] > 0 && 2 * lined[sz(edge)] >= all[sz(edge)])
        ++edge;
      capDegrees = std::min(edge * kCapBinDegrees + kCapMarginDegrees, kSurfaceMaxCapDegrees);
      // Beyond the socket's edge the ball shows: the ring kRingDegrees wide past the cap is
      // mostly soft tissue (a sphere through a bone's inside, or enclosing the head with the
      // cup's wall, is lined on and on).
      std::size_t ringAll = 0, ringLined = 0;
      for (int q = edge; q < std::min(bins, edge + static_cast<int>(kRingDegrees / kCapBinDegrees));
           ++q) {
        ringAll += all[sz(q)];
        ringLined += lined[sz(q)];
      }
      if (ringAll == 0 ||
          static_cast<double>(ringLined) > kRingLined * static_cast<double>(ringAll))
        return false;
    }
    // A ball fills its sphere and a socket lines it: over the cap, the voxels inside the sphere
    // (by more than the tolerance) are bone, and those within a shell outside it (the socket's
    // wall, kSocketWallMm) mostly bone. Two seeds on either side of a tube's marrow had a sphere
    // through its inner dips split the tube in two, every check passed.
    const double cosCap = std::cos(capDegrees * M_PI / 180.0);
    Eigen::Vector3i lo, hi;
    sphereBox(image, centreVoxel, bestRadius + kSocketWallMm, lo, hi);
    std::size_t ballVoxels = 0, ballBone = 0, wallVoxels = 0, wallBone = 0, openVoxels = 0,
                open = 0;
    for (int k = lo.z(); k <= hi.z(); ++k) {
      for (int j = lo.y(); j <= hi.y(); ++j) {
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(i, j, k)) - centreLps;
          const double d = u.norm();
          if (d < 1e-9)
            continue;
          const bool bone = solid.voxels[image.index(i, j, k)] != 0;
          if (u.dot(axis) < cosCap * d) {
            // Outside the cap, next to the sphere: where the ball shows, soft tissue.
            if (d >= bestRadius + tolerance && d <= bestRadius + kSocketWallMm) {
              ++openVoxels;
              open += bone ? 0u : 1u;
            }
            continue;
          }
          if (d <= bestRadius - tolerance) {
            ++ballVoxels;
            ballBone += bone ? 1u : 0u;
          } else if (d >= bestRadius + tolerance && d <= bestRadius + kSocketWallMm) {
            ++wallVoxels;
            wallBone += bone ? 1u : 0u;
          }
        }
      }
    }
    if (static_cast<double>(ballBone) < kBallFilled * static_cast<double>(ballVoxels) ||
        static_cast<double>(wallBone) <
            (fromSurface ? kSurfaceLined : kSocketLined) * static_cast<double>(wallVoxels) ||
        (fromSurface && static_cast<double>(open) < kSurfaceOpen * static_cast<double>(openVoxels)))
      return false;
    // The shell: every voxel whose box the sphere passes through, within the cap.
    shell.assign(joints.size(), 0);
    std::size_t marked = 0, uncovered = 0;
    for (int k = lo.z(); k <= hi.z(); ++k) {
      for (int j = lo.y(); j <= hi.y(); ++j) {
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const auto [near, far] = boxDistancesMm(Eigen::Vector3i(i, j, k), centreVoxel, spacing);
          if (near > bestRadius || far < bestRadius)
            continue;
          const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(i, j, k)) - centreLps;
          if (u.norm() < 1e-9 || u.dot(axis) < cosCap * u.norm()) {
            ++uncovered;
            continue;
          }
          shell[image.index(i, j, k)] = 1;
          ++marked;
        }
      }
    }
    if (fromSurface ? static_cast<double>(best) < kSurfaceSupport * static_cast<double>(uncovered)
                    : static_cast<double>(best) < kShellSupport * static_cast<double>(marked)) {
      shell.clear();
      return false;
    }
    sphere.ball = names[sz(ball)];
    sphere.socket = names[sz(ball == a ? b : a)];
    sphere.centreLps = centreLps;
    sphere.radiusMm = bestRadius;
    sphere.rmsMm = std::sqrt(squares / static_cast<double>(directions.size()));
    sphere.inliers = best;
    sphere.points = n;
    sphere.axisLps = axis;
    sphere.capDegrees = capDegrees;
    sphere.shellVoxels = marked;
    sphere.fromSurface = fromSurface;
    return true;
  };
  // The joint line's sphere: the densest. From the surface: of those that pass, the one the
  // most surface voxels lie on (a ball shows much of itself; the hip bone's own curves, fitted
  // denser on the phantom, are small).
  const Candidate* chosen = nullptr;
  std::vector<const Candidate*> tried;
  for (const Candidate& candidate : candidates) {
    bool seen = false;
    for (const Candidate* t : tried)
      seen = seen || ((t->centre - candidate.centre).norm() < kSameCandidateMm &&
                      std::fabs(t->radius - candidate.radius) < kSameCandidateMm);
    if (seen)
      continue;
    tried.push_back(&candidate);
    if ((!chosen || candidate.count > chosen->count) && finish(candidate)) {
      chosen = &candidate;
      if (!fromSurface)
        break;
    }
  }
  if (!chosen || !finish(*chosen)) {
    shell.clear();
    return false;
  }
  return true;
}

// Each patch of the boundary between two seeded bones (CompetingOptions::seededPatchJointShare):
// the faces between their voxels, in 26-connected pieces; a piece of at least seededPatchMinShare
// of the pair's boundary whose faces are less than seededPatchJointShare joint-like (a joint
// line, or cortex against cortex) is a cut through a bone, refused. The share over the whole
// boundary hides one: the real pelvis averaged to 5 mm slices, the right hip's basin ran round
// the sacroiliac joint into the back of the sacrum, 43 % of the whole boundary joint-like (the
// joint itself, 80 %) but two pieces of 31 % each at 23-24 %.
//
// And the boundary's depth (CompetingOptions::seededCutDepthMm): `depthMm(v)` is the distance map
// at v, `topMm[b]` the top of bone b's hill.
template <typename Inside, typename JointFace, typename Depth>
void checkSeededBoundaries(const core::CtImage& image, const std::vector<std::int16_t>& label,
                           int firstAuto, const std::vector<std::string>& names, Inside inside,
                           JointFace jointFace, Depth depthMm, const std::vector<double>& topMm,
                           const CompetingOptions& options, double maxSpacing) {
  if (firstAuto < 2)
    return;
  const Eigen::Vector3d spacing = image.spacingMm();
  const double faceMm2[3] = {spacing.y() * spacing.z(), spacing.x() * spacing.z(),
                             spacing.x() * spacing.y()};
  struct Face {
    std::size_t v, n;
    int axis;
  };
  std::map<std::pair<int, int>, std::vector<Face>> faces;
  forEachLabelFace(image, label, [&](std::size_t v, std::size_t n, int a) {
    if (label[v] < firstAuto && label[n] < firstAuto)
      faces[{std::min(label[v], label[n]), std::max(label[v], label[n])}].push_back({v, n, a});
  });
  // Largest boundaries first.
  std::vector<std::pair<std::pair<int, int>, const std::vector<Face>*>> pairs;
  for (const auto& [pair, list] : faces)
    pairs.push_back({pair, &list});
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
    return a.second->size() > b.second->size();
  });
  for (const auto& [pair, listPointer] : pairs) {
    const std::vector<Face>& list = *listPointer;
    const double pairFaces = static_cast<double>(list.size());
    // One pass over the faces: the cancellous and joint-like counts, and the depths.
    std::size_t insideFaces = 0, jointFaces = 0;
    std::vector<double> depth;
    if (options.seededCutDepthMm > 0.0)
      depth.reserve(list.size());
    for (const Face& f : list) {
      insideFaces += inside(f.v) && inside(f.n) ? 1u : 0u;
      jointFaces += jointFace(f.v, f.n) ? 1u : 0u;
      if (options.seededCutDepthMm > 0.0)
        depth.push_back(std::min(depthMm(f.v), depthMm(f.n)));
    }
    const double share = static_cast<double>(insideFaces) / pairFaces;
    const double jointShare = static_cast<double>(jointFaces) / pairFaces;
    if (share >= options.insideShare) {
      throw SeededPairRefused(
          fmt::format(
              "the {} and the {} seeds lie in one bone: their parts meet through the inside of a "
              "bone ({:.0f} % of the boundary between them is cancellous bone or marrow), not at "
              "a joint; give one seed per bone{}",
              names[sz(pair.first)], names[sz(pair.second)], 100.0 * share,
              maxSpacing >= 3.0 ? fmt::format(" (at {:.1f} mm slices a joint may not show: if the "
                                              "seeds are in two bones, outline them with "
                                              "--anchors)",
                                              maxSpacing)
                                : std::string()),
          pair.first, pair.second);
    }
    if (jointShare < options.seededJointShare) {
      throw SeededPairRefused(
          fmt::format(
              "the {} and the {} cannot be told apart: the boundary found between them is not a "
              "joint (only {:.0f} % of it a joint line or cortex against cortex, {:.0f} % "
              "cancellous bone or marrow){}; outline them with --anchors (Live-Wire) or segment "
              "a thinner series",
              names[sz(pair.first)], names[sz(pair.second)], 100.0 * jointShare, 100.0 * share,
              maxSpacing >= 3.0
                  ? fmt::format(": at {:.1f} mm slices the joint does not show", maxSpacing)
                  : std::string()),
          pair.first, pair.second);
    }
    if (options.seededCutDepthMm > 0.0) {
      const auto at = depth.begin() + static_cast<std::ptrdiff_t>((depth.size() - 1) * 9 / 10);
      std::nth_element(depth.begin(), at, depth.end());
      const double lowerTop = std::min(topMm[sz(pair.first)], topMm[sz(pair.second)]);
      if (*at >= options.seededCutDepthMm && *at >= options.seededCutDepthShare * lowerTop) {
        throw SeededPairRefused(
            fmt::format(
                "the {} and the {} cannot be told apart: the boundary found between them runs "
                "through the thick of the bone (a tenth of it {:.1f} mm or more from the bone's "
                "surface, {:.0f} % as deep as the {}'s deepest point), not through a narrowing "
                "where "
                "two bones meet at a joint{}; outline them with --anchors (Live-Wire) or segment a "
                "thinner series",
                names[sz(pair.first)], names[sz(pair.second)], *at, 100.0 * *at / lowerTop,
                names[sz(topMm[sz(pair.first)] <= topMm[sz(pair.second)] ? pair.first
                                                                         : pair.second)],
                maxSpacing >= 3.0
                    ? fmt::format(": at {:.1f} mm slices a joint along the slices does not show",
                                  maxSpacing)
                    : std::string()),
            pair.first, pair.second);
      }
    }
    if (!(options.seededPatchJointShare > 0.0))
      continue;
    // The faces' voxels, joined when 26-neighbours (union-find over the voxels).
    std::map<std::size_t, std::uint32_t> node;
    std::vector<std::uint32_t> parent;
    auto nodeOf = [&](std::size_t v) {
      const auto [it, added] = node.emplace(v, static_cast<std::uint32_t>(parent.size()));
      if (added)
        parent.push_back(it->second);
      return it->second;
    };
    auto root = [&](std::uint32_t x) {
      while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
      return x;
    };
    auto join = [&](std::uint32_t a, std::uint32_t b) {
      a = root(a);
      b = root(b);
      if (a != b)
        parent[std::max(a, b)] = std::min(a, b);
    };
    for (const Face& f : list)
      join(nodeOf(f.v), nodeOf(f.n));
    for (const auto& [v, id] : node) {
      int i, j, k;
      ijkOf(image, v, i, j, k);
      forNeighbours(image, i, j, k, [&](std::size_t n) {
        const auto it = node.find(n);
        if (it != node.end())
          join(id, it->second);
      });
    }
    struct Patch {
      std::size_t total = 0, inside = 0, joint = 0;
      double areaMm2 = 0.0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    };
    std::map<std::uint32_t, Patch> patches;
    for (const Face& f : list) {
      Patch& p = patches[root(node.at(f.v))];
      ++p.total;
      p.inside += inside(f.v) && inside(f.n) ? 1u : 0u;
      p.joint += jointFace(f.v, f.n) ? 1u : 0u;
      p.areaMm2 += faceMm2[f.axis];
      int i, j, k;
      ijkOf(image, f.v, i, j, k);
      p.sum += image.voxelToLps(Eigen::Vector3d(i, j, k));
    }
    for (const auto& [id, p] : patches) {
      const double total = static_cast<double>(p.total);
      if (total < options.seededPatchMinShare * pairFaces)
        continue;
      const double patchJointShare = static_cast<double>(p.joint) / total;
      if (patchJointShare >= options.seededPatchJointShare)
        continue;
      throw SeededPairRefused(
          fmt::format(
              "the {} and the {} cannot be told apart: part of the boundary found between them "
              "({:.0f} mm^2 around {}, {:.0f} % of it) is not a joint (only {:.0f} % of that part "
              "a "
              "joint line or cortex against cortex, {:.0f} % cancellous bone or marrow): the "
              "growth cut through a bone there{}; outline them with --anchors (Live-Wire) or "
              "segment "
              "a thinner series",
              names[sz(pair.first)], names[sz(pair.second)], p.areaMm2, lpsText(p.sum / total),
              100.0 * total / pairFaces, 100.0 * patchJointShare,
              100.0 * static_cast<double>(p.inside) / total,
              maxSpacing >= 3.0
                  ? fmt::format(" (at {:.1f} mm slices a joint may not show)", maxSpacing)
                  : std::string()),
          pair.first, pair.second);
    }
  }
}

}  // namespace

std::vector<SliceContact> contactsAlongSlices(const core::CtImage& ct,
                                              const std::vector<SegmentedBone>& bones) {
  const std::size_t count = ct.voxelCount();
  std::vector<std::int16_t> label(count, -1);
  for (std::size_t b = bones.size(); b-- > 0;) {
    if (bones[b].mask.voxels.size() != count)
      throw std::invalid_argument(
          fmt::format("contactsAlongSlices: the {} mask has {} voxels, the CT {}", bones[b].bone,
                      bones[b].mask.voxels.size(), count));
    for (std::size_t v = 0; v < count; ++v) {
      if (bones[b].mask.voxels[v])
        label[v] = static_cast<std::int16_t>(std::min<std::size_t>(b, 32767));
    }
  }
  const Eigen::Vector3d spacing = ct.spacingMm();
  const double pixelMm2 = spacing.x() * spacing.y();
  struct Sum {
    std::size_t faces = 0;
    double zMin = std::numeric_limits<double>::infinity();
    double zMax = -std::numeric_limits<double>::infinity();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  };
  std::map<std::pair<int, int>, Sum> sums;
  forEachLabelFace(ct, label, [&](std::size_t v, std::size_t n, int axis) {
    if (axis != 2)
      return;
    Sum& e = sums[{std::min(label[v], label[n]), std::max(label[v], label[n])}];
    ++e.faces;
    int i, j, k;
    ijkOf(ct, v, i, j, k);
    const Eigen::Vector3d p = 0.5 * (ct.voxelToLps(Eigen::Vector3d(i, j, k)) +
                                     ct.voxelToLps(Eigen::Vector3d(i, j, k + 1)));
    e.zMin = std::min(e.zMin, p.z());
    e.zMax = std::max(e.zMax, p.z());
    e.sum += p;
  });
  std::vector<SliceContact> out;
  for (const auto& [pair, e] : sums) {
    SliceContact c;
    c.first = bones[sz(pair.first)].bone;
    c.second = bones[sz(pair.second)].bone;
    c.areaMm2 = static_cast<double>(e.faces) * pixelMm2;
    c.zMinMm = e.zMin;
    c.zMaxMm = e.zMax;
    c.centreLps = e.sum / static_cast<double>(e.faces);
    out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(), [](const SliceContact& x, const SliceContact& y) {
    return x.areaMm2 > y.areaMm2;
  });
  return out;
}

// The work, on a grid that holds every bone voxel (see segmentCompetingBones).
// After a growth with a sphere's shell as joint line: the ball bone lies inside the sphere and
// the socket outside, over the cap (the voxels within 6 mm of the sphere, their boxes wholly on
// one side by the tolerance): at most 5 % of either bone's voxels there on the wrong side, else
// the sphere was not the joint (a fit through the head's inner structure or the cup's wall, off
// the joint by a slice), refused.
void checkSphereSides(const core::CtImage& image, const std::vector<std::int16_t>& label,
                      const std::vector<std::string>& names, const JointSphere& sphere,
                      const CompetingOptions& options) {
  const int ball = boneIndex(names, sphere.ball), socket = boneIndex(names, sphere.socket);
  const Eigen::Vector3d spacing = image.spacingMm();
  const Eigen::Vector3d centreVoxel = image.lpsToVoxel(sphere.centreLps);
  const double cosCap = std::cos(sphere.capDegrees * M_PI / 180.0);
  const double tolerance = options.jointSphereToleranceMm;
  std::size_t ballIn = 0, ballOut = 0, socketIn = 0, socketOut = 0;
  Eigen::Vector3i lo, hi;
  sphereBox(image, centreVoxel, sphere.radiusMm + kSidesBandMm, lo, hi);
  for (int k = lo.z(); k <= hi.z(); ++k) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      for (int i = lo.x(); i <= hi.x(); ++i) {
        const std::int16_t l = label[image.index(i, j, k)];
        if (l != ball && l != socket)
          continue;
        const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(i, j, k)) - sphere.centreLps;
        const double d = u.norm();
        if (std::fabs(d - sphere.radiusMm) > kSidesBandMm || u.dot(sphere.axisLps) < cosCap * d)
          continue;
        const auto [near, far] = boxDistancesMm(Eigen::Vector3i(i, j, k), centreVoxel, spacing);
        const bool out = near > sphere.radiusMm + tolerance;
        const bool in = far < sphere.radiusMm - tolerance;
        if (l == ball) {
          ballIn += in ? 1u : 0u;
          ballOut += out ? 1u : 0u;
        } else {
          socketIn += in ? 1u : 0u;
          socketOut += out ? 1u : 0u;
        }
      }
    }
  }
  const auto wrong = [](std::size_t bad, std::size_t good) {
    return static_cast<double>(bad) > 0.05 * static_cast<double>(bad + good);
  };
  if (wrong(ballOut, ballIn) || wrong(socketIn, socketOut) || ballIn == 0 || socketOut == 0) {
    throw std::invalid_argument(fmt::format(
        "the {} grown with the sphere's shell as its joint does not lie inside the sphere ({} "
        "voxels inside, {} outside over the cup) or the {} not outside it ({} outside, {} "
        "inside): the sphere is not the joint",
        sphere.ball, ballIn, ballOut, sphere.socket, socketOut, socketIn));
  }
}

// The labels from `firstAuto` on (neighbours found automatically) with voxels in the band
// outside `sphere` over its cap (beyond its tolerance, within kSidesBandMm): where the socket
// lies (checkSphereSides).
std::vector<int> basinsBeyond(const core::CtImage& image, const std::vector<std::int16_t>& label,
                              int firstAuto, const JointSphere& sphere, double toleranceMm) {
  const double cosCap = std::cos(sphere.capDegrees * M_PI / 180.0);
  std::vector<int> found;
  Eigen::Vector3i lo, hi;
  sphereBox(image, image.lpsToVoxel(sphere.centreLps), sphere.radiusMm + kSidesBandMm, lo, hi);
  for (int k = lo.z(); k <= hi.z(); ++k) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      for (int i = lo.x(); i <= hi.x(); ++i) {
        const std::int16_t l = label[image.index(i, j, k)];
        if (l < firstAuto || std::find(found.begin(), found.end(), l) != found.end())
          continue;
        const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(i, j, k)) - sphere.centreLps;
        const double d = u.norm();
        if (d > sphere.radiusMm + toleranceMm && d <= sphere.radiusMm + kSidesBandMm &&
            u.dot(sphere.axisLps) >= cosCap * d)
          found.push_back(l);
      }
    }
  }
  return found;
}

// What a refused growth leaves for a second one (CompetingOptions::jointFromSphere).
struct SphereAttempt {
  std::vector<std::uint8_t> shell;  // empty: no sphere fitted
  JointSphere sphere;
  bool afterPass = false;  // fitted after a growth that passed, whose ball crosses the sphere
  // After a growth that passed: the ball's surface sphere, beyond which over its cap an
  // automatic neighbour was found (now the socket's), and which the ball crosses.
  bool afterPassSurface = false;
  // Where a refused growth leaves it: the ball's sphere fitted to its surface (empty: none).
  std::vector<std::uint8_t> surfaceShell;
  JointSphere surfaceSphere;
};

// `second`: the sphere whose shell is made joint line (a second growth); `attempt`: where a
// first growth refused by checkSeededBoundaries leaves the sphere.
static CompetingResult segmentOnGrid(const core::CtImage& image, const std::vector<BoneSeed>& seeds,
                                     const CompetingOptions& options,
                                     const SphereAttempt* second = nullptr,
                                     SphereAttempt* attempt = nullptr) {
  const std::vector<std::uint8_t>* shell = second ? &second->shell : nullptr;
  if (image.voxelCount() == 0 || image.hu.size() != image.voxelCount())
    throw std::invalid_argument("the CT image is empty");
  if (!image.uniform())
    throw std::invalid_argument(
        "segmentCompetingBones needs one slice group (extract the seeds' group first)");
  if (seeds.empty())
    throw std::invalid_argument("no seed given");
  const Eigen::Vector3d spacing = image.spacingMm();
  const double maxSpacing = spacing.maxCoeff();
  const double voxelMm3 = spacing.prod();
  CompetingResult result;
  // 4 mm, or two voxels up to 3 mm slices; on thicker slices one voxel, at least 6 mm (the real
  // pelvis averaged to 4-6 mm slices: at two voxels L5 was no hill of its own over the disc's
  // partial volume, and the sacrum took it).
  result.markerDynamicMm =
      options.markerDynamicMm > 0.0
          ? options.markerDynamicMm
          : std::max(4.0, std::min(2.0 * maxSpacing, std::max(6.0, maxSpacing)));
  result.sameBoneDynamicMm =
      options.sameBoneDynamicMm > 0.0 ? options.sameBoneDynamicMm : std::max(1.0, 0.5 * maxSpacing);
  const auto& dims = image.dimensions;

  // Bones by name, in the order of their first seeds; seeds to voxels.
  std::vector<std::string> names;
  std::vector<int> boneOfSeed;
  std::vector<Eigen::Vector3i> seedVoxels;
  for (const BoneSeed& s : seeds) {
    auto it = std::find(names.begin(), names.end(), s.bone);
    if (it == names.end()) {
      names.push_back(s.bone);
      it = names.end() - 1;
    }
    boneOfSeed.push_back(static_cast<int>(it - names.begin()));
    const Eigen::Vector3d v = image.lpsToVoxel(s.pointLps);
    const Eigen::Vector3i q(static_cast<int>(std::lround(v.x())),
                            static_cast<int>(std::lround(v.y())),
                            static_cast<int>(std::lround(v.z())));
    if (!s.pointLps.allFinite() || q.minCoeff() < 0 || q.x() >= dims[0] || q.y() >= dims[1] ||
        q.z() >= dims[2]) {
      const Eigen::Vector3d lo = image.voxelToLps(Eigen::Vector3d(-0.5, -0.5, -0.5));
      const Eigen::Vector3d hi =
          image.voxelToLps(Eigen::Vector3d(dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5));
      throw std::invalid_argument(
          fmt::format("the {} seed {} lies outside the CT volume, which spans x {:.1f}..{:.1f}, y "
                      "{:.1f}..{:.1f}, z {:.1f}..{:.1f} mm (LPS)",
                      s.bone, lpsText(s.pointLps), std::min(lo.x(), hi.x()),
                      std::max(lo.x(), hi.x()), std::min(lo.y(), hi.y()), std::max(lo.y(), hi.y()),
                      std::min(lo.z(), hi.z()), std::max(lo.z(), hi.z())));
    }
    seedVoxels.push_back(q);
  }

  // 1. Threshold, metal out, marrow filled (scan ends closed).
  report(options, 0.0, "threshold");
  result.threshold = thresholdBone(image, options.threshold);
  result.metalMask = emptyMask(image);
  {
    std::vector<std::uint8_t> metal(image.hu.size(), 0);
    bool any = false;
    for (std::size_t i = 0; i < image.hu.size(); ++i) {
      if (image.hu[i] >= options.metalHu) {
        metal[i] = 1;
        any = true;
      }
    }
    if (any) {
      std::vector<std::size_t> sizes;
      const auto label = labelComponents(image, metal, sizes);
      std::vector<Eigen::Vector3d> sum(sizes.size(), Eigen::Vector3d::Zero());
      std::vector<int> maxHu(sizes.size(), 0);
      for (std::size_t v = 0; v < label.size(); ++v) {
        if (!label[v] || static_cast<double>(sizes[label[v]]) * voxelMm3 < options.minMetalMm3)
          continue;
        int i, j, k;
        ijkOf(image, v, i, j, k);
        sum[label[v]] += Eigen::Vector3d(i, j, k);
        maxHu[label[v]] = std::max(maxHu[label[v]], static_cast<int>(image.hu[v]));
        result.threshold.voxels[v] = 0;
        result.metalMask.voxels[v] = 1;
      }
      for (std::size_t c = 1; c < sizes.size(); ++c) {
        if (static_cast<double>(sizes[c]) * voxelMm3 < options.minMetalMm3)
          continue;
        MetalPiece piece;
        piece.centreLps = image.voxelToLps(sum[c] / static_cast<double>(sizes[c]));
        piece.volumeMm3 = static_cast<double>(sizes[c]) * voxelMm3;
        piece.maxHu = maxHu[c];
        result.metal.push_back(piece);
      }
      // The streaks around each piece: bright ones out of the threshold (before the fill).
      result.streakMask = emptyMask(image);
      if (options.detectStreaks) {
        std::vector<std::uint8_t> streak(image.hu.size(), 0);
        // Each piece's voxels, in one pass (the pieces in the order of result.metal).
        std::vector<std::vector<std::size_t>> voxelsOf(sizes.size());
        for (std::size_t v = 0; v < label.size(); ++v) {
          if (label[v] && static_cast<double>(sizes[label[v]]) * voxelMm3 >= options.minMetalMm3)
            voxelsOf[label[v]].push_back(v);
        }
        std::size_t m = 0;
        for (std::size_t c = 1; c < sizes.size(); ++c) {
          if (static_cast<double>(sizes[c]) * voxelMm3 < options.minMetalMm3)
            continue;
          findStreaks(image, voxelsOf[c], options, streak, result.metal[m++]);
        }
        for (std::size_t v = 0; v < streak.size(); ++v) {
          if (!streak[v] || result.metalMask.voxels[v])
            continue;
          if (streak[v] == 3)
            continue;  // bright over bone: the bone's (a streak through the cortex)
          result.streakMask.voxels[v] = 1;
          if (streak[v] == 1)
            result.threshold.voxels[v] = 0;
        }
      }
      if (options.refuseMetal && !result.metal.empty()) {
        const MetalPiece& p = result.metal.front();
        throw std::invalid_argument(fmt::format(
            "metal (an implant?) of {:.0f} mm^3 up to {} HU at {} with streaks over {} slices "
            "(up to {:.0f} mm from it; {} bright, {} dark voxels){}: refused (the bone near it "
            "is not reliable); segment around it without --refuse-metal, or place anchors",
            p.volumeMm3, p.maxHu, lpsText(p.centreLps), p.streakSlices, p.streakReachMm,
            p.brightStreakVoxels, p.darkStreakVoxels,
            result.metal.size() > 1 ? fmt::format(" and {} more pieces", result.metal.size() - 1)
                                    : std::string()));
      }
    }
  }
  if (result.streakMask.voxels.empty())
    result.streakMask = emptyMask(image);
  report(options, 0.1, "fill");
  VoxelMask solid = result.threshold;
  fillHolesInBox(solid, options.maxSliceHoleMm2);
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    const Eigen::Vector3i& q = seedVoxels[s];
    if (!solid.at(q.x(), q.y(), q.z())) {
      throw std::invalid_argument(fmt::format(
          "{} ({})", notInBone(image, result.threshold, q, seeds[s].pointLps, options.threshold),
          seeds[s].bone));
    }
  }

  // 2. The landscape: distance to the background (and to the joint lines), quantised.
  report(options, 0.2, "joint lines");
  // Thick slices blur a joint's cortex and its line: from 1 mm to 3 mm slices the sides' level
  // falls from half way between the thresholds to just above the weak one, the dip from 250 to
  // 120 HU (the sacroiliac joints of the real CT at 3 mm; the knee at 1 mm).
  const double blur = std::clamp((maxSpacing - 1.0) / 2.0, 0.0, 1.0);
  const double middleHu = 0.5 * (options.threshold.weakHu + options.threshold.strongHu);
  result.jointSideHu = options.jointSideHu > 0.0
                           ? options.jointSideHu
                           : middleHu + blur * (options.threshold.weakHu + 20.0 - middleHu);
  result.jointDipHu = options.jointDipHu != 0.0 ? options.jointDipHu : 250.0 - blur * 130.0;
  std::vector<std::uint8_t> joints = jointLines(image, solid, result.jointSideHu, result.jointDipHu,
                                                options.jointReachMm, options.jointBeyondMm);
  report(options, 0.35, "distance map");
  std::vector<std::uint16_t> level(solid.voxels.size(), 0);  // 0: not solid; else 1 + level
  int maxLevel = 0;
  {
    VoxelMask inner = solid;
    for (std::size_t i = 0; i < inner.voxels.size(); ++i)
      inner.voxels[i] = solid.voxels[i] && !joints[i] ? 1 : 0;
    const std::vector<float> d2 = squaredDistanceMm2(inner, false);
    for (std::size_t i = 0; i < level.size(); ++i) {
      if (!solid.voxels[i])
        continue;
      const double d = std::sqrt(static_cast<double>(d2[i]));
      const int l = std::min(65000, static_cast<int>(d / kLevelMm));
      level[i] = static_cast<std::uint16_t>(1 + l);
      maxLevel = std::max(maxLevel, l);
    }
  }
  // A sphere's shell (a second growth): a valley of its own voxels, the distance map around it
  // as the first growth had it (made joint line before the map, the shell lowered the cup's
  // wall and the pubis became a hill of its own).
  if (shell) {
    for (std::size_t v = 0; v < joints.size(); ++v) {
      if ((*shell)[v] && solid.voxels[v]) {
        joints[v] = 1;
        level[v] = 1;
      }
    }
  }
  auto levelOf = [&](std::size_t v) { return static_cast<int>(level[v]) - 1; };

  // Each bone's seeds, for the spheres' balls.
  std::vector<std::vector<Eigen::Vector3d>> seedsOf(names.size());
  for (std::size_t q = 0; q < seeds.size(); ++q)
    seedsOf[sz(boneOfSeed[q])].push_back(seeds[q].pointLps);
  // Where two seeded bones are refused, the sphere for a second growth (jointFromSphere).
  const auto sphereFor = [&](int a, int b, const std::vector<std::int16_t>* labels,
                             bool refused = true) {
    if (!attempt || !options.jointFromSphere)
      return;
    report(options, 0.8, "joint sphere");
    jointSphereShell(image, solid, joints, labels, a, b, names, seedsOf, options, false,
                     attempt->shell, attempt->sphere);
    // Where the joint shows nowhere (a head pressed into its socket): the head's own surface.
    if (refused)
      jointSphereShell(image, solid, joints, labels, a, b, names, seedsOf, options, true,
                       attempt->surfaceShell, attempt->surfaceSphere);
  };

  // 3. Seeds climb to the top of their hills (steepest ascent); the path is their marker.
  std::vector<std::vector<std::uint32_t>> markers(names.size());
  std::map<std::uint32_t, int> peakSeed;
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    std::size_t v = image.index(seedVoxels[s].x(), seedVoxels[s].y(), seedVoxels[s].z());
    for (;;) {
      markers[sz(boneOfSeed[s])].push_back(static_cast<std::uint32_t>(v));
      int i, j, k;
      ijkOf(image, v, i, j, k);
      std::size_t best = v;
      forNeighbours(image, i, j, k, [&](std::size_t n) {
        if (level[n] > level[best] || (level[n] == level[best] && level[n] > level[v] && n < best))
          best = n;
      });
      if (best == v)
        break;
      v = best;
    }
    const auto top = static_cast<std::uint32_t>(v);
    const auto found = peakSeed.find(top);
    if (found != peakSeed.end() && found->second != boneOfSeed[s]) {
      sphereFor(boneOfSeed[s], found->second, nullptr);
      throw SeededPairRefused(
          fmt::format(
              "the {} seed {} and the {} seed lie in one bone (both climb to the same top of its "
              "distance map): give one seed per bone",
              seeds[s].bone, lpsText(seeds[s].pointLps), names[sz(found->second)]),
          boneOfSeed[s], found->second);
    }
    peakSeed[top] = boneOfSeed[s];
  }

  // 4. The hills (union-find in decreasing level): markers of the neighbours, same-bone check.
  report(options, 0.5, "hills");
  std::vector<std::uint32_t> order;
  {
    std::vector<std::size_t> count(sz(maxLevel) + 2, 0);
    for (std::size_t i = 0; i < level.size(); ++i) {
      if (level[i])
        ++count[sz(maxLevel - levelOf(i))];
    }
    std::vector<std::size_t> startAt(count.size() + 1, 0);
    for (std::size_t l = 0; l < count.size(); ++l)
      startAt[l + 1] = startAt[l] + count[l];
    order.resize(startAt.back());
    for (std::size_t i = 0; i < level.size(); ++i) {
      if (level[i])
        order[startAt[sz(maxLevel - levelOf(i))]++] = static_cast<std::uint32_t>(i);
    }
  }
  const int autoDyn = static_cast<int>(std::lround(result.markerDynamicMm / kLevelMm));
  const int sameDyn = static_cast<int>(std::lround(result.sameBoneDynamicMm / kLevelMm));
  std::vector<std::uint32_t> compOf(level.size(), kNone);
  std::vector<Component> comps;
  std::vector<std::uint32_t> autoMarkers;
  auto find = [&](std::uint32_t c) {
    while (comps[c].parent != c) {
      comps[c].parent = comps[comps[c].parent].parent;
      c = comps[c].parent;
    }
    return c;
  };
  auto merge = [&](std::uint32_t a, std::uint32_t b, int at) {
    a = find(a);
    b = find(b);
    if (a == b)
      return a;
    const bool aHigher =
        comps[a].peakLevel > comps[b].peakLevel ||
        (comps[a].peakLevel == comps[b].peakLevel && comps[a].peakVoxel < comps[b].peakVoxel);
    const std::uint32_t hi = aHigher ? a : b, lo = aHigher ? b : a;
    const int dyn = comps[lo].peakLevel - at;
    const int boneLo = comps[lo].bone, boneHi = comps[hi].bone;
    if (boneLo >= 0 && boneHi >= 0 && boneLo != boneHi && dyn < sameDyn) {
      sphereFor(boneLo, boneHi, nullptr);
      throw SeededPairRefused(
          fmt::format(
              "the {} and the {} seeds lie in one bone: nothing narrows between them (the bone "
              "is {:.1f} mm thick at its narrowest between them, {:.1f} mm at the seeds' hill); "
              "give one seed per bone",
              names[sz(boneLo)], names[sz(boneHi)], 2.0 * at * kLevelMm,
              2.0 * comps[lo].peakLevel * kLevelMm),
          boneLo, boneHi);
    }
    int carried = boneHi;
    if (boneLo < 0) {
      if (dyn >= autoDyn)
        autoMarkers.push_back(comps[lo].peakVoxel);
    } else if (dyn < autoDyn && boneHi < 0) {
      // The seed's hill is a bump on a higher hill: the seed's bone is the higher hill.
      carried = boneLo;
      markers[sz(boneLo)].push_back(comps[hi].peakVoxel);
    }
    comps[lo].parent = hi;
    comps[hi].bone = carried;
    return hi;
  };
  for (std::uint32_t v : order) {
    const int l = levelOf(v);
    int i, j, k;
    ijkOf(image, v, i, j, k);
    std::uint32_t mine = kNone;
    forNeighbours(image, i, j, k, [&](std::size_t n) {
      if (compOf[n] == kNone)
        return;
      mine = mine == kNone ? find(compOf[n]) : merge(mine, compOf[n], l);
    });
    const auto seeded = peakSeed.find(v);
    const int bone = seeded == peakSeed.end() ? -1 : seeded->second;
    if (mine == kNone) {
      mine = static_cast<std::uint32_t>(comps.size());
      comps.push_back({mine, l, v, bone});
    } else if (bone >= 0) {
      Component& c = comps[mine];
      if (c.bone >= 0 && c.bone != bone && c.peakLevel - l < sameDyn) {
        sphereFor(bone, c.bone, nullptr);
        throw SeededPairRefused(
            fmt::format("the {} and the {} seeds lie in one bone: give one seed per bone",
                        names[sz(bone)], names[sz(c.bone)]),
            bone, c.bone);
      }
      if (c.bone < 0)
        c.bone = bone;
    }
    compOf[v] = mine;
  }
  for (std::uint32_t c = 0; c < comps.size(); ++c) {
    if (comps[c].parent == c && comps[c].bone < 0)
      autoMarkers.push_back(comps[c].peakVoxel);  // a bone of its own, whatever its size
  }
  compOf.clear();
  compOf.shrink_to_fit();
  result.automaticNeighbours = static_cast<int>(autoMarkers.size());

  // A sphere fitted to the ball's surface (no joint line showed) is a joint with a side for each
  // bone: the bone voxels next to the shell over its cap are markers, inside it the ball's,
  // outside it the socket's. Else the flood reached the socket's wall from the ball round the
  // cap's rim before the socket's own flood did (the hip phantom at 5 mm with no joint space:
  // the femur took the cup's wall). Not for a sphere fitted to the joint line: with the markers
  // a sphere through the head's inside, 11 mm off, passed every check on the same scans.
  if (shell && second->sphere.fromSurface) {
    const JointSphere& js = second->sphere;
    const int ballIndex = boneIndex(names, js.ball), socketIndex = boneIndex(names, js.socket);
    const double cosCap = std::cos(js.capDegrees * M_PI / 180.0);
    for (std::size_t v = 0; v < shell->size(); ++v) {
      if (!(*shell)[v] || !solid.voxels[v])
        continue;
      int i, j, k;
      ijkOf(image, v, i, j, k);
      forNeighbours(image, i, j, k, [&](std::size_t n) {
        if ((*shell)[n] || !level[n])
          return;
        int a, b, c;
        ijkOf(image, n, a, b, c);
        const Eigen::Vector3d u = image.voxelToLps(Eigen::Vector3d(a, b, c)) - js.centreLps;
        const double d = u.norm();
        if (u.dot(js.axisLps) < cosCap * d)
          return;
        markers[sz(d < js.radiusMm ? ballIndex : socketIndex)].push_back(
            static_cast<std::uint32_t>(n));
      });
    }
  }

  // 5. The flood from the markers (Meyer): highest level first, first come first served.
  report(options, 0.65, "flood");
  std::vector<std::int16_t> label(level.size(), -1);
  std::vector<std::vector<std::uint32_t>> bucket(sz(maxLevel) + 1);
  std::vector<std::size_t> head(bucket.size(), 0);
  int current = -1;
  auto push = [&](std::uint32_t v, std::int16_t lab) {
    label[v] = lab;
    const int l = levelOf(v);
    bucket[sz(l)].push_back(v);
    current = std::max(current, l);
  };
  for (std::size_t b = 0; b < markers.size(); ++b) {
    for (std::uint32_t v : markers[b]) {
      if (label[v] < 0)
        push(v, static_cast<std::int16_t>(b));
    }
  }
  const auto firstAuto = static_cast<std::int16_t>(names.size());
  for (std::size_t a = 0; a < autoMarkers.size(); ++a) {
    if (label[autoMarkers[a]] < 0)
      push(autoMarkers[a], static_cast<std::int16_t>(std::min<std::size_t>(
                               firstAuto + a, std::numeric_limits<std::int16_t>::max())));
  }
  while (current >= 0) {
    auto& q = bucket[sz(current)];
    if (head[sz(current)] == q.size()) {
      q.clear();  // a lower voxel may still reach an unlabelled one of this level: reusable
      head[sz(current)] = 0;
      --current;
      continue;
    }
    const std::uint32_t v = q[head[sz(current)]++];
    int i, j, k;
    ijkOf(image, v, i, j, k);
    const std::int16_t lab = label[v];
    forNeighbours(image, i, j, k, [&](std::size_t n) {
      if (level[n] && label[n] < 0)
        push(static_cast<std::uint32_t>(n), lab);
    });
  }

  // 6. Basins that meet through the inside of a bone are one bone. A joint shows on the CT as a
  // boundary of cortex (or of a joint line): bright on both sides; a bone's own hills meet in
  // its cancellous bone or marrow. Per pair of labels, the share of their 6-connected boundary
  // whose two voxels are both inside (darker than half way between the thresholds, not on a
  // joint line): from insideShare on, an automatic neighbour joins the basin it meets; two
  // seeded bones are refused.
  report(options, 0.75, "joints");
  {
    const double insideHu = 0.5 * (options.threshold.weakHu + options.threshold.strongHu);
    auto inside = [&](std::size_t v) { return image.hu[v] < insideHu && !joints[v]; };
    auto cortex = [&](std::size_t v) { return image.hu[v] >= options.threshold.strongHu; };
    // A joint: its line, or cortex against cortex (bones pressed together).
    auto jointFace = [&](std::size_t v, std::size_t n) {
      return joints[v] || joints[n] || (cortex(v) && cortex(n));
    };
    struct Boundary {
      std::size_t total = 0, inside = 0, joint = 0;
    };
    std::map<std::pair<int, int>, Boundary> boundary;
    forEachLabelFace(image, label, [&](std::size_t v, std::size_t n, int) {
      auto& e = boundary[{std::min(label[v], label[n]), std::max(label[v], label[n])}];
      ++e.total;
      e.inside += inside(v) && inside(n) ? 1u : 0u;
      e.joint += jointFace(v, n) ? 1u : 0u;
    });
    // Largest boundaries first: an automatic basin joins the bone it shares most with.
    std::vector<std::pair<std::pair<int, int>, Boundary>> pairs(boundary.begin(), boundary.end());
    std::stable_sort(pairs.begin(), pairs.end(),
                     [](const auto& a, const auto& b) { return a.second.total > b.second.total; });
    const int labels = static_cast<int>(firstAuto) + static_cast<int>(autoMarkers.size());
    std::vector<int> root(sz(std::min(labels, 32767) + 1));
    for (std::size_t r = 0; r < root.size(); ++r)
      root[r] = static_cast<int>(r);
    auto rootOf = [&](int l) {
      while (root[sz(l)] != l)
        l = root[sz(l)] = root[sz(root[sz(l)])];
      return l;
    };
    for (const auto& [pair, counts] : pairs) {
      const double total = static_cast<double>(counts.total);
      const double share = static_cast<double>(counts.inside) / total;
      const double jointShare = static_cast<double>(counts.joint) / total;
      const int a = rootOf(pair.first), b = rootOf(pair.second);
      if (a == b)
        continue;
      if (a < firstAuto && b < firstAuto) {
        // Two seeded bones: judged on their whole boundary once every neighbour has joined
        // (checkSeededBoundaries).
        continue;
      }
      if (share < options.insideShare && jointShare >= options.jointShare)
        continue;
      // The automatic one joins: the smaller index is the root, so a seeded bone keeps its own
      // (a and b are roots: a pair's first label can have a larger root than its second).
      root[sz(std::max(a, b))] = std::min(a, b);
    }
    if (second) {
      // A growth with a sphere's shell: outside the sphere over its cap lies the socket
      // (checkSphereSides), so a basin of its own there is the socket's (the hip phantom at 5 mm
      // with no joint space: the cup's medial wall, split from the hip bone by its cortex).
      const int socket = boneIndex(names, second->sphere.socket);
      std::vector<std::int16_t> roots(label.size());
      for (std::size_t v = 0; v < label.size(); ++v)
        roots[v] = label[v] >= 0 ? static_cast<std::int16_t>(rootOf(label[v])) : label[v];
      for (const int r :
           basinsBeyond(image, roots, firstAuto, second->sphere, options.jointSphereToleranceMm))
        root[sz(r)] = socket;
    }
    for (std::size_t i = 0; i < label.size(); ++i) {
      if (label[i] >= 0)
        label[i] = static_cast<std::int16_t>(rootOf(label[i]));
    }
    std::vector<double> topMm(names.size(), 0.0);
    for (std::size_t b = 0; b < names.size(); ++b) {
      for (std::uint32_t m : markers[b])
        topMm[b] = std::max(topMm[b], levelOf(m) * kLevelMm);
    }
    // The seeded bones' boundaries; where refused, the spheres for a second growth first.
    const auto checkBoundaries = [&] {
      try {
        checkSeededBoundaries(
            image, label, static_cast<int>(firstAuto), names, inside, jointFace,
            [&](std::size_t v) { return levelOf(v) * kLevelMm; }, topMm, options, maxSpacing);
      } catch (const SeededPairRefused& refused) {
        sphereFor(refused.first, refused.second, &label);
        throw;
      }
    };
    checkBoundaries();
    if (second) {
      checkSphereSides(image, label, names, second->sphere, options);
    } else if (attempt && maxSpacing >= kSphereAfterPassSpacingMm) {
      // On thick slices a growth that passed every check can still have a ball run across the
      // joint the slices hide, onto its socket's roof (the hip phantom at 5 mm, the roof's
      // joint between two slices: the femur took 1.7 cm^3 of the roof up to 15 mm above the
      // head). Where a sphere fits a seeded pair's joint and the ball crosses it, a second
      // growth with its shell is tried (growBones) and kept where it passes.
      for (std::size_t a = 0; a < names.size() && attempt->shell.empty(); ++a) {
        for (std::size_t b = a + 1; b < names.size() && attempt->shell.empty(); ++b) {
          sphereFor(static_cast<int>(a), static_cast<int>(b), &label, false);
          if (attempt->shell.empty())
            continue;
          try {
            checkSphereSides(image, label, names, attempt->sphere, options);
            attempt->shell.clear();  // the ball already lies inside it
          } catch (const std::invalid_argument&) {
            attempt->afterPass = true;
          }
        }
      }
      // A neighbour found automatically beyond the ball's surface sphere, over its cap, is a
      // piece of the socket the watershed kept apart (the hip phantom at 5 mm, a joint space of
      // 1 mm, slices a quarter off: 34 cm^3 of the cup's wall and ilium, its boundary with the hip
      // bone joint-like, written without a word). It joins the socket, and where the ball
      // crosses that sphere a growth with it is tried as well (growBones).
      bool kept = false;
      for (int l = firstAuto; l < labels && l < static_cast<int>(root.size()); ++l)
        kept = kept || rootOf(l) == l;
      for (std::size_t a = 0; kept && a < names.size() && !attempt->afterPassSurface; ++a) {
        for (std::size_t b = a + 1; b < names.size() && !attempt->afterPassSurface; ++b) {
          std::vector<std::uint8_t> surfaceShell;
          JointSphere surface;
          if (!jointSphereShell(image, solid, joints, &label, static_cast<int>(a),
                                static_cast<int>(b), names, seedsOf, options, true, surfaceShell,
                                surface))
            continue;
          std::vector<int> beyond =
              basinsBeyond(image, label, firstAuto, surface, options.jointSphereToleranceMm);
          const auto socket = static_cast<std::int16_t>(boneIndex(names, surface.socket));
          // ... and touching the socket (a piece of it).
          if (!beyond.empty()) {
            std::vector<int> touching;
            forEachLabelFace(image, label, [&](std::size_t v, std::size_t n, int) {
              const int other = label[v] == socket ? label[n] : label[n] == socket ? label[v] : -1;
              if (other >= firstAuto &&
                  std::find(touching.begin(), touching.end(), other) == touching.end())
                touching.push_back(other);
            });
            beyond.erase(std::remove_if(beyond.begin(), beyond.end(),
                                        [&](int r) {
                                          return std::find(touching.begin(), touching.end(), r) ==
                                                 touching.end();
                                        }),
                         beyond.end());
          }
          if (beyond.empty())
            continue;
          for (const int r : beyond)
            root[sz(r)] = socket;
          for (std::int16_t& l : label) {
            if (l >= firstAuto && root[sz(l)] == socket)
              l = socket;
          }
          checkBoundaries();
          try {
            checkSphereSides(image, label, names, surface, options);
          } catch (const std::invalid_argument&) {
            attempt->surfaceShell = std::move(surfaceShell);
            attempt->surfaceSphere = surface;
            attempt->afterPassSurface = true;
          }
        }
      }
    }
    int kept = 0;
    for (int l = firstAuto; l < labels && l < static_cast<int>(root.size()); ++l)
      kept += rootOf(l) == l ? 1 : 0;
    result.automaticNeighbours = kept;
  }

  // 7. The named bones: their label's piece holding their seeds, marrow filled.
  report(options, 0.85, "bones");
  result.unnamed = emptyMask(image);
  for (std::size_t i = 0; i < label.size(); ++i)
    result.unnamed.voxels[i] = solid.voxels[i] && label[i] >= firstAuto ? 1 : 0;
  for (std::size_t b = 0; b < names.size(); ++b) {
    SegmentedBone bone;
    bone.bone = names[b];
    VoxelMask mine = emptyMask(image);
    for (std::size_t i = 0; i < label.size(); ++i)
      mine.voxels[i] = label[i] == static_cast<std::int16_t>(b) ? 1 : 0;
    VoxelMask piece = emptyMask(image);
    for (std::size_t s = 0; s < seeds.size(); ++s) {
      if (boneOfSeed[s] != static_cast<int>(b))
        continue;
      bone.seedsLps.push_back(seeds[s].pointLps);
      bone.seedHu.push_back(image.at(seedVoxels[s].x(), seedVoxels[s].y(), seedVoxels[s].z()));
      if (!piece.at(seedVoxels[s].x(), seedVoxels[s].y(), seedVoxels[s].z()))
        piece = unite(piece, connectedComponent(mine, seedVoxels[s]));
    }
    fillHolesInBox(piece, options.maxSliceHoleMm2);
    for (std::size_t i = 0; i < label.size(); ++i) {
      if (piece.voxels[i] && label[i] >= 0 && label[i] != static_cast<std::int16_t>(b))
        piece.voxels[i] = 0;  // the fill does not take another bone's voxels
    }
    bone.mask = std::move(piece);
    result.bones.push_back(std::move(bone));
  }
  // The joint's slab on thick slices goes to the bone it holds (joint_slabs.hpp).
  if (options.jointSlabMinSliceMm > 0.0 && spacing.z() >= options.jointSlabMinSliceMm &&
      result.bones.size() >= 2) {
    std::vector<VoxelMask*> masks;
    for (SegmentedBone& b : result.bones)
      masks.push_back(&b.mask);
    const double soft = std::isfinite(options.softTissueHu) ? options.softTissueHu : 0.0;
    result.jointSlabVoxels = giveJointSlabs(image, masks, soft, options.jointSlabShare);
  }
  for (SegmentedBone& bone : result.bones) {
    const std::size_t n = bone.mask.count();
    bone.volumeMm3 = static_cast<double>(n) * voxelMm3;
    Eigen::Vector3i lo(dims[0], dims[1], dims[2]), hi(-1, -1, -1);
    for (int k = 0; k < dims[2]; ++k) {
      for (int j = 0; j < dims[1]; ++j) {
        for (int i = 0; i < dims[0]; ++i) {
          if (bone.mask.at(i, j, k)) {
            lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
            hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
          }
        }
      }
    }
    if (hi.x() >= 0)
      bone.extentMm = ((hi - lo).cast<double>() + Eigen::Vector3d::Ones()).cwiseProduct(spacing);
  }
  // Metal: the bone it lies in or on.
  for (MetalPiece& m : result.metal) {
    const Eigen::Vector3d c = image.lpsToVoxel(m.centreLps);
    const Eigen::Vector3i q(static_cast<int>(std::lround(c.x())),
                            static_cast<int>(std::lround(c.y())),
                            static_cast<int>(std::lround(c.z())));
    double best = 1e30;
    for (const SegmentedBone& b : result.bones) {
      // Nearest bone voxel within 10 mm of the piece's centre.
      const Eigen::Vector3i r =
          (Eigen::Vector3d::Constant(10.0).cwiseQuotient(spacing)).array().ceil().cast<int>();
      for (int k = std::max(0, q.z() - r.z()); k <= std::min(dims[2] - 1, q.z() + r.z()); ++k) {
        for (int j = std::max(0, q.y() - r.y()); j <= std::min(dims[1] - 1, q.y() + r.y()); ++j) {
          for (int i = std::max(0, q.x() - r.x()); i <= std::min(dims[0] - 1, q.x() + r.x()); ++i) {
            if (!b.mask.at(i, j, k))
              continue;
            const double d = (Eigen::Vector3d(i, j, k) - c).cwiseProduct(spacing).norm();
            if (d < best && d <= 10.0) {
              best = d;
              m.touches = b.bone;
            }
          }
        }
      }
    }
  }

  // 8. Checks before anything is written.
  for (const SegmentedBone& b : result.bones) {
    if (b.volumeMm3 < options.minVolumeMm3) {
      throw std::invalid_argument(fmt::format(
          "the {} grown from the seed {} has only {:.0f} mm^3 (at least {:.0f} expected): a speck "
          "of bone or calcification, or the seed lies on the joint between two bones",
          b.bone, lpsText(b.seedsLps.front()), b.volumeMm3, options.minVolumeMm3));
    }
    if (options.waistMinSliceMm > 0.0 && spacing.z() >= options.waistMinSliceMm) {
      if (const std::optional<Waist> w = waistOf(b.mask, spacing)) {
        throw std::invalid_argument(fmt::format(
            "the {} grown from the seed {} narrows along the slices to {:.0f} mm^2 at z = {:.1f} "
            "mm between {:.0f} and {:.0f} mm^2 within {:.0f} mm on either side: at {:.1f} mm "
            "slices it ran across a joint the slices do not show, into the bone beyond; outline "
            "the bones with --anchors (Live-Wire) or segment a thinner series",
            b.bone, lpsText(b.seedsLps.front()), w->areaMm2,
            image.voxelToLps(Eigen::Vector3d(0.0, 0.0, w->slice)).z(), w->belowMm2, w->aboveMm2,
            kWaistReachMm, spacing.z()));
      }
    }
    if (!options.checkPlausible)
      continue;
    const std::string why = implausibleBone(b.bone, b.volumeMm3, b.extentMm);
    if (!why.empty()) {
      // What it took: the other named bones and neighbours found automatically it touches.
      int touchesAuto = 0;
      std::vector<std::string> touched;
      std::vector<std::uint8_t> seen(sz(firstAuto) + autoMarkers.size() + 1, 0);
      for (int k = 0; k < dims[2]; ++k) {
        for (int j = 0; j < dims[1]; ++j) {
          for (int i = 0; i < dims[0]; ++i) {
            if (!b.mask.at(i, j, k))
              continue;
            forNeighbours(image, i, j, k, [&](std::size_t n) {
              const int l = label[n];
              if (l < 0 || seen[sz(l)] || l == static_cast<int>(&b - result.bones.data()))
                return;
              seen[sz(l)] = 1;
              if (l < firstAuto)
                touched.push_back(names[sz(l)]);
              else
                ++touchesAuto;
            });
          }
        }
      }
      std::string metalNote;
      for (const MetalPiece& m : result.metal) {
        if (m.touches == b.bone)
          metalNote = fmt::format("; metal ({:.0f} mm^3, up to {} HU) lies at {}", m.volumeMm3,
                                  m.maxHu, lpsText(m.centreLps));
      }
      throw std::invalid_argument(fmt::format(
          "the {} grown from the seed {} is not a {}: {}. Either the seed lies in another bone, "
          "or the growth ran into bone that touches it where the CT shows no joint (it borders "
          "{} bone(s) found automatically{}{}); check the seed, add a seed in each neighbouring "
          "bone (--seed NAME X Y Z), or place anchors (--anchors){}",
          b.bone, lpsText(b.seedsLps.front()), b.bone, why, touchesAuto,
          touched.empty() ? "" : " and the seeded ",
          [&] {
            std::string t;
            for (const auto& s : touched)
              t += (t.empty() ? "" : ", ") + s;
            return t;
          }(),
          metalNote));
    }
  }
  report(options, 1.0, "bones");
  return result;
}

ThresholdEstimate estimateBoneThreshold(const core::CtImage& image,
                                        const std::vector<Eigen::Vector3i>& seedVoxels,
                                        double radiusMm, double metalHu,
                                        const BoneThreshold& ceiling) {
  if (image.voxelCount() == 0 || image.hu.size() != image.voxelCount())
    throw std::invalid_argument("estimateBoneThreshold: the CT image is empty");
  if (seedVoxels.empty())
    throw std::invalid_argument("estimateBoneThreshold: no seed");
  const Eigen::Vector3d spacing = image.spacingMm();
  const Eigen::Vector3i r =
      (Eigen::Vector3d::Constant(radiusMm).cwiseQuotient(spacing)).array().ceil().cast<int>();
  const auto& d = image.dimensions;
  // Voxels of the union of the boxes (each voxel once), metal left out.
  std::vector<std::uint8_t> seen;
  std::vector<std::int16_t> values;
  Eigen::Vector3i lo(d[0], d[1], d[2]), hi(-1, -1, -1);
  for (const Eigen::Vector3i& q : seedVoxels) {
    lo = lo.cwiseMin((q - r).cwiseMax(Eigen::Vector3i::Zero()));
    hi = hi.cwiseMax((q + r).cwiseMin(Eigen::Vector3i(d[0] - 1, d[1] - 1, d[2] - 1)));
  }
  const Eigen::Vector3i n = hi - lo + Eigen::Vector3i::Ones();
  seen.assign(sz(n.x()) * sz(n.y()) * sz(n.z()), 0);
  for (const Eigen::Vector3i& q : seedVoxels) {
    for (int k = std::max(0, q.z() - r.z()); k <= std::min(d[2] - 1, q.z() + r.z()); ++k) {
      for (int j = std::max(0, q.y() - r.y()); j <= std::min(d[1] - 1, q.y() + r.y()); ++j) {
        for (int i = std::max(0, q.x() - r.x()); i <= std::min(d[0] - 1, q.x() + r.x()); ++i) {
          std::uint8_t& s =
              seen[(sz(k - lo.z()) * sz(n.y()) + sz(j - lo.y())) * sz(n.x()) + sz(i - lo.x())];
          if (s)
            continue;
          s = 1;
          const std::int16_t hu = image.at(i, j, k);
          if (hu < metalHu)
            values.push_back(hu);
        }
      }
    }
  }
  ThresholdEstimate e;
  e.voxels = values.size();
  // Soft tissue: the mode of a 10 HU histogram within -200..200, smoothed over 3 bins.
  std::vector<double> bins(40, 0.0);
  for (std::int16_t v : values) {
    if (v >= -200 && v < 200)
      bins[sz((v + 200) / 10)] += 1.0;
  }
  int best = -1;
  double bestCount = 0.0;
  for (int b = 0; b < 40; ++b) {
    const double c =
        bins[sz(b)] + (b > 0 ? bins[sz(b - 1)] : 0.0) + (b < 39 ? bins[sz(b + 1)] : 0.0);
    if (c > bestCount) {
      bestCount = c;
      best = b;
    }
  }
  e.softTissueHu = best < 0 ? 0.0 : -200.0 + 10.0 * best + 5.0;
  {
    std::vector<double> dev;
    for (std::int16_t v : values) {
      if (std::abs(v - e.softTissueHu) <= 60.0)
        dev.push_back(std::abs(v - e.softTissueHu));
    }
    if (!dev.empty()) {
      auto mid = dev.begin() + static_cast<std::ptrdiff_t>(dev.size() / 2);
      std::nth_element(dev.begin(), mid, dev.end());
      e.noiseHu = 1.4826 * *mid;
    }
  }
  // Cortex: the median of the brightest 2 %.
  if (!values.empty()) {
    std::vector<std::int16_t> v = values;
    const std::size_t top = std::max<std::size_t>(1, v.size() / 50);
    std::nth_element(v.begin(), v.end() - static_cast<std::ptrdiff_t>(top), v.end());
    std::vector<std::int16_t> bright(v.end() - static_cast<std::ptrdiff_t>(top), v.end());
    auto mid = bright.begin() + static_cast<std::ptrdiff_t>(bright.size() / 2);
    std::nth_element(bright.begin(), mid, bright.end());
    e.cortexHu = *mid;
  }
  for (const Eigen::Vector3i& q : seedVoxels) {
    std::vector<double> m;
    for (int k = std::max(0, q.z() - 1); k <= std::min(d[2] - 1, q.z() + 1); ++k)
      for (int j = std::max(0, q.y() - 1); j <= std::min(d[1] - 1, q.y() + 1); ++j)
        for (int i = std::max(0, q.x() - 1); i <= std::min(d[0] - 1, q.x() + 1); ++i)
          m.push_back(image.at(i, j, k));
    auto mid = m.begin() + static_cast<std::ptrdiff_t>(m.size() / 2);
    std::nth_element(m.begin(), mid, m.end());
    e.marrowHu.push_back(*mid);
  }
  const double s = e.softTissueHu;
  // Floors: a box with little bone (or none) must not take the soft tissue for it.
  const double strong =
      std::min(ceiling.strongHu, std::max(s + 200.0, s + kStrongFactor * (e.cortexHu - s)));
  const double weak =
      std::min({ceiling.weakHu, strong,
                std::max({s + kWeakFactor * (strong - s), s + 4.0 * e.noiseHu, s + 80.0})});
  e.surfaceCortexMinHu = std::min(600.0, std::round(s + 0.7 * (e.cortexHu - s)));
  e.threshold.strongHu = std::round(strong);
  e.threshold.weakHu = std::round(std::min(weak, strong));
  return e;
}

// The bounding box (lo..hi, voxels) of thresholdBone(image, threshold)'s voxels; hi.x() < 0 when
// there are none. Every voxel of a hysteresis threshold, and every path that connects it to a
// strong one, is at or above the weak level: the threshold runs on the box of those voxels only,
// and the answer is the same as on the whole image without a mask of the whole field of view.
static void boneBox(const core::CtImage& image, const BoneThreshold& threshold, Eigen::Vector3i& lo,
                    Eigen::Vector3i& hi) {
  const auto& d = image.dimensions;
  // hu >= weakHu for integer HU, in integers (the scan of every voxel vectorises).
  const int weak = static_cast<int>(std::ceil(std::clamp(threshold.weakHu, -40000.0, 40000.0)));
  Eigen::Vector3i wlo(d[0], d[1], d[2]), whi(-1, -1, -1);
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      const std::int16_t* row = image.hu.data() + image.index(0, j, k);
      int first = d[0], last = -1;
      for (int i = 0; i < d[0]; ++i) {
        const bool above = row[i] >= weak;
        first = above && i < first ? i : first;
        last = above ? i : last;
      }
      if (last < 0)
        continue;
      wlo = wlo.cwiseMin(Eigen::Vector3i(first, j, k));
      whi = whi.cwiseMax(Eigen::Vector3i(last, j, k));
    }
  }
  lo = Eigen::Vector3i(d[0], d[1], d[2]);
  hi = Eigen::Vector3i(-1, -1, -1);
  if (whi.x() < 0)
    return;
  core::CtImage box;
  box.dimensions = {whi.x() - wlo.x() + 1, whi.y() - wlo.y() + 1, whi.z() - wlo.z() + 1};
  box.pixelSpacingMm = image.pixelSpacingMm;
  for (int k = wlo.z(); k <= whi.z(); ++k)
    box.slicePositionsMm.push_back(image.slicePositionsMm[sz(k)]);
  box.hu.resize(box.voxelCount());
  const auto& b = box.dimensions;
  for (int k = 0; k < b[2]; ++k) {
    for (int j = 0; j < b[1]; ++j)
      std::copy_n(image.hu.data() + image.index(wlo.x(), wlo.y() + j, wlo.z() + k), b[0],
                  box.hu.data() + box.index(0, j, k));
  }
  const VoxelMask bone = thresholdBone(box, threshold);
  for (int k = 0; k < b[2]; ++k) {
    for (int j = 0; j < b[1]; ++j) {
      const std::uint8_t* row = bone.voxels.data() + box.index(0, j, k);
      for (int i = 0; i < b[0]; ++i) {
        if (row[i]) {
          lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
          hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
        }
      }
    }
  }
  if (hi.x() >= 0) {
    lo += wlo;
    hi += wlo;
  }
}

// One growth; where it refuses two seeded bones and a sphere fits the joint line they hold, a
// second with the sphere's shell as joint line (CompetingOptions::jointFromSphere).
static CompetingResult growBones(const core::CtImage& grid, const std::vector<BoneSeed>& seeds,
                                 const CompetingOptions& options) {
  SphereAttempt attempt;
  try {
    CompetingResult first = segmentOnGrid(grid, seeds, options, nullptr, &attempt);
    // The first growth passed; a sphere's is kept only where it passes too: the joint line's,
    // else the ball's surface's.
    for (const bool surface : {false, true}) {
      if (!(surface ? attempt.afterPassSurface : attempt.afterPass))
        continue;
      SphereAttempt second;
      second.shell = std::move(surface ? attempt.surfaceShell : attempt.shell);
      second.sphere = surface ? attempt.surfaceSphere : attempt.sphere;
      try {
        CompetingResult result = segmentOnGrid(grid, seeds, options, &second, nullptr);
        result.jointSphere = second.sphere;
        result.jointSphere->afterPass = true;
        return result;
      } catch (const std::invalid_argument&) {
      }
    }
    return first;
  } catch (const SeededPairRefused& refused) {
    if (attempt.shell.empty() && attempt.surfaceShell.empty())
      throw;
    // A second growth with the sphere fitted to the joint line, else one with the sphere fitted
    // to the ball's surface; where both are refused (any check), the first refusal stands, as it
    // says what is wrong with the bones as the CT shows them, and says the spheres were tried.
    std::vector<const JointSphere*> tried;
    for (const bool surface : {false, true}) {
      SphereAttempt second;
      second.shell = std::move(surface ? attempt.surfaceShell : attempt.shell);
      second.sphere = surface ? attempt.surfaceSphere : attempt.sphere;
      if (second.shell.empty())
        continue;
      try {
        CompetingResult result = segmentOnGrid(grid, seeds, options, &second, nullptr);
        result.jointSphere = second.sphere;
        return result;
      } catch (const std::invalid_argument&) {
        tried.push_back(surface ? &attempt.surfaceSphere : &attempt.sphere);
      }
    }
    const auto fitted = [](const JointSphere& s) {
      return fmt::format("{:.1f} mm fitted to {}", s.radiusMm,
                         s.fromSurface ? fmt::format("the {}'s head's surface", s.ball)
                                       : std::string("the joint line"));
    };
    const JointSphere& first = *tried.front();
    throw SeededPairRefused(
        tried.size() == 1
            ? fmt::format("{}; a sphere of {} as the {}'s head in the {}'s socket did not separate "
                          "them either",
                          refused.what(), fitted(first), first.ball, first.socket)
            : fmt::format("{}; neither a sphere of {} as the {}'s head in the {}'s socket nor one "
                          "of {} separated them",
                          refused.what(), fitted(first), first.ball, first.socket,
                          fitted(*tried.back())),
        refused.first, refused.second);
  }
}

CompetingResult segmentCompetingBones(const core::CtImage& image,
                                      const std::vector<BoneSeed>& seeds,
                                      const CompetingOptions& given) {
  if (image.voxelCount() == 0 || image.hu.size() != image.voxelCount() || !image.uniform() ||
      seeds.empty())
    return segmentOnGrid(image, seeds, given);  // its errors
  CompetingOptions options = given;
  ThresholdEstimate estimate;
  if (given.thresholdFromHistogram) {
    std::vector<Eigen::Vector3i> voxels;
    for (const BoneSeed& s : seeds) {
      const Eigen::Vector3d v = image.lpsToVoxel(s.pointLps);
      const Eigen::Vector3i q(static_cast<int>(std::lround(v.x())),
                              static_cast<int>(std::lround(v.y())),
                              static_cast<int>(std::lround(v.z())));
      const auto& d = image.dimensions;
      if (!s.pointLps.allFinite() || q.minCoeff() < 0 || q.x() >= d[0] || q.y() >= d[1] ||
          q.z() >= d[2])
        return segmentOnGrid(image, seeds, given);  // the outside-the-volume message
      voxels.push_back(q);
    }
    estimate =
        estimateBoneThreshold(image, voxels, given.thresholdBoxMm, given.metalHu, given.threshold);
    options.threshold = estimate.threshold;
    if (!std::isfinite(given.softTissueHu))
      options.softTissueHu = estimate.softTissueHu;
  }
  auto finish = [&](CompetingResult r) {
    r.thresholdUsed = options.threshold;
    r.thresholdFromHistogram = given.thresholdFromHistogram;
    r.estimate = estimate;
    return r;
  };
  // Everything happens on the box of the bone voxels (plus a margin of 2): the distance map,
  // the hills, the flood and the masks cost the bones' size, not the field of view's.
  const auto& d = image.dimensions;
  Eigen::Vector3i lo, hi;
  boneBox(image, options.threshold, lo, hi);
  const Eigen::Vector3i last(d[0] - 1, d[1] - 1, d[2] - 1);
  if (hi.x() < 0 || ((lo.array() <= 2).all() && (hi.array() >= last.array() - 2).all()))
    return finish(growBones(image, seeds, options));
  lo = (lo.array() - 2).max(0).matrix();
  hi = (hi.array() + 2).min(last.array()).matrix();
  // A seed inside the image but outside the box is in no bone: say why on the whole image.
  for (const BoneSeed& s : seeds) {
    const Eigen::Vector3d v = image.lpsToVoxel(s.pointLps);
    const Eigen::Vector3i q(static_cast<int>(std::lround(v.x())),
                            static_cast<int>(std::lround(v.y())),
                            static_cast<int>(std::lround(v.z())));
    const bool inImage =
        s.pointLps.allFinite() && q.minCoeff() >= 0 && q.x() < d[0] && q.y() < d[1] && q.z() < d[2];
    if (!inImage)
      return finish(growBones(image, seeds, options));  // the outside-the-volume message
    if ((q.array() < lo.array()).any() || (q.array() > hi.array()).any()) {
      const VoxelMask bone = thresholdBone(image, options.threshold);
      throw std::invalid_argument(
          fmt::format("{} ({})", notInBone(image, bone, q, s.pointLps, options.threshold), s.bone));
    }
  }
  core::CtImage box;
  box.dimensions = {hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1};
  box.direction = image.direction;
  box.pixelSpacingMm = image.pixelSpacingMm;
  box.originMm = image.voxelToLps(lo.cast<double>());
  for (int k = lo.z(); k <= hi.z(); ++k)
    box.slicePositionsMm.push_back(image.slicePositionsMm[sz(k)] -
                                   image.slicePositionsMm[sz(lo.z())]);
  box.groups = {{0, box.dimensions[2], box.dimensions[2] > 1 ? image.spacingMm().z() : 0.0}};
  box.seriesInstanceUid = image.seriesInstanceUid;
  box.folder = image.folder;
  box.hu.resize(box.voxelCount());
  const auto& b = box.dimensions;
  for (int k = 0; k < b[2]; ++k) {
    for (int j = 0; j < b[1]; ++j)
      std::copy_n(image.hu.data() + image.index(lo.x(), lo.y() + j, lo.z() + k), b[0],
                  box.hu.data() + box.index(0, j, k));
  }
  CompetingResult result = growBones(box, seeds, options);
  // Back on the whole grid.
  core::CtImage geometry;  // the image without its HU (emptyMask would copy them)
  geometry.dimensions = image.dimensions;
  geometry.originMm = image.originMm;
  geometry.direction = image.direction;
  geometry.pixelSpacingMm = image.pixelSpacingMm;
  geometry.slicePositionsMm = image.slicePositionsMm;
  geometry.groups = image.groups;
  geometry.seriesInstanceUid = image.seriesInstanceUid;
  geometry.folder = image.folder;
  auto expand = [&](VoxelMask& m) {
    VoxelMask full = emptyMask(geometry);
    for (int k = 0; k < b[2]; ++k) {
      for (int j = 0; j < b[1]; ++j)
        std::copy_n(m.voxels.data() + box.index(0, j, k), b[0],
                    full.voxels.data() + image.index(lo.x(), lo.y() + j, lo.z() + k));
    }
    m = std::move(full);
  };
  expand(result.threshold);
  expand(result.unnamed);
  expand(result.metalMask);
  expand(result.streakMask);
  for (SegmentedBone& s : result.bones)
    expand(s.mask);
  return finish(std::move(result));
}

std::optional<SphereCut> sphereCutFor(const CompetingResult& result, const std::string& bone) {
  if (!result.jointSphere || !result.jointSphere->fromSurface)
    return std::nullopt;
  const JointSphere& js = *result.jointSphere;
  if (bone != js.ball && bone != js.socket)
    return std::nullopt;
  SphereCut cut;
  cut.centreLps = js.centreLps;
  cut.radiusMm = js.radiusMm;
  cut.axisLps = js.axisLps;
  cut.capDegrees = js.capDegrees;
  cut.keepInside = bone == js.ball;
  return cut;
}

}  // namespace echoreg::segmentation
