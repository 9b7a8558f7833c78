#include "echoreg/simulation/anatomy.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/filters/mesh_io.h"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::simulation {
namespace {

using Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

// ---- Independent geometry on the meshes (no use of the SDFs that built them) ----

/// Closest distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
double pointTriangleDistance(const Vector3d& p, const Vector3d& a, const Vector3d& b,
                             const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0)
    return (p - a).norm();
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3)
    return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0)
    return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6)
    return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0)
    return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  }
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

/// Point-to-surface distances through a uniform grid of triangle buckets; exact up to `rangeMm`,
/// larger distances read as +infinity.
class SurfaceDistance {
 public:
  SurfaceDistance(const core::TriangleMesh& mesh, double rangeMm) : mesh_(mesh), cell_(rangeMm) {
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      Eigen::AlignedBox3d box;
      for (int k : mesh.triangles[t])
        box.extend(mesh.vertices[static_cast<std::size_t>(k)]);
      const Eigen::Vector3i lo = key(box.min()), hi = key(box.max());
      for (int i = lo.x(); i <= hi.x(); ++i)
        for (int j = lo.y(); j <= hi.y(); ++j)
          for (int k = lo.z(); k <= hi.z(); ++k)
            buckets_[{i, j, k}].push_back(t);
    }
  }
  double operator()(const Vector3d& p) const {
    const Eigen::Vector3i c = key(p);
    double best = std::numeric_limits<double>::infinity();
    for (int i = c.x() - 1; i <= c.x() + 1; ++i)
      for (int j = c.y() - 1; j <= c.y() + 1; ++j)
        for (int k = c.z() - 1; k <= c.z() + 1; ++k) {
          const auto it = buckets_.find({i, j, k});
          if (it == buckets_.end())
            continue;
          for (std::size_t t : it->second) {
            const auto& tri = mesh_.triangles[t];
            best = std::min(
                best, pointTriangleDistance(p, mesh_.vertices[static_cast<std::size_t>(tri[0])],
                                            mesh_.vertices[static_cast<std::size_t>(tri[1])],
                                            mesh_.vertices[static_cast<std::size_t>(tri[2])]));
          }
        }
    return best <= cell_ ? best : std::numeric_limits<double>::infinity();
  }

 private:
  Eigen::Vector3i key(const Vector3d& p) const {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / cell_)),
                           static_cast<int>(std::floor(p.y() / cell_)),
                           static_cast<int>(std::floor(p.z() / cell_)));
  }
  const core::TriangleMesh& mesh_;
  double cell_;
  std::map<std::array<int, 3>, std::vector<std::size_t>> buckets_;
};

/// Smallest distance from the vertices of `a` (those passing `keep`) to the surface of `b`.
double minDistance(const core::TriangleMesh& a, const core::TriangleMesh& b,
                   const std::function<bool(const Vector3d&)>& keep, double rangeMm = 12.0) {
  const SurfaceDistance distance(b, rangeMm);
  double best = std::numeric_limits<double>::infinity();
  for (const Vector3d& v : a.vertices) {
    if (keep(v))
      best = std::min(best, distance(v));
  }
  return best;
}

/// Least-squares sphere through points: {centre, radius}.
std::pair<Vector3d, double> fitSphere(const std::vector<Vector3d>& points) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(points.size()), 4);
  Eigen::VectorXd b(static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    a.row(r) << 2 * points[i].x(), 2 * points[i].y(), 2 * points[i].z(), 1.0;
    b(r) = points[i].squaredNorm();
  }
  const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
  return {x.head<3>(), std::sqrt(x(3) + x.head<3>().squaredNorm())};
}

/// Axis-aligned bounds of the vertices passing `keep`.
Eigen::AlignedBox3d boundsWhere(const core::TriangleMesh& mesh,
                                const std::function<bool(const Vector3d&)>& keep) {
  Eigen::AlignedBox3d box;
  for (const Vector3d& v : mesh.vertices) {
    if (keep(v))
      box.extend(v);
  }
  return box;
}

double angleDeg(const Vector3d& a, const Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / kPi;
}

KneeOptions meanShape(double resolutionMm) {
  KneeOptions options;
  options.seed = 0;
  options.meshResolutionMm = resolutionMm;
  return options;
}

/// The mean-shape knee at 1 mm, built once for the suite (and timed).
const Knee& meanKnee() {
  static const std::unique_ptr<Knee> knee = [] {
    const auto start = std::chrono::steady_clock::now();
    auto built = std::make_unique<Knee>(buildKnee(meanShape(1.0)));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "[ timing   ] buildKnee(seed 0, 1 mm): " << seconds << " s\n";
    return built;
  }();
  return *knee;
}

// ---- Tests ----

TEST(Anatomy, BoneNames) {
  EXPECT_EQ(boneName(BoneId::Femur), "femur");
  EXPECT_EQ(boneName(BoneId::Tibia), "tibia");
  EXPECT_EQ(boneName(BoneId::Fibula), "fibula");
  EXPECT_EQ(boneName(BoneId::Patella), "patella");
}

