// Execution counts per command (issue 14): each command that detects runs its captures through the
// VTK pipeline (filters::DetectionPipeline), and runs each capture's peak filter once and computes
// each frame's envelope once (`detect` streams the capture in blocks, one envelope execution per
// block; the others envelope the whole capture in one execution). The counts are the filters' own
// (RequestData, frames enveloped), tallied by capture by the pipeline.
#include "cli_test_support.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include "echoreg/filters/DetectionPipeline.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using filters::DetectionPipeline;
using test::runEchoreg;

// The executions since `before`, by capture; captures without any are left out.
std::map<std::string, DetectionPipeline::Executions> executionsSince(
    const std::map<std::string, DetectionPipeline::Executions>& before) {
  std::map<std::string, DetectionPipeline::Executions> since;
  for (const auto& [capture, now] : DetectionPipeline::executionsByCapture()) {
    const auto was = before.find(capture);
    DetectionPipeline::Executions delta = now;
    if (was != before.end()) {
      delta.envelope -= was->second.envelope;
      delta.peaks -= was->second.peaks;
      delta.envelopeFrames -= was->second.envelopeFrames;
    }
    if (delta.envelope != 0 || delta.peaks != 0)
      since[capture] = delta;
  }
  return since;
}

// Expects exactly `captures` detected, each with one peak execution, each frame enveloped once,
// and `envelopes(frames)` envelope executions. Captures named relative to a study are read from
// `folder`.
void expectEachDetectedOnce(const std::map<std::string, DetectionPipeline::Executions>& since,
                            const std::vector<std::string>& captures,
                            const std::function<int(long long)>& envelopes,
                            const std::string& folder = "") {
  EXPECT_EQ(since.size(), captures.size());
  for (const std::string& capture : captures) {
    const auto found = since.find(capture);
    ASSERT_NE(found, since.end()) << capture << " was not detected through the pipeline";
    const auto frames = static_cast<long long>(
        readSequence(folder.empty() ? capture : folder + "/" + capture).frameCount());
    EXPECT_EQ(found->second.envelopeFrames, frames) << capture << ": frames enveloped";
    EXPECT_EQ(found->second.envelope, envelopes(frames)) << capture << ": envelope executions";
    EXPECT_EQ(found->second.peaks, 1) << capture << ": peak filter executions";
  }
}

// The whole capture in one envelope execution (register, calibrate, the study).
int oneExecution(long long /*frames*/) {
  return 1;
}

// One envelope execution per block of frames (detect).
int oneExecutionPerBlock(long long frames) {
  const long long block = DetectionPipeline::kStreamFramesPerBlock;
  return static_cast<int>((frames + block - 1) / block);
}

class ExecutionCounts : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fixtureStudy();
    if (root_.empty())
      GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
    manifest_ = readJson(root_ + "/study.json");
  }
  std::string path(const std::string& relative) const { return root_ + "/" + relative; }

  std::string root_;
  nlohmann::json manifest_;
  test::TempDir dir_;
};

TEST_F(ExecutionCounts, DetectRunsThePipelineOnce) {
  const std::string sweep = path("captures/femur_ultrasound.igs.mha");
  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r = runEchoreg({"detect", sweep, "--out", dir_.file("d.csv")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectEachDetectedOnce(executionsSince(before), {sweep}, oneExecutionPerBlock);
  ASSERT_GT(readSequence(sweep).frameCount(),
            static_cast<std::size_t>(DetectionPipeline::kStreamFramesPerBlock))
      << "the sweep should take more than one block";
}

TEST_F(ExecutionCounts, RegisterRunsThePipelineOncePerSweep) {
  const std::string sweep = path("captures/tibia_ultrasound.igs.mha");
  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r =
      runEchoreg({"register", "--model", path("truth/tibia.vtp"), "--bone", "Tibia", "--capture",
                  sweep, "--calibration", path("truth/BeamToProbe.json"), "--initial",
                  path("truth/TibiaToCT.json"), "--out", dir_.file("r.json")});
  // (The sweep alone may leave the pose undetermined on some seeds: the detection ran all the
  // same.)
  ASSERT_TRUE(r.exitCode == 0 || r.err.find("not converged") != std::string::npos) << r.err;
  expectEachDetectedOnce(executionsSince(before), {sweep}, oneExecution);
}

TEST_F(ExecutionCounts, CalibrateRunsThePipelineOnceOnItsShots) {
  const nlohmann::json& c = manifest_.at("calibration");
  const std::string shots = path(c.at("capture"));
  const nlohmann::json& initial = c.at("initial_beam_to_probe_mm");
  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r = runEchoreg({"calibrate",
                                            "--sphere-capture",
                                            path(c.at("sphere_capture")),
                                            "--stylus-tip-to-stylus",
                                            path("truth/StylusTipToStylus.json"),
                                            "--capture",
                                            shots,
                                            "--sphere-radius",
                                            "25.4",
                                            "--stylus-tip-radius",
                                            "1.5",
                                            "--initial",
                                            initial[0].dump(),
                                            initial[1].dump(),
                                            initial[2].dump(),
                                            "--window-mm",
                                            c.at("window_mm")[0].dump(),
                                            c.at("window_mm")[1].dump(),
                                            "--fit-speed-of-sound",
                                            "--out",
                                            dir_.file("c.json")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectEachDetectedOnce(executionsSince(before), {shots}, oneExecution);
}

// The study: the calibration shots once, and each sweep once for both its points and its
// registration (before issue 14 each sweep was detected twice: by `detect` for the points, then
// by `register`). The truth's shots are left out so that Table 6.1's detection-rate runs, each a
// `detect` of its own on the first sweep, do not run.
TEST_F(ExecutionCounts, StudyRunDetectsEachSweepOnce) {
  const std::string study = dir_.file("study");
  fs::create_directories(study);
  for (const char* folder : {"captures", "ct", "truth"})
    fs::copy(path(folder), study + "/" + folder, fs::copy_options::recursive);
  nlohmann::json manifest = manifest_;
  manifest["truth"].erase("shots");
  std::ofstream(study + "/study.json") << manifest.dump(2);

  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r = runEchoreg({"study", "run", study, "--given-models"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::vector<std::string> captures = {manifest.at("calibration").at("capture")};
  for (const auto& [bone, entry] : manifest.at("bones").items()) {
    for (const auto& sweep : entry.at("ultrasound"))
      captures.push_back(sweep.get<std::string>());
  }
  ASSERT_GE(captures.size(), 3U) << "the fixture's study has a sweep per bone";
  // The study runs inside its folder: the captures as the manifest names them.
  expectEachDetectedOnce(executionsSince(before), captures, oneExecution, study);
}

}  // namespace
}  // namespace echoreg::simulation
