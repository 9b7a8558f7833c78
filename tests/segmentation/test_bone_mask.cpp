// Bone masks, surfaces, contours and the accessible surface on small analytic volumes (spheres and
// cylinders whose true surfaces are known exactly).
#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/segmentation/accessible_surface.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/nrrd_volume.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>

namespace {

using namespace echoreg;
using core::CtImage;

// A uniform CT of `n` voxels of `spacing` mm whose HU at a point is `hu(p)` averaged over 3^3
// sub-samples (partial volume), origin at (-n/2 * spacing) so the grid is centred on 0.
CtImage analyticCt(const Eigen::Vector3i& n, const Eigen::Vector3d& spacing,
                   const std::function<double(const Eigen::Vector3d&)>& hu) {
  CtImage ct;
  ct.dimensions = {n.x(), n.y(), n.z()};
  ct.pixelSpacingMm = spacing.head<2>();
  ct.originMm = -0.5 * (n.cast<double>() - Eigen::Vector3d::Ones()).cwiseProduct(spacing);
  for (int k = 0; k < n.z(); ++k)
    ct.slicePositionsMm.push_back(k * spacing.z());
  ct.groups = {{0, n.z(), spacing.z()}};
  ct.hu.resize(ct.voxelCount());
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d c = ct.voxelToLps(Eigen::Vector3d(i, j, k));
        double sum = 0.0;
        for (int a = -1; a <= 1; ++a) {
          for (int b = -1; b <= 1; ++b) {
            for (int d = -1; d <= 1; ++d)
              sum += hu(c + Eigen::Vector3d(a, b, d).cwiseProduct(spacing) / 3.0);
          }
        }
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>(std::lround(sum / 27.0));
      }
    }
  }
  return ct;
}

// A hollow "bone": cortex 1500 HU between radius r-3 and r, marrow -60 HU inside, soft tissue 40.
double hollowSphere(const Eigen::Vector3d& p, const Eigen::Vector3d& centre, double r) {
  const double d = (p - centre).norm();
  if (d > r)
    return 40.0;
  return d > r - 3.0 ? 1500.0 : -60.0;
}

TEST(BoneMask, GrowFillsTheMarrowAndRefusesBadSeeds) {
  const CtImage ct = analyticCt({48, 48, 40}, {0.8, 0.8, 1.0}, [](const Eigen::Vector3d& p) {
    return hollowSphere(p, Eigen::Vector3d::Zero(), 12.0);
  });
  // A seed in the marrow: the nearest bone in its slice encloses it.
  const auto grown = segmentation::growBone(ct, Eigen::Vector3d(0, 0, 0.3));
  const double sphere = 4.0 / 3.0 * M_PI * 12.0 * 12.0 * 12.0;
  // The mask holds every voxel above the weak threshold: the partial-volume layer too.
  EXPECT_GT(grown.volumeMm3, sphere);
  EXPECT_LT(grown.volumeMm3, 1.12 * sphere);
  EXPECT_TRUE(grown.mask.at(24, 24, 20));  // the centre (marrow) is filled
  EXPECT_EQ(grown.seedHu, -60);
  // Outside the volume, in soft tissue, too small.
  try {
    segmentation::growBone(ct, Eigen::Vector3d(0, 0, 100));
    FAIL() << "a seed outside the volume was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("outside the CT volume"), std::string::npos) << e.what();
  }
  try {
    segmentation::growBone(ct, Eigen::Vector3d(17, 17, 0));
    FAIL() << "a seed in soft tissue was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("is not in bone"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("40 HU"), std::string::npos) << e.what();
  }
  segmentation::GrowOptions big;
  big.minVolumeMm3 = 2.0 * sphere;
  EXPECT_THROW(segmentation::growBone(ct, Eigen::Vector3d(0, 0, 0), big), std::invalid_argument);
  CtImage twoGroups = ct;
  twoGroups.groups = {{0, 20, 1.0}, {20, 20, 1.0}};
  EXPECT_THROW(segmentation::growBone(twoGroups, Eigen::Vector3d(0, 0, 0)), std::invalid_argument);
}

