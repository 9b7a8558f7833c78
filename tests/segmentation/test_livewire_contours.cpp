// Live-wire contours on a synthetic CT with known truth: a bone sphere in soft tissue with partial
// volume and noise, on a rotated voxel frame with unevenly spaced slices. The sub-pixel contour
// lies within 0.25 mm of the true surface on sagittal, coronal and axial slices; anchors files
// (echoreg JSON and Slicer .mrk.json) are read and written; bad files are refused naming the file
// and the contour.
#include "echoreg/core/error.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

namespace echoreg::segmentation {
namespace {

using core::CtImage;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadius = 14.0;
constexpr double kBoneHu = 1200.0;
constexpr double kTissueHu = 40.0;

// 48 x 48 pixels of 0.8 mm, 30 slices: 20 at 1 mm then 10 at 2 mm; i along +y, j along +x, k
// along -z. Each voxel is the mean over 4 x 4 x 4 sub-samples of its extent (partial volume),
// plus noise of 10 HU.
struct Phantom {
  CtImage ct;
  Eigen::Vector3d centre;
};

Phantom spherePhantom() {
  Phantom ph;
  CtImage& ct = ph.ct;
  ct.dimensions = {48, 48, 30};
  ct.originMm = {-20.0, 10.0, 50.0};
  ct.direction << 0, 1, 0,  //
      1, 0, 0,              //
      0, 0, -1;
  ct.pixelSpacingMm = {0.8, 0.8};
  for (int k = 0; k < 30; ++k)
    ct.slicePositionsMm.push_back(k < 20 ? k : 19.0 + 2.0 * (k - 19));
  ct.groups = {{0, 20, 1.0}, {20, 10, 2.0}};
  ph.centre = ct.voxelToLps({23.6, 24.3, 19.4});
  ct.hu.resize(ct.voxelCount());
  core::Rng rng(2008);
  const auto& z = ct.slicePositionsMm;
  for (int k = 0; k < 30; ++k) {
    const double z0 =
        k == 0 ? z[0] - 0.5
               : 0.5 * (z[static_cast<std::size_t>(k - 1)] + z[static_cast<std::size_t>(k)]);
    const double z1 =
        k == 29 ? z[29] + 1.0
                : 0.5 * (z[static_cast<std::size_t>(k)] + z[static_cast<std::size_t>(k + 1)]);
    for (int j = 0; j < 48; ++j) {
      for (int i = 0; i < 48; ++i) {
        int inside = 0;
        for (int c = 0; c < 4; ++c)
          for (int b = 0; b < 4; ++b)
            for (int a = 0; a < 4; ++a) {
              const Eigen::Vector3d local((i - 0.5 + (a + 0.5) / 4) * 0.8,
                                          (j - 0.5 + (b + 0.5) / 4) * 0.8,
                                          z0 + (z1 - z0) * (c + 0.5) / 4);
              if ((ct.originMm + ct.direction * local - ph.centre).norm() <= kRadius)
                ++inside;
            }
        const double hu = kTissueHu + (kBoneHu - kTissueHu) * inside / 64.0 + rng.normal(0.0, 10.0);
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>(std::lround(hu));
      }
    }
  }
  return ph;
}

const Phantom& phantom() {
  static const Phantom ph = spherePhantom();
  return ph;
}

// Anchors on the true circle where `plane` at `offset` mm from the centre cuts the sphere.
AnchorSet circleAnchors(SlicePlane plane, double offset, int count, const std::string& label) {
  const Phantom& ph = phantom();
  const SlicePlaneAxes axes = slicePlaneAxes(plane);
  const double r = std::sqrt(kRadius * kRadius - offset * offset);
  AnchorSet set;
  set.plane = plane;
  set.positionMm = ph.centre[axes.normal] + offset;
  set.label = label;
  for (int k = 0; k < count; ++k) {
    const double t = 0.4 + 2.0 * kPi * k / count;
    Eigen::Vector3d p = ph.centre;
    p[axes.normal] += offset;
    p[axes.u] += r * std::cos(t);
    p[axes.v] += r * std::sin(t);
    set.anchorsLps.push_back(p);
  }
  return set;
}

TEST(LiveWireContour, SubpixelContourLiesOnTheSphereInEveryPlane) {
  const Phantom& ph = phantom();
  struct Case {
    SlicePlane plane;
    double offset;
  };
  for (const Case c : {Case{SlicePlane::Sagittal, 4.0}, Case{SlicePlane::Coronal, -3.0},
                       Case{SlicePlane::Axial, 2.5}, Case{SlicePlane::Sagittal, -7.5}}) {
    SCOPED_TRACE(std::string(slicePlaneName(c.plane)) + " " + std::to_string(c.offset));
    const AnchorSet anchors = circleAnchors(c.plane, c.offset, 6, "s1");
    const SliceContour contour = liveWireContour(ph.ct, anchors);
    const double r = std::sqrt(kRadius * kRadius - c.offset * c.offset);
    // Around the whole circle: at least one point per 1.2 samples of its length.
    EXPECT_GT(contour.pointsLps.size(),
              static_cast<std::size_t>(2 * kPi * r / (1.2 * contour.sampleSpacingMm)));
    EXPECT_DOUBLE_EQ(contour.sampleSpacingMm, 0.8);
    EXPECT_EQ(contour.anchorIndices.size(), 6u);
    const int normal = slicePlaneAxes(c.plane).normal;
    // Within 0.25 mm where the slices are 1 mm apart (0.09-0.10 mm measured). Where they are 2 mm
    // apart (slices 19 on) a surface nearly parallel to them (the sphere's cap) is blurred over a
    // slab thicker than its curvature allows to undo: within 0.45 mm there (0.39 mm measured on the
    // coronal cap).
    double worstFine = 0.0;
    double worstThick = 0.0;
    double sum = 0.0;
    for (const auto& p : contour.pointsLps) {
      EXPECT_NEAR(p[normal], anchors.positionMm, 1e-9);
      const double e = std::abs((p - ph.centre).norm() - kRadius);
      double& worst = ph.ct.lpsToVoxel(p).z() <= 19.0 ? worstFine : worstThick;
      worst = std::max(worst, e);
      sum += e;
    }
    EXPECT_LE(worstFine, 0.25);
    EXPECT_LE(worstThick, 0.45);
    EXPECT_LE(sum / static_cast<double>(contour.pointsLps.size()), 0.1);

    // Without the refinement the points are on the 0.8 mm grid: within a sample, not 0.25 mm.
    LiveWireContourOptions grid;
    grid.subpixelRefine = false;
    const SliceContour raw = liveWireContour(ph.ct, anchors, grid);
    double rawWorst = 0.0;
    for (const auto& p : raw.pointsLps)
      rawWorst = std::max(rawWorst, std::abs((p - ph.centre).norm() - kRadius));
    EXPECT_LE(rawWorst, 0.8 * std::sqrt(2.0));
    EXPECT_GT(rawWorst, 0.25);
    EXPECT_NEAR(raw.cost, contour.cost, 1e-12);
  }
}

TEST(LiveWireContour, ResliceInterpolatesUnevenSlicesOnARotatedFrame) {
  const Phantom& ph = phantom();
  // Trilinear sampling at a voxel centre gives the voxel; between slices 20 and 21 (2 mm apart
  // in the 2 mm group) it is the mean.
  const CtImage& ct = ph.ct;
  EXPECT_NEAR(sampleCt(ct, ct.voxelToLps({10, 12, 21})), ct.at(10, 12, 21), 1e-9);
  EXPECT_NEAR(sampleCt(ct, ct.voxelToLps({10, 12, 21.5})),
              0.5 * (ct.at(10, 12, 21) + ct.at(10, 12, 22)), 1e-9);
  const CtSlice slice =
      resliceCt(ct, SlicePlane::Axial, ph.centre.z(), {-1000, -1000}, {1000, 1000}, 0.8);
  // The axial plane spans the voxel centres: 48 samples 0.8 mm apart along x and y.
  EXPECT_EQ(slice.width, 48);
  EXPECT_EQ(slice.height, 48);
  const Eigen::Vector2d c = slice.pixel(ph.centre);
  const auto nearest = [&](const Eigen::Vector2d& q) {
    return slice
        .hu[static_cast<std::size_t>(std::lround(q.y()) * slice.width + std::lround(q.x()))];
  };
  EXPECT_GT(nearest(c), 1000.0f);
  EXPECT_LT(nearest(Eigen::Vector2d(1, 1)), 100.0f);
  EXPECT_TRUE(slice.lps(c.x(), c.y()).isApprox(ph.centre, 1e-12));
  EXPECT_THROW(
      resliceCt(ct, SlicePlane::Axial, ph.centre.z() + 500.0, {-1000, -1000}, {1000, 1000}, 0.8),
      std::invalid_argument);
  EXPECT_THROW(resliceCt(ct, SlicePlane::Axial, ph.centre.z(), {-1000, -1000}, {1000, 1000}, 0.0),
               std::invalid_argument);
}

TEST(LiveWireContour, BadAnchorsAreRefused) {
  const Phantom& ph = phantom();
  AnchorSet set = circleAnchors(SlicePlane::Sagittal, 4.0, 5, "femur-s7");
  AnchorSet off = set;
  off.anchorsLps[2].x() += 0.8;
  try {
    liveWireContour(ph.ct, off);
    FAIL() << "an anchor off the plane was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("femur-s7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("anchor 3"), std::string::npos) << e.what();
  }
  AnchorSet outside = set;
  outside.anchorsLps[1].y() += 60.0;
  EXPECT_THROW(liveWireContour(ph.ct, outside), std::invalid_argument);
  AnchorSet two = set;
  two.anchorsLps.resize(2);
  EXPECT_THROW(liveWireContour(ph.ct, two), std::invalid_argument);
  EXPECT_THROW(liveWireContour(CtImage{}, set), std::invalid_argument);
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// The FileError message of reading `text` as an anchors file.
std::string readError(const test::TempDir& dir, const std::string& text) {
  const std::string path = dir.file("bad.json");
  writeText(path, text);
  try {
    readAnchors(path);
  } catch (const core::FileError& e) {
    EXPECT_EQ(e.path(), path);
    return e.what();
  }
  return "";
}

TEST(LiveWireContour, AnchorsFilesAreReadAndWritten) {
  test::TempDir dir;
  const std::string echoreg = dir.file("anchors.json");
  // "plane", when given, holds for every contour: an axial contour in a sagittal file is refused.
  const std::string mixed = readError(dir, R"({"plane": "sagittal", "contours": [
    {"label": "s12", "anchors": [[10.2, 1, 2], [10.0, 5, 2], [10.1, 5, 7]]},
    {"anchors": [[1, 2, -30.0], [4, 2, -30.2], [4, 8, -29.9]]}]})");
  EXPECT_NE(mixed.find("contour \"contour 2\""), std::string::npos) << mixed;
  EXPECT_NE(mixed.find("axial"), std::string::npos) << mixed;

