// Surface registration on a small asymmetric closed shape with known truth: exact recovery with
// every loss and with the speed-of-sound scale, the hybrid of ultrasound and stylus points (ball
// tip offset), the landmark penalty fixing what one face cannot, the search about two landmarks'
// line, determinism, and refusals of bad input. The real femur with 150 noisy trials is in
// tests/filters/test_surface_registration_femur.cpp.
#include "echoreg/core/random.hpp"
#include "echoreg/core/surface_registration.hpp"
#include "mesh_test_support.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

using test::thrownMessage;

// A lumpy egg (no symmetry): an icosphere mapped radially by a positive function, then stretched.
TriangleMesh lumpyShape() {
  TriangleMesh mesh = test::icosphere(1.0, 3);
  for (Eigen::Vector3d& v : mesh.vertices) {
    const double r =
        1.0 + 0.15 * v.x() * v.y() + 0.1 * v.z() * v.z() * v.z() + 0.08 * std::sin(3.0 * v.x());
    v = Eigen::Vector3d(30.0 * v.x(), 20.0 * v.y(), 45.0 * v.z()) * r;
  }
  return mesh;
}

const SurfaceRegistration& lumpy() {
  static const SurfaceRegistration model(lumpyShape());
  return model;
}

Eigen::Isometry3d truthPose() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  t.translation() = Eigen::Vector3d(-95.0, 20.0, -480.0);
  return t;
}

// The truth off by a rotation about `centre` (model frame) and a translation.
Eigen::Isometry3d perturbed(const Eigen::Isometry3d& truth, double degrees, double mm,
                            const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  Eigen::Isometry3d e = Eigen::Isometry3d::Identity();
  e.linear() = Eigen::AngleAxisd(degrees * kDeg, Eigen::Vector3d(0.3, 1, -0.4).normalized())
                   .toRotationMatrix();
  e.translation() = centre - e.linear() * centre + mm * Eigen::Vector3d(1, 1, -1).normalized();
  return e * truth;
}

// Beams from `standoff` mm outside, along the inward normal, at random points of the model's
// triangles (model frame), expressed in the bone frame of `truth`; depths read at speed
// c_assumed = c_true / speedScale.
std::vector<SurfacePoint> beams(const TriangleMesh& mesh, const Eigen::Isometry3d& truth, int count,
                                std::uint64_t seed, double speedScale = 1.0,
                                double standoff = 15.0) {
  Rng rng(seed);
  const Eigen::Isometry3d toBone = truth.inverse();
  std::vector<SurfacePoint> points;
  while (static_cast<int>(points.size()) < count) {
    const int t = static_cast<int>(rng.below(mesh.triangles.size()));
    const auto& tri = mesh.triangles[static_cast<std::size_t>(t)];
    double u = rng.uniform(), v = rng.uniform();
    if (u + v > 1.0) {
      u = 1.0 - u;
      v = 1.0 - v;
    }
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Eigen::Vector3d q = a + u * (mesh.vertices[static_cast<std::size_t>(tri[1])] - a) +
                              v * (mesh.vertices[static_cast<std::size_t>(tri[2])] - a);
    const Eigen::Vector3d n = triangleNormal(mesh, t);
    points.push_back(beamSurfacePoint(toBone * Eigen::Vector3d(q + standoff * n),
                                      toBone.linear() * -n, standoff / speedScale));
  }
  return points;
}

double errorAt(const Eigen::Isometry3d& truth, const Eigen::Isometry3d& estimate,
               const Eigen::Vector3d& model) {
  return (estimate * (truth.inverse() * model) - model).norm();
}

