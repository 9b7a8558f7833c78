// `echoreg simulate` from the command line: usage errors exit 2, failures exit 1 naming the file
// and leaving nothing, a small study prints its summary.
#include "cli_test_support.hpp"
#include "test_support.hpp"

#include "echoreg/core/mesh.hpp"
#include "echoreg/filters/mesh_io.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

TEST(CliSimulate, UsageErrorsExitTwo) {
  test::TempDir dir;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"simulate", "--out", dir.file("s"), "--preset", "sawbones"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--size", "medium"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--bone", "femur"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--bone", "patella=p.stl"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--flexion", "170"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--adc", "int12"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--soft-tissue-scale", "1.5"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--probe-frequency", "40e6"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--osteophytes", "-1"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--osteophytes", "9"},
        std::vector<std::string>{"simulate", "--out", dir.file("s"), "--osteophytes", "nan"},
        std::vector<std::string>{"simulate"}}) {
    const test::CommandResult r = runEchoreg(args);
    EXPECT_EQ(r.exitCode, 2) << args.back() << ": " << r.err;
    EXPECT_FALSE(r.err.empty());
  }
  EXPECT_FALSE(fs::exists(dir.file("s")));
  const test::CommandResult help = runEchoreg({"simulate", "--help"});
  EXPECT_EQ(help.exitCode, 0);
  EXPECT_NE(help.out.find("--preset"), std::string::npos);
  EXPECT_NE(help.out.find("--fibula-in-tibia"), std::string::npos);
  for (const char* option : {"--probe-frequency", "--adc", "--soft-tissue-scale", "--osteophytes"})
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
}

// Osteophytes out of range or on a user's femur are refused naming the flag, writing nothing.
TEST(CliSimulate, BadOsteophytesAreRefusedNamingTheFlag) {
  test::TempDir dir;
  for (const char* value : {"-0.5", "8.5", "inf", "four"}) {
    const test::CommandResult r =
        runEchoreg({"simulate", "--out", dir.file("s"), "--osteophytes", value});
    EXPECT_EQ(r.exitCode, 2) << value << ": " << r.err;
    EXPECT_NE(r.err.find("--osteophytes"), std::string::npos) << value << ": " << r.err;
    EXPECT_NE(r.err.find("0 to 8"), std::string::npos) << value << ": " << r.err;
  }
  std::ofstream(dir.file("femur.stl")) << "solid femur\nendsolid femur\n";
  const test::CommandResult r = runEchoreg({"simulate", "--out", dir.file("s"), "--osteophytes",
                                            "4", "--bone", "femur=" + dir.file("femur.stl")});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("--osteophytes"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("procedural femur"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.file("s")));
}

// The spurs reach the study's truth meshes (the femur and the tibia gain bone; fibula and patella
// stay) and its manifest; a study without them records nothing.
TEST(CliSimulate, OsteophytesReachTheTruthAndTheManifest) {
  test::TempDir dir;
  for (const char* name : {"plain", "spurs"}) {
    std::vector<std::string> args = {
        "simulate", "--out", dir.file(name), "--size", "small", "--frames-per-bone", "20"};
    if (std::string(name) == "spurs") {
      args.push_back("--osteophytes");
      args.push_back("4");
    }
    const test::CommandResult r = runEchoreg(args);
    ASSERT_EQ(r.exitCode, 0) << name << ": " << r.err;
  }
  auto volumeMm3 = [&](const std::string& study, const std::string& bone) {
    return core::checkMesh(filters::readMesh(dir.file(study + "/truth/" + bone + ".vtp")))
        .volumeMm3;
  };
  // The library's Anatomy.OsteophytesBridgeTheJointMargins: 4 mm spurs add about 1,800 mm^3 to
  // the femur and 900 mm^3 to the tibia (on a 1 mm joint; the healthy joint here).
  for (const char* bone : {"femur", "tibia"}) {
    const double added = volumeMm3("spurs", bone) - volumeMm3("plain", bone);
    EXPECT_GT(added, 300.0) << bone;
    EXPECT_LT(added, 4000.0) << bone;
  }
  for (const char* bone : {"fibula", "patella"})
    EXPECT_NEAR(volumeMm3("spurs", bone), volumeMm3("plain", bone), 1e-6) << bone;
  std::ifstream spurs(dir.file("spurs/study.json"));
  EXPECT_EQ(nlohmann::json::parse(spurs).at("generator").at("osteophyte_mm"), 4.0);
  std::ifstream plain(dir.file("plain/study.json"));
  EXPECT_FALSE(nlohmann::json::parse(plain).at("generator").contains("osteophyte_mm"));
}

