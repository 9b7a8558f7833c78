// Bones that touch, segmented against each other (plain arrays, no VTK): a marker-based watershed
// of the bone mask's distance map (Meyer's priority flood). The marrow-filled bone mask is one
// solid where bones touch at a joint; inside it the distance to the background is high in the
// middle of each bone and dips where two bones meet (the joint's neck), and it is forced to 0 on
// the joint's dark line where one shows (a voxel darker than the cortex on both sides of it). Each
// seed climbs to the top of its hill; hills that stand out by `markerDynamicMm` over the saddle
// to a higher hill and hold no seed are the neighbours found automatically. From those markers the
// flood gives every voxel to the marker it reaches over the highest saddle, so each voxel goes to
// one bone and the boundary lies in the neck. See docs/segmentation.md.
#pragma once

#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/ct_image.hpp"

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace echoreg::segmentation {

struct BoneSeed {
  std::string bone;  ///< the bone's name; seeds with one name grow one bone
  Eigen::Vector3d pointLps = Eigen::Vector3d::Zero();
};

struct CompetingOptions {
  BoneThreshold threshold;
  /// Marrow and other enclosed background filled (see fillHoles), with the scan's first and last
  /// slices counted as closed: a canal cut by the scan's end is filled too.
  double maxSliceHoleMm2 = 2000.0;
  /// A hill of the distance map holding no seed becomes a neighbour's marker when it stands out by
  /// this over the saddle toward a higher hill, mm; 0: max(4 mm, 2 voxels).
  double markerDynamicMm = 0.0;
  /// Two seeds of different bones whose hills are joined by a saddle less than this below the
  /// lower hill's top lie in one bone (refused), mm; 0: max(1 mm, half a voxel).
  double sameBoneDynamicMm = 0.0;
  /// Joint lines: a voxel this much darker (HU) than bone >= jointSideHu on both sides of it
  /// (within `jointReachMm`, along one of 13 directions) belongs to no bone's hill. 0: from the
  /// slices (250 HU at 1 mm or less, 120 HU at 3 mm or more, linear between); negative: off.
  double jointDipHu = 0.0;
  /// 0: from the slices (half way between the thresholds, 400 HU, at 1 mm; weak + 20, 220 HU, at
  /// 3 mm: thick slices blur a joint's cortex).
  double jointSideHu = 0.0;
  double jointReachMm = 2.0;
  /// Two basins whose boundary runs through the inside of a bone (this share or more of it
  /// darker than half way between the thresholds and not on a joint line) are one bone: an
  /// automatic neighbour joins the bone, two seeded bones are refused.
  double insideShare = 0.5;
  /// A neighbour found automatically also joins the bone it meets when less than this share of
  /// their boundary looks like a joint (a joint line, or cortex against cortex).
  double jointShare = 0.7;
  /// Metal (implants): voxels at or above this HU, in pieces of at least minMetalMm3, are left out
  /// of every bone and reported.
  double metalHu = 2500.0;
  double minMetalMm3 = 20.0;
  /// Smallest acceptable bone, mm^3.
  double minVolumeMm3 = 500.0;
  /// Volume and extent checked against what the named bone can be (femur, tibia, fibula,
  /// patella, hip, sacrum, ...; see plausibleBone); false: only the minimum volume.
  bool checkPlausible = true;
  std::function<void(double, const std::string&)> progress;
};

struct MetalPiece {
  Eigen::Vector3d centreLps = Eigen::Vector3d::Zero();
  double volumeMm3 = 0.0;
  int maxHu = 0;
  std::string touches;  ///< the bone it lies in or on ("" when none)
};

struct SegmentedBone {
  std::string bone;
  std::vector<Eigen::Vector3d> seedsLps;
  std::vector<int> seedHu;
  VoxelMask mask;  ///< marrow filled, one 26-connected piece
  double volumeMm3 = 0.0;
  Eigen::Vector3d extentMm = Eigen::Vector3d::Zero();  ///< of the mask's box along i, j, k
};

struct CompetingResult {
  std::vector<SegmentedBone> bones;  ///< one per bone name, in the order of their first seeds
  VoxelMask threshold;               ///< the hysteresis threshold (metal removed)
  /// Bone voxels given to none of the named bones (the neighbours found automatically, and
  /// other bones not touching them): boneSurface's `exclude` together with the other named bones.
  VoxelMask unnamed;
  int automaticNeighbours = 0;  ///< markers found without a seed
  std::vector<MetalPiece> metal;
  /// The metal voxels left out (pieces of minMetalMm3 or more): boneSurface's `exclude` too, so
  /// an implant's brightness does not pull the surface onto it.
  VoxelMask metalMask;
  double markerDynamicMm = 0.0, sameBoneDynamicMm = 0.0;  ///< the values used
  double jointSideHu = 0.0, jointDipHu = 0.0;
};

/// Segments the bones of `seeds` in a uniform `image` against each other and against the
/// neighbours found automatically. Throws std::invalid_argument with a sentence for the user:
/// a seed outside the volume, not in bone (with the reason: its HU, no cortex around it, or
/// cortex not reached), two bones' seeds in one bone, a bone smaller than minVolumeMm3, or a
/// bone implausible for its name (what it is, what it should be, what to do).
CompetingResult segmentCompetingBones(const CtImage& image, const std::vector<BoneSeed>& seeds,
                                      const CompetingOptions& options = {});

/// Why a bone of this name cannot have this volume / extent ("" when it can). Names known:
/// femur, tibia, fibula, patella, hip / ilium / hip bone, sacrum, pelvis, vertebra, humerus
/// (the part of them a scan holds: upper bounds, since a scan may cut a bone).
std::string implausibleBone(const std::string& bone, double volumeMm3,
                            const Eigen::Vector3d& extentMm);

}  // namespace echoreg::segmentation
