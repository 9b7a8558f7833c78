// A user's femur mesh in the simulated knee: its anatomical frame from the mesh alone (long axis,
// head by a sphere fit, epicondyles, posterior condyles), a left femur mirrored to a right one,
// then a rigid placement on the knee's hip-knee line.
#include "anatomy_detail.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/filters/mesh_io.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace echoreg::simulation::detail {

using Eigen::Vector3d;

namespace {

constexpr double kCondyleAboveKneeMm = 1.0;  // as the procedural knee: condyles 1 mm above K

std::string mm(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", value);
  return text;
}

/// Least-squares sphere through `points` (algebraic fit): centre and radius.
bool fitSphere(const std::vector<Vector3d>& points, Vector3d& centre, double& radius) {
  if (points.size() < 10)
    return false;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(points.size()), 4);
  Eigen::VectorXd b(static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    a(row, 0) = 2.0 * points[i].x();
    a(row, 1) = 2.0 * points[i].y();
    a(row, 2) = 2.0 * points[i].z();
    a(row, 3) = 1.0;
    b(row) = points[i].squaredNorm();
  }
  const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
  centre = x.head<3>();
  const double r2 = x(3) + centre.squaredNorm();
  if (!(r2 > 0.0))
    return false;
  radius = std::sqrt(r2);
  return true;
}

/// What the mesh alone says about the femur (in its own coordinates).
struct FemurFrame {
  Vector3d axisPoint, proximal;  // shaft axis line, unit proximal direction
  Vector3d hip;
  double headRadius = 0.0;
  Vector3d medial;                 // unit, perpendicular to the shaft axis
  double posteriorOffsetMm = 0.0;  // distal end's centroid behind the shaft axis (> 0: right femur)
  Vector3d medialEpicondyle, lateralEpicondyle;
};

FemurFrame analyse(const core::TriangleMesh& mesh, const std::string& path) {
  const std::vector<Vector3d>& v = mesh.vertices;
  FemurFrame frame;
  // Long axis by PCA of the vertices.
  Vector3d centroid = Vector3d::Zero();
  for (const Vector3d& p : v)
    centroid += p;
  centroid /= static_cast<double>(v.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vector3d& p : v)
    covariance += (p - centroid) * (p - centroid).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  Vector3d axis = eigen.eigenvectors().col(2);
  const Eigen::Vector3d values = eigen.eigenvalues();
  if (!(values(2) > 4.0 * values(1))) {
    throw core::FileError(path, "does not look like a long bone (no dominant long axis)");
  }
  auto along = [&](const Vector3d& p, const Vector3d& point, const Vector3d& dir) {
    return (p - point).dot(dir);
  };
  double low = std::numeric_limits<double>::infinity();
  double high = -low;
  for (const Vector3d& p : v) {
    low = std::min(low, along(p, centroid, axis));
    high = std::max(high, along(p, centroid, axis));
  }
  const double length = high - low;
  // Refine the axis through the centroids of thin slices of the middle of the shaft.
  std::vector<Vector3d> centres;
  for (double f = 0.30; f <= 0.701; f += 0.05) {
    const double t = low + f * length;
    Vector3d sum = Vector3d::Zero();
    int count = 0;
    for (const Vector3d& p : v) {
      if (std::abs(along(p, centroid, axis) - t) < 0.012 * length) {
        sum += p;
        ++count;
      }
    }
    if (count >= 6)
      centres.push_back(sum / static_cast<double>(count));
  }
  if (centres.size() < 4)
    throw core::FileError(path, "does not look like a long bone (no shaft)");
  Vector3d mean = Vector3d::Zero();
  for (const Vector3d& c : centres)
    mean += c;
  mean /= static_cast<double>(centres.size());
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  for (const Vector3d& c : centres)
    spread += (c - mean) * (c - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> line(spread);
  Vector3d shaft = line.eigenvectors().col(2);
  if (shaft.dot(axis) < 0.0)
    shaft = -shaft;
  frame.axisPoint = mean;
  low = std::numeric_limits<double>::infinity();
  high = -low;
  for (const Vector3d& p : v) {
    low = std::min(low, along(p, mean, shaft));
    high = std::max(high, along(p, mean, shaft));
  }
  auto radial = [&](const Vector3d& p) {
    const Vector3d r = p - mean;
    return Vector3d(r - r.dot(shaft) * shaft);
  };
  // Proximal end = the end with the off-axis head: the vertex farthest from the shaft axis in
  // each end's last fifth.
  const double endLength = 0.2 * (high - low);
  std::size_t farLow = 0;
  std::size_t farHigh = 0;
  double farLowDistance = -1.0;
  double farHighDistance = -1.0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double t = along(v[i], mean, shaft);
    const double d = radial(v[i]).norm();
    if (t < low + endLength && d > farLowDistance) {
      farLowDistance = d;
      farLow = i;
    }
    if (t > high - endLength && d > farHighDistance) {
      farHighDistance = d;
      farHigh = i;
    }
  }
  const bool proximalHigh = farHighDistance >= farLowDistance;
  frame.proximal = proximalHigh ? shaft : Vector3d(-shaft);
  const Vector3d p = frame.proximal;
  const std::size_t seed = proximalHigh ? farHigh : farLow;
  const double proximalEnd = proximalHigh ? high : -low;  // along p, from `mean`
  const double distalEnd = proximalHigh ? low : -high;

  // Femoral head: iterative trimmed sphere fit starting one head radius inside the farthest point.
  const Vector3d out = radial(v[seed]).normalized();
  Vector3d centre = v[seed] - 22.0 * out;
  double radius = 22.0;
  for (double tolerance : {8.0, 5.0, 3.0, 2.0, 1.5, 1.5, 1.5}) {
    const Vector3d perpendicular = radial(centre).normalized();
    const Vector3d neck = (0.79 * perpendicular + 0.62 * p).normalized();  // ~52 deg to the shaft
    std::vector<Vector3d> shell;
    for (const Vector3d& q : v) {
      const double d = (q - centre).norm();
      if (std::abs(d - radius) < tolerance && (q - centre).dot(neck) > -0.3 * radius) {
        shell.push_back(q);
      }
    }
    if (!fitSphere(shell, centre, radius))
      break;
  }
  if (!(radius > 15.0 && radius < 35.0)) {
    throw core::FileError(
        path, "no femoral head found (the sphere fit gave a radius of " + mm(radius) + " mm)");
  }
  frame.hip = centre;
  frame.headRadius = radius;
  frame.medial = radial(centre).normalized();

  // Distal end: epicondyles (extremes across it) and the posterior condyles (centroid offset).
  Vector3d lateralMost = Vector3d::Zero();
  Vector3d medialMost = Vector3d::Zero();
  double lateralValue = std::numeric_limits<double>::infinity();
  double medialValue = -lateralValue;
  Vector3d distalSum = Vector3d::Zero();
  int distalCount = 0;
  const double span = proximalEnd - distalEnd;
  for (const Vector3d& q : v) {
    const double t = (q - mean).dot(p);
    if (t > distalEnd + 0.12 * span)
      continue;
    const double m = q.dot(frame.medial);
    if (m > medialValue) {
      medialValue = m;
      medialMost = q;
    }
    if (m < lateralValue) {
      lateralValue = m;
      lateralMost = q;
    }
    distalSum += radial(q);
    ++distalCount;
  }
  frame.medialEpicondyle = medialMost;
  frame.lateralEpicondyle = lateralMost;
  const Vector3d posteriorIfRight = p.cross(frame.medial);  // LPS: z x x = y (posterior)
  frame.posteriorOffsetMm =
      (distalSum / static_cast<double>(std::max(1, distalCount))).dot(posteriorIfRight);
  return frame;
}