TEST(Anatomy, BonesAreClosedWithPlausibleVolumes) {
  const Knee& knee = meanKnee();
  ASSERT_EQ(knee.bones.size(), 4u);
  const BoneId order[] = {BoneId::Femur, BoneId::Tibia, BoneId::Fibula, BoneId::Patella};
  // Adult male volumes (cm3): femur 400-600, tibia 250-400, fibula 35-80, patella 15-30.
  const double low[] = {400, 250, 35, 15};
  const double high[] = {600, 400, 80, 30};
  for (std::size_t i = 0; i < 4; ++i) {
    const Bone& bone = knee.bones[i];
    EXPECT_EQ(bone.id, order[i]);
    const core::MeshCheck check = core::checkMesh(bone.mesh);
    EXPECT_TRUE(check.closed()) << boneName(bone.id) << ": " << check.describe();
    EXPECT_EQ(check.degenerateTriangles, 0u) << boneName(bone.id);
    const double cm3 = check.volumeMm3 / 1000.0;
    std::cout << "[ measure  ] " << boneName(bone.id) << ": " << check.triangles << " triangles, "
              << cm3 << " cm3\n";
    EXPECT_GT(cm3, low[i]) << boneName(bone.id);
    EXPECT_LT(cm3, high[i]) << boneName(bone.id);
    if (bone.id != BoneId::Patella) {
      EXPECT_GT(check.triangles, 20000u);
      EXPECT_LT(check.triangles, 250000u);
    }
  }
}

TEST(Anatomy, SurfaceLandmarksLieOnTheSurface) {
  const Knee& knee = meanKnee();
  const std::map<BoneId, std::vector<std::string>> surface = {
      {BoneId::Femur,
       {"greater_trochanter", "lesser_trochanter", "medial_epicondyle", "lateral_epicondyle",
        "medial_condyle_distal", "lateral_condyle_distal"}},
      {BoneId::Tibia, {"tibial_tubercle", "medial_malleolus"}},
      {BoneId::Fibula, {"fibular_head", "lateral_malleolus"}}};
  for (const auto& [id, names] : surface) {
    const Bone& bone = knee.bone(id);
    const SurfaceDistance distance(bone.mesh, 5.0);
    for (const std::string& name : names) {
      ASSERT_EQ(bone.landmarks.count(name), 1u) << name;
      EXPECT_LT(distance(bone.landmarks.at(name)), 1.0) << boneName(id) << " " << name;
    }
  }
  // Interior landmarks are where the knee says they are.
  EXPECT_LT((knee.bone(BoneId::Femur).landmarks.at("hip_centre") - knee.hipCentre).norm(), 1e-9);
  EXPECT_LT((knee.bone(BoneId::Femur).landmarks.at("knee_centre") - knee.kneeCentre).norm(), 1e-9);
  EXPECT_LT((knee.bone(BoneId::Tibia).landmarks.at("ankle_centre") - knee.ankleCentre).norm(),
            1e-9);
  EXPECT_EQ(knee.bone(BoneId::Patella).landmarks.count("patella_centre"), 1u);
  EXPECT_EQ(knee.bone(BoneId::Tibia).landmarks.count("plateau_centre"), 1u);
}

TEST(Anatomy, HipCentreIsTheCentreOfTheHead) {
  const Knee& knee = meanKnee();
  const Vector3d hip = knee.hipCentre;
  // The medial and superior parts of the head, away from the neck (which leaves laterally and
  // distally): every vertex there is on the sphere.
  std::vector<Vector3d> head;
  for (const Vector3d& v : knee.bone(BoneId::Femur).mesh.vertices) {
    if ((v - hip).norm() < 35.0 && (v.x() > hip.x() || v.z() > hip.z()))
      head.push_back(v);
  }
  ASSERT_GT(head.size(), 500u);
  for (const Vector3d& v : head)
    EXPECT_NEAR((v - hip).norm(), 23.0, 2.0);
  const auto [centre, radius] = fitSphere(head);
  std::cout << "[ measure  ] femoral head fit: radius " << radius << " mm, centre off by "
            << (centre - hip).norm() << " mm\n";
  EXPECT_LT((centre - hip).norm(), 0.5);
  EXPECT_NEAR(radius, 23.0, 0.5);
}

