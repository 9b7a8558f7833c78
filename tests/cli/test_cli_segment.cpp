// echoreg segment end to end on a small DICOM phantom written by the simulator's writer: a hollow
// "bone" (a cylinder of cortex around marrow) and a thin one beside it, in three slice groups
// (5 mm / 1 mm / 5 mm) like the dissertation's protocol. Auto and anchors modes, the outputs,
// and every refusal (exit 1 naming the file, no output written; wrong usage exit 2).
#include "cli_test_support.hpp"
#include "test_support.hpp"

#include "echoreg/core/markups.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/simulation/ct.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace echoreg::cli {
namespace {

using test::runEchoreg;
namespace fs = std::filesystem;

constexpr double kRadius = 10.0;  // the big bone's outer radius, centred on x = y = 0

// HU of the phantom at a point: cortex 3 mm thick around marrow, a solid thin bone of radius 4
// centred at x = 17 (3 mm gap), soft tissue 40 HU.
double phantomHu(double x, double y) {
  const double r = std::hypot(x, y);
  if (r <= kRadius)
    return r > kRadius - 3.0 ? 1500.0 : -60.0;
  if (std::hypot(x - 17.0, y) <= 4.0)
    return 1400.0;
  return 40.0;
}

std::string writePhantom(const std::string& folder) {
  std::vector<double> hip, knee, ankle;
  for (int k = 0; k < 3; ++k)
    hip.push_back(-60.0 + 5.0 * k);
  for (int k = 0; k < 30; ++k)
    knee.push_back(-15.0 + k);
  for (int k = 0; k < 3; ++k)
    ankle.push_back(40.0 + 5.0 * k);
  core::CtImage v = core::axialCtImage(
      56, 48, 0.8, {-18.0, -18.8}, {{"hip", hip, 5.0}, {"knee", knee, 1.0}, {"ankle", ankle, 5.0}});
  v.hu.resize(v.voxelCount());
  for (int k = 0; k < v.dimensions[2]; ++k) {
    for (int j = 0; j < v.dimensions[1]; ++j) {
      for (int i = 0; i < v.dimensions[0]; ++i) {
        const Eigen::Vector3d c = v.voxelCentreMm(i, j, k);
        double sum = 0.0;  // partial volume: 4 x 4 samples in the pixel
        for (int a = 0; a < 4; ++a) {
          for (int b = 0; b < 4; ++b)
            sum += phantomHu(c.x() + (a - 1.5) * 0.2, c.y() + (b - 1.5) * 0.2);
        }
        v.hu[v.index(i, j, k)] = static_cast<std::int16_t>(std::lround(sum / 16.0));
      }
    }
  }
  simulation::DicomSeriesInfo info;
  info.patientId = "PHANTOM";
  info.uidSeed = 5;
  simulation::writeDicomSeries(folder, v, info);
  return folder;
}

class CliSegment : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    series_ = writePhantom(dir_->file("series"));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static test::TempDir* dir_;
  static std::string series_;
  test::TempDir out_;
};
test::TempDir* CliSegment::dir_ = nullptr;
std::string CliSegment::series_;

// Mean |radius - 10| of the model's vertices on the side wall (away from the caps at the knee
// group's ends, z -15 and 14).
double meanRadialError(const core::TriangleMesh& mesh) {
  double sum = 0.0;
  int n = 0;
  for (const auto& v : mesh.vertices) {
    if (v.z() < -12.0 || v.z() > 11.0)
      continue;
    sum += std::abs(std::hypot(v.x(), v.y()) - kRadius);
    ++n;
  }
  return n > 0 ? sum / n : 1e9;
}