Vector3d extreme(const std::vector<Vector3d>& points, const Vector3d& direction,
                 const std::function<bool(const Vector3d&)>& keep) {
  Vector3d best = Vector3d::Zero();
  double bestValue = -std::numeric_limits<double>::infinity();
  for (const Vector3d& q : points) {
    if (!keep(q))
      continue;
    const double value = q.dot(direction);
    if (value > bestValue) {
      bestValue = value;
      best = q;
    }
  }
  return best;
}

}  // namespace

void addFemurMeshLandmarks(const core::TriangleMesh& mesh, const FemurAxes& axes,
                           std::map<std::string, Vector3d>& landmarks) {
  const std::vector<Vector3d>& v = mesh.vertices;
  const Vector3d p = axes.proximal.normalized();
  const Vector3d medial = (axes.medial - axes.medial.dot(p) * p).normalized();
  const Vector3d posterior = p.cross(medial);  // LPS, right femur
  const double hipLevel = (axes.hip - axes.axisPoint).dot(p);
  auto level = [&](const Vector3d& q) { return (q - axes.axisPoint).dot(p); };
  auto fromAxis = [&](const Vector3d& q) {
    const Vector3d r = q - axes.axisPoint;
    return (r - r.dot(p) * p).norm();
  };
  landmarks["greater_trochanter"] =
      extreme(v, -medial, [&](const Vector3d& q) { return level(q) > hipLevel - 40.0; });
  landmarks["lesser_trochanter"] =
      extreme(v, (medial + posterior).normalized(), [&](const Vector3d& q) {
        return level(q) > hipLevel - 95.0 && level(q) < hipLevel - 50.0 && fromAxis(q) < 35.0;
      });
  landmarks["medial_condyle_distal"] = extreme(v, axes.down, [&](const Vector3d& q) {
    return (q - axes.epicondyleMiddle).dot(axes.medial) > 5.0;
  });
  landmarks["lateral_condyle_distal"] = extreme(v, axes.down, [&](const Vector3d& q) {
    return (q - axes.epicondyleMiddle).dot(axes.medial) < -5.0;
  });
}