TEST(BoneMask, GrowthDoesNotCrossAThinBridgeBetweenBones) {
  // Two solid spheres 2 mm apart, joined by a 1 mm rod of bone density (a joint's partial volume).
  const Eigen::Vector3d a(-11, 0, 0), b(11, 0, 0);
  const CtImage ct = analyticCt({64, 32, 32}, {0.8, 0.8, 0.8}, [&](const Eigen::Vector3d& p) {
    if ((p - a).norm() < 10.0 || (p - b).norm() < 10.0)
      return 1200.0;
    if (std::abs(p.x()) < 2.0 && std::hypot(p.y(), p.z()) < 0.5)
      return 1200.0;
    return 30.0;
  });
  segmentation::GrowOptions plain;
  plain.separationRadiusMm = 0.0;
  const auto joined = segmentation::growBone(ct, a, plain);
  const auto separated = segmentation::growBone(ct, a);
  const double ball = 4.0 / 3.0 * M_PI * 1000.0;
  EXPECT_GT(joined.volumeMm3, 1.8 * ball);  // without the opening both spheres come
  EXPECT_NEAR(separated.volumeMm3, ball, 0.12 * ball);
  const Eigen::Vector3d vb = ct.lpsToVoxel(b);
  EXPECT_FALSE(separated.mask.at(static_cast<int>(vb.x()), static_cast<int>(vb.y()),
                                 static_cast<int>(vb.z())));
  // The other sphere is what otherBones marks.
  const auto others = segmentation::otherBones(separated.threshold, separated.mask, 2.0);
  EXPECT_TRUE(
      others.at(static_cast<int>(vb.x()), static_cast<int>(vb.y()), static_cast<int>(vb.z())));
}

TEST(BoneSurface, SubVoxelSphereFromTheCt) {
  const double r = 12.0;
  const CtImage ct = analyticCt({48, 48, 40}, {0.8, 0.8, 1.0}, [&](const Eigen::Vector3d& p) {
    return hollowSphere(p, Eigen::Vector3d::Zero(), r);
  });
  const auto grown = segmentation::growBone(ct, Eigen::Vector3d(0, 0, 0));
  const auto surface = segmentation::boneSurface(ct, grown.mask, nullptr);
  const auto check = core::checkMesh(surface.mesh);
  ASSERT_TRUE(check.closed()) << check.describe();
  EXPECT_EQ(surface.components, 1);
  double sum = 0.0, worst = 0.0;
  for (const auto& v : surface.mesh.vertices) {
    const double e = v.norm() - r;
    sum += std::abs(e);
    worst = std::max(worst, std::abs(e));
  }
  const double mean = sum / static_cast<double>(surface.mesh.vertices.size());
  EXPECT_LT(mean, 0.12) << "voxels are 0.8 x 0.8 x 1 mm";
  EXPECT_LT(worst, 0.4);
  // The mask's own surface is coarser but closed too.
  const auto plain = segmentation::maskSurface(grown.mask);
  EXPECT_TRUE(core::checkMesh(plain.mesh).closed());
  double plainSum = 0.0;
  for (const auto& v : plain.mesh.vertices)
    plainSum += std::abs(v.norm() - r);
  EXPECT_LT(plainSum / static_cast<double>(plain.mesh.vertices.size()), 0.6);
  // Decimation keeps it closed.
  segmentation::BoneSurfaceOptions fewer;
  fewer.targetTriangles = 2000;
  const auto decimated = segmentation::boneSurface(ct, grown.mask, nullptr, fewer);
  EXPECT_TRUE(decimated.decimated);
  EXPECT_LE(decimated.mesh.triangles.size(), 2200u);
  EXPECT_TRUE(core::checkMesh(decimated.mesh).closed());
  // An empty region is refused.
  EXPECT_THROW(segmentation::boneSurface(ct, segmentation::emptyMask(ct), nullptr),
               std::invalid_argument);
  EXPECT_THROW(segmentation::maskSurface(segmentation::emptyMask(ct)), std::invalid_argument);
}

// A closed cylinder of radius r along z from z0 to z1, as a mesh.
core::TriangleMesh cylinder(double r, double z0, double z1, int segments = 96) {
  core::TriangleMesh m;
  for (int s = 0; s < segments; ++s) {
    const double a = 2.0 * M_PI * s / segments;
    m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), z0);
    m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), z1);
  }
  const int bottom = static_cast<int>(m.vertices.size());
  m.vertices.emplace_back(0, 0, z0);
  m.vertices.emplace_back(0, 0, z1);
  for (int s = 0; s < segments; ++s) {
    const int a0 = 2 * s, a1 = 2 * s + 1, b0 = 2 * ((s + 1) % segments), b1 = b0 + 1;
    m.triangles.push_back({a0, b0, b1});
    m.triangles.push_back({a0, b1, a1});
    m.triangles.push_back({bottom, b0, a0});
    m.triangles.push_back({bottom + 1, a1, b1});
  }
  return m;
}

