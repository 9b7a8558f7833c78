// A CT volume in Hounsfield units with its patient geometry: the one CT image type of echoreg.
// The DICOM reader makes it (segmentation::readDicomSeries), the segmentation works on it, the
// simulator synthesises it and the DICOM writer writes it (simulation::synthesizeCt,
// writeDicomSeries). Plain data without VTK, and the geometry helpers that map voxels to CT
// patient coordinates (LPS, mm). Slices may be unevenly spaced (the dissertation's hip 5 mm /
// knee 1 mm / ankle 5 mm protocol): their positions are kept, never assumed uniform.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::core {

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

  // What the simulator knows of its scan and the DICOM writer needs; empty when not known (the
  // DICOM and NRRD readers leave them empty, and so do the images the segmentation makes on other
  // slices: a group, a crop, a resampling; a copy of the same grid keeps them).

  /// Empty, or each slice's position along the k axis in patient coordinates, mm (the slice
  /// centre's projection on the k axis: z of an axial scan, DICOM's SliceLocation), as the
  /// slices were made. slicePositionsMm[k] == sliceLocationsMm[k] - sliceLocationsMm[0]; the
  /// DICOM writer prints these, since originMm + an offset can differ in the last bit.
  std::vector<double> sliceLocationsMm;
  /// Empty, or each slice's nominal thickness (DICOM's SliceThickness), mm.
  std::vector<double> sliceThicknessMm;
  /// Empty, or each group's name ("hip", "knee", "ankle" of the simulator's protocol), in the
  /// order of `groups`.
  std::vector<std::string> groupNames;

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
  /// Centre of voxel (i, j, k) in LPS, mm. For an axial image (direction the identity) with its
  /// slice locations kept: (originMm.x + i * pixelSpacingMm.x, originMm.y + j * pixelSpacingMm.y,
  /// sliceLocationsMm[k]), the very numbers the simulator sampled the voxel at; otherwise
  /// voxelToLps(i, j, k).
  Eigen::Vector3d voxelCentreMm(int i, int j, int k) const;
};

/// The slices of one group of an axial scan, for axialCtImage.
struct AxialSliceGroup {
  std::string name;          ///< kept in CtImage::groupNames
  std::vector<double> zMm;   ///< slice centres, increasing (evenly spaced in a protocol group)
  double thicknessMm = 0.0;  ///< every slice's nominal thickness
};

/// The geometry of an axial scan, without voxels (`hu` empty): `columns` x `rows` square pixels of
/// `pixelSpacingMm`, the centre of pixel (0, 0) of every slice at `firstPixelXYMm`, and the slices
/// of `groups` in order (the direction the identity). The slices' z are kept exactly as
/// sliceLocationsMm (and originMm.z is the first); each group is one CtSliceGroup (its spacing the
/// group's first step, 0 for a single slice) named in groupNames. No checks: the DICOM writer
/// checks what it writes.
CtImage axialCtImage(int columns, int rows, double pixelSpacingMm,
                     const Eigen::Vector2d& firstPixelXYMm,
                     const std::vector<AxialSliceGroup>& groups);

/// Linear resampling along k onto slices `spacingMm` apart from slice 0 to the last slice (the
/// in-plane grid is kept). spacingMm <= 0 uses the smallest step between consecutive slices. The
/// result is uniform (and keeps no slice locations, thicknesses or group names). Throws
/// std::invalid_argument for an empty image.
CtImage resampleUniform(const CtImage& image, double spacingMm = 0.0);

}  // namespace echoreg::core
