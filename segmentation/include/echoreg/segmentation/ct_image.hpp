// A CT volume in Hounsfield units with its patient geometry, as read from a DICOM series: the
// plain data that the segmentation works on (no VTK), and the geometry helpers that map voxels to
// CT patient coordinates (LPS, mm). Slices may be unevenly spaced (the dissertation's hip 5 mm /
// knee 1 mm / ankle 5 mm protocol): their positions are kept, never assumed uniform.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::segmentation {

/// A run of consecutive slices with one spacing (a protocol group).
struct CtSliceGroup {
  int firstSlice = 0;      ///< index of the group's first slice
  int count = 0;           ///< slices in the group
  double spacingMm = 0.0;  ///< between slice centres within the group (0 for a single slice)
};

struct CtImage {
  /// Voxels along i (columns), j (rows) and k (slices).
  std::array<int, 3> dimensions{0, 0, 0};
  /// Centre of voxel (0, 0, 0) in CT patient coordinates (LPS), mm.
  Eigen::Vector3d originMm = Eigen::Vector3d::Zero();
  /// Columns: the unit i, j and k axes in LPS (row direction, column direction, slice normal
  /// oriented so that slice positions increase).
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  /// In-plane pixel spacing along i and j, mm.
  Eigen::Vector2d pixelSpacingMm{1.0, 1.0};
  /// Position of each slice centre along the k axis, relative to slice 0 (so [0] == 0), strictly
  /// increasing, mm.
  std::vector<double> slicePositionsMm;
  /// Runs of equal spacing, in slice order, covering every slice.
  std::vector<CtSliceGroup> groups;
  /// Hounsfield units (each slice's own rescale applied, rounded), i fastest, then j, then k.
  std::vector<std::int16_t> hu;
  /// Identification, for messages and `info`.
  std::string seriesInstanceUid;
  std::string folder;

  std::size_t voxelCount() const {
    return static_cast<std::size_t>(dimensions[0]) * static_cast<std::size_t>(dimensions[1]) *
           static_cast<std::size_t>(dimensions[2]);
  }
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dimensions[1]) +
            static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(dimensions[0]) +
           static_cast<std::size_t>(i);
  }
  std::int16_t at(int i, int j, int k) const { return hu[index(i, j, k)]; }

  /// One slice spacing for the whole volume (a single group, or one slice).
  bool uniform() const { return groups.size() <= 1; }
  /// The spacing of a uniform volume (1 for a single slice); throws std::logic_error otherwise.
  double sliceSpacingMm() const;
  /// Spacing along i, j, k of a uniform volume.
  Eigen::Vector3d spacingMm() const;

  /// LPS position of a (possibly fractional) voxel index; k is interpolated between slice
  /// positions (extrapolated with the end groups' spacing outside them).
  Eigen::Vector3d voxelToLps(const Eigen::Vector3d& ijk) const;
  /// Inverse of voxelToLps (k fractional).
  Eigen::Vector3d lpsToVoxel(const Eigen::Vector3d& lps) const;
};

/// Linear resampling along k onto slices `spacingMm` apart from slice 0 to the last slice (the
/// in-plane grid is kept). spacingMm <= 0 uses the smallest step between consecutive slices. The
/// result is uniform. Throws std::invalid_argument for an empty image.
CtImage resampleUniform(const CtImage& image, double spacingMm = 0.0);

}  // namespace echoreg::segmentation
