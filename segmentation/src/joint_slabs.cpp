#include "echoreg/segmentation/joint_slabs.hpp"

#include <algorithm>
#include <stdexcept>
#include <tuple>

namespace echoreg::segmentation {

double slabMeanHu(const core::CtImage& ct, int i, int j, int k) {
  const auto& d = ct.dimensions;
  double sum = 0.0;
  int n = 0;
  for (int b = std::max(j - 1, 0); b <= std::min(j + 1, d[1] - 1); ++b) {
    for (int a = std::max(i - 1, 0); a <= std::min(i + 1, d[0] - 1); ++a) {
      sum += ct.hu[ct.index(a, b, k)];
      ++n;
    }
  }
  return n > 0 ? sum / n : 0.0;
}

namespace {

// The rule on the two slabs' means (readsAsJointSlab).
bool jointSlabByMeans(double slabHu, double inwardHu, double softTissueHu, double share) {
  return slabHu - softTissueHu <= share * (inwardHu - softTissueHu);
}

}  // namespace

bool readsAsJointSlab(const core::CtImage& ct, int i, int j, int k, int inward, double softTissueHu,
                      double share) {
  return jointSlabByMeans(slabMeanHu(ct, i, j, k), slabMeanHu(ct, i, j, inward), softTissueHu,
                          share);
}

std::size_t giveJointSlabs(const core::CtImage& ct, const std::vector<VoxelMask*>& bones,
                           double softTissueHu, double share) {
  if (share <= 0.0 || bones.size() < 2)
    return 0;
  const std::size_t n = ct.voxelCount();
  for (const VoxelMask* m : bones) {
    if (m == nullptr || m->voxels.size() != n)
      throw std::invalid_argument("giveJointSlabs: the masks lie on another grid than the CT");
  }
  const auto& d = ct.dimensions;
  std::vector<int> label(n, -1);
  for (std::size_t b = 0; b < bones.size(); ++b) {
    for (std::size_t v = 0; v < n; ++v) {
      if (bones[b]->voxels[v] != 0)
        label[v] = static_cast<int>(b);
    }
  }
  struct Move {
    double contrast;  // the inward voxel's mean HU over this one's
    std::size_t voxel;
    int from, to;
  };
  std::vector<Move> moves;
  for (int k = 1; k + 1 < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        const std::size_t v = ct.index(i, j, k);
        const int own = label[v];
        if (own < 0)
          continue;
        for (int step : {-1, 1}) {
          const int other = label[ct.index(i, j, k + step)];
          if (other < 0 || other == own || label[ct.index(i, j, k - step)] != own)
            continue;
          const double slabHu = slabMeanHu(ct, i, j, k);
          const double inwardHu = slabMeanHu(ct, i, j, k - step);
          if (jointSlabByMeans(slabHu, inwardHu, softTissueHu, share))
            moves.push_back({inwardHu - slabHu, v, own, other});
        }
      }
    }
  }
  std::sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) {
    return std::tie(b.contrast, a.voxel, a.to) < std::tie(a.contrast, b.voxel, b.to);
  });
  std::vector<std::uint8_t> kept(n, 0);  // a moved voxel's neighbours along k stay
  std::size_t moved = 0;
  const std::size_t layer = static_cast<std::size_t>(d[0]) * static_cast<std::size_t>(d[1]);
  for (const Move& m : moves) {
    if (kept[m.voxel] || bones[static_cast<std::size_t>(m.from)]->voxels[m.voxel] == 0)
      continue;
    bones[static_cast<std::size_t>(m.from)]->voxels[m.voxel] = 0;
    bones[static_cast<std::size_t>(m.to)]->voxels[m.voxel] = 1;
    kept[m.voxel - layer] = 1;  // k >= 1 and k + 1 < d[2] for every candidate
    kept[m.voxel + layer] = 1;
    ++moved;
  }
  return moved;
}

VoxelMask jointSlabSections(const core::CtImage& ct, const VoxelMask& region,
                            const VoxelMask* exclude, double softTissueHu, double share) {
  VoxelMask sections = region;
  if (share <= 0.0 || exclude == nullptr)
    return sections;
  const std::size_t n = ct.voxelCount();
  if (region.voxels.size() != n || exclude->voxels.size() != n)
    throw std::invalid_argument("jointSlabSections: the masks lie on another grid than the CT");
  const auto& d = ct.dimensions;
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        const std::size_t v = ct.index(i, j, k);
        if (region.voxels[v] != 0 || exclude->voxels[v] == 0)
          continue;
        for (int step : {-1, 1}) {
          const int inward = k - step;
          if (inward < 0 || inward >= d[2] || !region.at(i, j, inward))
            continue;
          if (readsAsJointSlab(ct, i, j, k, inward, softTissueHu, share)) {
            sections.voxels[v] = 1;
            break;
          }
        }
      }
    }
  }
  return sections;
}

}  // namespace echoreg::segmentation
