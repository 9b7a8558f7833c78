// MeshLocator against brute force over every triangle (mesh_test_support), the analytic sphere,
// and a cube whose vertices and edges rays are aimed at exactly.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "mesh_test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace echoreg::core {
namespace {

constexpr double kRadiusMm = 25.0;

Eigen::Vector3d randomDirection(Rng& rng) {
  Eigen::Vector3d d;
  do {
    d = {rng.normal(), rng.normal(), rng.normal()};
  } while (d.norm() < 1e-3);
  return d.normalized();
}

Eigen::Vector3d randomPoint(Rng& rng, double halfWidth) {
  return {rng.uniform(-halfWidth, halfWidth), rng.uniform(-halfWidth, halfWidth),
          rng.uniform(-halfWidth, halfWidth)};
}

// Largest distance between the icosphere's triangles and the sphere (its chord error).
double chordError(const TriangleMesh& mesh) {
  double nearest = kRadiusMm;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(mesh.triangles[i][0])];
    nearest = std::min(nearest, std::abs(triangleNormal(mesh, static_cast<int>(i)).dot(a)));
  }
  return kRadiusMm - nearest;
}

TEST(MeshLocator, SphereClosestPointEqualsBruteForce) {
  const TriangleMesh sphere = test::icosphere(kRadiusMm, 3);  // 1280 triangles
  ASSERT_TRUE(checkMesh(sphere).closed());
  ASSERT_GT(checkMesh(sphere).volumeMm3, 0.0);
  const MeshLocator locator(sphere);
  Rng rng = Rng::derive(7, "closest");
  for (int i = 0; i < 3000; ++i) {
    // Half anywhere in a box around the sphere, half within 1 mm of the surface.
    const Eigen::Vector3d p = i % 2 == 0 ? randomPoint(rng, 2.0 * kRadiusMm)
                                         : randomDirection(rng) * (kRadiusMm + rng.uniform(-1, 1));
    const ClosestPoint found = locator.closest(p);
    ASSERT_NEAR(found.distance, test::bruteClosestDistance(sphere, p), 1e-9) << i;
    ASSERT_GE(found.triangle, 0);
    EXPECT_NEAR((found.point - p).norm(), found.distance, 1e-12);
    // The barycentric weights are those of `point` in the reported triangle.
    const auto& tri = sphere.triangles[static_cast<std::size_t>(found.triangle)];
    Eigen::Vector3d rebuilt = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(found.barycentric[k], -1e-12);
      rebuilt += found.barycentric[k] *
                 sphere.vertices[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])];
    }
    EXPECT_NEAR(found.barycentric.sum(), 1.0, 1e-12);
    EXPECT_LT((rebuilt - found.point).norm(), 1e-9);
  }
}

TEST(MeshLocator, MaxDistancePrunesTheSearch) {
  const MeshLocator locator(test::icosphere(kRadiusMm, 2));
  const Eigen::Vector3d far(3.0 * kRadiusMm, 0.0, 0.0);
  const ClosestPoint none = locator.closest(far, 1.5 * kRadiusMm);
  EXPECT_EQ(none.triangle, -1);
  EXPECT_EQ(none.distance, 1.5 * kRadiusMm);
  const ClosestPoint found = locator.closest(far, 2.5 * kRadiusMm);
  EXPECT_GE(found.triangle, 0);
  EXPECT_NEAR(found.distance, 2.0 * kRadiusMm, 1e-12);  // (R, 0, 0) is a vertex
}