TEST(SurfaceRegistration, RecoversAKnownTransformExactlyWithEveryLoss) {
  const Eigen::Isometry3d truth = truthPose();
  const std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 80, 1);
  for (RobustLoss loss :
       {RobustLoss::Huber, RobustLoss::Cauchy, RobustLoss::Tukey, RobustLoss::Trim}) {
    SurfaceRegistrationOptions options;
    options.loss = loss;
    options.initial = perturbed(truth, 6.0, 5.0);
    options.toleranceMm = 1e-9;
    const SurfaceRegistrationResult r = lumpy().registerPoints(points, {}, options);
    ASSERT_TRUE(r.converged) << robustLossName(loss) << ": " << r.message;
    EXPECT_LT(errorAt(truth, r.transform, Eigen::Vector3d::Zero()), 1e-6) << robustLossName(loss);
    EXPECT_LT(r.rmsMm, 1e-6);
    EXPECT_EQ(r.speedOfSoundScale, 1.0);
    EXPECT_EQ(r.pointsUsed + r.pointsRejected, 80);
    // Trim leaves out its fraction (of points already on the surface) from the statistics.
    EXPECT_EQ(r.pointsRejected, loss == RobustLoss::Trim ? 8 : 0) << robustLossName(loss);
  }
}

TEST(SurfaceRegistration, PlainIcpConvergesWithoutNoise) {
  const Eigen::Isometry3d truth = truthPose();
  const std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 80, 2);
  SurfaceRegistrationOptions options;
  options.method = SurfaceMethod::Plain;
  options.initial = perturbed(truth, 4.0, 3.0);
  options.maxIterations = 500;
  options.plainRmsChangeMm = 1e-9;
  const SurfaceRegistrationResult r = lumpy().registerPoints(points, {}, options);
  ASSERT_TRUE(r.converged) << r.message;
  // Point-to-point ICP creeps (linear convergence); it still gets there.
  EXPECT_LT(errorAt(truth, r.transform, Eigen::Vector3d::Zero()), 0.05);
  EXPECT_EQ(r.pointsRejected, 0);
}

TEST(SurfaceRegistration, FitsTheSpeedOfSoundAlongEachBeam) {
  const Eigen::Isometry3d truth = truthPose();
  // Depths read at 1540 m/s through tissue whose speed is 4 % higher.
  const std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 80, 3, 1.04);
  SurfaceRegistrationOptions options;
  options.initial = perturbed(truth, 5.0, 4.0);
  options.toleranceMm = 1e-9;
  const SurfaceRegistrationResult fixedSpeed = lumpy().registerPoints(points, {}, options);
  options.fitSpeedOfSound = true;
  const SurfaceRegistrationResult fitted = lumpy().registerPoints(points, {}, options);
  ASSERT_TRUE(fitted.converged) << fitted.message;
  EXPECT_NEAR(fitted.speedOfSoundScale, 1.04, 1e-9);
  EXPECT_LT(errorAt(truth, fitted.transform, Eigen::Vector3d::Zero()), 1e-6);
  // Without the scale every point sits 0.58 mm inside the surface (15 mm / 1.04 vs 15 mm).
  EXPECT_GT(fixedSpeed.rmsAllMm, 0.3);
}

TEST(SurfaceRegistration, HybridStylusPointsCarryTheirBallTipRadius) {
  const Eigen::Isometry3d truth = truthPose();
  const TriangleMesh& mesh = lumpy().locator().mesh();
  std::vector<SurfacePoint> points = beams(mesh, truth, 40, 4);
  // Ten stylus points: the ball centre of a 1.5 mm tip touching the surface, sigma 0.2 mm.
  for (const SurfacePoint& beam : beams(mesh, truth, 10, 5, 1.0, 1.5)) {
    SurfacePoint stylus;
    stylus.point = beam.beamOrigin;
    stylus.source = PointSource::Stylus;
    stylus.sigmaMm = 0.2;
    stylus.surfaceOffsetMm = 1.5;
    points.push_back(stylus);
  }
  SurfaceRegistrationOptions options;
  options.initial = perturbed(truth, 5.0, 4.0);
  options.toleranceMm = 1e-9;
  const SurfaceRegistrationResult r = lumpy().registerPoints(points, {}, options);
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_LT(errorAt(truth, r.transform, Eigen::Vector3d::Zero()), 1e-6);
  EXPECT_EQ(r.pointsRejected, 0);
  for (double residual : r.residualsMm)
    EXPECT_NEAR(residual, 0.0, 1e-6);
}

