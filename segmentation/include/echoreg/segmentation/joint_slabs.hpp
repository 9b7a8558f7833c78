// The joint's slab between two bones along z on thick slices. Where two bones meet along z at a
// joint (the femur's condyles on the tibial plateau), a 4-5 mm slab holds the end of one bone,
// the joint space and perhaps the other bone's end plate at once; the watershed gives the whole
// slab to one of them. A contact voxel that reads much darker than its own bone's next voxel
// inward (its slab is mostly joint space) holds little of that bone, and what bone it holds
// belongs to the bone on its other side: the femur's condyles reach into the slab the tibia was
// given, the tibial plateau into the femur's.
//
// On the simulated knee at 5 mm slices, moving such voxels (at most 0.6 of the inward voxel's
// height above the soft tissue) to the other bone, with each bone's end shares taken from
// sections that keep the slabs moved away (jointSlabSections), brings the femur's mean surface
// distance from 0.29-0.32 mm to 0.26-0.29 mm on nine knees and the tibia's from 0.27-0.31 to
// 0.28-0.30 mm (docs/segmentation.md, tests/segmentation/test_thick_slices.cpp). With the
// truth's labels on those voxels the two would be 0.23 / 0.23 mm: the HU says right for about
// three moves in four.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/segmentation/bone_mask.hpp"

#include <cstddef>
#include <vector>

namespace echoreg::segmentation {

/// The mean HU of the 3 x 3 voxels in plane around (i, j, k) (those inside the image): a slab's
/// level with the cancellous texture averaged out.
double slabMeanHu(const core::CtImage& ct, int i, int j, int k);

/// True when the voxel (i, j, k) reads as the joint's slab against its bone's voxel inward
/// (i, j, inward): its 3 x 3 mean stands at most `share` as high above `softTissueHu` as the
/// inward voxel's does.
bool readsAsJointSlab(const core::CtImage& ct, int i, int j, int k, int inward, double softTissueHu,
                      double share);

/// Moves each joint slab voxel between two of `bones` (same grid as `ct`) to the other bone: a
/// voxel of one bone whose neighbour along k is the other's, whose neighbour the other way along k
/// is its own bone's and which readsAsJointSlab against it. The candidates are taken from the
/// labels as given, the darkest against its inward voxel first; a voxel moved keeps its
/// neighbours along k where they are (two voxels of a column never swap bones). Returns the
/// number of voxels moved. `share` <= 0 moves nothing.
std::size_t giveJointSlabs(const core::CtImage& ct, const std::vector<VoxelMask*>& bones,
                           double softTissueHu, double share);

/// The region whose sections give `region`'s end shares: the region and each voxel of `exclude`
/// next to it along k that readsAsJointSlab against the region's voxel (the slabs
/// giveJointSlabs moved away, and any like them). A bone's sections then stay whole where its
/// end slab went to the other bone. `share` <= 0 or no `exclude`: the region itself.
VoxelMask jointSlabSections(const core::CtImage& ct, const VoxelMask& region,
                            const VoxelMask* exclude, double softTissueHu, double share);

}  // namespace echoreg::segmentation