PlacedFemur placeUserFemur(const std::string& path, const Vector3d& kneeCentreCt) {
  core::TriangleMesh mesh = filters::readMesh(path);
  core::MeshCheck check = core::checkMesh(mesh);
  if (!check.closed()) {
    throw core::FileError(
        path, "the femur mesh is " + check.describe() + "; a bone mesh must be a closed surface");
  }
  if (check.volumeMm3 < 0.0)
    core::flipWinding(mesh);
  FemurFrame frame = analyse(mesh, path);
  if (frame.posteriorOffsetMm < 0.0) {
    // A left femur: mirror it across its sagittal plane (through the shaft axis, normal medial)
    // and restore the outward winding.
    const Vector3d n = frame.medial;
    for (Vector3d& q : mesh.vertices)
      q -= 2.0 * (q - frame.axisPoint).dot(n) * n;
    core::flipWinding(mesh);
    frame = analyse(mesh, path);
    if (frame.posteriorOffsetMm < 0.0) {
      throw core::FileError(path, "could not tell the femur's posterior side after mirroring");
    }
  }
  const std::vector<Vector3d>& v = mesh.vertices;
  // Knee centre: below the epicondyles' middle, along the mechanical axis (hip to knee), at the
  // level of the distal condyles less kCondyleAboveKneeMm. The axis depends on the knee centre,
  // and the epicondyles (extremes square to that axis) on the axis; a few rounds settle them.
  Vector3d medialEpicondyle = frame.medialEpicondyle;
  Vector3d lateralEpicondyle = frame.lateralEpicondyle;
  Vector3d knee = 0.5 * (medialEpicondyle + lateralEpicondyle) - 25.0 * frame.proximal;
  const double distalEnd = [&] {
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vector3d& q : v)
      lowest = std::min(lowest, (q - frame.axisPoint).dot(frame.proximal));
    return lowest;
  }();
  for (int round = 0; round < 6; ++round) {
    const Vector3d up = (frame.hip - knee).normalized();
    const Vector3d medial = (frame.medial - frame.medial.dot(up) * up).normalized();
    auto distal = [&](const Vector3d& q) {
      return (q - frame.axisPoint).dot(frame.proximal) < distalEnd + 60.0;
    };
    medialEpicondyle = extreme(v, medial, distal);
    lateralEpicondyle = extreme(v, -medial, distal);
    const Vector3d middle = 0.5 * (medialEpicondyle + lateralEpicondyle);
    double deepest = -std::numeric_limits<double>::infinity();
    for (const Vector3d& q : v)
      deepest = std::max(deepest, (middle - q).dot(up));
    knee = middle - (deepest + kCondyleAboveKneeMm) * up;
  }
  const Vector3d up = (frame.hip - knee).normalized();

  Bone bone;
  bone.id = BoneId::Femur;
  bone.landmarks["hip_centre"] = frame.hip;
  bone.landmarks["knee_centre"] = knee;
  bone.landmarks["medial_epicondyle"] = medialEpicondyle;
  bone.landmarks["lateral_epicondyle"] = lateralEpicondyle;
  FemurAxes axes;
  axes.axisPoint = frame.axisPoint;
  axes.proximal = frame.proximal;
  axes.hip = frame.hip;
  axes.medial = (medialEpicondyle - lateralEpicondyle).normalized();
  axes.down = -up;
  axes.epicondyleMiddle = 0.5 * (medialEpicondyle + lateralEpicondyle);
  addFemurMeshLandmarks(mesh, axes, bone.landmarks);

  // Place: knee centre at kneeCentreCt, the hip straight above, the epicondylar axis along +x.
  const Vector3d z = (frame.hip - knee).normalized();
  const Vector3d epicondylar = medialEpicondyle - lateralEpicondyle;
  const Vector3d x = (epicondylar - epicondylar.dot(z) * z).normalized();
  Eigen::Matrix3d rows;
  rows.row(0) = x.transpose();
  rows.row(1) = z.cross(x).transpose();
  rows.row(2) = z.transpose();
  const Eigen::Isometry3d place =
      Eigen::Translation3d(kneeCentreCt) * Eigen::Isometry3d(rows) * Eigen::Translation3d(-knee);
  bone.mesh = core::transformed(mesh, place);
  for (auto& entry : bone.landmarks)
    entry.second = place * entry.second;
  bone.diaphysisCorticalMm = 5.5;
  setAxisProfile(bone, place * frame.axisPoint, place.linear() * frame.proximal);

  PlacedFemur placed;
  placed.bone = std::move(bone);
  placed.hipKneeLengthMm = (frame.hip - knee).norm();
  return placed;
}

}  // namespace echoreg::simulation::detail