TEST(Contours, PlaneSectionsOfACylinder) {
  const auto mesh = cylinder(10.0, -20.0, 20.0);
  ASSERT_TRUE(core::checkMesh(mesh).closed());
  ASSERT_GT(core::checkMesh(mesh).volumeMm3, 0.0);
  // A sagittal cut at x = 6: the rectangle |y| <= 8, |z| <= 20.
  const auto loops = segmentation::planeSections(mesh, segmentation::SlicePlane::Sagittal, 6.0);
  ASSERT_EQ(loops.size(), 1u);
  double area = 0.0;
  for (std::size_t i = 0; i < loops[0].size(); ++i) {
    const auto& p = loops[0][i];
    const auto& q = loops[0][(i + 1) % loops[0].size()];
    EXPECT_DOUBLE_EQ(p.x(), 6.0);
    area += p.y() * q.z() - q.y() * p.z();
  }
  EXPECT_GT(area, 0.0) << "counter-clockwise in (y, z)";
  EXPECT_NEAR(0.5 * area, 2.0 * 8.0 * 40.0, 0.5);
  // Axial: a circle; none beyond the mesh.
  const auto ring = segmentation::planeSections(mesh, segmentation::SlicePlane::Axial, 3.3);
  ASSERT_EQ(ring.size(), 1u);
  for (const auto& p : ring[0]) {
    EXPECT_LE(std::hypot(p.x(), p.y()), 10.0 + 1e-9);
    EXPECT_GE(std::hypot(p.x(), p.y()), 10.0 * std::cos(M_PI / 96.0) - 1e-9);
    EXPECT_DOUBLE_EQ(p.z(), 3.3);
  }
  EXPECT_TRUE(segmentation::planeSections(mesh, segmentation::SlicePlane::Sagittal, 11.0).empty());
  const auto positions =
      segmentation::evenSlicePositions(mesh, segmentation::SlicePlane::Sagittal, 4);
  ASSERT_EQ(positions.size(), 4u);
  EXPECT_NEAR(positions[0], -7.5, 1e-9);
  EXPECT_NEAR(positions[3], 7.5, 1e-9);
  EXPECT_THROW(segmentation::evenSlicePositions(mesh, segmentation::SlicePlane::Sagittal, 0),
               std::invalid_argument);
}

