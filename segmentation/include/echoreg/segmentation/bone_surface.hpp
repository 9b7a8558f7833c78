// Bone masks to closed surfaces in CT patient coordinates (LPS, mm). The surface is the
// iso-surface of the CT itself at the half-way level between the bone's cortex and the soft
// tissue around it, restricted to a thin band around a region (the grown mask, or the mask the
// live-wire contours enclose): inside the band's interior the field is forced to the cortex's
// value and outside the band to the soft tissue's, so marrow, other bones and the band's edges
// cannot make surfaces, and the result is closed. Vertices are sub-voxel (trilinear
// interpolation of HU, VTK flying edges), then smoothed (windowed sinc) and optionally
// decimated. A mask alone (no CT) gives the discrete iso-surface of the smoothed mask instead.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/end_shares.hpp"
#include "echoreg/segmentation/joint_slabs.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <optional>

namespace echoreg::segmentation {

/// A sphere that bounds the bone over a cap about an axis: the joint of a ball and its socket
/// where the CT shows none (a head pressed into its cup on thick slices; the sphere fitted to the
/// head's surface, CompetingResult::jointSphere, sphereCutFor in bone_labels.hpp). Over the cap,
/// within one voxel of the sphere, the field is at most what puts its crossing on the sphere
/// (linear in the distance to it, so trilinear interpolation keeps it there), and the other
/// bone's voxels there are read from the CT instead of as soft tissue: the model's surface over
/// the joint is the sphere, not the boundary of the voxels each bone was given.
struct SphereCut {
  Eigen::Vector3d centreLps = Eigen::Vector3d::Zero();
  double radiusMm = 0.0;
  Eigen::Vector3d axisLps = Eigen::Vector3d::UnitZ();  ///< unit, the cap's centre direction
  double capDegrees = 0.0;                             ///< the cap's half angle about the axis
  bool keepInside = true;  ///< the ball keeps what lies inside, the socket what lies outside
};

struct BoneSurfaceOptions {
  /// Iso level, HU; 0 chooses half way between the cortex (median of the region's voxels above
  /// cortexMinHu, 1 mm or more inside it) and the soft tissue (median of the ring 1.5-3 mm
  /// outside the region, bone excluded).
  double isoHu = 0.0;
  double cortexMinHu = 600.0;
  /// The band around the region where the CT decides, mm; beyond it the field is soft tissue.
  double bandMm = 2.0;
  /// ... and at least this many voxels along each axis (thick slices: a 2 mm band is no voxel
  /// along z at 3 mm; the band is then an ellipsoid's dilation, max(bandMm, bandVoxels *
  /// spacing) per axis). 0: mm only. 1 chosen on the simulated knee at 3 and 5 mm slices
  /// (tests/segmentation/test_thick_slices.cpp, docs/segmentation.md); 1-2 give the same
  /// model there. At 1 mm slices and 0.8 mm pixels the mm decide (nothing changes).
  double bandVoxels = 1.0;
  /// The region's interior deeper than this is forced to the cortex's value, mm.
  double interiorMm = 1.5;
  /// ... and at least this many voxels along each axis (as bandVoxels); 0: mm only. 1 (1.5
  /// voxels was worse at 3 and 5 mm: the interior then eats the cortex's partial volume).
  double interiorVoxels = 1.0;
  /// The bone's level taken locally (isoHu 0 only): each band voxel's edge lies half way
  /// between the soft tissue and the brightest HU of the region and band within localLevelMm in
  /// plane on its own slice, at least the bone's one cortex level (and localMinContrastHu above
  /// the soft tissue). The one level is a median over the whole bone: thick slices lower it by
  /// partial volume while a shaft's cortex still reads 1500 HU in plane, so the surfaces seen in
  /// plane came out 0.2 mm too large at 3 and 5 mm slices; at 1 mm the local level halves the
  /// error (tests/segmentation/test_thick_slices.cpp, docs/segmentation.md). Along z the one
  /// level stays (a slab's partial volume is not a cortex to take half of). false: the one
  /// level everywhere (as before).
  bool localLevel = true;
  double localLevelMm = 1.5;
  double localMinContrastHu = 100.0;
  /// On slices at least this thick (mm; 0: never), with the local level, the field on the voxels
  /// at the bone's ends along z and beyond them is their share of bone from the bone's sections
  /// (zEndShares, as zEndFieldValue); a flat end's own voxel is full (1). A slab over a rounded
  /// end holds the cortex of the end's sides too, so its HU says more bone than there is; a slab
  /// under a flat plate reads less. On the simulated knee at 5 mm it brings the mean surface
  /// distance of femur / tibia / fibula / patella from 0.43 / 0.55 / 0.29 / 0.22 mm to 0.32 /
  /// 0.30 / 0.23 / 0.19 mm (seed 3; seeds 5 and 7 alike); at 3 and 1 mm it cost the tibia's plateau
  /// (tests/segmentation/test_thick_slices.cpp, docs/segmentation.md): hence 4 mm.
  double endSharesMinSliceMm = 4.0;
  EndShareOptions endShares;
  /// With the ends' shares: the sections that give them keep the joint's slabs next to the
  /// region that read as such (jointSlabSections, at most this share of the inward voxel's
  /// height above the soft tissue; the rule segmentCompetingBones moves them to the other bone
  /// by, CompetingOptions::jointSlabShare), so a bone's ends around a slab it gave away are placed
  /// as before (on the simulated knee at 5 mm the tibia's MSD 0.300 -> 0.298 mm on seed 9, 0.299
  /// -> 0.285 on seed 11). 0: the region's own sections.
  double jointSlabShare = 0.6;
  /// Where given, the bone is bounded by this sphere over its cap (SphereCut).
  std::optional<SphereCut> sphereCut;
  /// Windowed-sinc smoothing (Taubin): iterations (0: none) and pass band (0-2, lower smooths
  /// more).
  int smoothingIterations = 10;
  double passBand = 0.1;
  /// Decimate to about this many triangles when the surface has more (0: keep every triangle);
  /// a decimation that would break the surface's closedness is not applied.
  std::size_t targetTriangles = 0;
  /// Closed pieces smaller than this are dropped (noise), mm^3.
  double minComponentMm3 = 50.0;
};

struct BoneSurfaceResult {
  core::TriangleMesh mesh;  ///< closed, wound outward, CT LPS mm
  double isoHu = 0.0;
  double cortexHu = 0.0;
  double softTissueHu = 0.0;
  int components = 0;  ///< closed pieces kept
  int droppedComponents = 0;
  bool decimated = false;
};

/// The radii max(mm, voxels * spacing) along i, j, k.
Eigen::Vector3d morphologyRadiiMm(const Eigen::Vector3d& spacingMm, double mm, double voxels);

/// Dilation (grow) or erosion of `mask` by the ellipsoid of morphologyRadiiMm(its spacing, mm,
/// voxels): the ball of `mm` when no axis needs more (the same voxels as dilate / erode).
VoxelMask dilateOrErode(const VoxelMask& mask, double mm, double voxels, bool grow);

/// The CT iso-surface of the bone around `region` (see the file comment). `exclude` (optional,
/// same grid) marks voxels of other bones: they count as soft tissue. `ct` must be uniform (one
/// group). Throws std::invalid_argument for an empty region, grids that differ, a non-uniform
/// CT, or a surface that comes out empty or not closed.
BoneSurfaceResult boneSurface(const core::CtImage& ct, const VoxelMask& region,
                              const VoxelMask* exclude, const BoneSurfaceOptions& options = {});

/// The surface of a mask alone: the 0.5 level of the mask blurred by a Gaussian of sigmaMm
/// (no CT), smoothed and decimated as above. Throws std::invalid_argument for an empty mask.
BoneSurfaceResult maskSurface(const VoxelMask& mask, double sigmaMm = 0.6,
                              const BoneSurfaceOptions& options = {});

}  // namespace echoreg::segmentation
