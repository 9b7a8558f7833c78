// Bone masks on a CT (plain arrays, no VTK): the protocol group that holds a point, hysteresis
// threshold of cortical bone, seeded region growing that does not leak across a joint (growth in
// the mask opened by a small ball, then given back its border), marrow filling, and the
// morphology the surface step needs. A mask lives on the voxel grid of the core::CtImage it came
// from.
#pragma once

#include "echoreg/core/ct_image.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace echoreg::segmentation {

/// A binary mask on the voxel grid of `geometry` (a core::CtImage whose `hu` may be empty).
struct VoxelMask {
  core::CtImage geometry;
  std::vector<std::uint8_t> voxels;  ///< 0 or 1, same layout as core::CtImage::hu

  std::size_t count() const;
  bool at(int i, int j, int k) const { return voxels[geometry.index(i, j, k)] != 0; }
};

/// An empty (all 0) mask on the grid of `image` (geometry copied, HU dropped).
VoxelMask emptyMask(const core::CtImage& image);

/// The slices of protocol group `group` as a core::CtImage of their own (uniform). Throws
/// std::invalid_argument for a group index out of range.
core::CtImage extractGroup(const core::CtImage& image, std::size_t group);

/// Index of the group whose slices span `pointLps` along k (to half the group's spacing beyond its
/// end slices); -1 for a point in a gap between groups or outside the volume.
int groupContaining(const core::CtImage& image, const Eigen::Vector3d& pointLps);

struct BoneThreshold {
  double strongHu = 600.0;  ///< cortical bone: every voxel at or above it is bone
  double weakHu = 200.0;    ///< cancellous bone / partial volume: bone when connected to strong
};

/// Hysteresis threshold: voxels >= strongHu, plus voxels >= weakHu 26-connected to them.
/// Throws std::invalid_argument when weakHu > strongHu or the image is empty.
VoxelMask thresholdBone(const core::CtImage& image, const BoneThreshold& threshold = {});

struct GrowOptions {
  BoneThreshold threshold;
  /// Radius (mm) of the erosion that cuts the bridges partial volume leaves between bones
  /// touching at a joint: the bones are the components of the eroded (marrow-filled) mask; a
  /// bone voxel within the radius plus 1.5 voxels of another component, and nearer to it than to
  /// the seed's, belongs to that other bone; the seed's bone is the rest connected to the seed.
  /// 0 grows in the plain mask.
  double separationRadiusMm = 2.4;
  /// The radius is at least this many of the grid's largest spacing (thick slices leave wider
  /// bridges: 6 mm at 3 mm slices), when separationRadiusMm > 0.
  double separationVoxels = 2.0;
  /// Marrow and other enclosed background: filled in 3D (not connected to the volume's border)
  /// and per axial slice when the enclosed area is at most this (mm^2; a femoral canal is a few
  /// hundred, a pelvic ring's cavity thousands). 0 fills no per-slice holes.
  double maxSliceHoleMm2 = 2000.0;
  /// Smallest acceptable bone, mm^3 (a seed on a speck of bone is refused).
  double minVolumeMm3 = 500.0;
  /// Called with a fraction done and a short stage name.
  std::function<void(double, const std::string&)> progress;
};

struct GrowResult {
  VoxelMask mask;       ///< the grown bone, marrow filled
  VoxelMask threshold;  ///< every bone voxel of the image (the hysteresis threshold)
  /// Bone voxels that belong to the other bones (nearer another component of the eroded mask):
  /// boneSurface's `exclude`.
  VoxelMask others;
  Eigen::Vector3i seedVoxel = Eigen::Vector3i::Zero();
  double volumeMm3 = 0.0;
  int seedHu = 0;
};

/// Grows the bone that contains `seedLps` (CT patient coordinates, mm) in a uniform `image` (one
/// group: see extractGroup). The seed may be on the cortex, in cancellous bone or in the marrow.
/// Throws std::invalid_argument with a sentence for the user: the image is not uniform, the seed
/// lies outside the volume, the seed is not in bone (its HU), the seed lies on a joint's bridge
/// that went to another bone, or the grown bone is smaller than minVolumeMm3.
GrowResult growBone(const core::CtImage& image, const Eigen::Vector3d& seedLps,
                    const GrowOptions& options = {});

/// Union of masks on one grid (throws std::invalid_argument when the grids differ).
VoxelMask unite(const VoxelMask& a, const VoxelMask& b);

/// Dilation / erosion by a ball of `radiusMm` (mm, using the grid's spacings; uniform grids).
VoxelMask dilate(const VoxelMask& mask, double radiusMm);
VoxelMask erode(const VoxelMask& mask, double radiusMm);

/// Fills enclosed background: 3D (background not 6-connected to the border) and per axial slice
/// the background regions not 4-connected to the slice's border whose area is at most
/// `maxSliceHoleMm2` (0: none; infinity: all). `closedScanEnds`: the first and last slices do
/// not count as border in 3D, so a marrow canal the scan cuts open is filled too.
void fillHoles(VoxelMask& mask, double maxSliceHoleMm2 = 2000.0, bool closedScanEnds = false);

/// Squared Euclidean distance (mm^2, the grid's spacings) from every voxel to the nearest
/// foreground voxel (`toForeground`) or background voxel; 0 on the voxels themselves.
std::vector<float> squaredDistanceMm2(const VoxelMask& mask, bool toForeground);

/// The bone voxels of `threshold` that do not belong to the bone around `region`: those not
/// 26-connected to threshold-and-region through threshold voxels within `bandMm` of the region.
/// Given to boneSurface as `exclude`, so a neighbouring bone in the band cannot join the surface.
VoxelMask otherBones(const VoxelMask& threshold, const VoxelMask& region, double bandMm);

/// The 26-connected component of `mask` containing voxel `seed` (empty when seed is 0 there).
VoxelMask connectedComponent(const VoxelMask& mask, const Eigen::Vector3i& seed);

}  // namespace echoreg::segmentation
