#include "registration_trials.hpp"

#include "echoreg/core/random.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

namespace echoreg::test {

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d randomUnit(core::Rng& rng) {
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
  } while (v.norm() < 1e-9);
  return v.normalized();
}

// A unit vector within `maxAngle` (rad) of `axis`, uniform in angle.
Eigen::Vector3d tilted(core::Rng& rng, const Eigen::Vector3d& axis, double maxAngle) {
  Eigen::Vector3d side = axis.cross(randomUnit(rng));
  if (side.norm() < 1e-9)
    side = axis.unitOrthogonal();
  return Eigen::AngleAxisd(rng.uniform(0.0, maxAngle), side.normalized()) * axis;
}

}  // namespace

FemurTrials::FemurTrials(const core::MeshLocator& model) : model_(model) {
  const core::TriangleMesh& mesh = model.mesh();
  const auto box = core::bounds(mesh);
  const double bottom = box[0].z();
  // The condyles: the bounds of the vertices within 20 mm of the distal end.
  Eigen::Vector3d low = Eigen::Vector3d::Constant(1e30), high = Eigen::Vector3d::Constant(-1e30);
  for (const Eigen::Vector3d& v : mesh.vertices) {
    if (v.z() < bottom + 20.0) {
      low = low.cwiseMin(v);
      high = high.cwiseMax(v);
    }
  }
  kneeCentre_ = 0.5 * (low + high);
  kneeCentre_.z() = bottom + 20.0;
  const double cosine = std::cos(50.0 * kPi / 180.0);
  for (int t = 0; t < static_cast<int>(mesh.triangles.size()); ++t) {
    const auto& tri = mesh.triangles[static_cast<std::size_t>(t)];
    const Eigen::Vector3d centre = (mesh.vertices[static_cast<std::size_t>(tri[0])] +
                                    mesh.vertices[static_cast<std::size_t>(tri[1])] +
                                    mesh.vertices[static_cast<std::size_t>(tri[2])]) /
                                   3.0;
    const Eigen::Vector3d n = core::triangleNormal(mesh, t);
    const double height = centre.z() - kneeCentre_.z();
    if (height >= 60.0 && height <= 130.0 && -n.y() >= cosine)
      triangles_[0].push_back(t);
    if (height >= 12.0 && height <= 45.0 && -n.x() >= cosine)
      triangles_[1].push_back(t);
    if (height >= 12.0 && height <= 45.0 && n.x() >= cosine)
      triangles_[2].push_back(t);
  }
  for (const auto& region : triangles_) {
    if (region.empty())
      throw std::invalid_argument("FemurTrials: a region of the distal femur has no triangle");
  }
}

RegistrationTrial FemurTrials::make(std::uint64_t seed, int index, const TrialOptions& o) const {
  core::Rng rng = core::Rng::derive(seed, "femur-trial", static_cast<std::uint64_t>(index));
  const core::TriangleMesh& mesh = model_.mesh();
  RegistrationTrial trial;
  // The truth: the bone tracker's frame anywhere, turned anyhow.
  trial.truth.linear() =
      Eigen::AngleAxisd(rng.uniform(0.0, kPi), randomUnit(rng)).toRotationMatrix();
  trial.truth.translation() =
      Eigen::Vector3d(rng.uniform(-200, 200), rng.uniform(-200, 200), rng.uniform(-600, 0));
  const Eigen::Isometry3d modelToBone = trial.truth.inverse();
  const double assumedOverTrue = 1.0 / (1.0 + o.speedError);
  while (static_cast<int>(trial.points.size()) < o.points) {
    const double pick = rng.uniform();
    const std::vector<int>& region = triangles_[pick < 0.4 ? 0 : pick < 0.7 ? 1 : 2];
    const int t = region[static_cast<std::size_t>(rng.below(region.size()))];
    const auto& tri = mesh.triangles[static_cast<std::size_t>(t)];
    double u = rng.uniform(), v = rng.uniform();
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(tri[2])];
    const Eigen::Vector3d target = a + u * (b - a) + v * (c - a);
    const Eigen::Vector3d direction =
        -tilted(rng, core::triangleNormal(mesh, t), o.tiltDeg * kPi / 180.0);
    const double standoff = rng.uniform(o.standoffMinMm, o.standoffMaxMm);
    const Eigen::Vector3d origin = target - standoff * direction;
    const auto hit = model_.firstHit(origin, direction);
    if (!hit || !hit->entering || std::abs(hit->t - standoff) > 1e-6)
      continue;  // occluded
    // Depth as measured: the echo's time of flight read with the assumed speed, plus noise.
    double depth = hit->t * assumedOverTrue + rng.normal(0.0, o.noiseMm);
    const bool outlier = rng.chance(o.outlierFraction);
    if (outlier)
      depth += (rng.chance(0.5) ? 1.0 : -1.0) * rng.uniform(3.0, 15.0);
    if (depth <= 0.5)
      continue;
    trial.points.push_back(core::beamSurfacePoint(
        modelToBone * origin, modelToBone.linear() * direction, depth, o.sigmaMm));
    trial.outlier.push_back(outlier);
  }
  // A landmark-like initial error: a rotation about the knee centre and a translation.
  const double angle = rng.uniform(o.initialRotationMinDeg, o.initialRotationMaxDeg) * kPi / 180.0;
  Eigen::Isometry3d error = Eigen::Isometry3d::Identity();
  error.linear() = Eigen::AngleAxisd(angle, randomUnit(rng)).toRotationMatrix();
  error.translation() =
      kneeCentre_ - error.linear() * kneeCentre_ +
      rng.uniform(o.initialTranslationMinMm, o.initialTranslationMaxMm) * randomUnit(rng);
  trial.initial = error * trial.truth;
  return trial;
}