TEST(MeshLocator, SphereFirstAndAllHitsEqualBruteForce) {
  const TriangleMesh sphere = test::icosphere(kRadiusMm, 3);
  const MeshLocator locator(sphere);
  Rng rng = Rng::derive(7, "rays");
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d origin = randomPoint(rng, 2.0 * kRadiusMm);
    // Two rays in three aim at a point inside the sphere, so most of them hit.
    const Eigen::Vector3d direction =
        i % 3 == 0 ? randomDirection(rng)
                   : (randomPoint(rng, 0.5 * kRadiusMm) - origin).normalized();
    const auto expected = test::bruteFirstHit(sphere, origin, direction);
    const auto found = locator.firstHit(origin, direction);
    ASSERT_EQ(found.has_value(), expected.has_value()) << i;
    if (!found)
      continue;
    ++hits;
    ASSERT_NEAR(found->t, expected->t, 1e-9) << i;
    EXPECT_EQ(found->triangle, expected->triangle) << i;
    EXPECT_LT((found->point - (origin + expected->t * direction)).norm(), 1e-9);
    // Entering exactly when the origin is outside the sphere's mesh.
    EXPECT_EQ(found->entering, !locator.inside(origin)) << i;
    EXPECT_EQ(found->entering, direction.dot(found->normal) < 0.0);
    const auto all = locator.allHits(origin, direction);
    ASSERT_FALSE(all.empty());
    EXPECT_EQ(all.front().t, found->t);
    EXPECT_EQ(all.size(), locator.inside(origin) ? 1u : 2u) << i;
    for (std::size_t k = 1; k < all.size(); ++k)
      EXPECT_LT(all[k - 1].t, all[k].t);
    // tMax and tMin cut the interval (tMin, tMax].
    EXPECT_FALSE(locator.firstHit(origin, direction, found->t * (1 - 1e-9)).has_value());
    EXPECT_EQ(locator.allHits(origin, direction, 1e30, found->t).size(), all.size() - 1);
  }
  EXPECT_GT(hits, 1500);
}

TEST(MeshLocator, RaysThroughSphereVerticesAndEdgesCrossOnce) {
  const TriangleMesh sphere = test::icosphere(kRadiusMm, 3);
  const MeshLocator locator(sphere);
  // Through a vertex (5 or 6 triangles meet there) and out through its antipodal vertex.
  for (const Eigen::Vector3d& v : sphere.vertices) {
    const Eigen::Vector3d unit = v.normalized();
    const auto hits = locator.allHits(2.0 * v, -unit);
    ASSERT_EQ(hits.size(), 2u) << v.transpose();
    EXPECT_NEAR(hits[0].t, kRadiusMm, 1e-9);
    EXPECT_NEAR(hits[1].t, 3.0 * kRadiusMm, 1e-9);
    EXPECT_TRUE(hits[0].entering);
    EXPECT_FALSE(hits[1].entering);
    EXPECT_NEAR(locator.firstHit(2.0 * v, -unit)->t, kRadiusMm, 1e-9);
  }
  // Through the middle of every edge (two triangles share it).
  int edges = 0;
  for (const auto& tri : sphere.triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      const Eigen::Vector3d m = 0.5 * (sphere.vertices[static_cast<std::size_t>(tri[k])] +
                                       sphere.vertices[static_cast<std::size_t>(tri[(k + 1) % 3])]);
      const Eigen::Vector3d unit = m.normalized();
      const auto hits = locator.allHits(m + kRadiusMm * unit, -unit);
      ASSERT_EQ(hits.size(), 2u) << m.transpose();
      EXPECT_NEAR(hits[0].t, kRadiusMm, 1e-9);
      ++edges;
    }
  }
  EXPECT_EQ(edges, 3 * 1280);
}

TEST(MeshLocator, InsideAndSignedDistanceMatchTheAnalyticSphere) {
  const TriangleMesh sphere = test::icosphere(kRadiusMm, 4);  // 5120 triangles
  const double chord = chordError(sphere);
  ASSERT_GT(chord, 0.0);
  ASSERT_LT(chord, 0.1);
  const MeshLocator locator(sphere);
  Rng rng = Rng::derive(7, "inside");
  int checked = 0, inside = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d p = i % 2 == 0 ? randomPoint(rng, 1.5 * kRadiusMm)
                                         : randomDirection(rng) * (kRadiusMm + rng.uniform(-1, 1));
    const double analytic = p.norm() - kRadiusMm;
    EXPECT_NEAR(locator.signedDistance(p), analytic, chord + 1e-12) << i;
    // The mesh lies in the shell [R - chord, R]; outside it the answer is known.
    if (analytic < -chord || analytic > 0.0) {
      EXPECT_EQ(locator.inside(p), analytic < 0.0) << i;
      ++checked;
      inside += analytic < 0.0 ? 1 : 0;
    }
  }
  EXPECT_GT(checked, 2800);
  EXPECT_GT(inside, 800);
  // The centre and the vertices' neighbourhood (parity rays from there pass near edges).
  EXPECT_TRUE(locator.inside(Eigen::Vector3d::Zero()));
  for (const Eigen::Vector3d& v : sphere.vertices) {
    ASSERT_TRUE(locator.inside(0.999 * v)) << v.transpose();
    ASSERT_FALSE(locator.inside(1.001 * v)) << v.transpose();
  }
}