TEST(SurfaceRegistration, LandmarksFixWhatOneFaceCannot) {
  // Points on the top face of a cube only: the face does not fix the slide within its plane.
  const SurfaceRegistration cube(test::cube(60.0));
  const Eigen::Isometry3d truth = truthPose();
  std::vector<SurfacePoint> points;
  Rng rng(6);
  for (int i = 0; i < 30; ++i) {
    const Eigen::Vector3d q(rng.uniform(5, 55), rng.uniform(5, 55), 60.0);
    points.push_back(
        beamSurfacePoint(truth.inverse() * Eigen::Vector3d(q + Eigen::Vector3d(0, 0, 20)),
                         truth.inverse().linear() * -Eigen::Vector3d::UnitZ(), 20.0));
  }
  std::vector<LandmarkPair> landmarks;
  for (const Eigen::Vector3d& m :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(60, 0, 30), Eigen::Vector3d(0, 60, 60)})
    landmarks.push_back({"l", truth.inverse() * m, m, 1.0});
  SurfaceRegistrationOptions options;
  options.initial = perturbed(truth, 3.0, 5.0, Eigen::Vector3d(30, 30, 30));
  options.toleranceMm = 1e-9;
  options.useLandmarks = false;
  const SurfaceRegistrationResult alone = cube.registerPoints(points, landmarks, options);
  options.useLandmarks = true;
  const SurfaceRegistrationResult withLandmarks = cube.registerPoints(points, landmarks, options);
  const Eigen::Vector3d centre(30, 30, 30);
  EXPECT_GT(errorAt(truth, alone.transform, centre), 1.0);
  ASSERT_TRUE(withLandmarks.converged) << withLandmarks.message;
  EXPECT_LT(errorAt(truth, withLandmarks.transform, centre), 1e-6);
  ASSERT_EQ(withLandmarks.landmarkResidualsMm.size(), 3u);
  EXPECT_LT(withLandmarks.landmarkResidualsMm[0], 1e-6);
}

TEST(SurfaceRegistration, SearchesTheRotationAboutTwoLandmarks) {
  const Eigen::Isometry3d truth = truthPose();
  const std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 60, 7);
  const Eigen::Vector3d m1(28, 5, -20), m2(-25, -3, 30);
  const LandmarkPair a{"a", truth.inverse() * m1, m1, 3.0};
  const LandmarkPair b{"b", truth.inverse() * m2, m2, 3.0};
  // The landmarks place the line; the rotation about it is 150 deg off the truth.
  double offBy = 0.0;
  for (double angle = 0.0; angle < 2 * kPi; angle += 0.01) {
    const Eigen::Isometry3d guess = poseFromTwoLandmarks(a, b, angle);
    if (errorAt(truth, guess, Eigen::Vector3d(0, 0, 0)) <
        errorAt(truth, poseFromTwoLandmarks(a, b, offBy), Eigen::Vector3d(0, 0, 0)))
      offBy = angle;
  }
  SurfaceRegistrationOptions options;
  options.initial = poseFromTwoLandmarks(a, b, offBy + 150 * kDeg);
  options.toleranceMm = 1e-9;
  const SurfaceRegistrationResult once = lumpy().registerPoints(points, {a, b}, options);
  options.searchAboutAxis = true;
  options.axisPoint = a.bone;
  options.axisDirection = b.bone - a.bone;
  options.axisStarts = 12;
  const SurfaceRegistrationResult searched = lumpy().registerPoints(points, {a, b}, options);
  EXPECT_EQ(searched.starts, 12);
  ASSERT_TRUE(searched.converged) << searched.message;
  EXPECT_LT(errorAt(truth, searched.transform, Eigen::Vector3d::Zero()), 1e-6);
  EXPECT_GT(errorAt(truth, once.transform, Eigen::Vector3d::Zero()), 1.0);
}