TEST(Contours, AnchorsSitOnTheCorners) {
  // A 40 x 20 mm rectangle sampled every 0.5 mm: anchors every ~12 mm, the four corners among them.
  std::vector<Eigen::Vector3d> loop;
  auto edge = [&](Eigen::Vector3d a, Eigen::Vector3d b) {
    const int n = static_cast<int>(std::lround((b - a).norm() / 0.5));
    for (int i = 0; i < n; ++i)
      loop.push_back(a + (b - a) * i / n);
  };
  edge({0, 0, 0}, {0, 40, 0});
  edge({0, 40, 0}, {0, 40, 20});
  edge({0, 40, 20}, {0, 0, 20});
  edge({0, 0, 20}, {0, 0, 0});
  const auto anchors = segmentation::proposeLoopAnchors(loop);
  // The four corners, then each side split into pieces of at most 12 mm: 4 + 2 x 3 + 2 x 1.
  EXPECT_EQ(anchors.size(), 12u);
  for (std::size_t i = 0; i < anchors.size(); ++i) {
    EXPECT_LE((anchors[(i + 1) % anchors.size()] - anchors[i]).norm(), 12.0 + 1e-9);
  }
  for (const Eigen::Vector3d& corner : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 40, 0),
                                        Eigen::Vector3d(0, 40, 20), Eigen::Vector3d(0, 0, 20)}) {
    double nearest = 1e9;
    for (const auto& a : anchors)
      nearest = std::min(nearest, (a - corner).norm());
    EXPECT_LT(nearest, 0.6) << corner.transpose();
  }
  // Clipped to z <= 15 (the end of a scan): the cut's two ends become corners.
  const auto clipped = segmentation::clipLoopZ(loop, -1e9, 15.0);
  const auto cut = segmentation::proposeLoopAnchors(clipped);
  int onCut = 0;
  for (const auto& a : cut) {
    EXPECT_LE(a.z(), 15.0 + 1e-9);
    if (std::abs(a.z() - 15.0) < 1e-9 && (std::abs(a.y()) < 1e-9 || std::abs(a.y() - 40.0) < 1e-9))
      ++onCut;
  }
  EXPECT_EQ(onCut, 2);
  // Live-wire between two anchors on the scan's end is replaced by the straight cut.
  segmentation::SliceContour wire;
  wire.pointsLps = {{0, 0, 15}, {0, 5, 12}, {0, 10, 15}, {0, 10, 0}, {0, 0, 0}};
  wire.anchorIndices = {0, 2, 3, 4};
  segmentation::AnchorSet wireAnchors;
  wireAnchors.anchorsLps = {{0, 0, 15.2}, {0, 10, 14.9}, {0, 10, 0}, {0, 0, 0}};
  EXPECT_EQ(segmentation::straightenAtScanEnds(wire, wireAnchors, -100.0, 15.0, 0.5), 1);
  ASSERT_EQ(wire.pointsLps.size(), 4u);
  EXPECT_EQ(wire.anchorIndices, (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(wire.pointsLps[0].z(), 15.2);  // the anchors themselves
  EXPECT_EQ(wire.pointsLps[1].z(), 14.9);
  wireAnchors.anchorsLps.pop_back();  // anchors that do not match the contour: left alone
  EXPECT_EQ(segmentation::straightenAtScanEnds(wire, wireAnchors, -100.0, 15.0, 0.5), 0);
  // A tiny loop gets none.
  std::vector<Eigen::Vector3d> tiny{{0, 0, 0}, {0, 1, 0}, {0, 1, 1}};
  EXPECT_TRUE(segmentation::proposeLoopAnchors(tiny).empty());
  // Proposed sets on a cylinder: one per sagittal slice, each on the surface.
  const auto sets = segmentation::proposeAnchors(cylinder(10.0, -20.0, 20.0),
                                                 segmentation::SlicePlane::Sagittal, 5);
  ASSERT_EQ(sets.size(), 5u);
  for (const auto& s : sets) {
    EXPECT_GE(s.anchorsLps.size(), 4u);
    for (const auto& a : s.anchorsLps)
      EXPECT_NEAR(a.x(), s.positionMm, 1e-9);
  }
}

TEST(Contours, InterpolatedMaskOfACylinder) {
  // Sagittal sections of a cylinder of radius 10 (axis z), every 2 mm: the mask's volume.
  const auto mesh = cylinder(10.0, -12.0, 12.0, 180);
  std::vector<segmentation::SliceContour> contours;
  for (double x : segmentation::evenSlicePositions(mesh, segmentation::SlicePlane::Sagittal, 10)) {
    for (auto& loop : segmentation::planeSections(mesh, segmentation::SlicePlane::Sagittal, x)) {
      segmentation::SliceContour c;
      c.positionMm = x;
      c.pointsLps = loop;
      contours.push_back(c);
    }
  }
  const CtImage grid =
      analyticCt({40, 40, 36}, {0.8, 0.8, 1.0}, [](const Eigen::Vector3d&) { return 0.0; });
  const auto mask = segmentation::contoursToMask(contours, grid);
  const double volume = static_cast<double>(mask.count()) * 0.8 * 0.8 * 1.0;
  const double truth = M_PI * 100.0 * 24.0;
  EXPECT_NEAR(volume, truth, 0.04 * truth);
  EXPECT_TRUE(mask.at(20, 20, 18));
  EXPECT_FALSE(mask.at(20, 20, 1));  // z = -16.5: beyond the cylinder's end
  EXPECT_FALSE(mask.at(2, 20, 18));  // x = -14.4
  EXPECT_THROW(segmentation::contoursToMask({}, grid), std::invalid_argument);
  // Contours beside the grid enclose none of its voxels: an empty mask (which the surface step
  // refuses).
  std::vector<segmentation::SliceContour> away = contours;
  for (auto& c : away) {
    for (auto& p : c.pointsLps)
      p.y() += 100.0;
  }
  EXPECT_EQ(segmentation::contoursToMask(away, grid).count(), 0u);
  contours[1].plane = segmentation::SlicePlane::Axial;
  EXPECT_THROW(segmentation::contoursToMask(contours, grid), std::invalid_argument);
}

core::TriangleMesh icosphere(double r, int subdivisions) {
  core::TriangleMesh m;
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  for (const auto& v : std::vector<Eigen::Vector3d>{{-1, t, 0},
                                                    {1, t, 0},
                                                    {-1, -t, 0},
                                                    {1, -t, 0},
                                                    {0, -1, t},
                                                    {0, 1, t},
                                                    {0, -1, -t},
                                                    {0, 1, -t},
                                                    {t, 0, -1},
                                                    {t, 0, 1},
                                                    {-t, 0, -1},
                                                    {-t, 0, 1}}) {
    m.vertices.push_back(v.normalized() * r);
  }
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::vector<std::array<int, 3>> next;
    std::map<std::pair<int, int>, int> mid;
    auto middle = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end())
        return it->second;
      m.vertices.push_back(
          (m.vertices[static_cast<std::size_t>(a)] + m.vertices[static_cast<std::size_t>(b)])
              .normalized() *
          r);
      return mid[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    for (const auto& tri : m.triangles) {
      const int a = middle(tri[0], tri[1]), b = middle(tri[1], tri[2]), c = middle(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    m.triangles = next;
  }
  return m;
}

TEST(AccessibleSurface, ViewDirectionsAndRegions) {
  const auto sphere = icosphere(20.0, 4);
  ASSERT_GT(core::checkMesh(sphere).volumeMm3, 0.0);
  segmentation::AccessibleSurfaceOptions o;
  o.viewDirections = {Eigen::Vector3d(0, -2, 0)};  // anterior, not unit
  o.maxAngleDeg = 60.0;
  const auto front = segmentation::accessibleSurface(sphere, o);
  // A cap of half-angle 60 degrees: (1 - cos 60) / 2 of the sphere.
  EXPECT_NEAR(front.fractionOfArea, 0.25, 0.02);
  for (const auto& v : front.mesh.vertices)
    EXPECT_LT(v.y(), -8.0);
  // Two spheres one behind the other: the back one is hidden along the view.
  core::TriangleMesh two = sphere;
  const auto behind = icosphere(10.0, 3);
  const int offset = static_cast<int>(two.vertices.size());
  for (const auto& v : behind.vertices)
    two.vertices.push_back(v + Eigen::Vector3d(0, 40, 0));
  for (const auto& t : behind.triangles)
    two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const auto visible = segmentation::accessibleSurface(two, o);
  for (const auto& v : visible.mesh.vertices)
    EXPECT_LT(v.y(), 0.0) << "the sphere behind is hidden";
  // Regions: a ball of 10 mm around a surface point keeps a cap.
  segmentation::AccessibleSurfaceOptions r;
  r.regions = {{"epicondyle", Eigen::Vector3d(20, 0, 0), 10.0}};
  const auto cap = segmentation::accessibleSurface(sphere, r);
  for (const auto& v : cap.mesh.vertices)
    EXPECT_LT((v - Eigen::Vector3d(20, 0, 0)).norm(), 11.0);
  EXPECT_GT(cap.areaMm2, 200.0);
  // Bad values.
  segmentation::AccessibleSurfaceOptions bad;
  bad.viewDirections = {Eigen::Vector3d::Zero()};
  EXPECT_THROW(segmentation::accessibleSurface(sphere, bad), std::invalid_argument);
  bad.viewDirections.clear();
  bad.regions = {{"far", Eigen::Vector3d(100, 0, 0), 5.0}};
  EXPECT_THROW(segmentation::accessibleSurface(sphere, bad), std::invalid_argument);
  EXPECT_THROW(segmentation::accessibleSurface(core::TriangleMesh{}, o), std::invalid_argument);
}

TEST(MaskNrrd, AMaskReadsBackWithItsGeometry) {
  const CtImage ct = analyticCt({4, 3, 2}, {0.5, 0.5, 2.0},
                                [](const Eigen::Vector3d& p) { return p.x() > 0 ? 1000.0 : 0.0; });
  auto mask = segmentation::emptyMask(ct);
  mask.voxels[ct.index(3, 2, 1)] = 1;
  test::TempDir dir;
  segmentation::writeNrrdVolume(dir.file("m.nrrd"), mask.geometry, mask.voxels);
  const auto back = segmentation::readNrrdVolume(dir.file("m.nrrd"));
  ASSERT_TRUE(back.isMask);
  EXPECT_EQ(back.mask, mask.voxels);
  EXPECT_TRUE(back.image.originMm.isApprox(ct.originMm, 1e-12));
  EXPECT_TRUE(back.image.voxelToLps({3, 2, 1}).isApprox(ct.voxelToLps({3, 2, 1}), 1e-12));
  EXPECT_THROW(
      segmentation::writeNrrdVolume(dir.file("missing/m.nrrd"), mask.geometry, mask.voxels),
      core::FileError);
}

}  // namespace
