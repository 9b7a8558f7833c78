// Execution counts per command (issue 14): each command that detects runs its captures through the
// VTK pipeline (filters::DetectionPipeline), and runs each capture's peak filter once and computes
// each frame's envelope once, streaming the capture in blocks (one envelope execution per block;
// only the study's signals figures envelope the whole capture in one execution). The counts are
// the filters' own (RequestData, frames enveloped), tallied by capture by the pipeline.
#include "cli_test_support.hpp"
#include "file_bytes.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include "command_figure.hpp"
#include "csv_table.hpp"
#include "echoreg/filters/detection_pipeline.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
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
// and `envelopes(frames)` envelope executions; `updates` names captures updated more often than
// once, with the number of further updates of the whole capture at once (each a peak execution
// and one envelope execution of every frame). Captures named relative to a study are read from
// `folder`.
void expectEachDetectedOnce(const std::map<std::string, DetectionPipeline::Executions>& since,
                            const std::vector<std::string>& captures,
                            const std::function<int(long long)>& envelopes,
                            const std::string& folder = "",
                            const std::map<std::string, int>& updates = {}) {
  EXPECT_EQ(since.size(), captures.size());
  for (const std::string& capture : captures) {
    const auto found = since.find(capture);
    ASSERT_NE(found, since.end()) << capture << " was not detected through the pipeline";
    const auto frames = static_cast<long long>(
        core::readSequence(folder.empty() ? capture : folder + "/" + capture).frameCount());
    const auto more = updates.find(capture);
    const int further = more == updates.end() ? 0 : more->second;
    EXPECT_EQ(found->second.envelopeFrames, (1 + further) * frames)
        << capture << ": frames enveloped";
    EXPECT_EQ(found->second.envelope, envelopes(frames) + further)
        << capture << ": envelope executions";
    EXPECT_EQ(found->second.peaks, 1 + further) << capture << ": peak filter executions";
  }
}

// The signals figures `study run` drew of `bone`'s first sweep in `study`.
int signalsFigures(const std::string& study, const std::string& bone) {
  int figures = 0;
  for (const char* which : {"accepted", "rejected"})
    figures += fs::exists(study + "/results/figures/signals_" + bone + "_" + which + ".png");
  return figures;
}

// One envelope execution per block of frames (detect, register, calibrate, the study's sweeps).
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
  // A copy of the fixture's study without the truth's shots, so that Table 6.1's detection-rate
  // runs (each a `detect` of its own on the first sweep) do not run; returns its folder.
  std::string copyWithoutShots() const {
    const std::string study = dir_.file("study");
    fs::create_directories(study);
    for (const char* folder : {"captures", "ct", "truth"})
      fs::copy(path(folder), study + "/" + folder, fs::copy_options::recursive);
    nlohmann::json manifest = manifest_;
    manifest["truth"].erase("shots");
    std::ofstream(study + "/study.json") << manifest.dump(2);
    return study;
  }

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
  ASSERT_GT(core::readSequence(sweep).frameCount(),
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
  expectEachDetectedOnce(executionsSince(before), {sweep}, oneExecutionPerBlock);
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
  expectEachDetectedOnce(executionsSince(before), {shots}, oneExecutionPerBlock);
}