TEST(SurfaceRegistration, SameInputSameBytes) {
  const Eigen::Isometry3d truth = truthPose();
  std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 50, 8);
  Rng rng(9);
  for (SurfacePoint& p : points)
    p = beamSurfacePoint(p.beamOrigin, p.beamDirection, p.depthMm + rng.normal(0, 0.4));
  SurfaceRegistrationOptions options;
  options.initial = perturbed(truth, 5.0, 5.0);
  options.restarts = 3;
  options.seed = 42;
  options.fitSpeedOfSound = true;
  const SurfaceRegistrationResult first = lumpy().registerPoints(points, {}, options);
  const SurfaceRegistrationResult second = lumpy().registerPoints(points, {}, options);
  EXPECT_EQ(first.starts, 4);
  EXPECT_TRUE(first.transform.matrix() == second.transform.matrix());
  EXPECT_EQ(first.speedOfSoundScale, second.speedOfSoundScale);
  EXPECT_EQ(first.residualsMm, second.residualsMm);
}

TEST(SurfaceRegistration, PointsFarFromTheModelAreNotConverged) {
  const Eigen::Isometry3d truth = truthPose();
  const std::vector<SurfacePoint> points = beams(lumpy().locator().mesh(), truth, 40, 10);
  SurfaceRegistrationOptions options;
  // A start 90 deg and 150 mm off: whatever it settles on, the points do not lie on the surface.
  options.initial = perturbed(truth, 90.0, 150.0);
  options.maxIterations = 30;
  const SurfaceRegistrationResult r = lumpy().registerPoints(points, {}, options);
  if (errorAt(truth, r.transform, Eigen::Vector3d::Zero()) > 1.0) {
    EXPECT_FALSE(r.converged);
    EXPECT_FALSE(r.message.empty());
  }
  // Points of another shape altogether (a sphere of 80 mm): never a converged transform.
  std::vector<SurfacePoint> sphere;
  Rng rng(11);
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d u =
        Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    SurfacePoint p;
    p.point = 80.0 * u;
    sphere.push_back(p);
  }
  options.initial = Eigen::Isometry3d::Identity();
  const SurfaceRegistrationResult wrong = lumpy().registerPoints(sphere, {}, options);
  EXPECT_FALSE(wrong.converged);
  EXPECT_GT(wrong.rmsAllMm, 2.0);
}

TEST(SurfaceRegistration, RefusesBadModelsAndInput) {
  TriangleMesh open = test::icosphere(20.0, 2);
  open.triangles.pop_back();
  EXPECT_NE(thrownMessage([&] { SurfaceRegistration r(open); }).find("boundary"),
            std::string::npos);
  EXPECT_NE(thrownMessage([&] { SurfaceRegistration r(TriangleMesh{}); }).find("no triangles"),
            std::string::npos);
  TriangleMesh inward = test::icosphere(20.0, 2);
  flipWinding(inward);
  EXPECT_NE(thrownMessage([&] { SurfaceRegistration r(inward); }).find("inward"),
            std::string::npos);

  const std::vector<SurfacePoint> good = beams(lumpy().locator().mesh(), truthPose(), 10, 12);
  const SurfaceRegistrationOptions defaults;
  const auto refusal = [&](std::vector<SurfacePoint> points,
                           const SurfaceRegistrationOptions& options,
                           std::vector<LandmarkPair> landmarks = {}) {
    return thrownMessage([&] { lumpy().registerPoints(points, landmarks, options); });
  };
  EXPECT_NE(refusal({good[0], good[1]}, defaults).find("at least 3 points"), std::string::npos);
  EXPECT_NE(refusal({}, defaults).find("at least 3 points"), std::string::npos);
  std::vector<SurfacePoint> bad = good;
  bad[4].point.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(refusal(bad, defaults).find("point 4 is not finite"), std::string::npos);
  bad = good;
  bad[2].sigmaMm = 0.0;
  EXPECT_NE(refusal(bad, defaults).find("point 2: sigma"), std::string::npos);
  bad = good;
  bad[3].beamDirection *= 2.0;
  EXPECT_NE(refusal(bad, defaults).find("point 3: beam direction"), std::string::npos);
  bad = good;
  bad[5].depthMm = -1.0;
  EXPECT_NE(refusal(bad, defaults).find("negative depth"), std::string::npos);
  bad = good;
  for (SurfacePoint& p : bad)
    p.hasBeam = false;
  SurfaceRegistrationOptions speed;
  speed.fitSpeedOfSound = true;
  EXPECT_NE(refusal(bad, speed).find("speed of sound"), std::string::npos);
  SurfaceRegistrationOptions trim;
  trim.trimFraction = 0.6;
  EXPECT_NE(refusal(good, trim).find("trim"), std::string::npos);
  SurfaceRegistrationOptions restarts;
  restarts.restarts = -1;
  EXPECT_NE(refusal(good, restarts).find("restarts"), std::string::npos);
  EXPECT_NE(
      refusal(good, defaults, {{"lateral", Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0}})
          .find("landmark lateral: sigma"),
      std::string::npos);
  EXPECT_THROW(parseRobustLoss("l2"), std::invalid_argument);
  EXPECT_THROW(parseSurfaceMethod("icp"), std::invalid_argument);
  EXPECT_EQ(parseRobustLoss("tukey"), RobustLoss::Tukey);
}

