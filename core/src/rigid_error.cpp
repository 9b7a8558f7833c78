// Registration error against a reference, decomposed along the CT axes (see rigid_error.hpp).
#include "echoreg/core/rigid_error.hpp"

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

constexpr double kDegPerRad = 57.295779513082320876798;

void checkRotation(const Eigen::Matrix3d& r, const char* what) {
  if (!r.allFinite() ||
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
      std::abs(r.determinant() - 1.0) > 1e-6) {
    throw std::invalid_argument(std::string(what) + " is not a rotation (orthonormal, det +1)");
  }
}

}  // namespace

Eigen::Vector3d rotationAnglesZyxDeg(const Eigen::Matrix3d& r) {
  checkRotation(r, "the matrix");
  // r = Rz(c) Ry(b) Rx(a): r20 = -sin b, r21 = cos b sin a, r22 = cos b cos a,
  // r10 = sin c cos b, r00 = cos c cos b.
  const double b = std::atan2(-r(2, 0), std::hypot(r(2, 1), r(2, 2)));
  double a = 0.0;
  double c = 0.0;
  if (std::hypot(r(2, 1), r(2, 2)) > 1e-12) {
    a = std::atan2(r(2, 1), r(2, 2));
    c = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: only a -/+ c is determined; take c = 0
    a = std::atan2(-r(1, 2), r(1, 1));
  }
  return Eigen::Vector3d(a, b, c) * kDegPerRad;
}

Eigen::Matrix3d rotationFromAnglesZyxDeg(const Eigen::Vector3d& anglesDeg) {
  const Eigen::Vector3d a = anglesDeg / kDegPerRad;
  return (Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

RigidError rigidError(const Eigen::Isometry3d& reference, const Eigen::Isometry3d& estimate,
                      const std::vector<Eigen::Vector3d>& targetsCt,
                      const Eigen::Vector3d& centreCt) {
  if (!reference.matrix().allFinite() || !estimate.matrix().allFinite() || !centreCt.allFinite()) {
    throw std::invalid_argument("rigid error: a matrix or the centre is not finite");
  }
  checkRotation(reference.linear(), "the reference's rotation part");
  checkRotation(estimate.linear(), "the estimate's rotation part");
  Eigen::Isometry3d refInverse = Eigen::Isometry3d::Identity();
  refInverse.linear() = reference.linear().transpose();
  refInverse.translation() = -(reference.linear().transpose() * reference.translation());
  const Eigen::Isometry3d e = estimate * refInverse;
  RigidError out;
  out.errorMatrix = e.matrix();
  out.translationMm = e * centreCt - centreCt;
  out.rotationDeg = rotationAnglesZyxDeg(e.linear());
  for (std::size_t i = 0; i < targetsCt.size(); ++i) {
    if (!targetsCt[i].allFinite()) {
      throw std::invalid_argument("rigid error: target " + std::to_string(i) + " is not finite");
    }
    out.targetErrorsMm.push_back((e * targetsCt[i] - targetsCt[i]).norm());
  }
  return out;
}

RigidError meanAbsoluteError(const std::vector<RigidError>& rows) {
  if (rows.empty())
    throw std::invalid_argument("mean absolute error of no registrations");
  RigidError mean;
  mean.targetErrorsMm.assign(rows.front().targetErrorsMm.size(), 0.0);
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].targetErrorsMm.size() != mean.targetErrorsMm.size()) {
      throw std::invalid_argument("mean absolute error: row " + std::to_string(r) + " has " +
                                  std::to_string(rows[r].targetErrorsMm.size()) +
                                  " targets, row 0 has " +
                                  std::to_string(mean.targetErrorsMm.size()));
    }
    mean.translationMm += rows[r].translationMm.cwiseAbs();
    mean.rotationDeg += rows[r].rotationDeg.cwiseAbs();
    for (std::size_t t = 0; t < mean.targetErrorsMm.size(); ++t) {
      mean.targetErrorsMm[t] += std::abs(rows[r].targetErrorsMm[t]);
    }
  }
  const double n = static_cast<double>(rows.size());
  mean.translationMm /= n;
  mean.rotationDeg /= n;
  for (double& t : mean.targetErrorsMm)
    t /= n;
  return mean;
}

}  // namespace echoreg::core
