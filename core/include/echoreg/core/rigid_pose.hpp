// The one rule for tracked poses used as rigid transforms (issue 15, item 2). Real optical
// trackers write rotations orthonormal only to a few 1e-4 (PLUS's own recordings: 2e-4 to 5e-4),
// so a pose within kPoseOrthonormalTolerance is re-orthonormalised (the nearest rotation, by SVD)
// and counted; beyond it (a scale, a shear, a reflection) or with a last row other than 0 0 0 1
// within kPoseLastRowTolerance, or not finite, or with a translation beyond kPoseMaxTranslationMm
// (no tracker measures 10 m away: a unit or a damaged number), it is refused, naming the frame and
// the transform.
// docs/formats.md ("Poses").
#pragma once

#include "echoreg/core/sequence.hpp"

#include <Eigen/Core>

#include <optional>
#include <string>

namespace echoreg::core {

/// Largest |R^T R - I| and |det R - 1| accepted (and then re-orthonormalised).
constexpr double kPoseOrthonormalTolerance = 1e-2;
/// Largest deviation of the last row from 0 0 0 1.
constexpr double kPoseLastRowTolerance = 1e-6;
/// Largest |translation| accepted, mm: optical and electromagnetic trackers measure within a few
/// metres, so a pose beyond 10 m is a damaged number or a unit mistake (um for mm), which would
/// otherwise be carried into results as 300-digit coordinates.
constexpr double kPoseMaxTranslationMm = 1e4;
/// Poses within this of a rotation are used as they are (not counted as re-orthonormalised).
constexpr double kPoseExactTolerance = 1e-6;

/// How far a 4x4 is from a rigid transform: max(|R^T R - I|, |det R - 1|) of its 3x3 part.
double poseOrthonormalDeviation(const Eigen::Matrix4d& matrix);

/// Why `matrix` cannot be used as a rigid pose ("" when it can): in the user's words, e.g. "its
/// rotation is off orthonormal by 0.0201 (max |R^T R - I|; accepted up to 0.01) and its
/// determinant is 1.0303: a scale or shear, not a rigid pose".
std::string poseProblem(const Eigen::Matrix4d& matrix);

/// The nearest rigid transform (rotation by SVD, determinant +1; translation kept; last row 0 0 0
/// 1). Call only on a matrix poseProblem() accepts.
Eigen::Matrix4d reorthonormalised(const Eigen::Matrix4d& matrix);

struct RigidPoseReport {
  int checked = 0;            ///< valid poses of the transform
  int reorthonormalised = 0;  ///< of those, the ones further than kPoseExactTolerance
  double largestDeviation = 0.0;
};

/// Applies the rule to every valid ("OK") pose of `transform` ("ProbeToTracker") in `sequence`, in
/// place. Throws FileError(path, "frame N: its ProbeToTrackerTransform is not a rigid pose: ...")
/// for the first pose refused. A transform the capture does not hold is left to the caller.
RigidPoseReport enforceRigidPoses(Sequence& sequence, const std::string& path,
                                  const std::string& transform);

/// "PATH: 412 of 1000 StylusToTracker poses re-orthonormalised (largest deviation 5.1e-04, within
/// 1e-02)", or nothing when none was.
std::optional<std::string> rigidPoseNote(const RigidPoseReport& report, const std::string& path,
                                         const std::string& transform);

}  // namespace echoreg::core