TEST(Anatomy, FemurSizesAndAxes) {
  const Knee& knee = meanKnee();
  const Bone& femur = knee.bone(BoneId::Femur);
  const Vector3d k = knee.kneeCentre;
  EXPECT_LT((k - Vector3d(-95, 20, -480)).norm(), 1e-12);
  const double length = (knee.hipCentre - k).norm();
  EXPECT_GE(length, 430.0);
  EXPECT_LE(length, 450.0);
  // Mechanical axis of the straight leg along CT z: hip above knee above ankle.
  EXPECT_LT(angleDeg(knee.hipCentre - knee.ankleCentre, Vector3d::UnitZ()), 0.5);
  EXPECT_LT(angleDeg(knee.hipCentre - k, Vector3d::UnitZ()), 0.5);
  // Shaft in ~6 degrees valgus to the mechanical axis (coronal projection), its top lateral (-x)
  // of the hip-knee line.
  const Vector3d shaft = femur.axisProximal - femur.axisDistal;
  const Vector3d coronal(1.0, 0.0, 1.0);
  const double valgus =
      angleDeg(shaft.cwiseProduct(coronal), (knee.hipCentre - k).cwiseProduct(coronal));
  std::cout << "[ measure  ] femoral anatomical-mechanical angle " << valgus << " deg\n";
  EXPECT_NEAR(valgus, 6.0, 0.5);
  EXPECT_LT(shaft.x(), 0.0);
  // Anteversion: the head lies in front of the shaft, ~12 degrees from the epicondylar axis in the
  // plane square to the shaft.
  const Vector3d s = shaft.normalized();
  const Vector3d r =
      (knee.hipCentre - femur.axisDistal) - (knee.hipCentre - femur.axisDistal).dot(s) * s;
  const Vector3d x = (Vector3d::UnitX() - s.x() * s).normalized();
  const Vector3d anterior = x.cross(s);  // -y for s ~ z
  const double anteversion = std::atan2(r.dot(anterior), r.dot(x)) * 180.0 / kPi;
  std::cout << "[ measure  ] femoral anteversion " << anteversion << " deg, offset " << r.norm()
            << " mm\n";
  EXPECT_NEAR(anteversion, 12.0, 1.0);
  EXPECT_GT(r.norm(), 38.0);
  EXPECT_LT(r.norm(), 50.0);
  // Mid-shaft diameter (slab square to z; the 6 degree tilt stretches it by 0.5 %).
  const double zMid = k.z() + 0.5 * length;
  const auto mid =
      boundsWhere(femur.mesh, [&](const Vector3d& v) { return std::abs(v.z() - zMid) < 0.5; });
  std::cout << "[ measure  ] femoral mid-shaft " << mid.sizes().x() << " x " << mid.sizes().y()
            << " mm\n";
  EXPECT_GE(mid.sizes().x(), 27.0);
  EXPECT_LE(mid.sizes().x(), 30.5);
  // Bicondylar width and prominent epicondyles (proud of the condyles' sides).
  const auto distal =
      boundsWhere(femur.mesh, [&](const Vector3d& v) { return v.z() < k.z() + 60; });
  std::cout << "[ measure  ] bicondylar width " << distal.sizes().x() << " mm, AP "
            << distal.sizes().y() << " mm\n";
  EXPECT_NEAR(distal.sizes().x(), 85.0, 2.5);
  const Vector3d medialEpi = femur.landmarks.at("medial_epicondyle");
  const Vector3d lateralEpi = femur.landmarks.at("lateral_epicondyle");
  EXPECT_NEAR(medialEpi.x(), distal.max().x(), 0.5);
  EXPECT_NEAR(lateralEpi.x(), distal.min().x(), 0.5);
  auto sideAwayFrom = [&](const Vector3d& epicondyle) {
    return boundsWhere(femur.mesh, [&](const Vector3d& v) {
      return v.z() < k.z() + 40 && std::hypot(v.y() - epicondyle.y(), v.z() - epicondyle.z()) > 15;
    });
  };
  const double medialProud = medialEpi.x() - sideAwayFrom(medialEpi).max().x();
  const double lateralProud = sideAwayFrom(lateralEpi).min().x() - lateralEpi.x();
  std::cout << "[ measure  ] epicondyles proud of the condyles: medial " << medialProud
            << " mm, lateral " << lateralProud << " mm\n";
  EXPECT_GT(medialProud, 2.0);
  EXPECT_GT(lateralProud, 2.0);
  EXPECT_LT(medialProud, 12.0);
  EXPECT_LT(lateralProud, 12.0);
  // Trochlear groove: across the front at 30 mm above the joint, the most anterior surface dips
  // back between the two facets.
  std::map<int, double> front;  // 2 mm bins of x -> most anterior y
  for (const Vector3d& v : femur.mesh.vertices) {
    if (std::abs(v.z() - (k.z() + 30.0)) > 1.0)
      continue;
    const int bin = static_cast<int>(std::floor((v.x() - k.x()) / 2.0));
    auto it = front.find(bin);
    if (it == front.end() || v.y() < it->second)
      front[bin] = v.y();
  }
  double groove = -1e9, lateralFacet = 1e9, medialFacet = 1e9;
  for (const auto& [bin, y] : front) {
    const double xMm = 2.0 * bin + 1.0;
    if (std::abs(xMm) < 6.0)
      groove = std::max(groove, y);
    if (xMm < -8.0 && xMm > -25.0)
      lateralFacet = std::min(lateralFacet, y);
    if (xMm > 8.0 && xMm < 25.0)
      medialFacet = std::min(medialFacet, y);
  }
  std::cout << "[ measure  ] trochlear groove depth: " << groove - lateralFacet
            << " mm below the lateral facet, " << groove - medialFacet << " below the medial\n";
  EXPECT_GT(groove - lateralFacet, 3.0);
  EXPECT_GT(groove - medialFacet, 1.5);
  EXPECT_LT(groove - lateralFacet, 10.0);
}

TEST(Anatomy, TibiaSizes) {
  const Knee& knee = meanKnee();
  const Bone& tibia = knee.bone(BoneId::Tibia);
  const Vector3d plateau = tibia.landmarks.at("plateau_centre");
  const auto top =
      boundsWhere(tibia.mesh, [&](const Vector3d& v) { return v.z() > plateau.z() - 12; });
  std::cout << "[ measure  ] tibial plateau " << top.sizes().x() << " x " << top.sizes().y()
            << " mm\n";
  EXPECT_NEAR(top.sizes().x(), 78.0, 3.0);
  EXPECT_NEAR(top.sizes().y(), 50.0, 3.0);
  const auto all = boundsWhere(tibia.mesh, [](const Vector3d&) { return true; });
  std::cout << "[ measure  ] tibial length " << all.sizes().z() << " mm\n";
  EXPECT_GE(all.sizes().z(), 370.0);
  EXPECT_LE(all.sizes().z(), 380.0);
  // Medial malleolus reaches 10-15 mm below the plafond (the ankle centre).
  EXPECT_GE(knee.ankleCentre.z() - all.min().z(), 10.0);
  EXPECT_LE(knee.ankleCentre.z() - all.min().z(), 15.0);
  const Vector3d medialMalleolus = tibia.landmarks.at("medial_malleolus");
  EXPECT_NEAR(
      medialMalleolus.x(),
      boundsWhere(tibia.mesh, [&](const Vector3d& v) { return v.z() < knee.ankleCentre.z() + 30; })
          .max()
          .x(),
      0.5);
  // Tubercle 25-30 mm below the plateau, proud of the front of the condyles above it.
  const Vector3d tubercle = tibia.landmarks.at("tibial_tubercle");
  EXPECT_GE(plateau.z() - tubercle.z(), 25.0);
  EXPECT_LE(plateau.z() - tubercle.z(), 30.0);
  const auto rim = boundsWhere(tibia.mesh, [&](const Vector3d& v) {
    return v.z() > plateau.z() - 12 && v.z() < plateau.z() - 8 &&
           std::abs(v.x() - tubercle.x()) < 8;
  });
  EXPECT_LT(tubercle.y(), rim.min().y() - 1.5);
  // Triangular shaft with an anterior crest: narrow at the front, wide at the back.
  const double zMid = knee.ankleCentre.z() + 0.55 * (plateau.z() - knee.ankleCentre.z());
  auto slab = [&](const Vector3d& v) { return std::abs(v.z() - zMid) < 0.5; };
  const auto section = boundsWhere(tibia.mesh, slab);
  const auto crest = boundsWhere(
      tibia.mesh, [&](const Vector3d& v) { return slab(v) && v.y() < section.min().y() + 4.0; });
  const auto back = boundsWhere(
      tibia.mesh, [&](const Vector3d& v) { return slab(v) && v.y() > section.max().y() - 8.0; });
  std::cout << "[ measure  ] tibial mid-shaft " << section.sizes().x() << " x "
            << section.sizes().y() << " mm; width 4 mm behind the crest " << crest.sizes().x()
            << " mm, near the back " << back.sizes().x() << " mm\n";
  EXPECT_LT(crest.sizes().x(), 11.0);
  EXPECT_GT(back.sizes().x(), 18.0);
}