TEST(MeshLocator, CubeRaysThroughVerticesAndEdgesCountEachCrossingOnce) {
  constexpr double kSize = 10.0;
  const TriangleMesh box = test::cube(kSize);
  ASSERT_TRUE(checkMesh(box).closed());
  ASSERT_NEAR(checkMesh(box).volumeMm3, 1000.0, 1e-9);
  const MeshLocator locator(box);
  const Eigen::Vector3d centre = Eigen::Vector3d::Constant(kSize / 2);

  // Aimed at each vertex along the body diagonal: in at that vertex, out at the opposite one.
  for (const Eigen::Vector3d& v : box.vertices) {
    const Eigen::Vector3d direction = (centre - v).normalized();
    const Eigen::Vector3d origin = v - 20.0 * direction;
    const auto hits = locator.allHits(origin, direction);
    ASSERT_EQ(hits.size(), 2u) << v.transpose();
    EXPECT_NEAR(hits[0].t, 20.0, 1e-9);
    EXPECT_NEAR(hits[1].t, 20.0 + kSize * std::sqrt(3.0), 1e-9);
    EXPECT_TRUE(hits[0].entering);
    EXPECT_FALSE(hits[1].entering);
    // Aimed at the vertex from other directions that still enter the cube.
    for (const Eigen::Vector3d& offset :
         {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(3, 1, 2), Eigen::Vector3d(2, 3, 1)}) {
      const Eigen::Vector3d inward = (centre + 0.1 * offset - v).normalized();
      ASSERT_EQ(locator.allHits(v - 20.0 * inward, inward).size(), 2u) << v.transpose();
      EXPECT_NEAR(locator.firstHit(v - 20.0 * inward, inward)->t, 20.0, 1e-9);
    }
  }
  // Aimed at points along the 12 edges between faces, entering obliquely.
  int edgeRays = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int corner = 0; corner < 4; ++corner) {
      for (double along : {0.3, 5.0, 7.77}) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        p[axis] = along;
        p[(axis + 1) % 3] = (corner & 1) ? kSize : 0.0;
        p[(axis + 2) % 3] = (corner & 2) ? kSize : 0.0;
        Eigen::Vector3d target = centre;
        target[axis] = along + 0.5;
        const Eigen::Vector3d direction = (target - p).normalized();
        const auto hits = locator.allHits(p - 15.0 * direction, direction);
        ASSERT_EQ(hits.size(), 2u) << p.transpose();
        EXPECT_NEAR(hits[0].t, 15.0, 1e-9);
        ++edgeRays;
      }
    }
  }
  EXPECT_EQ(edgeRays, 36);
  // Square on to a face through the diagonal that its two triangles share.
  for (double s : {1.0, 2.5, 5.0, 9.0}) {
    const auto hits = locator.allHits({s, s, -5.0}, {0, 0, 1});
    ASSERT_EQ(hits.size(), 2u) << s;
    EXPECT_NEAR(hits[0].t, 5.0, 1e-12);
    EXPECT_NEAR(hits[1].t, 15.0, 1e-12);
  }
  // Touching a vertex or an edge from outside is no crossing.
  const Eigen::Vector3d graze = Eigen::Vector3d(1, -1, 0).normalized();
  EXPECT_TRUE(locator.allHits(Eigen::Vector3d(0, 0, 0) - 10.0 * graze, graze).empty());
  EXPECT_TRUE(locator.allHits(Eigen::Vector3d(0, 0, 5) - 10.0 * graze, graze).empty());
  EXPECT_FALSE(locator.firstHit(Eigen::Vector3d(0, 0, 5) - 10.0 * graze, graze).has_value());
  // Along an edge: the side faces are parallel to the ray; it enters and leaves at the corners.
  const auto alongEdge = locator.allHits({0, 0, -10}, {0, 0, 1});
  ASSERT_EQ(alongEdge.size(), 2u);
  EXPECT_NEAR(alongEdge[0].t, 10.0, 1e-12);
  EXPECT_TRUE(alongEdge[0].entering);
  EXPECT_NEAR(alongEdge[1].t, 20.0, 1e-12);

  // inside() against the analytic box, on points of the grid planes through edges and vertices.
  for (double x = -2.5; x <= 12.5; x += 1.25) {
    for (double y = -2.5; y <= 12.5; y += 1.25) {
      for (double z = -2.5; z <= 12.5; z += 1.25) {
        const bool onFace = x == 0 || x == kSize || y == 0 || y == kSize || z == 0 || z == kSize;
        if (onFace)
          continue;
        const bool expected = x > 0 && x < kSize && y > 0 && y < kSize && z > 0 && z < kSize;
        ASSERT_EQ(locator.inside({x, y, z}), expected) << x << " " << y << " " << z;
        const double d = locator.signedDistance({x, y, z});
        EXPECT_EQ(d < 0.0, expected);
      }
    }
  }
  EXPECT_NEAR(locator.signedDistance(centre), -5.0, 1e-12);
  EXPECT_NEAR(locator.signedDistance({13, 14, 5}), 5.0, 1e-12);  // to the edge x = y = 10
}