TEST(SurfaceRegistration, TwoLandmarkPoseAndSpread) {
  const LandmarkPair a{"medial", Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(10, 10, 10), 3.0};
  const LandmarkPair b{"lateral", Eigen::Vector3d(80, 0, 0), Eigen::Vector3d(10, 90, 10), 3.0};
  for (double angle : {0.0, 1.0, 2.5}) {
    const Eigen::Isometry3d t = poseFromTwoLandmarks(a, b, angle);
    EXPECT_LT((t * a.bone - a.model).norm(), 1e-9);
    EXPECT_LT((t * b.bone - b.model).norm(), 1e-9);
  }
  // The angle turns about the model's line.
  const Eigen::Vector3d off(40, 10, 0);
  const Eigen::Vector3d p0 = poseFromTwoLandmarks(a, b, 0.0) * off;
  const Eigen::Vector3d p1 = poseFromTwoLandmarks(a, b, kPi / 2) * off;
  EXPECT_NEAR((p0 - Eigen::Vector3d(10, 50, 10)).norm(), 10.0, 1e-9);
  EXPECT_NEAR((p0 - p1).norm(), std::sqrt(2.0) * 10.0, 1e-9);

  const LandmarkPair same{"same", Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(10, 10, 10.5), 3.0};
  EXPECT_NE(thrownMessage([&] { poseFromTwoLandmarks(a, same); }).find("within 1 mm"),
            std::string::npos);
  const LandmarkPair far{"far", Eigen::Vector3d(150, 0, 0), Eigen::Vector3d(10, 90, 10), 3.0};
  EXPECT_NE(thrownMessage([&] { poseFromTwoLandmarks(a, far); }).find("swapped or wrong"),
            std::string::npos);

  const LandmarkPair mid{"mid", Eigen::Vector3d(40, 2, 0), Eigen::Vector3d(10, 50, 12), 3.0};
  const LandmarkSpread line = landmarkSpread({a, mid, b});
  EXPECT_TRUE(line.collinear);
  EXPECT_EQ(line.first, 0);
  EXPECT_EQ(line.second, 2);
  const LandmarkPair hip{"hip", Eigen::Vector3d(40, 0, 400), Eigen::Vector3d(10, 50, 410), 3.0};
  EXPECT_FALSE(landmarkSpread({a, b, hip}).collinear);
  EXPECT_THROW(landmarkSpread({a}), std::invalid_argument);
}

}  // namespace
}  // namespace echoreg::core

