#include "echoreg/core/rigid_pose.hpp"

#include "echoreg/core/error.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace echoreg::core {

namespace {

std::string shortNumber(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g", value);
  return buffer;
}

}  // namespace

double poseOrthonormalDeviation(const Eigen::Matrix4d& matrix) {
  const Eigen::Matrix3d r = matrix.topLeftCorner<3, 3>();
  const double orthogonality =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return std::max(orthogonality, std::abs(r.determinant() - 1.0));
}

std::string poseProblem(const Eigen::Matrix4d& matrix) {
  if (!matrix.allFinite())
    return "it holds a number that is not finite";
  const double lastRow = (matrix.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff();
  if (lastRow > kPoseLastRowTolerance) {
    return "its last row is " + shortNumber(matrix(3, 0)) + " " + shortNumber(matrix(3, 1)) + " " +
           shortNumber(matrix(3, 2)) + " " + shortNumber(matrix(3, 3)) +
           ", not 0 0 0 1: a projective matrix, not a rigid pose";
  }
  const double distance = matrix.topRightCorner<3, 1>().stableNorm();  // 1e308 squared overflows
  if (!(distance <= kPoseMaxTranslationMm)) {
    return "its translation is " + shortNumber(distance) +
           " mm from the tracker's origin, beyond the " + shortNumber(kPoseMaxTranslationMm) +
           " mm (10 m) any tracker measures: a unit or a damaged number";
  }
  const Eigen::Matrix3d r = matrix.topLeftCorner<3, 3>();
  const double orthogonality =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double determinant = r.determinant();
  if (orthogonality > kPoseOrthonormalTolerance ||
      std::abs(determinant - 1.0) > kPoseOrthonormalTolerance) {
    return "its rotation is off orthonormal by " + shortNumber(orthogonality) +
           " (max |R^T R - I|) with determinant " + shortNumber(determinant) + ", accepted up to " +
           shortNumber(kPoseOrthonormalTolerance) +
           ": a scale, shear or reflection, not a rigid pose";
  }
  return "";
}

Eigen::Matrix4d reorthonormalised(const Eigen::Matrix4d& matrix) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(matrix.topLeftCorner<3, 3>(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  if ((u * v.transpose()).determinant() < 0.0)
    u.col(2) = -u.col(2);
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = u * v.transpose();
  out.topRightCorner<3, 1>() = matrix.topRightCorner<3, 1>();
  return out;
}

RigidPoseReport enforceRigidPoses(Sequence& sequence, const std::string& path,
                                  const std::string& transform) {
  RigidPoseReport report;
  if (transform.empty())
    return report;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const auto it = sequence.frames[f].transforms.find(transform);
    if (it == sequence.frames[f].transforms.end() || !it->second.valid())
      continue;
    Eigen::Matrix4d& matrix = it->second.matrix;
    const std::string problem = poseProblem(matrix);
    if (!problem.empty()) {
      throw FileError(path, "frame " + std::to_string(f) + ": its " + transform +
                                "Transform is not a rigid pose: " + problem);
    }
    ++report.checked;
    const double deviation = poseOrthonormalDeviation(matrix);
    report.largestDeviation = std::max(report.largestDeviation, deviation);
    const bool lastRowExact = matrix.row(3) == Eigen::RowVector4d(0, 0, 0, 1);
    if (deviation > kPoseExactTolerance || !lastRowExact) {
      if (deviation > kPoseExactTolerance)
        ++report.reorthonormalised;
      matrix = deviation > kPoseExactTolerance ? reorthonormalised(matrix) : matrix;
      matrix.row(3) = Eigen::RowVector4d(0, 0, 0, 1);
    }
  }
  return report;
}

std::optional<std::string> rigidPoseNote(const RigidPoseReport& report, const std::string& path,
                                         const std::string& transform) {
  if (report.reorthonormalised == 0)
    return std::nullopt;
  return path + ": " + std::to_string(report.reorthonormalised) + " of " +
         std::to_string(report.checked) + " " + transform +
         " poses re-orthonormalised (largest deviation " + shortNumber(report.largestDeviation) +
         ", within " + shortNumber(kPoseOrthonormalTolerance) + ")";
}

}  // namespace echoreg::core