  writeText(echoreg, R"({"contours": [
    {"label": "s12", "anchors": [[10.2, 1, 2], [10.0, 5, 2], [10.1, 5, 7], [9.9, 1, 6]]},
    {"anchors": [[1, 2, -30.0], [4, 2, -30.2], [4, 8, -29.9]]}]})");
  const std::vector<AnchorSet> sets = readAnchors(echoreg);
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].label, "s12");
  EXPECT_EQ(sets[0].plane, SlicePlane::Sagittal);
  EXPECT_NEAR(sets[0].positionMm, 10.05, 1e-12);
  ASSERT_EQ(sets[0].anchorsLps.size(), 4u);
  EXPECT_TRUE(sets[0].anchorsLps[2].isApprox(Eigen::Vector3d(10.1, 5, 7)));
  EXPECT_EQ(sets[1].label, "contour 2");
  EXPECT_EQ(sets[1].plane, SlicePlane::Axial);
  EXPECT_NEAR(sets[1].positionMm, -30.033333333333333, 1e-12);

  // Written as Slicer closed curves, read back the same.
  const std::string slicer = dir.file("anchors.mrk.json");
  writeAnchors(slicer, sets);
  const std::vector<AnchorSet> back = readAnchors(slicer);
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t s = 0; s < 2; ++s) {
    EXPECT_EQ(back[s].label, sets[s].label);
    EXPECT_EQ(back[s].plane, sets[s].plane);
    EXPECT_DOUBLE_EQ(back[s].positionMm, sets[s].positionMm);
    ASSERT_EQ(back[s].anchorsLps.size(), sets[s].anchorsLps.size());
    for (std::size_t i = 0; i < sets[s].anchorsLps.size(); ++i)
      EXPECT_EQ(back[s].anchorsLps[i], sets[s].anchorsLps[i]);
  }
  std::ifstream in(slicer);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"ClosedCurve\""), std::string::npos);

  // A Slicer file in RAS with a fiducial list beside the curve: only the curve is a contour.
  writeText(slicer, R"({"markups": [
    {"type": "Fiducial", "coordinateSystem": "RAS", "controlPoints": [{"label": "F-1", "position": [0, 0, 0]}]},
    {"type": "ClosedCurve", "name": "c7", "coordinateSystem": "RAS", "controlPoints": [
      {"label": "1", "position": [-1, -2, 3]}, {"label": "2", "position": [-1, -6, 3.3]},
      {"label": "3", "position": [-1, -6, 9]}]}]})");
  const std::vector<AnchorSet> ras = readAnchors(slicer);
  ASSERT_EQ(ras.size(), 1u);
  EXPECT_EQ(ras[0].label, "c7");
  EXPECT_EQ(ras[0].plane, SlicePlane::Sagittal);  // RAS x = -1 is LPS x = 1 for all three
  EXPECT_DOUBLE_EQ(ras[0].positionMm, 1.0);
  EXPECT_EQ(ras[0].anchorsLps[1], Eigen::Vector3d(1, 6, 3.3));
}