TrialError trialError(const Eigen::Isometry3d& truth, const Eigen::Isometry3d& estimate,
                      const Eigen::Vector3d& kneeCentreModel) {
  TrialError e;
  const Eigen::Vector3d bone = truth.inverse() * kneeCentreModel;
  e.kneeMm = (estimate * bone - kneeCentreModel).norm();
  const Eigen::Matrix3d r = truth.linear().transpose() * estimate.linear();
  e.rotationDeg = Eigen::AngleAxisd(r).angle() * 180.0 / kPi;
  return e;
}

core::TriangleMesh subdivided(const core::TriangleMesh& mesh, int parts) {
  if (parts < 1)
    throw std::invalid_argument("subdivided: parts must be >= 1");
  core::TriangleMesh out;
  out.vertices = mesh.vertices;
  std::map<std::tuple<int, int, int>, int> edgePoints;  // (low vertex, high vertex, step from low)
  // Index of grid point (i, j) of triangle (a, b, c): a + i/n (b - a) + j/n (c - a).
  for (const auto& tri : mesh.triangles) {
    const int n = parts;
    std::vector<int> grid(static_cast<std::size_t>((n + 1) * (n + 1)), -1);
    auto at = [&](int i, int j) -> int& { return grid[static_cast<std::size_t>(i * (n + 1) + j)]; };
    auto edgePoint = [&](int from, int to, int step) {
      if (step == 0)
        return from;
      if (step == n)
        return to;
      const int low = std::min(from, to), high = std::max(from, to);
      const int k = from == low ? step : n - step;
      const auto key = std::make_tuple(low, high, k);
      const auto found = edgePoints.find(key);
      if (found != edgePoints.end())
        return found->second;
      const Eigen::Vector3d& p = out.vertices[static_cast<std::size_t>(low)];
      const Eigen::Vector3d& q = out.vertices[static_cast<std::size_t>(high)];
      out.vertices.push_back(p + (q - p) * (static_cast<double>(k) / n));
      const int index = static_cast<int>(out.vertices.size()) - 1;
      edgePoints.emplace(key, index);
      return index;
    };
    const Eigen::Vector3d a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    const Eigen::Vector3d c = mesh.vertices[static_cast<std::size_t>(tri[2])];
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        if (j == 0) {
          at(i, j) = edgePoint(tri[0], tri[1], i);
        } else if (i == 0) {
          at(i, j) = edgePoint(tri[0], tri[2], j);
        } else if (i + j == n) {
          at(i, j) = edgePoint(tri[1], tri[2], j);
        } else {
          out.vertices.push_back(a + (b - a) * (static_cast<double>(i) / n) +
                                 (c - a) * (static_cast<double>(j) / n));
          at(i, j) = static_cast<int>(out.vertices.size()) - 1;
        }
      }
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        out.triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
        if (i + j + 1 < n)
          out.triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  }
  return out;
}

double percentile(std::vector<double> values, double percent) {
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const double position = percent / 100.0 * static_cast<double>(values.size() - 1);
  const std::size_t low = static_cast<std::size_t>(std::floor(position));
  const std::size_t high = std::min(low + 1, values.size() - 1);
  return values[low] + (position - static_cast<double>(low)) * (values[high] - values[low]);
}

}  // namespace echoreg::test