TEST_F(CliSegment, AutoThenAnchorsGiveTheBone) {
  const std::string model = out_.file("bone.vtp"), mask = out_.file("bone.nrrd"),
                    anchors = out_.file("a.mrk.json");
  auto r = runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--auto", "--seed", "0",
                       "5", "0", "--out", model, "--mask", mask, "--anchors-out", anchors,
                       "--slices", "8", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["mode"], "auto");
  EXPECT_EQ(json["group"]["index"], 1);
  EXPECT_EQ(json["group"]["slices"], 30);
  EXPECT_EQ(json["seeds"][0]["seed_hu"], -60);  // in the marrow: filled
  EXPECT_TRUE(json["surface"]["closed"].get<bool>());
  ASSERT_EQ(json["warnings"].size(), 1u);
  EXPECT_NE(json["warnings"][0].get<std::string>().find("3 slice groups"), std::string::npos);
  const core::TriangleMesh mesh = filters::readMesh(model);
  EXPECT_TRUE(core::checkMesh(mesh).closed());
  EXPECT_LT(meanRadialError(mesh), 0.1) << "sub-voxel (0.8 mm pixels)";
  // The thin bone beside it stays out.
  for (const auto& v : mesh.vertices)
    EXPECT_LT(v.x(), 12.5);
  EXPECT_TRUE(fs::exists(mask));
  const auto curves = core::readMarkups(anchors);
  EXPECT_EQ(curves.size(), 8u);
  for (const auto& c : curves)
    EXPECT_EQ(c.type, "ClosedCurve");

  // The proposed anchors, fed back: live-wire contours, filled, refined.
  const std::string fromAnchors = out_.file("lw.vtp");
  r = runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--anchors", anchors, "--out",
                  fromAnchors, "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto lw = nlohmann::json::parse(r.out);
  EXPECT_EQ(lw["mode"], "anchors");
  EXPECT_EQ(lw["contours"].size(), 8u);
  EXPECT_GE(lw["straight_cuts_at_scan_ends"].get<int>(), 8)
      << "each contour crosses both ends of the group";
  const core::TriangleMesh lwMesh = filters::readMesh(fromAnchors);
  EXPECT_TRUE(core::checkMesh(lwMesh).closed());
  EXPECT_LT(meanRadialError(lwMesh), 0.15);
  // Without the CT's refinement: the contours' own surface, coarser but close.
  const std::string plain = out_.file("plain.vtp");
  r = runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--anchors", anchors, "--out",
                  plain, "--no-refine"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_LT(meanRadialError(filters::readMesh(plain)), 0.6);
}

// Several bones' seeds (--seed BONE X Y Z): they grow against each other, --bone's make the
// model; the erosion of before stays available (--method erosion) and gives the same bone.
TEST_F(CliSegment, CompetingSeedsAndTheErosionMethod) {
  const std::string model = out_.file("bone.vtp"), eroded = out_.file("eroded.vtp");
  auto r =
      runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--auto", "--seed", "femur",
                  "0", "5", "0", "--seed", "fibula", "17", "0", "0", "--out", model, "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["method"], "watershed");
  // The joint's slab rule runs on slices of 4 mm and more only (these are 1 mm): none moved.
  EXPECT_EQ(json["joint_slab_voxels"], 0);
  ASSERT_EQ(json["bones"].size(), 2u);
  EXPECT_EQ(json["bones"][0]["bone"], "femur");
  EXPECT_TRUE(json["bones"][0]["modelled"].get<bool>());
  EXPECT_EQ(json["bones"][1]["bone"], "fibula");
  EXPECT_FALSE(json["bones"][1]["modelled"].get<bool>());
  // The thin bone (radius 4 mm, 30 slices): about pi 16 30 = 1508 mm^3.
  EXPECT_NEAR(json["bones"][1]["volume_mm3"].get<double>(), 1508.0, 250.0);
  const double volume = json["surface"]["volume_mm3"];
  const core::TriangleMesh mesh = filters::readMesh(model);
  EXPECT_LT(meanRadialError(mesh), 0.1);
  for (const auto& v : mesh.vertices)
    EXPECT_LT(v.x(), 12.5);

  r = runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--auto", "--method", "erosion",
                  "--seed", "0", "5", "0", "--out", eroded, "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["method"], "erosion");
  EXPECT_NEAR(json["surface"]["volume_mm3"].get<double>(), volume, 0.01 * volume);
  EXPECT_LT(meanRadialError(filters::readMesh(eroded)), 0.1);
}