TEST(Anatomy, FibulaAndPatellaSizes) {
  const Knee& knee = meanKnee();
  const Bone& fibula = knee.bone(BoneId::Fibula);
  const Bone& tibia = knee.bone(BoneId::Tibia);
  const Vector3d plateau = tibia.landmarks.at("plateau_centre");
  const auto all = boundsWhere(fibula.mesh, [](const Vector3d&) { return true; });
  EXPECT_GE(plateau.z() - all.max().z(), 10.0);
  EXPECT_LE(plateau.z() - all.max().z(), 15.0);
  const Vector3d head = fibula.landmarks.at("fibular_head");
  EXPECT_LT(head.x(), plateau.x() - 20.0);  // lateral
  EXPECT_GT(head.y(), plateau.y());         // posterior
  const double zMid = 0.5 * (all.min().z() + all.max().z());
  const auto mid =
      boundsWhere(fibula.mesh, [&](const Vector3d& v) { return std::abs(v.z() - zMid) < 0.5; });
  std::cout << "[ measure  ] fibular mid-shaft " << mid.sizes().x() << " x " << mid.sizes().y()
            << " mm\n";
  EXPECT_GE(mid.sizes().x(), 12.0);
  EXPECT_LE(mid.sizes().x(), 15.0);
  EXPECT_GE(mid.sizes().y(), 12.0);
  EXPECT_LE(mid.sizes().y(), 15.0);
  const double tibiaTip = boundsWhere(tibia.mesh, [](const Vector3d&) { return true; }).min().z();
  std::cout << "[ measure  ] lateral malleolus " << tibiaTip - all.min().z()
            << " mm below the medial\n";
  EXPECT_NEAR(tibiaTip - all.min().z(), 10.0, 3.0);
  EXPECT_LT(fibula.landmarks.at("lateral_malleolus").x(), knee.ankleCentre.x() - 20.0);

  const Bone& patella = knee.bone(BoneId::Patella);
  const auto p = boundsWhere(patella.mesh, [](const Vector3d&) { return true; });
  EXPECT_NEAR(p.sizes().x(), 45.0, 1.5);
  EXPECT_NEAR(p.sizes().z(), 45.0, 1.5);
  EXPECT_NEAR(p.sizes().y(), 22.0, 1.5);
  const Bone& femur = knee.bone(BoneId::Femur);
  const double gap = minDistance(patella.mesh, femur.mesh, [](const Vector3d&) { return true; });
  std::cout << "[ measure  ] patellofemoral gap " << gap << " mm\n";
  EXPECT_GE(gap, 3.0);
  EXPECT_LE(gap, 6.0);
  const auto front = boundsWhere(
      femur.mesh, [&](const Vector3d& v) { return std::abs(v.z() - p.center().z()) < 5.0; });
  EXPECT_LT(p.max().y(), front.min().y());  // wholly in front of the femur at its level
}

TEST(Anatomy, JointSpaceBetweenFemurAndTibia) {
  const Knee& knee = meanKnee();
  const Bone& femur = knee.bone(BoneId::Femur);
  const Bone& tibia = knee.bone(BoneId::Tibia);
  const double z = knee.kneeCentre.z();
  const double femurToTibia =
      minDistance(femur.mesh, tibia.mesh, [&](const Vector3d& v) { return v.z() < z + 40; });
  const double tibiaToFemur =
      minDistance(tibia.mesh, femur.mesh, [&](const Vector3d& v) { return v.z() > z - 40; });
  const SurfaceDistance toTibia(tibia.mesh, 12.0);
  const double medial = toTibia(femur.landmarks.at("medial_condyle_distal"));
  const double lateral = toTibia(femur.landmarks.at("lateral_condyle_distal"));
  std::cout << "[ measure  ] femur-tibia closest " << femurToTibia << " / " << tibiaToFemur
            << " mm; under the condyles medial " << medial << ", lateral " << lateral << " mm\n";
  // Closest distances both ways above 3 mm: the surfaces do not meet or cross.
  EXPECT_GE(femurToTibia, 3.0);
  EXPECT_GE(tibiaToFemur, 3.0);
  EXPECT_LE(femurToTibia, 6.0);
  EXPECT_GE(medial, 3.0);
  EXPECT_LE(medial, 6.0);
  EXPECT_GE(lateral, 3.0);
  EXPECT_LE(lateral, 6.0);
}

