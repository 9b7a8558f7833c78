// Issue 15, items 1 and 9: no command writes over one of its inputs or over another of its outputs
// (after links), and a transform's --out ending in .tfm is refused; in each case exit 1, a message
// naming both flags, and nothing written or destroyed.
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void spill(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// No file of `dir` other than `expected` exists (no output, no temporary left behind).
void expectOnly(const std::string& dir, std::vector<std::string> expected) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir))
    names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(names, expected);
}

class CliOutputPaths : public ::testing::Test {
 protected:
  void SetUp() override {
    capture_ = dir_.file("sweep.igs.mha");
    core::writeSequence(test::makeDemoSweep({8}), capture_);
    bytes_ = slurp(capture_);
  }

  void expectRefused(const test::CommandResult& result, const std::vector<std::string>& phrases) {
    EXPECT_EQ(result.exitCode, 1) << result.err;
    for (const std::string& phrase : phrases) {
      EXPECT_TRUE(contains(result.err, phrase))
          << "expected \"" << phrase << "\" in: " << result.err;
    }
    EXPECT_EQ(slurp(capture_), bytes_) << "the input was changed";
  }

  test::TempDir dir_;
  std::string capture_;
  std::string bytes_;
};

TEST_F(CliOutputPaths, DetectRefusesToWriteOverItsCapture) {
  const auto result = runEchoreg({"detect", capture_, "--out", capture_});
  expectRefused(result, {"--out", "the same file as the input capture", "refusing to overwrite"});
  expectOnly(dir_.path(), {"sweep.igs.mha"});
}

TEST_F(CliOutputPaths, DetectRefusesACaptureReachedThroughLinks) {
  fs::create_symlink(capture_, dir_.file("link.igs.mha"));
  fs::create_directory(dir_.file("sub"));
  const std::string viaDots = dir_.path() + "/sub/../link.igs.mha";
  expectRefused(runEchoreg({"detect", capture_, "--out", viaDots}), {"--out", "capture"});
  fs::create_hard_link(capture_, dir_.file("hard.igs.mha"));
  expectRefused(runEchoreg({"detect", capture_, "--out", dir_.file("hard.igs.mha")}),
                {"--out", "capture"});
  EXPECT_TRUE(fs::is_symlink(dir_.file("link.igs.mha")));
  expectOnly(dir_.path(), {"hard.igs.mha", "link.igs.mha", "sub", "sweep.igs.mha"});
}

TEST_F(CliOutputPaths, DetectRefusesAnEmptyOut) {
  const auto result = runEchoreg({"detect", capture_, "--out", ""});
  expectRefused(result, {"--out is an empty name"});
}

TEST_F(CliOutputPaths, TransformCommandsRefuseToWriteOverAnInput) {
  // Refused before anything is read: the inputs need not be valid for the check.
  const std::string tip = dir_.file("tip.json");
  spill(tip, "{}");
  const std::string tipBytes = slurp(tip);
  expectRefused(runEchoreg({"pivot", "--capture", capture_, "--out", capture_}),
                {"--out", "--capture"});
  expectRefused(runEchoreg({"calibrate", "--sphere-capture", capture_, "--stylus-tip-to-stylus",
                            tip, "--capture", capture_, "--initial", "0", "0", "0", "--out", tip}),
                {"--out", "--stylus-tip-to-stylus"});
  expectRefused(runEchoreg({"landmarks", "--capture", capture_, "--stylus-tip-to-stylus", tip,
                            "--landmarks", tip, "--out", tip}),
                {"--out", "--stylus-tip-to-stylus"});
  expectRefused(runEchoreg({"register", "--model", tip, "--points", capture_, "--initial", tip,
                            "--out", capture_}),
                {"--out", "--points"});
  EXPECT_EQ(slurp(tip), tipBytes);
  expectOnly(dir_.path(), {"sweep.igs.mha", "tip.json"});
}

TEST_F(CliOutputPaths, TransformOutEndingInTfmIsRefused) {
  const std::string tip = dir_.file("tip.json");
  spill(tip, "{}");
  const std::string out = dir_.file("result.tfm");
  const std::vector<std::vector<std::string>> commands{
      {"pivot", "--capture", capture_, "--out", out},
      {"calibrate", "--sphere-capture", capture_, "--stylus-tip-to-stylus", tip, "--capture",
       capture_, "--initial", "0", "0", "0", "--out", out},
      {"landmarks", "--capture", capture_, "--stylus-tip-to-stylus", tip, "--landmarks", tip,
       "--out", out},
      {"register", "--model", tip, "--points", capture_, "--initial", tip, "--out", out}};
  for (const auto& args : commands) {
    SCOPED_TRACE(args.front());
    expectRefused(runEchoreg(args), {"--out", "ends in .tfm", "give --out a .json name"});
    EXPECT_FALSE(fs::exists(out));
  }
  expectOnly(dir_.path(), {"sweep.igs.mha", "tip.json"});
}

TEST_F(CliOutputPaths, EvaluateAndFiguresRefuseToWriteOverAnInput) {
  const std::string reference = dir_.file("reference.json");
  spill(reference,
        R"({"from": "Femur", "to": "CT", "matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
  const std::string referenceBytes = slurp(reference);
  expectRefused(runEchoreg({"evaluate", "--reference", reference, "--estimate", reference, "--out",
                            reference}),
                {"--out", "the same file as the input --reference"});
  const std::string csv = dir_.file("errors.csv");
  spill(csv, "estimate,error_mm\na,1\nb,2\n");
  const std::string csvBytes = slurp(csv);
  expectRefused(runEchoreg({"figure", "boxplot", "--group", "a=" + csv, "--out", csv}),
                {"--out", "--group"});
  expectRefused(runEchoreg({"figure", "signals", "--capture", capture_, "--out", capture_}),
                {"--out", "--capture"});
  expectRefused(runEchoreg({"figure", "registration", "--model", csv, "--points", csv,
                            "--transform", reference, "--out", reference}),
                {"--out", "--transform"});
  EXPECT_EQ(slurp(reference), referenceBytes);
  EXPECT_EQ(slurp(csv), csvBytes);
  expectOnly(dir_.path(), {"errors.csv", "reference.json", "sweep.igs.mha"});
}

TEST_F(CliOutputPaths, SegmentRefusesTwoOutputsOfOneName) {
  fs::create_directory(dir_.file("series"));
  const std::string model = dir_.file("femur.vtp");
  const auto result =
      runEchoreg({"segment", "--dicom", dir_.file("series"), "--bone", "femur", "--auto", "--seed",
                  "0", "0", "0", "--out", model, "--accessible-out", model});
  expectRefused(result, {"--out", "--accessible-out", "are the same file"});
  expectOnly(dir_.path(), {"series", "sweep.igs.mha"});
}

}  // namespace
}  // namespace echoreg::cli
