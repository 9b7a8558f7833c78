// The beam calibration's Ceres half (core/src/beam_calibration.cpp): one Levenberg-Marquardt
// round over the used shots, and the residuals' Jacobian by automatic differentiation.
#include "module.hpp"

#include "solver_options.hpp"

#include <ceres/ceres.h>

#include <memory>
#include <stdexcept>
#include <string>

namespace echoreg::solve {

using core::detail::ShotData;
using core::detail::ShotResidual;

namespace {

std::unique_ptr<ceres::CostFunction> makeCost(int count, const ShotData& data) {
  switch (count) {
    case 3:
      return std::make_unique<ceres::AutoDiffCostFunction<ShotResidual<3>, 1, 3>>(
          new ShotResidual<3>(data));
    case 4:
      return std::make_unique<ceres::AutoDiffCostFunction<ShotResidual<4>, 1, 4>>(
          new ShotResidual<4>(data));
    case 5:
      return std::make_unique<ceres::AutoDiffCostFunction<ShotResidual<5>, 1, 5>>(
          new ShotResidual<5>(data));
    case 6:
      return std::make_unique<ceres::AutoDiffCostFunction<ShotResidual<6>, 1, 6>>(
          new ShotResidual<6>(data));
    default:
      throw std::logic_error("beam calibration: no cost function for " + std::to_string(count) +
                             " parameters");
  }
}

}  // namespace

core::detail::BeamRound beamRound(int count, const std::vector<ShotData>& data,
                                  const std::vector<bool>& used, Eigen::VectorXd& x) {
  const ceres::Solver::Options solver = levenbergMarquardt(1e-12, 1e-14, 1e-12);
  ceres::Problem problem;
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (used[i])
      problem.AddResidualBlock(makeCost(count, data[i]).release(), nullptr, x.data());
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  core::detail::BeamRound round;
  round.usable = summary.IsSolutionUsable();
  round.converged = summary.termination_type == ceres::CONVERGENCE;
  round.iterations = static_cast<int>(summary.iterations.size()) - 1;
  round.message = summary.message;
  return round;
}

int beamJacobian(int count, const std::vector<ShotData>& data, const Eigen::VectorXd& x,
                 core::detail::ShotJacobian& jacobian) {
  jacobian.resize(static_cast<Eigen::Index>(data.size()), count);
  const double* blocks[] = {x.data()};
  for (std::size_t i = 0; i < data.size(); ++i) {
    const auto cost = makeCost(count, data[i]);
    double residual = 0.0;
    double* row[] = {jacobian.row(static_cast<Eigen::Index>(i)).data()};
    if (!cost->Evaluate(blocks, &residual, row))
      return static_cast<int>(i);
  }
  return -1;
}

}  // namespace echoreg::solve
