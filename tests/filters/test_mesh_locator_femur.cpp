// MeshLocator on the real femur (../shared/data/meshes/femur.stl, 20k triangles) against brute
// force over every triangle and against the generalised winding number.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/filters/mesh_io.h"
#include "mesh_test_support.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

namespace echoreg::core {
namespace {

struct Femur {
  TriangleMesh mesh;
  Eigen::Vector3d low, high;
};

Femur loadFemur(const std::string& path) {
  Femur femur;
  femur.mesh = filters::readMesh(path);
  const auto box = bounds(femur.mesh);
  femur.low = box[0];
  femur.high = box[1];
  return femur;
}

// Uniform in the mesh's bounds grown by `marginMm` on every side.
Eigen::Vector3d randomPoint(Rng& rng, const Femur& femur, double marginMm) {
  Eigen::Vector3d p;
  for (int k = 0; k < 3; ++k)
    p[k] = rng.uniform(femur.low[k] - marginMm, femur.high[k] + marginMm);
  return p;
}

TEST(MeshLocatorFemur, ClosestPointEqualsBruteForce) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  const Femur femur = loadFemur(path);
  ASSERT_GT(femur.mesh.triangles.size(), 10000u);
  const MeshLocator locator(femur.mesh);
  Rng rng = Rng::derive(11, "femur-closest");
  for (int i = 0; i < 2000; ++i) {
    // Half in the grown bounds, half within 2 mm of a random vertex (near the surface).
    const Eigen::Vector3d p =
        i % 2 == 0
            ? randomPoint(rng, femur, 20.0)
            : femur.mesh.vertices[rng.below(femur.mesh.vertices.size())] +
                  Eigen::Vector3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
    const ClosestPoint found = locator.closest(p);
    ASSERT_NEAR(found.distance, test::bruteClosestDistance(femur.mesh, p), 1e-9) << i;
    EXPECT_NEAR((found.point - p).norm(), found.distance, 1e-9);
  }
}

TEST(MeshLocatorFemur, FirstHitEqualsBruteForce) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  const Femur femur = loadFemur(path);
  const MeshLocator locator(femur.mesh);
  Rng rng = Rng::derive(11, "femur-rays");
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    // From around the bone toward a random surface vertex's neighbourhood, like a beam.
    const Eigen::Vector3d origin = randomPoint(rng, femur, 30.0);
    const Eigen::Vector3d target =
        femur.mesh.vertices[rng.below(femur.mesh.vertices.size())] +
        Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const Eigen::Vector3d direction = (target - origin).normalized();
    const auto expected = test::bruteFirstHit(femur.mesh, origin, direction);
    const auto found = locator.firstHit(origin, direction);
    ASSERT_EQ(found.has_value(), expected.has_value()) << i;
    if (!found)
      continue;
    ++hits;
    ASSERT_NEAR(found->t, expected->t, 1e-9) << i;
    EXPECT_EQ(found->triangle, expected->triangle) << i;
    // The crossings alternate in and out, starting from the side the origin is on.
    const auto all = locator.allHits(origin, direction);
    ASSERT_EQ(all.front().t, found->t);
    EXPECT_EQ(all.size() % 2, locator.inside(origin) ? 1u : 0u) << i;
    bool in = locator.inside(origin);
    for (const RayHit& hit : all) {
      EXPECT_EQ(hit.entering, !in) << i << " t " << hit.t;
      in = hit.entering;
    }
  }
  EXPECT_GT(hits, 1500);
}

TEST(MeshLocatorFemur, InsideAgreesWithTheWindingNumber) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  const Femur femur = loadFemur(path);
  const MeshCheck check = checkMesh(femur.mesh);
  ASSERT_TRUE(check.closed()) << check.describe();
  const MeshLocator locator(femur.mesh);
  Rng rng = Rng::derive(11, "femur-inside");
  int inside = 0;
  for (int i = 0; i < 600; ++i) {
    // Points within 3 mm of the surface half of the time, so both answers are common.
    const Eigen::Vector3d p =
        i % 2 == 0
            ? randomPoint(rng, femur, 5.0)
            : femur.mesh.vertices[rng.below(femur.mesh.vertices.size())] +
                  Eigen::Vector3d(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    const double winding = test::windingNumber(femur.mesh, p);
    ASSERT_TRUE(std::abs(winding) < 1e-6 || std::abs(winding - 1.0) < 1e-6) << winding;
    const bool expected = winding > 0.5;
    ASSERT_EQ(locator.inside(p), expected) << i;
    EXPECT_EQ(locator.signedDistance(p) < 0.0, expected) << i;
    inside += expected ? 1 : 0;
  }
  EXPECT_GT(inside, 100);
}

}  // namespace
}  // namespace echoreg::core