TEST_F(CliSegment, AccessibleSurfaceAlongAViewDirection) {
  const std::string model = out_.file("bone.vtp"), accessible = out_.file("front.vtp");
  const auto r =
      runEchoreg({"segment",          "--dicom",  series_, "--bone", "femur",           "--auto",
                  "--seed",           "0",        "-8.5",  "0",      "--out",           model,
                  "--view-direction", "0",        "-1",    "0",      "--max-angle-deg", "45",
                  "--accessible-out", accessible, "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  const double fraction = json["accessible"]["fraction_of_area"];
  EXPECT_GT(fraction, 0.1);
  EXPECT_LT(fraction, 0.35);
  for (const auto& v : filters::readMesh(accessible).vertices)
    EXPECT_LT(v.y(), -6.0);
}

TEST_F(CliSegment, RefusalsNameTheFileAndWriteNothing) {
  const std::string model = out_.file("m.vtp");
  auto refused = [&](std::vector<std::string> args, const std::string& phrase) {
    std::vector<std::string> full{"segment", "--dicom", series_, "--bone", "femur", "--out", model};
    full.insert(full.end(), args.begin(), args.end());
    const auto r = runEchoreg(full);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("echoreg segment: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(phrase), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(model)) << phrase;
    EXPECT_FALSE(fs::exists(out_.file("m.nrrd"))) << phrase;
  };
  refused({"--auto", "--seed", "200", "0", "0"}, "outside the CT's slices");
  refused({"--auto", "--seed", "0", "0", "25"}, "gap between its slice groups");
  refused({"--auto", "--seed", "-16", "-16", "0", "--mask", out_.file("m.nrrd")},
          "is not in bone: 40 HU");
  // A CT with bone nowhere near the seed's HU: the threshold above every voxel.
  refused({"--auto", "--seed", "0", "5", "0", "--threshold-hu", "3000", "2500"},
          "no voxel of the CT is bone by the threshold");
  refused({"--auto", "--seed", "0", "5", "0", "--threshold-hu", "100", "200"}, "WEAK <= STRONG");
  // Two bones' seeds in one bone (on either side of its marrow), and a named seed off the scan.
  refused({"--auto", "--seed", "femur", "0", "5", "0", "--seed", "tibia", "0", "-5", "3"},
          "lie in one bone");
  refused({"--auto", "--seed", "femur", "0", "5", "0", "--seed", "tibia", "0", "0", "300"},
          "the tibia seed (0.0, 0.0, 300.0) mm lies outside the CT's slices");
  // Anchors files.
  const std::string notJson = out_.file("bad.mrk.json");
  std::ofstream(notJson) << "{ not json";
  refused({"--anchors", notJson}, notJson);
  const std::string twoPoints = out_.file("two.mrk.json");
  core::writeMarkups(twoPoints,
                     {core::Markup{"ClosedCurve", "c", {{"a", {0, -10, -5}}, {"b", {0, 10, -5}}}}});
  refused({"--anchors", twoPoints}, "at least 3");
  const std::string outside = out_.file("outside.mrk.json");
  core::writeMarkups(
      outside,
      {core::Markup{
          "ClosedCurve", "c", {{"a", {0, -10, 100}}, {"b", {0, 10, 100}}, {"c", {0, 0, 110}}}}});
  refused({"--anchors", outside}, "no anchor lies within the CT's slices");
  // Anchors so close that two fall on one pixel of the slice: no closed contour.
  const std::string tiny = out_.file("tiny.mrk.json");
  core::writeMarkups(
      tiny,
      {core::Markup{"ClosedCurve",
                    "c",
                    {{"a", {0.1, 0.0, 0.05}}, {"b", {0.1, 1.5, 0.95}}, {"c", {0.1, 1.45, 0.95}}}}});
  refused({"--anchors", tiny}, "at least 3 distinct anchors");
  refused({"--anchors", out_.file("missing.mrk.json")}, "missing.mrk.json");
  // The output's folder must exist; the DICOM folder too.
  {
    const auto r = runEchoreg({"segment", "--dicom", series_, "--bone", "femur", "--auto", "--seed",
                               "0", "5", "0", "--out", out_.file("nowhere/m.vtp")});
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out_.file("nowhere")));
  }
  {
    const auto r = runEchoreg({"segment", "--dicom", out_.file("no-ct"), "--bone", "femur",
                               "--auto", "--seed", "0", "5", "0", "--out", model});
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no-ct"), std::string::npos) << r.err;
  }
}

TEST_F(CliSegment, WrongUsageExitsTwo) {
  const std::string model = out_.file("m.vtp");
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"--auto"},                                                      // no seed
           {"--anchors", "a.mrk.json", "--auto", "--seed", "0", "0", "0"},  // both modes
           {},                                                              // neither
           {"--auto", "--seed", "0", "0"},                                  // two numbers
           {"--auto", "--seed", "0", "0", "0", "--with-fibula"},            // one seed, two bones
           {"--auto", "--seed", "0", "0", "0", "--view-direction", "0", "1",
            "0"},  // no --accessible-out
           {"--auto", "--seed", "0", "0", "0", "--plane", "oblique"},
           {"--auto", "--seed", "tibia", "0", "0", "0"},  // no seed of --bone femur
           {"--auto", "--seed", "femur", "x", "0", "0"},  // not a number
           {"--auto", "--seed", "0", "0", "0", "--method", "flood"}}) {
    std::vector<std::string> full{"segment", "--dicom", series_, "--bone", "femur", "--out", model};
    full.insert(full.end(), args.begin(), args.end());
    const auto r = runEchoreg(full);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_FALSE(fs::exists(model));
  }
}

}  // namespace
}  // namespace echoreg::cli
