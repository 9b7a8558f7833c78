#include "echoreg/simulation/sdf.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace echoreg::simulation {
namespace {

using Eigen::Vector3d;

TEST(Sdf, PrimitivesAreDistances) {
  const Vector3d a(0, 0, 0), b(0, 0, 10);
  EXPECT_NEAR(sdf::sphere(Vector3d(3, 4, 0), a, 2.0), 3.0, 1e-12);
  EXPECT_NEAR(sdf::capsule(Vector3d(5, 0, 5), a, b, 1.0), 4.0, 1e-12);
  EXPECT_NEAR(sdf::capsule(Vector3d(0, 0, 13), a, b, 1.0), 2.0, 1e-12);
  // A round cone with equal radii is a capsule.
  EXPECT_NEAR(sdf::roundCone(Vector3d(5, 1, 5), a, b, 2.0, 2.0),
              sdf::capsule(Vector3d(5, 1, 5), a, b, 2.0), 1e-9);
  // Beyond the ends it is the end spheres.
  EXPECT_NEAR(sdf::roundCone(Vector3d(0, 0, -5), a, b, 3.0, 1.0), 2.0, 1e-9);
  EXPECT_NEAR(sdf::roundCone(Vector3d(0, 0, 15), a, b, 3.0, 1.0), 4.0, 1e-9);
  // An ellipsoid is zero on its surface and signed.
  const Vector3d radii(10, 5, 3);
  EXPECT_NEAR(sdf::ellipsoid(Vector3d(10, 0, 0), a, radii), 0.0, 1e-12);
  EXPECT_NEAR(sdf::ellipsoid(Vector3d(0, 0, 4), a, radii), 1.0, 0.05);
  EXPECT_LT(sdf::ellipsoid(Vector3d(1, 1, 1), a, radii), 0.0);
  // Smooth union never exceeds the plain one and equals it far from the blend.
  EXPECT_LE(sdf::smoothUnion(1.0, 1.5, 2.0), 1.0);
  EXPECT_EQ(sdf::smoothUnion(1.0, 5.0, 2.0), 1.0);
}

TEST(Sdf, SphereMeshIsClosedAndOnTheSurface) {
  const sdf::Field field = [](const Vector3d& p) {
    return sdf::sphere(p, Vector3d(1, 2, 3), 20.0);
  };
  const Eigen::AlignedBox3d box(Vector3d(-25, -25, -25), Vector3d(27, 29, 31));
  const core::TriangleMesh mesh = sdf::meshField(field, box, 1.5, "sphere");
  const core::MeshCheck check = core::checkMesh(mesh);
  EXPECT_TRUE(check.closed()) << check.describe();
  // Newton-projected vertices are on the sphere; the flat triangles lose a little volume.
  for (const Vector3d& v : mesh.vertices)
    EXPECT_NEAR((v - Vector3d(1, 2, 3)).norm(), 20.0, 1e-6);
  const double exact = 4.0 / 3.0 * 3.14159265358979 * 8000.0;
  EXPECT_NEAR(check.volumeMm3, exact, 0.01 * exact);
  EXPECT_GT(check.volumeMm3, 0.0);
}

TEST(Sdf, FineGridsAreDecimatedAndStayClosed) {
  const sdf::Field field = [](const Vector3d& p) {
    return sdf::ellipsoid(p, Vector3d::Zero(), Vector3d(30, 20, 15));
  };
  const Eigen::AlignedBox3d box(Vector3d(-33, -23, -18), Vector3d(33, 23, 18));
  const core::TriangleMesh full = sdf::meshField(field, box, 0.4, "ellipsoid", 0);
  const core::TriangleMesh fewer = sdf::meshField(field, box, 0.4, "ellipsoid", 20000);
  EXPECT_GT(full.triangles.size(), 60000u);
  EXPECT_LE(fewer.triangles.size(), 21000u);
  const core::MeshCheck check = core::checkMesh(fewer);
  EXPECT_TRUE(check.closed()) << check.describe();
  double worst = 0.0;
  for (const Vector3d& v : fewer.vertices)
    worst = std::max(worst, std::abs(field(v)));
  EXPECT_LT(worst, 1e-3);
  const double exact = 4.0 / 3.0 * 3.14159265358979 * 30 * 20 * 15;
  EXPECT_NEAR(check.volumeMm3, exact, 0.01 * exact);
}

TEST(Sdf, RayExitAndBoxChecks) {
  const sdf::Field field = [](const Vector3d& p) { return sdf::sphere(p, Vector3d::Zero(), 10.0); };
  const Vector3d exit = sdf::rayExit(field, Vector3d(1, 0, 0), Vector3d(0, 1, 0));
  EXPECT_NEAR(exit.norm(), 10.0, 1e-6);
  EXPECT_NEAR(exit.x(), 1.0, 1e-12);
  EXPECT_THROW(sdf::rayExit(field, Vector3d(20, 0, 0), Vector3d(1, 0, 0)), std::invalid_argument);
  // A box that cuts the solid would give an open mesh: refused.
  const Eigen::AlignedBox3d small(Vector3d(-5, -5, -5), Vector3d(5, 5, 5));
  EXPECT_THROW(sdf::meshField(field, small, 1.0, "sphere"), std::invalid_argument);
  EXPECT_THROW(sdf::meshField(field, small, 0.0, "sphere"), std::invalid_argument);
  const Eigen::AlignedBox3d found = sdf::solidBounds(
      field, Eigen::AlignedBox3d(Vector3d(-50, -50, -50), Vector3d(50, 50, 50)), 2.0, 1.0);
  EXPECT_TRUE(found.contains(Eigen::AlignedBox3d(Vector3d(-10, -10, -10), Vector3d(10, 10, 10))));
  EXPECT_LT(found.sizes().maxCoeff(), 32.0);
}

}  // namespace
}  // namespace echoreg::simulation
