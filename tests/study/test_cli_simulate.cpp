// `echoreg simulate` from the command line: usage errors exit 2, failures exit 1 naming the file
// and leaving nothing, a small study prints its summary.
#include "cli_test_support.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace echoreg {
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
  for (const char* option : {"--probe-frequency", "--adc", "--soft-tissue-scale"})
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
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
}  // namespace echoreg