// An arthritic knee: the joint narrowed to 1 mm and closed (0 mm), the patella on the trochlea.
TEST(Anatomy, NarrowedJointAndPatellaOnTheFemur) {
  for (double gap : {1.0, 0.0}) {
    KneeOptions options = meanShape(2.0);
    options.tibiofemoralGapMm = gap;
    options.patellofemoralGapMm = 0.0;
    const Knee knee = buildKnee(options);
    const Bone& femur = knee.bone(BoneId::Femur);
    const double z = knee.kneeCentre.z();
    const double tibiaToFemur = minDistance(knee.bone(BoneId::Tibia).mesh, femur.mesh,
                                            [&](const Vector3d& v) { return v.z() > z - 25; });
    const double patellaToFemur = minDistance(knee.bone(BoneId::Patella).mesh, femur.mesh,
                                              [](const Vector3d&) { return true; });
    std::cout << "[ measure  ] joint " << gap << " mm asked: tibia-femur " << tibiaToFemur
              << " mm, patella-femur " << patellaToFemur << " mm\n";
    EXPECT_NEAR(tibiaToFemur, gap, 0.02);
    EXPECT_LT(patellaToFemur, 0.3);  // placed by its ellipsoid against the femur's vertices
    // The fibula moved with the tibia: still at its joints, not inside the tibia.
    EXPECT_GT(minDistance(knee.bone(BoneId::Fibula).mesh, knee.bone(BoneId::Tibia).mesh,
                          [](const Vector3d&) { return true; }),
              0.3);
  }
  KneeOptions bad = meanShape(2.0);
  bad.patellofemoralGapMm = -1.0;
  EXPECT_THROW(buildKnee(bad), std::invalid_argument);
  bad = meanShape(2.0);
  bad.tibiofemoralGapMm = 12.0;
  EXPECT_THROW(buildKnee(bad), std::invalid_argument);
}

// Marginal osteophytes: at each margin of the tibiofemoral joint the tibia rises to within the
// clearance of the femur (without them the margin's wedge opens from the contact outward), the
// bones stay apart (no tibia vertex inside the femur), the spurs are bone added only near the joint
// (the tibia and the femur far from it unchanged), and the option is checked.
TEST(Anatomy, OsteophytesBridgeTheJointMargins) {
  KneeOptions options = meanShape(1.0);
  options.tibiofemoralGapMm = 1.0;
  const Knee plain = buildKnee(options);
  options.osteophyteMm = 4.0;
  const Knee arthritic = buildKnee(options);
  const double z = plain.kneeCentre.z();
  for (double side : {1.0, -1.0}) {
    auto margin = [&](const Vector3d& v) {
      return side * (v.x() - plain.kneeCentre.x()) > 25.0 && v.z() > z - 15.0;
    };
    const double before =
        minDistance(plain.bone(BoneId::Tibia).mesh, plain.bone(BoneId::Femur).mesh, margin);
    const double after =
        minDistance(arthritic.bone(BoneId::Tibia).mesh, arthritic.bone(BoneId::Femur).mesh, margin);
    std::cout << "[ measure  ] " << (side > 0 ? "medial" : "lateral") << " margin: tibia-femur "
              << before << " mm without osteophytes, " << after << " mm with\n";
    EXPECT_GT(before, after + 1.0);  // the wedge beside the contact, 1.6 mm at a 1 mm joint
    EXPECT_NEAR(after, kOsteophyteClearanceMm, 0.3);
  }
  const core::MeshLocator femurSurface(arthritic.bone(BoneId::Femur).mesh);
  for (const Vector3d& v : arthritic.bone(BoneId::Tibia).mesh.vertices) {
    if (v.z() > z - 20.0) {
      ASSERT_FALSE(femurSurface.inside(v)) << "tibia inside the femur at " << v.transpose();
    }
  }
  // Far from the joint the bones are the same (the meshes of the same fields).
  const auto top = [](const core::TriangleMesh& m) { return core::bounds(m)[1].z(); };
  EXPECT_NEAR(top(arthritic.bone(BoneId::Femur).mesh), top(plain.bone(BoneId::Femur).mesh), 0.05);
  EXPECT_NEAR(core::bounds(arthritic.bone(BoneId::Tibia).mesh)[0].z(),
              core::bounds(plain.bone(BoneId::Tibia).mesh)[0].z(), 0.05);
  // Bone added: the tibia's and the femur's volumes grow by the spurs (a few hundred mm^3).
  for (BoneId id : {BoneId::Femur, BoneId::Tibia}) {
    const double added = core::checkMesh(arthritic.bone(id).mesh).volumeMm3 -
                         core::checkMesh(plain.bone(id).mesh).volumeMm3;
    std::cout << "[ measure  ] " << boneName(id) << ": osteophytes add " << added << " mm^3\n";
    EXPECT_GT(added, 100.0) << boneName(id);
    EXPECT_LT(added, 3000.0) << boneName(id);
    EXPECT_TRUE(core::checkMesh(arthritic.bone(id).mesh).closed()) << boneName(id);
  }
  KneeOptions bad = meanShape(2.0);
  bad.osteophyteMm = 9.0;
  EXPECT_THROW(buildKnee(bad), std::invalid_argument);
  bad.osteophyteMm = -1.0;
  EXPECT_THROW(buildKnee(bad), std::invalid_argument);
}

