// A bone mask as a NRRD volume that 3D Slicer opens as a segmentation / label map in place: uint8
// voxels (1 bone, 0 background), gzip-free raw encoding, geometry in LPS (space directions from the
// CT's direction and spacings, space origin the first voxel's centre).
#pragma once

#include "echoreg/segmentation/bone_mask.hpp"

#include <string>

namespace echoreg::segmentation {

/// Writes `mask` (its grid must be uniform) to `path` atomically. Throws FileError naming `path`
/// when it cannot be written, std::invalid_argument for a non-uniform or empty grid.
void writeMaskNrrd(const std::string& path, const VoxelMask& mask);

}  // namespace echoreg::segmentation
