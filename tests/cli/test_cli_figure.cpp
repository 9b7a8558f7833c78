// `echoreg figure ...` end to end: each kind of figure from files, its numbers, bad input.
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/mesh_io.h"

#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace {

using echoreg::test::runEchoreg;
using echoreg::test::TempDir;

// A closed box mesh 40 x 40 x 40 mm centred at the origin.
echoreg::core::TriangleMesh boxMesh() {
  echoreg::core::TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.push_back({(i & 1) ? 20.0 : -20.0, (i & 2) ? 20.0 : -20.0, (i & 4) ? 20.0 : -20.0});
  }
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

std::array<int, 2> pngSize(const std::string& path) {
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  int dims[3];
  reader->GetOutput()->GetDimensions(dims);
  return {dims[0], dims[1]};
}

TEST(CliFigure, RegistrationFigureCountsPointsPerBand) {
  TempDir dir;
  echoreg::filters::writeMesh(dir.file("box.vtp"), boxMesh());
  // The points in the tracker's frame; FemurToCT shifts them by +10 mm in x.
  std::ofstream(dir.file("points.csv")) << "x,y,z\n"
                                           "-10,0,-21\n"   // 1 mm below the bottom face
                                           "-10,5,23.5\n"  // 3.5 mm above the top face
                                           "-10,-30,0\n"   // 10 mm in front
                                           "-10,0,0\n";    // 20 mm inside
  echoreg::core::TransformFile t;
  t.from = "Femur";
  t.to = "CT";
  t.matrix = Eigen::Matrix4d::Identity();
  t.matrix(0, 3) = 10.0;
  echoreg::core::writeTransformFile(dir.file("FemurToCT.json"), t, false);
  const auto r =
      runEchoreg({"figure", "registration", "--model", dir.file("box.vtp"), "--points",
                  dir.file("points.csv"), "--transform", dir.file("FemurToCT.json"), "--out",
                  dir.file("reg.png"), "--width", "600", "--height", "300", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["points"], 4);
  EXPECT_EQ(json["bands"][0]["points"], 1);
  EXPECT_EQ(json["bands"][1]["points"], 1);
  EXPECT_EQ(json["bands"][2]["points"], 2);
  EXPECT_NEAR(json["mean_signed_mm"].get<double>(), (1 + 3.5 + 10 - 20) / 4.0, 1e-9);
  EXPECT_EQ(pngSize(dir.file("reg.png")), (std::array<int, 2>{600, 300}));
}

TEST(CliFigure, CalibrationFigureReadsTheCalibrationsShots) {
  TempDir dir;
  nlohmann::json cal = {{"from", "Beam"},
                        {"to", "Probe"},
                        {"matrix", {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}},
                        {"sphere_center_mm", {10, 20, 30}},
                        {"sphere_radius_mm", 25.4}};
  cal["shots"] = nlohmann::json::array();
  for (int i = 0; i < 20; ++i) {
    const double a = 0.3 * i;
    const double residual = i < 15 ? 0.2 : (i < 18 ? 0.7 : -1.5);
    const double r = 25.4 + residual;
    cal["shots"].push_back({{"frame", i},
                            {"depth_mm", 20.0},
                            {"residual_mm", residual},
                            {"used", true},
                            {"point_mm", {10 + r * std::cos(a), 20 + r * std::sin(a), 30.0}}});
  }
  std::ofstream(dir.file("cal.json")) << cal.dump();
  const auto r =
      runEchoreg({"figure", "calibration", "--calibration", dir.file("cal.json"), "--out",
                  dir.file("cal.png"), "--width", "600", "--height", "300", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["bands"][0]["points"], 15);
  EXPECT_EQ(json["bands"][1]["points"], 3);
  EXPECT_EQ(json["bands"][2]["points"], 2);
  // A calibration written before points were recorded is refused, naming the file.
  cal["shots"][0].erase("point_mm");
  std::ofstream(dir.file("old.json")) << cal.dump();
  const auto old = runEchoreg({"figure", "calibration", "--calibration", dir.file("old.json"),
                               "--out", dir.file("old.png")});
  EXPECT_EQ(old.exitCode, 1);
  EXPECT_NE(old.err.find("old.json"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.file("old.png")));
}

TEST(CliFigure, SignalsFigureGivesEachSettingsVerdict) {
  TempDir dir;
  echoreg::test::DemoSweepOptions options;
  options.frames = 20;
  std::vector<double> depths;
  echoreg::core::writeSequence(echoreg::test::makeDemoSweep(options, &depths),
                               dir.file("sweep.igs.mha"));
  const auto r = runEchoreg({"figure", "signals", "--capture", dir.file("sweep.igs.mha"), "--frame",
                             "5", "--preset", "mozes2008", "--preset", "default", "--out",
                             dir.file("sig.png"), "--width", "800", "--height", "600", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  ASSERT_EQ(json["settings"].size(), 2u);
  ASSERT_TRUE(json["settings"][1]["accepted"].get<bool>()) << r.out;
  EXPECT_NEAR(json["settings"][1]["depth_mm"].get<double>(), depths[5], 1.0);
  EXPECT_EQ(pngSize(dir.file("sig.png")), (std::array<int, 2>{800, 600}));
  const auto bad = runEchoreg({"figure", "signals", "--capture", dir.file("sweep.igs.mha"),
                               "--frame", "20", "--out", dir.file("bad.png")});
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_NE(bad.err.find("has no frame 20"), std::string::npos) << bad.err;
}

// figure signals resolves its settings as detect does: a --params file (and the flags) over each
// preset, through detect's pipeline. A doubled threshold factor doubles the threshold drawn (the
// envelope is the same); the file's preset is the one setting when no --preset is given.
TEST(CliFigure, SignalsFigureUsesTheParamsFilesSettings) {
  TempDir dir;
  echoreg::test::DemoSweepOptions options;
  options.frames = 12;
  echoreg::core::writeSequence(echoreg::test::makeDemoSweep(options), dir.file("sweep.igs.mha"));
  const auto signals = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"figure",   "signals", "--capture", dir.file("sweep.igs.mha"),
                                  "--frame",  "4",       "--width",   "500",
                                  "--height", "400",     "--out",     dir.file("sig.png"),
                                  "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    return runEchoreg(args);
  };
  const auto plain = signals({"--preset", "mozes2008"});
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  const double threshold = nlohmann::json::parse(plain.out)["settings"][0]["threshold"];
  ASSERT_GT(threshold, 0.0);

  std::ofstream(dir.file("params.json")) << R"({"threshold-factor": 3.0})";
  const auto tuned = signals({"--preset", "mozes2008", "--params", dir.file("params.json")});
  ASSERT_EQ(tuned.exitCode, 0) << tuned.err;
  const auto json = nlohmann::json::parse(tuned.out);
  ASSERT_EQ(json["settings"].size(), 1u);
  EXPECT_NEAR(json["settings"][0]["threshold"].get<double>(), 2.0 * threshold, 1e-9 * threshold);
  // A flag over the file, as detect's precedence says.
  const auto flag = signals(
      {"--preset", "mozes2008", "--params", dir.file("params.json"), "--threshold-factor", "0.75"});
  ASSERT_EQ(flag.exitCode, 0) << flag.err;
  EXPECT_NEAR(nlohmann::json::parse(flag.out)["settings"][0]["threshold"].get<double>(),
              0.5 * threshold, 1e-9 * threshold);

  std::ofstream(dir.file("shadow.json")) << R"({"preset": "shadow"})";
  const auto filePreset = signals({"--params", dir.file("shadow.json")});
  ASSERT_EQ(filePreset.exitCode, 0) << filePreset.err;
  const auto presetJson = nlohmann::json::parse(filePreset.out);
  ASSERT_EQ(presetJson["settings"].size(), 1u);
  EXPECT_EQ(presetJson["settings"][0]["preset"], "shadow");

  std::ofstream(dir.file("bad.json")) << R"({"threshold-factor": "high"})";
  const auto bad = signals({"--params", dir.file("bad.json")});
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_NE(bad.err.find("bad.json"), std::string::npos) << bad.err;
  std::ofstream(dir.file("unknown.json")) << R"({"treshold-factor": 2})";
  const auto unknown = signals({"--params", dir.file("unknown.json")});
  EXPECT_EQ(unknown.exitCode, 1);
  EXPECT_NE(unknown.err.find("treshold-factor"), std::string::npos) << unknown.err;
}

TEST(CliFigure, BoxplotFigureRunsTheAnova) {
  TempDir dir;
  std::ofstream(dir.file("a.csv"))
      << "estimate,error_mm\na,0.24\nb,0.31\nc,0.18\nd,0.45\ne,0.29\nf,0.33\nmean_abs,0.3\n";
  std::ofstream(dir.file("b.csv"))
      << "estimate,error_mm\na,0.52\nb,0.61\nc,0.47\nd,0.70\ne,0.39\nf,0.58\ng,0.66\n";
  std::ofstream(dir.file("c.csv")) << "estimate,knee\na,0.30\nb,0.28\nc,0.41\nd,0.36\ne,0.25\n";
  const auto r =
      runEchoreg({"figure", "boxplot", "--group", "A=" + dir.file("a.csv"), "--group",
                  "B=" + dir.file("b.csv"), "--group", "C=" + dir.file("c.csv") + ":knee", "--out",
                  dir.file("box.png"), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["groups"][0]["n"], 6);  // the mean_abs summary row is not a value
  EXPECT_NEAR(json["anova"]["p"].get<double>(), 0.0001989631127352939, 1e-10);
  const auto missing = runEchoreg({"figure", "boxplot", "--group",
                                   "A=" + dir.file("a.csv") + ":nope", "--out", dir.file("x.png")});
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_NE(missing.err.find("has no column \"nope\""), std::string::npos) << missing.err;
  const auto usage =
      runEchoreg({"figure", "boxplot", "--group", "nofile", "--out", dir.file("x.png")});
  EXPECT_EQ(usage.exitCode, 1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}

}  // namespace