TEST(Anatomy, FibulaTouchesTheTibiaOnlyAtTheTibiofibularJoints) {
  const Knee& knee = meanKnee();
  const Bone& fibula = knee.bone(BoneId::Fibula);
  const Bone& tibia = knee.bone(BoneId::Tibia);
  const double top = knee.kneeCentre.z() - 60.0;
  const double bottom = knee.ankleCentre.z() + 40.0;
  const double proximal =
      minDistance(fibula.mesh, tibia.mesh, [&](const Vector3d& v) { return v.z() > top; });
  const double distal =
      minDistance(fibula.mesh, tibia.mesh, [&](const Vector3d& v) { return v.z() < bottom; });
  const double shaft = minDistance(fibula.mesh, tibia.mesh, [&](const Vector3d& v) {
    return v.z() < top - 20 && v.z() > bottom + 20;
  });
  std::cout << "[ measure  ] fibula-tibia: proximal joint " << proximal << " mm, distal joint "
            << distal << " mm, shafts " << shaft << " mm\n";
  EXPECT_GT(proximal, 0.2);
  EXPECT_LT(proximal, 2.0);
  EXPECT_GT(distal, 0.2);
  EXPECT_LT(distal, 2.0);
  EXPECT_GT(shaft, 4.0);
}

TEST(Anatomy, FlexionRotatesTheLegAboutTheEpicondylarAxis) {
  const Knee straight = buildKnee(meanShape(2.0));
  KneeOptions options = meanShape(2.0);
  options.flexionDeg = 30.0;
  const Knee flexed = buildKnee(options);
  const Bone& femur = straight.bone(BoneId::Femur);
  const Vector3d medialEpi = femur.landmarks.at("medial_epicondyle");
  const Vector3d lateralEpi = femur.landmarks.at("lateral_epicondyle");
  EXPECT_EQ(femur.mesh.vertices, flexed.bone(BoneId::Femur).mesh.vertices);
  for (BoneId id : {BoneId::Tibia, BoneId::Fibula, BoneId::Patella}) {
    const Bone& a = straight.bone(id);
    const Bone& b = flexed.bone(id);
    ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
    ASSERT_EQ(a.mesh.triangles, b.mesh.triangles);
    // Rigid about the line through the epicondyles: distances to both stay the same...
    double worst = 0.0;
    for (std::size_t i = 0; i < a.mesh.vertices.size(); ++i) {
      worst = std::max(worst, std::abs((a.mesh.vertices[i] - medialEpi).norm() -
                                       (b.mesh.vertices[i] - medialEpi).norm()));
      worst = std::max(worst, std::abs((a.mesh.vertices[i] - lateralEpi).norm() -
                                       (b.mesh.vertices[i] - lateralEpi).norm()));
    }
    EXPECT_LT(worst, 1e-6) << boneName(id);
  }
  // ... and the tibia turns by the asked angle, about the epicondylar direction, posteriorly.
  const Vector3d a0 =
      straight.bone(BoneId::Tibia).axisProximal - straight.bone(BoneId::Tibia).axisDistal;
  const Vector3d a1 =
      flexed.bone(BoneId::Tibia).axisProximal - flexed.bone(BoneId::Tibia).axisDistal;
  EXPECT_NEAR(angleDeg(a0, a1), 30.0, 1e-6);
  EXPECT_GT(a0.cross(a1).normalized().dot((medialEpi - lateralEpi).normalized()), 1.0 - 1e-9);
  EXPECT_GT(flexed.ankleCentre.y(), straight.ankleCentre.y() + 100.0);
  EXPECT_NEAR(angleDeg(flexed.anteriorCt, -Vector3d::UnitY()), 15.0, 1e-6);
  // The joint stays open through the range.
  for (double degrees : {10.0, 45.0, 60.0, 90.0}) {
    options.flexionDeg = degrees;
    const Knee knee = buildKnee(options);
    const double gap = minDistance(knee.bone(BoneId::Tibia).mesh, knee.bone(BoneId::Femur).mesh,
                                   [](const Vector3d&) { return true; });
    const double patella = minDistance(
        knee.bone(BoneId::Patella).mesh, knee.bone(BoneId::Femur).mesh,
        [](const Vector3d&) { return true; }, 30.0);
    std::cout << "[ measure  ] flexion " << degrees << " deg: femur-tibia closest " << gap
              << " mm, patella-femur " << patella << " mm\n";
    EXPECT_GT(gap, 1.5) << degrees;
    EXPECT_GT(patella, 1.0) << degrees;
  }
}

TEST(Anatomy, SameOptionsGiveIdenticalMeshes) {
  KneeOptions options;
  options.seed = 7;
  options.meshResolutionMm = 2.0;
  options.flexionDeg = 20.0;
  const Knee a = buildKnee(options);
  const Knee b = buildKnee(options);
  for (std::size_t i = 0; i < a.bones.size(); ++i) {
    EXPECT_EQ(a.bones[i].mesh.vertices, b.bones[i].mesh.vertices);
    EXPECT_EQ(a.bones[i].mesh.triangles, b.bones[i].mesh.triangles);
    EXPECT_EQ(a.bones[i].landmarks, b.bones[i].landmarks);
  }
}