TEST(MeshLocator, SameMeshSameAnswersOnEveryThread) {
  const TriangleMesh sphere = test::icosphere(kRadiusMm, 3);
  const MeshLocator first(sphere), second(sphere);
  Rng rng = Rng::derive(7, "threads");
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 400; ++i)
    points.push_back(randomPoint(rng, 2.0 * kRadiusMm));
  auto run = [&](const MeshLocator& locator, std::vector<double>& out) {
    out.clear();
    for (const Eigen::Vector3d& p : points) {
      const ClosestPoint c = locator.closest(p);
      out.insert(out.end(), {c.point.x(), c.point.y(), c.point.z(), c.distance,
                             static_cast<double>(c.triangle), locator.signedDistance(p)});
      const auto hit = locator.firstHit(p, (-p).normalized());
      out.push_back(hit ? hit->t : -1.0);
    }
  };
  std::vector<double> serial, again, threadA, threadB;
  run(first, serial);
  run(second, again);
  std::thread a([&] { run(first, threadA); });
  std::thread b([&] { run(first, threadB); });
  a.join();
  b.join();
  ASSERT_EQ(serial.size(), again.size());
  EXPECT_EQ(std::memcmp(serial.data(), again.data(), serial.size() * sizeof(double)), 0);
  EXPECT_EQ(serial, threadA);
  EXPECT_EQ(serial, threadB);
}

TEST(MeshLocator, EmptyMeshFindsNothing) {
  const MeshLocator locator{TriangleMesh{}};
  EXPECT_FALSE(locator.firstHit({0, 0, 0}, {1, 0, 0}).has_value());
  EXPECT_TRUE(locator.allHits({0, 0, 0}, {1, 0, 0}).empty());
  EXPECT_EQ(locator.closest({0, 0, 0}, 5.0).triangle, -1);
  EXPECT_FALSE(locator.inside({0, 0, 0}));
}

TEST(MeshLocator, BadInputNamesTheValue) {
  TriangleMesh bad = test::cube(1.0);
  bad.triangles[3][1] = 8;
  try {
    MeshLocator locator(bad);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 3 has vertex index 8"), std::string::npos)
        << e.what();
  }
  TriangleMesh notFinite = test::cube(1.0);
  notFinite.vertices[2].x() = std::nan("");
  EXPECT_THROW(MeshLocator{notFinite}, std::invalid_argument);

  const MeshLocator locator(test::cube(1.0));
  try {
    (void)locator.firstHit({0, 0, -1}, {0, 0, 2});
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("(0, 0, 2) is not of unit length"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW((void)locator.allHits({0, 0, std::nan("")}, {0, 0, 1}), std::invalid_argument);
  EXPECT_THROW((void)locator.closest({0, 0, std::nan("")}), std::invalid_argument);
  EXPECT_THROW((void)locator.closest({0, 0, 0}, -1.0), std::invalid_argument);
  EXPECT_THROW((void)locator.inside({std::nan(""), 0, 0}), std::invalid_argument);
}

}  // namespace
}  // namespace echoreg::core
