// Paired-point rigid registration (weighted Horn/Umeyama with a proper rotation) and Fitzpatrick's
// expected registration errors.
#include "echoreg/core/paired_point.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

std::string pairName(std::size_t i) {
  return "pair " + std::to_string(i);
}

// Largest and second principal RMS spread (mm) of the points with positive weight, about their
// weighted centroid.
Eigen::Vector3d principalSpread(const std::vector<Eigen::Vector3d>& points,
                                const std::vector<double>& w, const Eigen::Vector3d& centroid,
                                double weightSum) {
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (w[i] <= 0.0)
      continue;
    const Eigen::Vector3d d = points[i] - centroid;
    c += w[i] * d * d.transpose();
  }
  c /= weightSum;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  // Ascending eigenvalues -> descending spreads.
  const Eigen::Vector3d ev = eig.eigenvalues().cwiseMax(0.0);
  return Eigen::Vector3d(std::sqrt(ev[2]), std::sqrt(ev[1]), std::sqrt(ev[0]));
}

void checkNotCollinear(const Eigen::Vector3d& spread, const char* side) {
  // Collinear (or coincident) when the second principal spread is below 1e-3 of the first or
  // below 1e-6 mm: the rotation about the points' line is then undetermined.
  if (!(spread[0] > 1e-9) || spread[1] < 1e-3 * spread[0] || spread[1] < 1e-6) {
    throw std::invalid_argument(
        std::string("the ") + side + " points are collinear (second principal spread " +
        std::to_string(spread[1]) + " mm against " + std::to_string(spread[0]) +
        " mm): the rotation about their line is undetermined");
  }
}

}  // namespace

PairedPointResult registerPairedPoints(const std::vector<Eigen::Vector3d>& from,
                                       const std::vector<Eigen::Vector3d>& to,
                                       const std::vector<double>& weights) {
  if (from.size() != to.size()) {
    throw std::invalid_argument("paired points: " + std::to_string(from.size()) +
                                " 'from' points but " + std::to_string(to.size()) + " 'to' points");
  }
  if (!weights.empty() && weights.size() != from.size()) {
    throw std::invalid_argument("paired points: " + std::to_string(weights.size()) +
                                " weights for " + std::to_string(from.size()) + " pairs");
  }
  if (from.size() < 3) {
    throw std::invalid_argument("paired points: " + std::to_string(from.size()) +
                                " pairs, at least 3 needed");
  }
  std::vector<double> w(from.size(), 1.0);
  int positive = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (!from[i].allFinite() || !to[i].allFinite()) {
      throw std::invalid_argument("paired points: " + pairName(i) + " has a non-finite coordinate");
    }
    if (!weights.empty()) {
      if (!std::isfinite(weights[i]) || weights[i] < 0.0) {
        throw std::invalid_argument("paired points: " + pairName(i) + " has weight " +
                                    std::to_string(weights[i]) + " (must be finite and >= 0)");
      }
      w[i] = weights[i];
    }
    positive += w[i] > 0.0 ? 1 : 0;
  }
  if (positive < 3) {
    throw std::invalid_argument("paired points: " + std::to_string(positive) +
                                " pairs of positive weight, at least 3 needed");
  }
  double wsum = 0.0;
  Eigen::Vector3d cf = Eigen::Vector3d::Zero();
  Eigen::Vector3d ct = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    wsum += w[i];
    cf += w[i] * from[i];
    ct += w[i] * to[i];
  }
  cf /= wsum;
  ct /= wsum;
  checkNotCollinear(principalSpread(from, w, cf, wsum), "'from'");
  checkNotCollinear(principalSpread(to, w, ct, wsum), "'to'");

  // Umeyama: H = sum w (to - ct)(from - cf)^T = U S V^T, R = U diag(1, 1, det(U V^T)) V^T.
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    h += w[i] * (to[i] - ct) * (from[i] - cf).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0)
    d(2, 2) = -1.0;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();

  PairedPointResult result;
  result.transform.linear() = r;
  result.transform.translation() = ct - r * cf;
  double sum = 0.0;
  result.residualsMm.reserve(from.size());
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double e = (result.transform * from[i] - to[i]).norm();
    result.residualsMm.push_back(e);
    sum += e * e;
  }
  result.freMm = std::sqrt(sum / static_cast<double>(from.size()));
  return result;
}

double expectedTargetErrorMm(const std::vector<Eigen::Vector3d>& fiducials, double fleMm,
                             const Eigen::Vector3d& target) {
  if (fiducials.size() < 3) {
    throw std::invalid_argument("expected TRE: " + std::to_string(fiducials.size()) +
                                " fiducials, at least 3 needed");
  }
  if (!(fleMm >= 0.0) || !std::isfinite(fleMm) || !target.allFinite()) {
    throw std::invalid_argument("expected TRE: FLE must be finite and >= 0 and the target finite");
  }
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : fiducials) {
    if (!p.allFinite())
      throw std::invalid_argument("expected TRE: a fiducial is not finite");
    c += p;
  }
  const double n = static_cast<double>(fiducials.size());
  c /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : fiducials)
    cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov / n);
  const Eigen::Vector3d lambda = eig.eigenvalues().cwiseMax(0.0);  // mean squared coordinates
  const Eigen::Vector3d t = eig.eigenvectors().transpose() * (target - c);
  double sum = 0.0;
  for (Eigen::Index k = 0; k < 3; ++k) {
    // Squared distances from principal axis k: the other two coordinates.
    const Eigen::Index a = (k + 1) % 3;
    const Eigen::Index b = (k + 2) % 3;
    const double dk2 = t[a] * t[a] + t[b] * t[b];
    const double fk2 = lambda[a] + lambda[b];
    if (!(fk2 > 0.0)) {
      throw std::invalid_argument("expected TRE: the fiducials are collinear");
    }
    sum += dk2 / fk2;
  }
  return std::sqrt(fleMm * fleMm / n * (1.0 + sum / 3.0));
}

double expectedFiducialErrorMm(int fiducials, double fleMm) {
  if (fiducials < 3) {
    throw std::invalid_argument("expected FRE: " + std::to_string(fiducials) +
                                " fiducials, at least 3 needed");
  }
  if (!(fleMm >= 0.0) || !std::isfinite(fleMm)) {
    throw std::invalid_argument("expected FRE: FLE must be finite and >= 0");
  }
  return std::sqrt(1.0 - 2.0 / static_cast<double>(fiducials)) * fleMm;
}

}  // namespace echoreg::core
