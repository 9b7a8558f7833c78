// Dwell detection: where a tracked stylus tip rests on a landmark. The stylus is carried from one
// landmark to the next, held still on each for a moment, and the tracker drops frames (INVALID)
// now and then; each dwell gives one landmark position. Used by `echoreg landmarks` and by
// `echoreg register --landmarks-capture` (initial, paired-point registration).
// docs/registration.md.
#pragma once

#include "echoreg/core/paired_point.hpp"
#include "echoreg/core/sequence.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace echoreg::core {

struct DwellOptions {
  /// Largest distance of any tip position of a dwell from the dwell's median position, mm.
  double maxMotionMm = 1.0;
  /// Shortest dwell, seconds (first to last valid frame of the dwell).
  double minDurationS = 0.5;
  /// Fewest valid frames in a dwell.
  int minFrames = 10;
  /// Consecutive dwells whose means are closer than this are one landmark (the stylus pivoted on
  /// it, or a jitter split the rest), mm. PLUS uses 5 mm (a third of its 15 mm landmark spacing).
  double mergeDistanceMm = 5.0;
  /// The motion test runs on the tip smoothed by a centred moving mean over this time, s (tracker
  /// jitter and tremor of a few tenths of a mm would otherwise break a rest at 1 mm). 0: none.
  double smoothingS = 0.1;
};

struct Dwell {
  int firstFrame = 0;  ///< first valid frame of the dwell (index into the inputs)
  int lastFrame = 0;   ///< last valid frame of the dwell (inclusive)
  Eigen::Vector3d meanMm = Eigen::Vector3d::Zero();  ///< mean tip position over the dwell
  double spreadMm = 0.0;  ///< RMS distance of the dwell's positions from meanMm
  int frames = 0;         ///< valid frames averaged
};

/// The stylus' resting periods, in time order. Algorithm (docs/registration.md, "Dwells"):
/// frames that are not `valid` are ignored (a gap does not end a dwell). The positions are
/// smoothed by a centred moving mean over smoothingS for the motion test only. A run of
/// consecutive valid frames is grown greedily from each start frame while every position stays
/// within maxMotionMm of the run's component-wise median (checked as the run grows, against the
/// median recomputed when the run has doubled); a run that lasts minDurationS and has minFrames
/// valid frames is a dwell, and the search restarts after it; otherwise the start advances by one
/// frame. Consecutive runs whose means are within mergeDistanceMm are merged into one dwell.
/// Each run contributes its stable core to the mean: its raw positions within maxMotionMm / 2
/// of their median (all of them when that leaves fewer than minFrames).
/// Throws std::invalid_argument when the three vectors differ in size, an option is not
/// positive (mergeDistanceMm may be 0: no merging), timestamps decrease, or a valid frame has a
/// non-finite position or timestamp.
std::vector<Dwell> detectDwells(const std::vector<Eigen::Vector3d>& positions,
                                const std::vector<double>& timestampsS,
                                const std::vector<bool>& valid, const DwellOptions& options);

/// Dwells matched in time order to landmarks: which dwell is which landmark, and the paired-point
/// registration landmarks -> dwell means.
struct DwellMatch {
  std::vector<int> dwellIndex;     ///< per landmark, the index of its dwell
  PairedPointResult registration;  ///< landmarks (from) -> dwell means (to)
  /// FRE of the best other choice of dwells (infinity when there was no other): a value close to
  /// registration.freMm means the choice was ambiguous.
  double runnerUpFreMm = 0.0;
  long long candidates = 1;  ///< choices of dwells tried
};

/// Pairs landmarks[i] with the i-th chosen dwell, in time order. With as many dwells as
/// landmarks all are used; with more (the stylus rested away from the landmarks, before, between
/// or after them) every in-order choice of landmarks.size() dwells is registered and the one of
/// smallest FRE taken. Throws std::invalid_argument when there are fewer dwells than landmarks
/// (saying how many were found), fewer than 3 landmarks, more than 2e6 choices, or when the
/// registration refuses (collinear points).
DwellMatch matchDwellsInOrder(const std::vector<Dwell>& dwells,
                              const std::vector<Eigen::Vector3d>& landmarks);

struct StylusTrack {
  std::vector<Eigen::Vector3d> tipInReference;  ///< one per frame (zero where not valid)
  std::vector<double> timestampsS;              ///< one per frame (frame index when absent)
  std::vector<bool> valid;                      ///< both transforms present and OK in the frame
};

/// The stylus tip in the reference marker's frame for every frame of `capture`:
/// tip = inv(ReferenceToTracker) * StylusToTracker * StylusTipToStylus * (0,0,0).
/// `stylusTransform` / `referenceTransform` name the transforms without the "Transform" suffix;
/// an empty `referenceTransform` leaves the tip in the tracker's frame. Throws
/// std::invalid_argument when the capture lacks one of the transforms (naming those it has) or
/// none of its frames has both valid. (Callers wrap it in FileError naming the capture.)
StylusTrack stylusTipTrack(const Sequence& capture, const Eigen::Isometry3d& stylusTipToStylus,
                           const std::string& stylusTransform = "StylusToTracker",
                           const std::string& referenceTransform = "ReferenceToTracker");

}  // namespace echoreg::core
