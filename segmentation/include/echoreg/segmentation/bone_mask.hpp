// Bone masks on a CT (plain arrays, no VTK): the protocol group that holds a point, hysteresis
// threshold of cortical bone, seeded region growing that does not leak across a joint (growth in
// the mask opened by a small ball, then given back its border), marrow filling, and the
// morphology the surface step needs. A mask lives on the voxel grid of the CtImage it came from.
#pragma once

#include "echoreg/segmentation/ct_image.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace echoreg::segmentation {

/// A binary mask on the voxel grid of `geometry` (a CtImage whose `hu` may be empty).
struct VoxelMask {
  CtImage geometry;
  std::vector<std::uint8_t> voxels;  ///< 0 or 1, same layout as CtImage::hu

  std::size_t count() const;
  bool at(int i, int j, int k) const { return voxels[geometry.index(i, j, k)] != 0; }
};

/// An empty (all 0) mask on the grid of `image` (geometry copied, HU dropped).
VoxelMask emptyMask(const CtImage& image);

/// The slices of protocol group `group` as a CtImage of their own (uniform). Throws
/// std::invalid_argument for a group index out of range.
CtImage extractGroup(const CtImage& image, std::size_t group);

/// Index of the group whose slices span `pointLps` along k (the nearest group when the point lies
/// in a gap is NOT returned: -1 then, and for points outside the volume in-plane or along k).
int groupContaining(const CtImage& image, const Eigen::Vector3d& pointLps);

struct BoneThreshold {
  double strongHu = 600.0;  ///< cortical bone: every voxel at or above it is bone
  double weakHu = 200.0;    ///< cancellous bone / partial volume: bone when connected to strong
};

/// Hysteresis threshold: voxels >= strongHu, plus voxels >= weakHu 26-connected to them.
/// Throws std::invalid_argument when weakHu > strongHu or the image is empty.
VoxelMask thresholdBone(const CtImage& image, const BoneThreshold& threshold = {});

struct GrowOptions {
  BoneThreshold threshold;
  /// Radius (voxels, in-plane; along k scaled by the spacings) of the opening that cuts thin
  /// bridges between bones touching at a joint before growing; 0 grows in the plain mask.
  int separationRadiusVoxels = 1;
  /// Fill the marrow: background not reachable from the volume's border (3D), then per axial
  /// slice background not reachable from the slice's border.
  bool fillHoles = true;
  /// Smallest acceptable mask, mm^3 (a seed on a speck of bone is refused).
  double minVolumeMm3 = 500.0;
  /// Called with a fraction done and a short stage name.
  std::function<void(double, const std::string&)> progress;
};

struct GrowResult {
  VoxelMask mask;        ///< the grown bone, marrow filled
  VoxelMask threshold;   ///< every bone voxel of the image (the hysteresis threshold)
  Eigen::Vector3i seedVoxel = Eigen::Vector3i::Zero();
  double volumeMm3 = 0.0;
  int seedHu = 0;
};

/// Grows the bone that contains `seedLps` (CT patient coordinates, mm) in a uniform `image` (one
/// group: see extractGroup). The seed may be on the cortex, in cancellous bone or in the marrow
/// (then the nearest bone voxel within 15 mm in its axial slice, enclosed by bone, is used).
/// Throws std::invalid_argument with a sentence for the user: the image is not uniform, the seed
/// lies outside the volume, the seed is not in bone (its HU and the nearest bone), or the grown
/// bone is smaller than minVolumeMm3.
GrowResult growBone(const CtImage& image, const Eigen::Vector3d& seedLps,
                    const GrowOptions& options = {});

/// Union of masks on one grid (throws std::invalid_argument when the grids differ).
VoxelMask unite(const VoxelMask& a, const VoxelMask& b);

/// Dilation / erosion by a ball of `radiusMm` (mm, using the grid's spacings; uniform grids).
VoxelMask dilate(const VoxelMask& mask, double radiusMm);
VoxelMask erode(const VoxelMask& mask, double radiusMm);

/// Fills enclosed background: 3D (background not 6-connected to the border) and, when
/// `perSlice`, per axial slice (background not 4-connected to the slice's border).
void fillHoles(VoxelMask& mask, bool perSlice = true);

/// The bone voxels of `threshold` that do not belong to the bone around `region`: those not
/// 26-connected to threshold-and-region through threshold voxels within `bandMm` of the region.
/// Given to boneSurface as `exclude`, so a neighbouring bone in the band cannot join the surface.
VoxelMask otherBones(const VoxelMask& threshold, const VoxelMask& region, double bandMm);

/// The 26-connected component of `mask` containing voxel `seed` (empty when seed is 0 there).
VoxelMask connectedComponent(const VoxelMask& mask, const Eigen::Vector3i& seed);

}  // namespace echoreg::segmentation