TEST(CliSimulate, FailuresNameTheFileAndLeaveNothing) {
  test::TempDir dir;
  fs::create_directories(dir.file("taken"));
  std::ofstream(dir.file("taken/notes.txt")) << "keep me";
  test::CommandResult r = runEchoreg({"simulate", "--out", dir.file("taken"), "--size", "small"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(dir.file("taken")), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not empty"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_regular_file(dir.file("taken/notes.txt")));

  r = runEchoreg({"simulate", "--out", dir.file("s"), "--size", "small", "--bone",
                  "femur=" + dir.file("missing.stl")});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(dir.file("missing.stl")), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.file("s")));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir.path()))
    ++entries;
  EXPECT_EQ(entries, 1u) << "only the folder made by the test remains";
}

TEST(CliSimulate, SmallStudySummaryAsJson) {
  test::TempDir dir;
  const test::CommandResult r = runEchoreg({"simulate", "--out", dir.file("s"), "--size", "small",
                                            "--seed", "11", "--frames-per-bone", "40", "--preset",
                                            "phantom", "--registrations", "2", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  // 8 + 2 ultrasound captures per bone; no hip rotation for a clamped phantom.
  EXPECT_EQ(summary.at("captures"), 12);
  EXPECT_TRUE(fs::is_regular_file(dir.file("s/captures/tibia_ultrasound_2.igs.mha")));
  EXPECT_EQ(summary.at("ct").at("columns"), 256);
  EXPECT_GT(summary.at("ultrasound_frames").get<int>(), 60);
  EXPECT_TRUE(fs::is_regular_file(dir.file("s/study.json")));
  EXPECT_TRUE(r.err.empty()) << "no progress on a non-terminal: " << r.err;
}

TEST(CliSimulate, InVivoOptionsReachTheCapturesAndTheManifest) {
  test::TempDir dir;
  const test::CommandResult r =
      runEchoreg({"simulate", "--out", dir.file("s"), "--size", "small", "--frames-per-bone", "20",
                  "--standoff", "none", "--probe-frequency", "7e6", "--adc", "int16-12bit",
                  "--soft-tissue-scale", "0.3"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::ifstream capture(dir.file("s/captures/tibia_ultrasound.igs.mha"), std::ios::binary);
  std::string header(4096, '\0');
  capture.read(header.data(), static_cast<std::streamsize>(header.size()));
  EXPECT_NE(header.find("ElementType = MET_SHORT"), std::string::npos);
  EXPECT_NE(header.find("EchoregTransducerFrequencyHz = 7000000"), std::string::npos);
  EXPECT_NE(header.find("EchoregSamplingFrequencyHz = 50000000"), std::string::npos);
  std::ifstream manifest(dir.file("s/study.json"));
  const nlohmann::json study = nlohmann::json::parse(manifest);
  EXPECT_EQ(study.at("generator").at("probe_frequency_hz"), 7e6);
  EXPECT_EQ(study.at("generator").at("adc"), "int16-12bit");
  EXPECT_EQ(study.at("generator").at("soft_tissue_scale"), 0.3);
}

}  // namespace
}  // namespace echoreg::cli
