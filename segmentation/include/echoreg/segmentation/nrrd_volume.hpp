// NRRD volumes on a CT's grid: int16 (HU) or uint8 (masks, labels) voxels with their LPS geometry,
// as 3D Slicer writes and reads them ("space: left-posterior-superior", "space directions" =
// direction columns x spacing, "space origin" = the first voxel's centre). Used for segmentation
// masks (`--mask MASK.nrrd`) and for handing a CT to Slicer.
#pragma once

#include "echoreg/core/ct_image.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::segmentation {

struct NrrdWriteOptions {
  bool gzip = true;  ///< "encoding: gzip" (zlib), else "encoding: raw"
};

/// Writes `voxels` (i fastest, then j, then k; geometry.voxelCount() of them) on the grid of
/// `geometry` (dimensions, originMm, direction, pixelSpacingMm and its uniform slice spacing; its
/// own `hu` is not used) to `path` as a single-file NRRD (.nrrd), little endian, atomically.
/// Throws std::invalid_argument when `geometry` is not uniform (resample or extract a group first)
/// or the voxel count differs; FileError naming `path` when it cannot be written.
void writeNrrdVolume(const std::string& path, const core::CtImage& geometry,
                     const std::vector<std::int16_t>& voxels, const NrrdWriteOptions& options = {});
void writeNrrdVolume(const std::string& path, const core::CtImage& geometry,
                     const std::vector<std::uint8_t>& voxels, const NrrdWriteOptions& options = {});

/// A volume read back from NRRD: the geometry in `image` (one group), the voxels in `hu` for int16
/// files or in `mask` for uint8 files (the other stays empty).
struct NrrdVolume {
  core::CtImage image;
  std::vector<std::uint8_t> mask;
  bool isMask = false;  ///< uint8 voxels
};

/// Reads a 3D single-file NRRD of int16 ("short") or uint8 ("uchar") voxels, raw or gzip encoded,
/// little endian, in "left-posterior-superior" (or "right-anterior-superior", converted to LPS)
/// space with space directions and origin, as writeNrrdVolume and 3D Slicer write them. Throws
/// FileError naming `path` for anything else (other types, detached data, non-orthogonal
/// directions, truncated data...).
NrrdVolume readNrrdVolume(const std::string& path);

}  // namespace echoreg::segmentation