namespace echoreg::core {
namespace {

// A closed tube of lumpy, tapering cross-section from z0 to z1 with flat end caps: the long one
// is the bone, the short one the same bone as a scan of z0..z1 cut it.
TriangleMesh lumpyTube(double z0, double z1) {
  TriangleMesh mesh;
  const int segments = 72;
  const int rings = static_cast<int>(std::round((z1 - z0) / 2.0)) + 1;
  auto radius = [](double theta, double z) {
    return 22.0 + 4.0 * std::cos(theta) + 3.0 * std::sin(2.0 * theta) + 0.12 * z +
           4.0 * std::sin(0.15 * z + 2.0 * theta);
  };
  for (int k = 0; k < rings; ++k) {
    const double z = z0 + (z1 - z0) * k / (rings - 1);
    for (int s = 0; s < segments; ++s) {
      const double theta = 2.0 * kPi * s / segments;
      const double r = radius(theta, z);
      mesh.vertices.push_back({r * std::cos(theta), r * std::sin(theta), z});
    }
  }
  const int bottom = static_cast<int>(mesh.vertices.size());
  mesh.vertices.push_back({0, 0, z0});
  const int top = bottom + 1;
  mesh.vertices.push_back({0, 0, z1});
  auto at = [&](int k, int s) { return k * segments + (s % segments); };
  for (int k = 0; k + 1 < rings; ++k) {
    for (int s = 0; s < segments; ++s) {
      mesh.triangles.push_back({at(k, s), at(k, s + 1), at(k + 1, s + 1)});
      mesh.triangles.push_back({at(k, s), at(k + 1, s + 1), at(k + 1, s)});
    }
  }
  for (int s = 0; s < segments; ++s) {
    mesh.triangles.push_back({bottom, at(0, s + 1), at(0, s)});
    mesh.triangles.push_back({top, at(rings - 1, s), at(rings - 1, s + 1)});
  }
  if (checkMesh(mesh).volumeMm3 < 0.0)
    flipWinding(mesh);
  return mesh;
}

TEST(SurfaceRegistration, PointsBeyondAScanCutModelAreNotMatchedToItsCaps) {
  const TriangleMesh bone = lumpyTube(-70.0, 70.0);
  const TriangleMesh scanned = lumpyTube(-20.0, 20.0);
  const std::vector<bool> caps = scanEndCaps(scanned);
  // The two fans of the caps (72 triangles each) and their rims (2 x 144 side-wall triangles).
  EXPECT_EQ(std::count(caps.begin(), caps.end(), true), 144 + 288);
  const std::vector<bool> boneCaps = scanEndCaps(bone);
  EXPECT_EQ(std::count(boneCaps.begin(), boneCaps.end(), true), 144 + 288);

  // Beams on the bone's side wall over z -60..60: two thirds of them lie beyond the scan.
  const Eigen::Isometry3d truth = truthPose();
  std::vector<SurfacePoint> points;
  for (const SurfacePoint& p : beams(bone, truth, 400, 11)) {
    const double z = (truth * p.at(1.0)).z();
    if (std::abs(z) < 60.0)
      points.push_back(p);
  }
  SurfaceRegistrationOptions options;
  options.initial = perturbed(truth, 3.0, 3.0);
  const SurfaceRegistration model(scanned);
  const SurfaceRegistrationResult plain = model.registerPoints(points, {}, options);
  options.excludedTriangles = caps;
  const SurfaceRegistrationResult cut = model.registerPoints(points, {}, options);
  ASSERT_TRUE(cut.converged) << cut.message;
  EXPECT_LT(errorAt(truth, cut.transform, Eigen::Vector3d::Zero()), 1e-4);
  EXPECT_GT(cut.pointsBeyondModel, static_cast<int>(points.size()) / 2);
  EXPECT_EQ(cut.pointsUsed + cut.pointsBeyondModel, static_cast<int>(points.size()));
  // Without the caps excluded the points beyond the scan pull the model along its axis (or the
  // fit is refused): either way not the exact answer.
  EXPECT_TRUE(!plain.converged || errorAt(truth, plain.transform, Eigen::Vector3d::Zero()) > 0.01)
      << errorAt(truth, plain.transform, Eigen::Vector3d::Zero());
  options.excludedTriangles = {true, false};
  EXPECT_NE(thrownMessage([&] {
              model.registerPoints(points, {}, options);
            }).find("one flag per triangle"),
            std::string::npos);
}

}  // namespace
}  // namespace echoreg::core