TEST(LiveWireContour, BadAnchorsFilesAreRefusedNamingFileAndContour) {
  test::TempDir dir;
  EXPECT_THROW(readAnchors(dir.file("missing.json")), core::FileError);
  std::string m = readError(dir, "{not json");
  EXPECT_NE(m.find("not a JSON"), std::string::npos) << m;
  m = readError(dir, R"({"something": 1})");
  EXPECT_NE(m.find("neither"), std::string::npos) << m;
  m = readError(dir, R"({"contours": []})");
  EXPECT_NE(m.find("no contour"), std::string::npos) << m;
  m = readError(dir, R"({"contours": [{"label": "t3", "anchors": [[1, 2, 3], [1, 5, 3]]}]})");
  EXPECT_NE(m.find("contour \"t3\": 2 anchors"), std::string::npos) << m;
  m = readError(dir,
                R"({"contours": [{"label": "t4", "anchors": [[1, 2, 3], [2, 5, 4], [9, 1, 8]]}]})");
  EXPECT_NE(m.find("contour \"t4\": anchors are not in one"), std::string::npos) << m;
  m = readError(dir,
                R"({"contours": [{"label": "t5", "anchors": [[1, 2, 3], [1, 2, 4], [1, 2, 8]]}]})");
  EXPECT_NE(m.find("contour \"t5\": anchors lie on a line"), std::string::npos) << m;
  m = readError(
      dir, R"({"contours": [{"label": "t6", "anchors": [[1, 2, 3], [1, "a", 4], [1, 2, 8]]}]})");
  EXPECT_NE(m.find("contour \"t6\", anchor 2"), std::string::npos) << m;
  m = readError(
      dir, R"({"plane": "oblique", "contours": [{"anchors": [[1, 2, 3], [1, 5, 4], [1, 2, 8]]}]})");
  EXPECT_NE(m.find("oblique"), std::string::npos) << m;
  m = readError(
      dir,
      R"({"plane": "axial", "contours": [{"label": "t7", "anchors": [[1, 2, 3], [1, 5, 4], [1, 2, 8]]}]})");
  EXPECT_NE(m.find("contour \"t7\": anchors lie in a sagittal plane"), std::string::npos) << m;
  m = readError(dir, R"({"markups": [{"type": "Fiducial", "controlPoints": []}]})");
  EXPECT_NE(m.find("no contour"), std::string::npos) << m;
  m = readError(dir, R"({"markups": [{"type": "ClosedCurve", "name": "k1", "controlPoints": [
      {"position": [0, 0, 0]}, {"position": [3, 4, 0]}, {"position": [6, 1, 9]}]}]})");
  EXPECT_NE(m.find("contour \"k1\": anchors are not in one"), std::string::npos) << m;

  // Nothing is written for a set with fewer than 3 anchors.
  AnchorSet two;
  two.label = "short";
  two.anchorsLps = {{0, 0, 0}, {0, 1, 0}};
  const std::string out = dir.file("out.mrk.json");
  EXPECT_THROW(writeAnchors(out, {two}), core::FileError);
  EXPECT_FALSE(std::ifstream(out).good());
}

}  // namespace
}  // namespace echoreg::segmentation
