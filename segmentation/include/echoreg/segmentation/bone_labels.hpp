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

#include "echoreg/core/ct_image.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"

#include <Eigen/Core>

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::segmentation {

struct BoneSeed {
  std::string bone;  ///< the bone's name; seeds with one name grow one bone
  Eigen::Vector3d pointLps = Eigen::Vector3d::Zero();
};

/// The bone threshold of this patient, from the CT's histogram around the seeds (see
/// estimateBoneThreshold).
struct ThresholdEstimate {
  double softTissueHu = 0.0;     ///< the soft tissue's peak (mode within -200..200 HU)
  double noiseHu = 0.0;          ///< its spread (1.4826 MAD of the voxels within 60 HU of the peak)
  double cortexHu = 0.0;         ///< the cortex (median of the brightest 2 %, metal left out)
  std::vector<double> marrowHu;  ///< per seed: the median of its 3 x 3 x 3 voxels
  BoneThreshold threshold;       ///< the levels chosen
  /// The surface's cortexMinHu for this CT: min(600, S + 0.7 (C - S)) (600 when not estimated).
  double surfaceCortexMinHu = 600.0;
  std::size_t voxels = 0;  ///< voxels of the boxes looked at
};

/// The threshold for this CT from the histogram of boxes of +-`radiusMm` around the seeds
/// (voxel indices, in the image): strong = S + 0.41 (C - S) and weak = S + 0.29 (strong - S),
/// S the soft tissue's peak and C the cortex; weak at least S + 4 noise, both capped at
/// `ceiling` (the fixed defaults, 600 / 200 HU: they are right for a well mineralised bone, and
/// the estimate only lowers them for faint bone or a soft cortex at thick slices); floors S + 200
/// and S + 80. The factors give 575 / 199 HU on the simulated knee (S 45, C 1337 HU), whose
/// accuracy is that of 600 / 200. Throws std::invalid_argument for an
/// empty image or no seed.
ThresholdEstimate estimateBoneThreshold(const core::CtImage& image,
                                        const std::vector<Eigen::Vector3i>& seedVoxels,
                                        double radiusMm = 30.0, double metalHu = 2500.0,
                                        const BoneThreshold& ceiling = {});

struct CompetingOptions {
  BoneThreshold threshold;
  /// The threshold from this CT's histogram around the seeds (estimateBoneThreshold, capped at
  /// `threshold`); false: `threshold` as given (--threshold-hu).
  bool thresholdFromHistogram = true;
  double thresholdBoxMm = 30.0;  ///< the boxes' half size around each seed, mm
  /// Marrow and other enclosed background filled (see fillHoles), with the scan's first and last
  /// slices counted as closed: a canal cut by the scan's end is filled too.
  double maxSliceHoleMm2 = 2000.0;
  /// A hill of the distance map holding no seed becomes a neighbour's marker when it stands out by
  /// this over the saddle toward a higher hill, mm; 0: max(4 mm, 2 voxels) up to 3 mm slices, on
  /// thicker ones max(6 mm, 1 voxel) (the largest spacing).
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
  /// A joint line lies between two bones: along the direction in which it is darker than both
  /// sides, the voxels for this far beyond each side's first bright voxel are bone (a joint's
  /// subchondral plates have cancellous bone behind them). A thin wall's cancellous core between
  /// its two cortices (the acetabulum's walls, an iliac wing) has soft tissue there within a
  /// cortex or two, and is no joint line: counted as one, it made a piece of an independent hip
  /// phantom's cup wall a neighbour of its own at 1 and 3 mm slices (1 and 3 mm joint spaces:
  /// four of twelve scans wrong without a word, 15-20 cm^3 of the hip bone left out; 1 mm: one
  /// of them mended, 2 mm: three, 3 mm: all four, nothing else in the suite changed beyond
  /// 0.05 mm). Directions whose step is longer than this (along z on thicker slices) are not
  /// checked: one voxel there reaches past a plate and a wall alike. 0: off.
  double jointBeyondMm = 3.0;
  /// Two basins whose boundary runs through the inside of a bone (this share or more of it
  /// darker than half way between the thresholds and not on a joint line) are one bone: an
  /// automatic neighbour joins the bone, two seeded bones are refused.
  double insideShare = 0.5;
  /// A neighbour found automatically also joins the bone it meets when less than this share of
  /// their boundary looks like a joint (a joint line, or cortex against cortex).
  double jointShare = 0.7;
  /// Two seeded bones whose boundary is less than this share joint-like (a joint line, or cortex
  /// against cortex) are refused: the watershed cut through bone where the CT shows no joint (a
  /// joint lost in thick slices: a real femur's knee at 5 mm, 25-27 %, where the labels were
  /// wrong without a word; bones it separates: 50-53 % at 5 mm, 88-100 % at 1-3 mm). 0: off.
  double seededJointShare = 0.4;
  /// The same for each 26-connected piece of that boundary holding at least seededPatchMinShare
  /// of it: a piece less than seededPatchJointShare joint-like is refused (a cut through a bone
  /// beside a real joint, which the whole boundary's share hides). The real pelvis averaged to
  /// 5 mm slices: two such pieces of 31 % each at 23-24 % beside the sacroiliac joint's 80 %; the
  /// simulated knees' femur and tibia at 5 mm: every piece 45-73 %. 0: off.
  double seededPatchJointShare = 0.35;
  double seededPatchMinShare = 0.1;
  /// Two seeded bones whose boundary runs through the thick of the solid are refused: at a joint
  /// the bones narrow to it, and their boundary lies near the background or a joint line; a cut
  /// through a bone lies deep inside it. Refused when the 90th percentile of the boundary's
  /// depth (the distance map at its faces) is at least seededCutDepthMm and at least
  /// seededCutDepthShare of the lower of the two bones' tops. The independent hip phantom at
  /// 5 mm slices, the femur's basin across the acetabular roof into the ilium, the boundary
  /// through the posterior column: 5.1-6.1 mm, 0.36-0.44 (wrong without a word before); bones
  /// separated right (154 boundaries: the real pelvis at 3-6 mm slices, the simulated knees at
  /// 3 and 5 mm with their variants, the phantom's right scans): at most 3.2 mm, and where
  /// deeper than 1 mm at most 0.27 (0.43 against a thin bone's low top: the fibula's, 1.8 mm,
  /// at 3 mm slices). 0: off.
  double seededCutDepthMm = 4.0;
  double seededCutDepthShare = 0.32;
  /// A ball-and-socket joint (the hip) whose line does not show where it lies along thick
  /// slices (the acetabular roof on 5 mm slices): when two seeded bones are refused by the
  /// checks above, a sphere is fitted to the joint-line voxels the two hold (where the joint
  /// crosses the slices it shows; RANSAC, then least squares on its inliers). Where one fits
  /// (radius within jointSphereMinRadiusMm..jointSphereMaxRadiusMm, one bone's seeds inside it
  /// and the other's outside, or after the flood none inside and one of the two holding its
  /// centre, at least jointSphereMinInliers voxels within
  /// jointSphereToleranceMm spread over a cap of at least jointSphereMinCapDegrees, bone filling
  /// it and lining it over the cap, the joint line over much of it), its shell over that cap
  /// becomes joint line and the bones are grown again, every check run again and the ball found
  /// inside the sphere, the socket outside; else, or when the second growth is refused too, the
  /// first refusal stands. Where that sphere does not separate them (no joint line shows: the
  /// head pressed into its socket), a sphere is fitted to the ball's surface where the socket
  /// does not cover it (a Hough transform over the surface voxels' gradients, then least
  /// squares), its cap where bone lines it, and the bones are grown again with the shell's two
  /// sides as markers. On slices of 4 mm or more the joint line's sphere is fitted after a
  /// growth that passed too, and where the ball crosses it the second growth is kept if it
  /// passes. false: off. Measured on the independent hip phantom at 5 mm: right 16 of 16 scans
  /// (before 6; the 4 with no joint space by the surface's sphere); the femur off the cup's roof
  /// where the first growth passed (docs/segmentation.md).
  bool jointFromSphere = true;
  double jointSphereMinRadiusMm = 12.0;
  double jointSphereMaxRadiusMm = 35.0;
  double jointSphereToleranceMm = 1.5;
  int jointSphereMinInliers = 40;
  double jointSphereMinCapDegrees = 60.0;
  /// The joint's slab on thick slices (joint_slabs.hpp): on slices at least jointSlabMinSliceMm
  /// thick (0: never), a voxel of a named bone at a contact along z with another named bone that
  /// stands at most jointSlabShare as high above the soft tissue as its bone's next voxel inward
  /// goes to the other bone (giveJointSlabs). 0.6 chosen on the simulated knee at 5 mm, seeds 3,
  /// 5 and 7 (0.5 / 0.55 / 0.6 / 0.65 / 0.7: femur and tibia MSD 0.287 / 0.282 / 0.278 / 0.281 /
  /// 0.281 mm on average); 4 mm as the ends' shares (BoneSurfaceOptions::endSharesMinSliceMm).
  double jointSlabMinSliceMm = 4.0;
  double jointSlabShare = 0.6;
  /// The soft tissue's level for that rule, HU; NaN: the histogram's (ThresholdEstimate) when
  /// thresholdFromHistogram, else 0 (water).
  double softTissueHu = std::numeric_limits<double>::quiet_NaN();
  /// On slices at least this thick (0: never), a named bone whose slice area along k falls to
  /// half or less of the largest within 15 mm on both sides (each side at least 300 mm^2) is
  /// refused: the watershed ran across a joint that the thick slices hide. On the simulated knee
  /// at 5 mm with faint cancellous bone (150 HU) the tibia's basin took the femur's condyles and
  /// both models were written wrong without a word (femur Dice 0.29-0.48); the tibia's area there
  /// falls from 5,035 to 1,624 voxels and rises again to 4,852 within three slices. A whole
  /// bone's waist (the tibia's shaft) is far longer than 15 mm.
  double waistMinSliceMm = 4.0;
  /// Metal (implants): voxels at or above this HU, in pieces of at least minMetalMm3, are left out
  /// of every bone and reported.
  double metalHu = 2500.0;
  double minMetalMm3 = 20.0;
  /// Streaks around metal (beam hardening, photon starvation): on each axial slice through a
  /// piece, rays every 2 degrees from its centre out to streakReachMm; a voxel is a streak's when
  /// it differs by streakHu or more from the median of the ray samples within +-10 degrees at its
  /// radius (a streak is a few degrees wide; a bone spans tens) along a run of at least
  /// streakRunMm of the ray with one sign. Bright streak voxels are left out of the bone
  /// threshold (a streak cannot join or bridge bone) and, with the dark ones, out of the surface.
  bool detectStreaks = true;
  double streakReachMm = 60.0;
  double streakHu = 150.0;
  double streakRunMm = 10.0;
  /// Refuse (throw, naming the metal: where, how large) instead of segmenting around it.
  bool refuseMetal = false;
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
  std::size_t brightStreakVoxels = 0, darkStreakVoxels = 0;  ///< around it (see detectStreaks)
  int streakSlices = 0;                                      ///< axial slices with a streak
  double streakReachMm = 0.0;  ///< the farthest streak voxel from the piece's centre, in plane
};

/// The sphere that separated a ball-and-socket joint (CompetingOptions::jointFromSphere).
struct JointSphere {
  std::string ball, socket;  ///< the bone holding the centre, the other one
  Eigen::Vector3d centreLps = Eigen::Vector3d::Zero();
  double radiusMm = 0.0;
  double rmsMm = 0.0;           ///< of the inliers' distances to the sphere
  int inliers = 0, points = 0;  ///< joint-line voxels within the tolerance, of those fitted
  Eigen::Vector3d axisLps = Eigen::Vector3d::Zero();  ///< the cap's centre direction
  double capDegrees = 0.0;                            ///< the shell's half angle about the axis
  std::size_t shellVoxels = 0;                        ///< voxels made joint line
  /// Fitted to the ball's surface where it is not covered (no joint line showed), not to the
  /// joint line: `inliers` and `points` count surface voxels.
  bool fromSurface = false;
  /// Tried after a growth that passed every check (on slices of 4 mm or more): its ball had
  /// crossed the sphere, or a piece of its socket lay apart beyond it.
  bool afterPass = false;
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
  /// Voxels moved to the other bone as the joint's slab (CompetingOptions::jointSlabShare).
  std::size_t jointSlabVoxels = 0;
  /// The metal voxels left out (pieces of minMetalMm3 or more): boneSurface's `exclude` too, so
  /// an implant's brightness does not pull the surface onto it.
  VoxelMask metalMask;
  /// The streak voxels (bright and dark) around the metal: boneSurface's `exclude` too.
  VoxelMask streakMask;
  double markerDynamicMm = 0.0, sameBoneDynamicMm = 0.0;  ///< the values used
  double jointSideHu = 0.0, jointDipHu = 0.0;
  BoneThreshold thresholdUsed;  ///< the levels the segmentation used
  bool thresholdFromHistogram = false;
  ThresholdEstimate estimate;  ///< when the levels came from the histogram
  /// When the first growth was refused and a sphere fitted to a ball-and-socket joint's line
  /// separated the bones (CompetingOptions::jointFromSphere).
  std::optional<JointSphere> jointSphere;
};

/// Segments the bones of `seeds` in a uniform `image` against each other and against the
/// neighbours found automatically. Throws std::invalid_argument with a sentence for the user:
/// a seed outside the volume, not in bone (with the reason: its HU, no cortex around it, or
/// cortex not reached), two bones' seeds in one bone, a bone smaller than minVolumeMm3, or a
/// bone implausible for its name (what it is, what it should be, what to do).
CompetingResult segmentCompetingBones(const core::CtImage& image,
                                      const std::vector<BoneSeed>& seeds,
                                      const CompetingOptions& options = {});

/// The sphere that bounds `bone`'s model over its joint (BoneSurfaceOptions::sphereCut): where
/// `result`'s joint sphere was fitted to the ball's surface (no joint showed: the CT leaves the
/// bones' boundary there to the voxels each was given) and `bone` is its ball or its socket.
/// Empty otherwise (a sphere fitted to the joint line lies in the joint space the CT shows, and
/// can lie a slice off at the head's pole: the CT places the surfaces there).
std::optional<SphereCut> sphereCutFor(const CompetingResult& result, const std::string& bone);

/// Where the automatic boundary of a bone is uncertain, per slice of a plane family: the part of
/// the region's boundary (its voxels with a 6-neighbour outside it) that touches another bone
/// (the watershed's boundary: a joint, where the CT cannot show which bone a voxel is), or
/// that has little contrast (the voxel less than lowContrastHu brighter than the outside
/// neighbour: faint bone, a blurred joint).
struct UncertaintyOptions {
  /// The slab of voxels each slice stands for: +- this about its position, mm; 0: half the
  /// distance to the next slice (at least half a voxel).
  double halfWidthMm = 0.0;
  double lowContrastHu = 100.0;
  /// A slice is uncertain from this share of its boundary touching another bone on ...
  double minShare = 0.05;
  /// ... or this share with little contrast (a thin cortex at 3 mm slices shows ~10 % of its
  /// boundary below 100 HU of contrast on every slice of the real CT's hip bone: not a reason).
  double minLowContrastShare = 0.25;
};

struct SliceUncertainty {
  double positionMm = 0.0;  ///< along the plane's normal (LPS x, y or z)
  std::size_t boundaryVoxels = 0, contactVoxels = 0, lowContrastVoxels = 0;
  double share = 0.0;  ///< (contact + low contrast) / boundary
  double contactShare = 0.0, lowContrastShare = 0.0;
  std::vector<std::string> neighbours;  ///< the bones touched, most contact first
  bool uncertain = false;
};

/// The uncertainty of each slice at `positionsMm` (sorted or not) of `plane` for `region`
/// against `neighbours` (name, mask on the same grid; "" for bones found automatically). `ct` is
/// uniform; throws std::invalid_argument for grids that differ.
std::vector<SliceUncertainty> sliceUncertainty(
    const core::CtImage& ct, const VoxelMask& region,
    const std::vector<std::pair<std::string, const VoxelMask*>>& neighbours, SlicePlane plane,
    const std::vector<double>& positionsMm, const UncertaintyOptions& options = {});

/// Where two named bones meet along the slices: the faces between a voxel of one and its
/// neighbour along k of the other. On slices thicker than a joint space is wide a joint that
/// lies along the slices (a knee's plateau, a hip's acetabular roof) shows in no voxel, and that
/// part of the boundary is the segmentation's guess: the independent hip phantom at 5 mm slices
/// had its femur take the cup and the ilium there without a word.
struct SliceContact {
  std::string first, second;          ///< the bones, in the order of `bones`
  double areaMm2 = 0.0;               ///< the faces' area (one pixel each)
  double zMinMm = 0.0, zMaxMm = 0.0;  ///< the faces' LPS z range (between the two slices)
  Eigen::Vector3d centreLps = Eigen::Vector3d::Zero();  ///< the faces' mean
};

/// The contacts along k between each pair of `bones` (masks on `ct`'s grid; a voxel in two
/// masks counts for the first), largest first; pairs that do not meet are left out. Throws
/// std::invalid_argument for a mask on another grid.
std::vector<SliceContact> contactsAlongSlices(const core::CtImage& ct,
                                              const std::vector<SegmentedBone>& bones);

/// Why a bone of this name cannot have this volume / extent ("" when it can). Names known:
/// femur, tibia, fibula, patella, hip / ilium / hip bone, sacrum, pelvis, vertebra, humerus
/// (the part of them a scan holds: upper bounds, since a scan may cut a bone).
std::string implausibleBone(const std::string& bone, double volumeMm3,
                            const Eigen::Vector3d& extentMm);

}  // namespace echoreg::segmentation
