// Image tests: one figure of each kind, produced through the CLI, compared with a small committed
// baseline by VTK's vtkTesting (its image difference, which tolerates a pixel's shift). Run with
// ECHOREG_UPDATE_BASELINES=1 to write the baselines after a deliberate change (then look at them).
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/mesh_io.h"

#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkTesting.h>
#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#ifndef ECHOREG_BASELINE_DIR
#error "ECHOREG_BASELINE_DIR must name tests/cli/baselines"
#endif

namespace {

using echoreg::test::runEchoreg;
using echoreg::test::TempDir;

// Compares `png` with baselines/<name>; with ECHOREG_UPDATE_BASELINES set, writes it there instead.
void expectMatchesBaseline(const std::string& png, const std::string& name) {
  const std::string baseline = std::string(ECHOREG_BASELINE_DIR) + "/" + name;
  if (std::getenv("ECHOREG_UPDATE_BASELINES") != nullptr) {
    std::filesystem::copy_file(png, baseline, std::filesystem::copy_options::overwrite_existing);
    GTEST_SKIP() << "baseline written: " << baseline;
  }
  ASSERT_TRUE(std::filesystem::exists(baseline)) << "no baseline " << baseline;
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(png.c_str());
  vtkNew<vtkTesting> testing;
  testing->AddArgument("-V");
  testing->AddArgument(baseline.c_str());
  testing->AddArgument("-T");
  const std::string tmp = std::filesystem::path(png).parent_path().string();
  testing->AddArgument(tmp.c_str());
  std::ostringstream log;
  const int result = testing->RegressionTest(reader, 15.0, log);
  EXPECT_EQ(result, vtkTesting::PASSED) << name << " differs from its baseline: " << log.str();
}

// A 30 mm sphere standing in for a bone.
void writeSphereModel(const std::string& path) {
  const echoreg::core::TriangleMesh mesh =
      echoreg::core::uvSphere(Eigen::Vector3d::Zero(), 30.0, 24, 48);
  echoreg::filters::writeMesh(path, mesh);
}

TEST(FigureBaselines, Registration) {
  TempDir dir;
  writeSphereModel(dir.file("bone.vtp"));
  std::ofstream points(dir.file("points.csv"));
  points << "x,y,z\n";
  for (int i = 0; i < 24; ++i) {  // a ring of points at 1, 4 and 7 mm off the surface
    const double a = 2 * M_PI * i / 24;
    const double r = 30.0 + (i % 3 == 0 ? 1.0 : (i % 3 == 1 ? 4.0 : 7.0));
    points << r * std::cos(a) << ',' << 0.0 << ',' << r * std::sin(a) << '\n';
  }
  points.close();
  echoreg::core::TransformFile t;
  t.from = "Femur";
  t.to = "CT";
  echoreg::core::writeTransformFile(dir.file("FemurToCT.json"), t, false);
  const auto r = runEchoreg({"figure", "registration", "--model", dir.file("bone.vtp"), "--points",
                             dir.file("points.csv"), "--transform", dir.file("FemurToCT.json"),
                             "--title", "registration", "--width", "480", "--height", "220",
                             "--out", dir.file("registration.png")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectMatchesBaseline(dir.file("registration.png"), "registration.png");
}

TEST(FigureBaselines, Calibration) {
  TempDir dir;
  nlohmann::json cal = {{"sphere_center_mm", {0, 0, 0}}, {"sphere_radius_mm", 25.4}};
  cal["shots"] = nlohmann::json::array();
  for (int i = 0; i < 30; ++i) {
    const double a = 0.2 * i;
    const double residual = i % 5 == 0 ? 1.2 : (i % 5 == 1 ? 0.7 : 0.1);
    const double r = 25.4 + residual;
    cal["shots"].push_back(
        {{"frame", i},
         {"residual_mm", residual},
         {"used", true},
         {"point_mm", {r * std::cos(a) * 0.8, -r * 0.6, r * std::sin(a) * 0.8}}});
  }
  std::ofstream(dir.file("cal.json")) << cal.dump();
  const auto r =
      runEchoreg({"figure", "calibration", "--calibration", dir.file("cal.json"), "--width", "480",
                  "--height", "220", "--out", dir.file("calibration.png")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectMatchesBaseline(dir.file("calibration.png"), "calibration.png");
}

TEST(FigureBaselines, Signals) {
  TempDir dir;
  echoreg::test::DemoSweepOptions options;
  options.frames = 8;
  echoreg::core::writeSequence(echoreg::test::makeDemoSweep(options), dir.file("sweep.igs.mha"));
  const auto r = runEchoreg({"figure", "signals", "--capture", dir.file("sweep.igs.mha"), "--frame",
                             "3", "--preset", "mozes2008", "--preset", "default", "--width", "500",
                             "--height", "420", "--out", dir.file("signals.png")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectMatchesBaseline(dir.file("signals.png"), "signals.png");
}

TEST(FigureBaselines, Boxplot) {
  TempDir dir;
  std::ofstream(dir.file("a.csv")) << "e\n0.24\n0.31\n0.18\n0.45\n0.29\n0.33\n";
  std::ofstream(dir.file("b.csv")) << "e\n0.52\n0.61\n0.47\n0.70\n0.39\n0.58\n0.66\n1.9\n";
  const auto r =
      runEchoreg({"figure", "boxplot", "--group", "glove=" + dir.file("a.csv"), "--group",
                  "gel=" + dir.file("b.csv"), "--column", "e", "--title", "boxplot", "--width",
                  "420", "--height", "320", "--out", dir.file("boxplot.png")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectMatchesBaseline(dir.file("boxplot.png"), "boxplot.png");
}

}  // namespace
