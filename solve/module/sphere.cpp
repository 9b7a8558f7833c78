// The sphere fit's geometric refinement (core/src/fits.cpp): Levenberg-Marquardt over the
// centre and (unless known) the radius, with Ceres.
#include "module.hpp"

#include "solver_options.hpp"

#include <ceres/ceres.h>

#include <cmath>
#include <stdexcept>

namespace echoreg::solve {

namespace {

struct SphereResidual {
  explicit SphereResidual(const Eigen::Vector3d& point) : point_(point) {}

  template <typename T>
  bool operator()(const T* centre, const T* radius, T* residual) const {
    const T dx = T(point_.x()) - centre[0];
    const T dy = T(point_.y()) - centre[1];
    const T dz = T(point_.z()) - centre[2];
    residual[0] = ceres::sqrt(dx * dx + dy * dy + dz * dz) - radius[0];
    return true;
  }

 private:
  Eigen::Vector3d point_;
};

}  // namespace

void refineSphere(const std::vector<Eigen::Vector3d>& points, bool knownRadius,
                  Eigen::Vector3d& centre, double& radiusMm) {
  double c[3] = {centre.x(), centre.y(), centre.z()};
  double r[1] = {radiusMm};
  ceres::Problem problem;
  for (const auto& p : points) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SphereResidual, 1, 3, 1>(new SphereResidual(p)), nullptr, c,
        r);
  }
  if (knownRadius)
    problem.SetParameterBlockConstant(r);
  const ceres::Solver::Options options = levenbergMarquardt(1e-16, 1e-16, 1e-14);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable() || !std::isfinite(c[0]) || !std::isfinite(c[1]) ||
      !std::isfinite(c[2]) || !std::isfinite(r[0])) {
    throw std::invalid_argument("the sphere fit did not converge on these points: " +
                                summary.message);
  }
  centre = Eigen::Vector3d(c[0], c[1], c[2]);
  radiusMm = r[0];
}

}  // namespace echoreg::solve