TEST(Anatomy, AnotherSeedIsAnotherSpecimenWithinTheRanges) {
  const Knee mean = buildKnee(meanShape(2.0));
  const double meanLength = (mean.hipCentre - mean.kneeCentre).norm();
  std::vector<double> lengths;
  for (std::uint64_t seed : {1, 2, 3}) {
    KneeOptions options;
    options.seed = seed;
    options.meshResolutionMm = 2.0;
    const Knee knee = buildKnee(options);
    const double length = (knee.hipCentre - knee.kneeCentre).norm();
    lengths.push_back(length);
    EXPECT_GT(std::abs(length - meanLength), 0.1) << seed;
    EXPECT_NEAR(length, meanLength, 0.04 * meanLength + 1e-9) << seed;
    EXPECT_NE(knee.bone(BoneId::Tibia).mesh.vertices, mean.bone(BoneId::Tibia).mesh.vertices);
    for (const Bone& bone : knee.bones) {
      EXPECT_TRUE(core::checkMesh(bone.mesh).closed()) << seed << " " << boneName(bone.id);
    }
    const double joint = minDistance(knee.bone(BoneId::Femur).mesh, knee.bone(BoneId::Tibia).mesh,
                                     [](const Vector3d&) { return true; });
    const double fibula = minDistance(knee.bone(BoneId::Fibula).mesh, knee.bone(BoneId::Tibia).mesh,
                                      [](const Vector3d&) { return true; });
    std::cout << "[ measure  ] seed " << seed << ": hip-knee " << length << " mm, joint space "
              << joint << " mm, fibula-tibia " << fibula << " mm\n";
    EXPECT_GE(joint, 3.0);
    EXPECT_LE(joint, 6.0);
    EXPECT_LT(fibula, 2.0);
    EXPECT_GT(fibula, 0.1);
  }
  EXPECT_NE(lengths[0], lengths[1]);
}

TEST(Anatomy, LeftFemurMeshIsMirroredAndPlaced) {
  // The procedural femur, turned into a left femur somewhere else, must come back in place.
  const Knee mean = buildKnee(meanShape(2.0));
  const Bone& reference = mean.bone(BoneId::Femur);
  core::TriangleMesh left = reference.mesh;
  for (Vector3d& v : left.vertices)
    v.x() = -v.x();
  core::flipWinding(left);
  const Eigen::Isometry3d elsewhere = Eigen::Translation3d(40, -300, 900) *
                                      Eigen::AngleAxisd(0.7, Vector3d(0.3, -0.5, 0.8).normalized());
  left = core::transformed(left, elsewhere);
  test::TempDir dir;
  const std::string path = dir.file("left_femur.stl");
  filters::writeMesh(path, left);

  KneeOptions options = meanShape(2.0);
  options.meshFiles[BoneId::Femur] = path;
  const Knee knee = buildKnee(options);
  const Bone& femur = knee.bone(BoneId::Femur);
  const core::MeshCheck check = core::checkMesh(femur.mesh);
  EXPECT_TRUE(check.closed()) << check.describe();
  EXPECT_NEAR(check.volumeMm3, core::checkMesh(reference.mesh).volumeMm3, 1.0);
  for (const char* name : {"hip_centre", "knee_centre", "medial_epicondyle", "lateral_epicondyle",
                           "greater_trochanter", "lesser_trochanter", "medial_condyle_distal",
                           "lateral_condyle_distal"}) {
    const Vector3d off = femur.landmarks.at(name) - reference.landmarks.at(name);
    std::cout << "[ measure  ] mirrored femur " << name << " off by " << off.norm() << " mm\n";
    if (std::string(name).find("condyle_distal") != std::string::npos) {
      // The lowest point of a flat condyle slides along it: its height is what is defined.
      EXPECT_LT(std::abs(off.z()), 0.5) << name;
      EXPECT_LT(off.norm(), 4.0) << name;
    } else {
      EXPECT_LT(off.norm(), 2.0) << name;
    }
  }
  EXPECT_LT((knee.hipCentre - mean.hipCentre).norm(), 1.0);
  // Same surface: the placed vertices lie on the reference mesh.
  const SurfaceDistance distance(reference.mesh, 5.0);
  double worst = 0.0;
  for (std::size_t i = 0; i < femur.mesh.vertices.size(); i += 7) {
    worst = std::max(worst, distance(femur.mesh.vertices[i]));
  }
  std::cout << "[ measure  ] mirrored femur surface off by at most " << worst << " mm\n";
  EXPECT_LT(worst, 1.5);
}

TEST(Anatomy, RealFemurIsPlacedAtTheHip) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  KneeOptions options = meanShape(2.0);
  options.meshFiles[BoneId::Femur] = path;
  const Knee knee = buildKnee(options);
  const Bone& femur = knee.bone(BoneId::Femur);
  const core::MeshCheck check = core::checkMesh(femur.mesh);
  EXPECT_TRUE(check.closed()) << check.describe();
  EXPECT_NEAR(check.volumeMm3, std::abs(core::checkMesh(filters::readMesh(path)).volumeMm3),
              1e-6 * check.volumeMm3);
  // An independent sphere fit to the placed head.
  std::vector<Vector3d> head;
  for (const Vector3d& v : femur.mesh.vertices) {
    if ((v - knee.hipCentre).norm() < 30.0 &&
        (v.x() > knee.hipCentre.x() || v.z() > knee.hipCentre.z())) {
      head.push_back(v);
    }
  }
  ASSERT_GT(head.size(), 50u);
  const auto [centre, radius] = fitSphere(head);
  std::cout << "[ measure  ] real femur: hip-knee " << (knee.hipCentre - knee.kneeCentre).norm()
            << " mm, head radius " << radius << " mm, head centre "
            << (centre - knee.hipCentre).norm() << " mm from the knee's hip centre\n";
  EXPECT_LT((centre - knee.hipCentre).norm(), 2.0);
  EXPECT_GT(radius, 18.0);
  EXPECT_LT(radius, 30.0);
  // A right femur: head medial (+x) of the shaft, condyles behind it (+y).
  const double zMid = 0.5 * (knee.hipCentre.z() + knee.kneeCentre.z());
  const auto mid =
      boundsWhere(femur.mesh, [&](const Vector3d& v) { return std::abs(v.z() - zMid) < 2.0; });
  EXPECT_GT(knee.hipCentre.x(), mid.center().x() + 20.0);
  const auto condyles = boundsWhere(
      femur.mesh, [&](const Vector3d& v) { return v.z() < knee.kneeCentre.z() + 25.0; });
  EXPECT_GT(condyles.max().y(), mid.max().y() + 10.0);
  EXPECT_GT(femur.landmarks.at("medial_epicondyle").x(),
            femur.landmarks.at("lateral_epicondyle").x() + 60.0);
  const double joint =
      minDistance(femur.mesh, knee.bone(BoneId::Tibia).mesh, [](const Vector3d&) { return true; });
  std::cout << "[ measure  ] real femur to procedural tibia: " << joint << " mm\n";
  EXPECT_GT(joint, 1.0);
  const double patella = minDistance(knee.bone(BoneId::Patella).mesh, femur.mesh,
                                     [](const Vector3d&) { return true; });
  EXPECT_GT(patella, 2.0);
}

