// The files of samples/ must keep working: every --params file loads in `echoreg detect`, there
// is one per preset and one for a phantom, the real study's manifest passes `study run`'s checks
// and stops only at its first missing file, and the Slicer anchors file reads as live-wire
// contours.
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::runEchoreg;

const fs::path kSamples = ECHOREG_SAMPLES_DIR;

nlohmann::json readJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(Samples, EveryParamsFileLoadsInDetect) {
  test::TempDir dir;
  const std::string capture = dir.file("sweep.igs.mha");
  test::DemoSweepOptions sweep;
  sweep.frames = 80;
  core::writeSequence(test::makeDemoSweep(sweep), capture);
  std::set<std::string> presets;
  int files = 0;
  for (const auto& entry : fs::directory_iterator(kSamples / "params")) {
    if (entry.path().extension() != ".json")
      continue;
    ++files;
    SCOPED_TRACE(entry.path().string());
    const nlohmann::json params = readJson(entry.path());
    ASSERT_TRUE(params.contains("preset"));
    presets.insert(params["preset"].get<std::string>());
    const auto result = runEchoreg({"detect", capture, "--params", entry.path().string(), "--out",
                                    dir.file("depths.csv"), "--json"});
    ASSERT_EQ(result.exitCode, 0) << result.err;
    const nlohmann::json summary = nlohmann::json::parse(result.out);
    EXPECT_EQ(summary["preset"], params["preset"]);
    EXPECT_EQ(summary["frames"], 80);
    // What the file sets is what ran.
    if (params.contains("speed-of-sound")) {
      EXPECT_EQ(summary["speed_of_sound_mps"].get<double>(),
                params["speed-of-sound"].get<double>());
    }
    if (params.contains("envelope")) {
      EXPECT_EQ(summary["envelope"], params["envelope"]);
    }
    if (params.contains("peaks")) {
      EXPECT_EQ(summary["peaks"], params["peaks"]);
    }
  }
  for (const std::string& preset : core::detectionPresetNames())
    EXPECT_EQ(presets.count(preset), 1U) << "no sample params file for the preset " << preset;
  EXPECT_TRUE(fs::exists(kSamples / "params" / "phantom-water.json"));
  EXPECT_GE(files, static_cast<int>(core::detectionPresetNames().size()) + 1);
}

TEST(Samples, RealStudyManifestParsesAsFarAsItsMissingFiles) {
  test::TempDir dir;
  const fs::path study = fs::path(dir.file("study"));
  fs::create_directories(study);
  fs::copy_file(kSamples / "real-study" / "study.json", study / "study.json");
  const nlohmann::json manifest = readJson(study / "study.json");
  EXPECT_EQ(manifest["format"], "echoreg-study");
  EXPECT_FALSE(manifest.contains("truth")) << "a real study has no ground truth";

  const auto result = runEchoreg({"study", "run", study.string()});
  EXPECT_EQ(result.exitCode, 1);
  // Every check of the manifest passed: the run stops at the first file it needs.
  const std::string firstFile = manifest["calibration"]["pivot_capture"].get<std::string>();
  EXPECT_NE(result.err.find(firstFile + ": is missing"), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find("must be"), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find("not valid JSON"), std::string::npos) << result.err;
}

TEST(Samples, SlicerAnchorsReadAsSagittalLiveWireContours) {
  const fs::path path = kSamples / "anchors" / "femur_sagittal.mrk.json";
  const nlohmann::json markups = readJson(path);
  ASSERT_TRUE(markups.contains("markups"));
  EXPECT_EQ(markups["markups"][0]["type"], "ClosedCurve");
  const std::vector<segmentation::AnchorSet> contours = segmentation::readAnchors(path.string());
  ASSERT_EQ(contours.size(), 40U);
  for (const auto& contour : contours) {
    SCOPED_TRACE(contour.label);
    ASSERT_GE(contour.anchorsLps.size(), 3U);
    EXPECT_EQ(contour.plane, segmentation::SlicePlane::Sagittal);
    for (const Eigen::Vector3d& anchor : contour.anchorsLps)
      EXPECT_NEAR(anchor.x(), contour.positionMm, 1e-9) << "one sagittal plane per contour";
  }
}

}  // namespace
}  // namespace echoreg::cli
