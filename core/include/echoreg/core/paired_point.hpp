// Paired-point rigid registration (Horn 1987 / Umeyama 1991, weighted), its fiducial registration
// error, and Fitzpatrick's (1998) expected target registration error. Used for the landmark
// (initial) registration of each bone and for phantom registration (PLUS's golden data).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

namespace echoreg::core {

struct PairedPointResult {
  /// Maps `from` points onto `to` points: to_i ~ transform * from_i. Rotation proper (det +1).
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  /// Fiducial registration error: RMS of |transform * from_i - to_i| (unweighted), mm.
  double freMm = 0.0;
  std::vector<double> residualsMm;  ///< per pair, |transform * from_i - to_i|
};

/// Least-squares rigid transform taking `from` onto `to`. `weights` (empty = all 1) weights each
/// pair, e.g. 1 / sigma_i^2 for a landmark localised to sigma_i mm. Throws std::invalid_argument
/// (naming the pair) on sizes that differ, fewer than 3 pairs, a non-finite coordinate, a weight
/// that is negative or not finite, fewer than 3 pairs of positive weight, or points that are
/// collinear on either side (the rotation about their line is then undetermined).
PairedPointResult registerPairedPoints(const std::vector<Eigen::Vector3d>& from,
                                       const std::vector<Eigen::Vector3d>& to,
                                       const std::vector<double>& weights = {});

/// Fitzpatrick, West & Maurer (1998): expected TRE at `target` for fiducials `fiducials` (in the
/// same space) localised with isotropic RMS error `fleMm`:
/// TRE^2 = FLE^2 / N * (1 + 1/3 * sum_k d_k^2 / f_k^2), d_k the target's distance from principal
/// axis k of the fiducial configuration and f_k the fiducials' RMS distance from it. FLE is the
/// 3D RMS error (sqrt(3) sigma for sigma per axis). Throws std::invalid_argument for fewer than 3
/// fiducials, collinear fiducials, a negative or non-finite FLE, or non-finite points.
double expectedTargetErrorMm(const std::vector<Eigen::Vector3d>& fiducials, double fleMm,
                             const Eigen::Vector3d& target);

/// Fitzpatrick's expected FRE for N fiducials: FRE^2 = (1 - 2/N) FLE^2. Throws
/// std::invalid_argument for N < 3 or a negative or non-finite FLE.
double expectedFiducialErrorMm(int fiducials, double fleMm);

}  // namespace echoreg::core