TEST(Anatomy, MeshWithAHoleIsRefusedNamingTheFile) {
  const Knee knee = buildKnee(meanShape(3.0));
  core::TriangleMesh holed = knee.bone(BoneId::Femur).mesh;
  holed.triangles.erase(holed.triangles.begin() + 100, holed.triangles.begin() + 103);
  test::TempDir dir;
  const std::string path = dir.file("holed_femur.stl");
  filters::writeMesh(path, holed);
  KneeOptions options = meanShape(3.0);
  options.meshFiles[BoneId::Femur] = path;
  try {
    buildKnee(options);
    FAIL() << "a femur with a hole was accepted";
  } catch (const core::FileError& error) {
    EXPECT_EQ(error.path(), path);
    EXPECT_NE(std::string(error.what()).find("boundary edges"), std::string::npos) << error.what();
  }
}

TEST(Anatomy, BadOptionsAreRefused) {
  auto message = [](const KneeOptions& options) {
    try {
      buildKnee(options);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  KneeOptions options;
  options.meshResolutionMm = 0.0;
  EXPECT_NE(message(options).find("meshResolutionMm"), std::string::npos);
  options = KneeOptions{};
  options.flexionDeg = std::nan("");
  EXPECT_NE(message(options).find("flexionDeg"), std::string::npos);
  options = KneeOptions{};
  options.flexionDeg = 95.0;
  EXPECT_NE(message(options).find("flexionDeg"), std::string::npos);
  options = KneeOptions{};
  options.meshFiles[BoneId::Tibia] = "tibia.stl";
  EXPECT_NE(message(options).find("tibia"), std::string::npos);
  options = KneeOptions{};
  options.meshFiles[BoneId::Femur] = "/nonexistent/femur.stl";
  EXPECT_THROW(buildKnee(options), core::FileError);
  // Not a femur: a sphere has no long axis.
  test::TempDir dir;
  const std::string path = dir.file("ball.stl");
  filters::writeMesh(path, buildKnee(meanShape(3.0)).bone(BoneId::Patella).mesh);
  options.meshFiles[BoneId::Femur] = path;
  try {
    buildKnee(options);
    FAIL() << "a patella was accepted as a femur";
  } catch (const core::FileError& error) {
    EXPECT_EQ(error.path(), path);
  }
}

TEST(Anatomy, CorticalShellAndMedullaryCanal) {
  const Knee& knee = meanKnee();
  const std::map<BoneId, double> diaphysis = {
      {BoneId::Femur, 5.5}, {BoneId::Tibia, 4.5}, {BoneId::Fibula, 2.0}};
  for (const auto& [id, thickness] : diaphysis) {
    const Bone& bone = knee.bone(id);
    const Vector3d middle = 0.5 * (bone.axisProximal + bone.axisDistal);
    const Vector3d end = bone.axisDistal + 0.02 * (bone.axisProximal - bone.axisDistal);
    EXPECT_NEAR(bone.corticalThicknessMm(middle), thickness, 1e-9) << boneName(id);
    EXPECT_NEAR(bone.corticalThicknessMm(end), 1.0, 1e-9) << boneName(id);
    EXPECT_EQ(bone.medullaryRadiusMm(end), 0.0) << boneName(id);
    EXPECT_NEAR(bone.distanceFromAxisMm(middle), 0.0, 1e-9);
    // Along the diaphysis the canal plus the cortex fit inside the outer surface.
    double canal = 0.0;
    double worstMargin = std::numeric_limits<double>::infinity();
    for (const Vector3d& v : bone.mesh.vertices) {
      const double u = bone.axialFraction(v);
      if (u < 0.25 || u > 0.75)
        continue;
      canal = std::max(canal, bone.medullaryRadiusMm(v));
      worstMargin = std::min(worstMargin, bone.distanceFromAxisMm(v) - bone.medullaryRadiusMm(v) -
                                              bone.corticalThicknessMm(v));
    }
    std::cout << "[ measure  ] " << boneName(id) << ": canal radius up to " << canal
              << " mm, cortex " << thickness << " mm, margin " << worstMargin << " mm\n";
    EXPECT_GT(canal, id == BoneId::Fibula ? 1.0 : 3.0) << boneName(id);
    EXPECT_GE(worstMargin, 0.4) << boneName(id);
  }
  const Bone& patella = knee.bone(BoneId::Patella);
  EXPECT_EQ(patella.medullaryRadiusMm(patella.landmarks.at("patella_centre")), 0.0);
  EXPECT_EQ(patella.corticalThicknessMm(patella.landmarks.at("patella_centre")), 1.0);
}

}  // namespace
}  // namespace echoreg::simulation
