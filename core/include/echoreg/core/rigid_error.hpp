// The error of an estimated registration against a reference (Mozes 2008, Eq. 4.5): the error
// matrix in CT space, decomposed into translations along and rotations about the CT axes (x
// medial-lateral, y anterior-posterior, z superior-inferior), R = Rz * Ry * Rx, the distances at
// named targets, and tables of many registrations with the mean of absolute values (Tables
// 5.3-5.7). docs/registration.md ("Errors").
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace echoreg::core {

/// Angles (rx, ry, rz) in degrees with r = Rz(rz) * Ry(ry) * Rx(rx), ry in [-90, 90]. Throws
/// std::invalid_argument when r is not a rotation (orthonormal, det +1, within 1e-6).
Eigen::Vector3d rotationAnglesZyxDeg(const Eigen::Matrix3d& r);

/// The rotation Rz(rz) * Ry(ry) * Rx(rx) for angles in degrees.
Eigen::Matrix3d rotationFromAnglesZyxDeg(const Eigen::Vector3d& anglesDeg);

struct RigidError {
  /// E = estimate * inverse(reference): CT -> CT, taking each point where the reference puts it
  /// to where the estimate puts it. (The dissertation's inv(T_mech) * T_US in its row-vector
  /// reading; see docs/registration.md.)
  Eigen::Matrix4d errorMatrix = Eigen::Matrix4d::Identity();
  /// E(centre) - centre, mm along CT x, y, z (the matrix's own translation when centre = 0).
  Eigen::Vector3d translationMm = Eigen::Vector3d::Zero();
  /// (rx, ry, rz) of E's rotation about CT x, y, z, degrees, R = Rz * Ry * Rx.
  Eigen::Vector3d rotationDeg = Eigen::Vector3d::Zero();
  /// |E(t) - t| for each target t (CT, mm).
  std::vector<double> targetErrorsMm;
};

/// The error of `estimate` against `reference` (both bone marker -> CT). Translations are the
/// displacement of `centreCt` (default the CT origin, the dissertation's plain decomposition).
/// Throws std::invalid_argument for a non-finite matrix or target or a rotation part that is not
/// a rotation.
RigidError rigidError(const Eigen::Isometry3d& reference, const Eigen::Isometry3d& estimate,
                      const std::vector<Eigen::Vector3d>& targetsCt = {},
                      const Eigen::Vector3d& centreCt = Eigen::Vector3d::Zero());

/// Mean of absolute values of every component over the rows (translation, rotation, targets);
/// errorMatrix is left identity. Throws std::invalid_argument when rows is empty or the rows
/// have different numbers of targets.
RigidError meanAbsoluteError(const std::vector<RigidError>& rows);

}  // namespace echoreg::core
