// The share of bone in the voxels at a bone's ends along z, from its sections on the slices
// around them (shape-based interpolation, as the --anchors contours are filled). On thick slices
// a slab over a rounded end holds the cortex of the end's sides as well as of the end itself, so
// its HU does not tell how much of the slab is bone (on the simulated knee at 5 mm the end
// voxels' median HU is 450 / 550 / 626 / 576 at a true share of 0.4 / 0.6 / 0.8 / 1.0), while
// the sections in plane change smoothly from slice to slice.
#pragma once

#include "echoreg/segmentation/bone_mask.hpp"

#include <cstddef>
#include <vector>

namespace echoreg::segmentation {

struct EndShareOptions {
  /// Where a slice's section lies along z, in slices from the slice's centre towards the bone's
  /// inside (0-0.5). A region holds a voxel when the slab has bone enough to show, so over a
  /// rounded end its outline is the slab's larger sections, nearer the slab's inner face than its
  /// centre. 0.4 chosen on the simulated knee at 5 mm slices (seed 3, before the flat rule:
  /// 0.25 / 0.35 / 0.45 / 0.55 gave a mean MSD of 0.328 / 0.298 / 0.308 / 0.353 mm over the four
  /// bones, 0 gave 0.486).
  double sectionOffsetSlices = 0.4;
  /// Beyond the last slice that holds the region the solid closes (section_closing.hpp) this
  /// many slices past that slice's centre: 0.6, a tenth of a slab into the slab the region
  /// leaves out (it may hold a little bone, too little to show). With the --anchors filling's
  /// 0.5 (the slab's face) the fibula came out worse at 5 mm (MSD 0.249 -> 0.267 / 0.231 ->
  /// 0.243 / 0.230 -> 0.235 mm on seeds 3 / 5 / 7; femur, tibia, patella the same to 0.001 mm).
  double closingReachSlices = 0.6;
  /// An end is flat (the tibial plateau) where its section shrinks by less than this many
  /// slices' spacing from the slice inside it to the end's slice: there the sections say little
  /// of where the end lies in its slab (VoxelShare::flatEnd; boneSurface takes the slab as full).
  double flatShrinkSlices = 0.1;
};

struct VoxelShare {
  std::size_t voxel = 0;  ///< index in the grid (core::CtImage::index)
  double share = 0.0;     ///< the part of the voxel's slab the bone fills, 0-1
  bool flatEnd = false;   ///< the end is flat (EndShareOptions::flatShrinkSlices)
};

/// For each z end of `region` (a region voxel whose neighbour along k is outside it, with its
/// 3 x 3 neighbours in plane inside it: the end faces z) the share of bone in that voxel and in
/// the voxel beyond it (unless `exclude` marks the latter: another bone's). Each slice's section
/// is the region on that slice; its in-plane signed distance d_k(i, j) (mm, negative inside, half
/// a pixel off the pixel centres) is placed at z_k - s o h (s: the end's direction along k, o:
/// sectionOffsetSlices, h: the spacing) and interpolated linearly along z between slices; next
/// to a slice whose neighbour holds no section the solid closes as the --anchors filling does
/// (closedSectionDistanceMm: d = d_k + max(1, D_k / c) |z - z_k|, D_k the section's deepest
/// inside distance, c = (o + closingReachSlices) h). The share is
/// the part of the voxel's slab (z_k +- h / 2) where d < 0 (40 samples). Ends on the scan's first
/// or last slice (the scan cuts the bone there) and at a gap of one slice in the region (the
/// bone goes on beyond it) are not ends. `sectionRegion` (optional, a superset of `region`): the
/// region whose slices give the sections, where they should reach further than the ends
/// (jointSlabSections). `region`, `exclude` and `sectionRegion` must lie on one uniform grid;
/// throws std::invalid_argument otherwise.
std::vector<VoxelShare> zEndShares(const VoxelMask& region, const VoxelMask* exclude,
                                   const EndShareOptions& options = {},
                                   const VoxelMask* sectionRegion = nullptr);

/// The field value (0-1, contoured at 0.5) to give a z end's voxel whose slab the bone fills by
/// `share` (0-1, from the slab's face on the bone's side), so that the field interpolated
/// linearly between the voxel's centre and its neighbours' along z (1 on the bone's side, 0
/// beyond) crosses 0.5 where the bone ends: share - 1/2 slabs from the voxel's centre,
///
///   f = 1 - 1 / (1 + 2 s)   for s < 1/2,      f = 1 / (3 - 2 s)   for s >= 1/2.
///
/// The share itself as the field put a share of 0.75 a third of a slab out from the centre
/// instead of a quarter, and 0.25 a third in (up to 0.42 mm off at 5 mm slices): with the
/// truth's shares on the simulated knee at 5 mm (seed 3) the field of the share gave MSD
/// femur / tibia / fibula / patella 0.249 / 0.200 / 0.219 / 0.159 mm, this one 0.221 / 0.154 /
/// 0.188 / 0.140. `share` outside 0-1 is clamped.
double zEndFieldValue(double share);

}  // namespace echoreg::segmentation