// The study: the calibration shots once, and each sweep once for both its points and its
// registration (before issue 14 each sweep was detected twice: by `detect` for the points, then
// by `register`). The truth's shots are left out so that Table 6.1's detection-rate runs, each a
// `detect` of its own on the first sweep, do not run.
TEST_F(ExecutionCounts, StudyRunDetectsEachSweepOnce) {
  const std::string study = copyWithoutShots();
  const nlohmann::json manifest = readJson(study + "/study.json");

  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r = runEchoreg({"study", "run", study, "--given-models"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::vector<std::string> captures = {manifest.at("calibration").at("capture")};
  for (const auto& [bone, entry] : manifest.at("bones").items()) {
    for (const auto& sweep : entry.at("ultrasound"))
      captures.push_back(sweep.get<std::string>());
  }
  ASSERT_GE(captures.size(), 3U) << "the fixture's study has a sweep per bone";
  // The signals figures of the first bone's first sweep update its envelope and peaks once per
  // setting compared (mozes2008 and the study's), each figure in a pipeline of its own with the
  // whole capture at once.
  const std::string bone = manifest.at("bones").begin().key();
  const int figures = signalsFigures(study, bone);
  ASSERT_GT(figures, 0) << "the study drew no signals figure";
  const std::string figured = manifest.at("bones").at(bone).at("ultrasound").at(0);
  // The study runs inside its folder: the captures as the manifest names them.
  expectEachDetectedOnce(executionsSince(before), captures, oneExecutionPerBlock, study,
                         {{figured, 2 * figures}});
}

// The study's signals figures draw the study's setting as its sweeps were detected: its preset with
// its --params (before, the figure ran the preset alone), and are tallied with the rest.
TEST_F(ExecutionCounts, StudySignalsFiguresUseTheStudysParams) {
  const std::string study = copyWithoutShots();
  const nlohmann::json manifest = readJson(study + "/study.json");
  const std::string params = dir_.file("params.json");
  std::ofstream(params) << R"({"threshold-factor": 2.0})";

  const auto before = DetectionPipeline::executionsByCapture();
  const test::CommandResult r =
      runEchoreg({"study", "run", study, "--given-models", "--params", params});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto since = executionsSince(before);

  // The figures are of the first bone's first sweep.
  const std::string bone = manifest.at("bones").begin().key();
  const std::string sweep = manifest.at("bones").at(bone).at("ultrasound").at(0);
  const int figures = signalsFigures(study, bone);
  ASSERT_GT(figures, 0) << "the study drew no signals figure";
  const auto found = since.find(sweep);
  ASSERT_NE(found, since.end());
  const auto frames = static_cast<long long>(core::readSequence(study + "/" + sweep).frameCount());
  const int updates = 1 + 2 * figures;  // the detection, then 2 settings per figure
  EXPECT_EQ(found->second.peaks, updates) << "the figures' peak filter updates are tallied";
  // The detection streamed in blocks, each figure's settings the whole capture at once.
  EXPECT_EQ(found->second.envelope, oneExecutionPerBlock(frames) + 2 * figures);
  EXPECT_EQ(found->second.envelopeFrames, updates * frames);

  // The accepted frame's figure is the one drawn with the study's preset and --params, not the
  // one without them.
  const cli::CsvTable points =
      cli::readCsvTable(study + "/results/points/" + bone + "_ultrasound_1.csv");
  const int status = points.column("status");
  const int frame = points.column("frame");
  ASSERT_GE(status, 0);
  ASSERT_GE(frame, 0);
  std::string accepted;
  for (const auto& row : points.rows) {
    if (row[static_cast<std::size_t>(status)] == "accepted") {
      accepted = row[static_cast<std::size_t>(frame)];
      break;
    }
  }
  ASSERT_FALSE(accepted.empty());
  const std::string preset = manifest.at("detection").at("preset");
  const auto draw = [&](const std::string& paramsFile, const std::string& out) {
    cli::SignalsFigureRequest request;
    request.capture = study + "/" + sweep;
    request.frame = std::stoi(accepted);
    request.settings = {{"mozes2008", "", {}}, {preset, paramsFile, {}}};
    request.title = bone + " sweep, frame " + accepted + " (accepted by the study's detection)";
    request.out = out;
    std::ostringstream printed, err;
    EXPECT_EQ(cli::runSignalsFigure(request, cli::Streams{printed, err}), 0) << err.str();
    return test::fileBytes(out);
  };
  const std::string drawn =
      test::fileBytes(study + "/results/figures/signals_" + bone + "_accepted.png");
  EXPECT_TRUE(draw(params, dir_.file("with.png")) == drawn) << "drawn with the study's --params";
  EXPECT_FALSE(draw("", dir_.file("without.png")) == drawn) << "the --params change the figure";
}

}  // namespace
}  // namespace echoreg::simulation
