// `echoreg detect` on the inputs issue 12 met: frames of several rows, ring-downs longer than the
// record, --causal=false, whole numbers written 30.0, a transducer that does not move, windows
// inside the ring-down, and captures where most frames are rejected.
#include "aline_generator.hpp"
#include "cli_test_support.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace echoreg::cli {
namespace {

using test::runEchoreg;

// A static transducer over bone at a steady depth: a ring-down burst, speckle, the bone echo at
// `boneSample`, its shadow; int16 samples, `rows` rows per frame.
core::Sequence staticCapture(int frames, int samples, double boneSample, int rows = 1,
                             double boneAmplitude = 900.0) {
  core::Sequence sequence;
  sequence.elementType = core::ElementType::Int16;
  sequence.frameSize = {samples, rows};
  sequence.acquisition.samplingFrequencyHz = 50e6;
  sequence.acquisition.speedOfSoundMps = 1540.0;
  test::PulseModel pulse;
  for (int f = 0; f < frames; ++f) {
    core::SequenceFrame frame;
    frame.timestampS = 0.01 * f;
    sequence.frames.push_back(frame);
    for (int r = 0; r < rows; ++r) {
      std::vector<test::EchoSpec> echoes{{8.0, 20000.0}, {16.0, 15000.0}};
      for (double s = 60.0; s < boneSample - 10.0; s += 3.0) {
        echoes.push_back({s, 40.0 * ((static_cast<int>(s) * 7 + f) % 11 - 5)});
      }
      echoes.push_back({boneSample + 0.2 * (f % 3), boneAmplitude});
      const std::vector<float> x = test::makeEchoRecord(samples, echoes, pulse, 60.0, 4.0,
                                                        static_cast<std::uint64_t>(f * 31 + r + 1));
      for (float v : x) {
        const auto code = static_cast<std::int16_t>(std::lround(std::clamp(v, -32768.F, 32767.F)));
        std::uint8_t bytes[2];
        std::memcpy(bytes, &code, 2);
        sequence.pixels.push_back(bytes[0]);
        sequence.pixels.push_back(bytes[1]);
      }
    }
  }
  return sequence;
}

TEST(CliDetectInputs, FramesOfSeveralRowsAreRefused) {
  test::TempDir dir;
  const std::string capture = dir.file("holder.igs.mha");
  core::writeSequence(staticCapture(4, 1500, 400.0, 15), capture);
  const std::string csv = dir.file("d.csv");
  const auto result = runEchoreg({"detect", capture, "--out", csv});
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_NE(result.err.find("holder.igs.mha"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("15 rows of 1500 samples"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(csv));
}

// Issue 15, item 8: a calibration without the probe's pose would be ignored without a word.
TEST(CliDetectInputs, BeamToProbeWithoutAPoseIsRefused) {
  test::TempDir dir;
  const std::string capture = dir.file("static.igs.mha");
  core::writeSequence(staticCapture(4, 1500, 400.0, 1), capture);
  const std::string calibration = dir.file("calibration.json");
  std::ofstream(calibration) << R"({"from": "Beam", "to": "Probe", "matrix": [[1, 0, 0, 0], )"
                             << R"([0, 1, 0, 0], [0, 0, 1, 2.5], [0, 0, 0, 1]]})";
  const std::string csv = dir.file("d.csv");
  const auto result = runEchoreg({"detect", capture, "--beam-to-probe", calibration, "--out", csv});
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_NE(result.err.find("--beam-to-probe"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("--pose"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(csv));
}

TEST(CliDetectInputs, ARingDownLongerThanTheRecordIsRefused) {
  test::TempDir dir;
  const std::string capture = dir.file("c.igs.mha");
  core::writeSequence(staticCapture(4, 1500, 400.0), capture);
  const std::string csv = dir.file("d.csv");
  const auto result = runEchoreg({"detect", capture, "--ring-down", "1500", "--out", csv});
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_NE(result.err.find("covers the whole 1500-sample record"), std::string::npos)
      << result.err;
  EXPECT_FALSE(std::filesystem::exists(csv));
}

TEST(CliDetectInputs, CausalFalseIsZeroPhase) {
  test::TempDir dir;
  const std::string capture = dir.file("c.igs.mha");
  core::writeSequence(staticCapture(6, 1500, 400.0), capture);
  const auto run = [&](const std::vector<std::string>& extra, const std::string& name) {
    std::vector<std::string> args{"detect", capture,     "--preset", "mozes2008", "--peaks",
                                  "max",    "--history", "1",        "--out",     dir.file(name)};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto result = runEchoreg(args);
    EXPECT_EQ(result.exitCode, 0) << result.err;
    std::ifstream in(dir.file(name));
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string causal = run({"--causal"}, "causal.csv");
  const std::string causalTrue = run({"--causal=true"}, "true.csv");
  const std::string zeroPhase = run({"--causal=false"}, "false.csv");
  EXPECT_EQ(causal, causalTrue);
  EXPECT_NE(causal, zeroPhase);  // the one causal pass moves every peak deeper
}

TEST(CliDetectInputs, WholeNumbersMayBeWrittenWithAPointInParamsFiles) {
  test::TempDir dir;
  const std::string capture = dir.file("c.igs.mha");
  core::writeSequence(staticCapture(4, 1500, 400.0), capture);
  std::ofstream(dir.file("ok.json")) << R"({"envelope-window": 30.0})";
  std::ofstream(dir.file("bad.json")) << R"({"envelope-window": 30.5})";
  auto result = runEchoreg(
      {"detect", capture, "--params", dir.file("ok.json"), "--out", dir.file("d.csv"), "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  EXPECT_EQ(nlohmann::json::parse(result.out)["envelope_window_samples"], 30);
  result =
      runEchoreg({"detect", capture, "--params", dir.file("bad.json"), "--out", dir.file("e.csv")});
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_NE(result.err.find("must be a whole number, found 30.5"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("e.csv")));
}

TEST(CliDetectInputs, AStaticTransducerWithoutPosesKeepsItsEchoes) {
  // A strapped transducer that does not move: without poses (0, 0, depth) says nothing about
  // where the beam was, so the spatial filter does not run; the temporal filter keeps a steady
  // bone.
  test::TempDir dir;
  const std::string capture = dir.file("c.igs.mha");
  core::writeSequence(staticCapture(60, 1500, 400.0), capture);
  const auto result = runEchoreg({"detect", capture, "--out", dir.file("d.csv"), "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  const auto summary = nlohmann::json::parse(result.out);
  EXPECT_EQ(summary["rejected_by_reason"].count("too-close"), 0U) << summary.dump();
  EXPECT_GE(summary["accepted"].get<int>(), 54) << summary.dump();
  EXPECT_EQ(summary["ring_down_source"], "measured");
  EXPECT_LT(summary["ring_down_samples"].get<int>(), 80);  // not the old fixed 200 samples
}

TEST(CliDetectInputs, AWindowInsideTheRingDownAndFewAcceptedFramesAreExplained) {
  test::TempDir dir;
  const std::string capture = dir.file("c.igs.mha");
  core::writeSequence(staticCapture(20, 1500, 400.0), capture);
  // The burst lasts to about sample 30 (0.46 mm); a window of 0.1-0.4 mm lies inside it.
  const auto result = runEchoreg(
      {"detect", capture, "--window-mm", "0.1", "0.4", "--out", dir.file("d.csv"), "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  const auto summary = nlohmann::json::parse(result.out);
  EXPECT_EQ(summary["rejected_by_reason"]["in-ring-down"], 20) << summary.dump();
  std::string warnings;
  for (const auto& w : summary["warnings"])
    warnings += w.get<std::string>() + "\n";
  EXPECT_NE(warnings.find("inside the ring-down"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("only 0.0 % of the frames were accepted"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("in-ring-down"), std::string::npos) << warnings;
  EXPECT_NE(result.err.find("warning: only 0.0 %"), std::string::npos) << result.err;
}

TEST(CliDetectInputs, UnsignedSixteenBitCapturesAreRead) {
  test::TempDir dir;
  core::Sequence sequence = staticCapture(8, 1500, 400.0);
  // The same records stored as uint16 around mid-scale.
  sequence.elementType = core::ElementType::UInt16;
  for (std::size_t i = 0; i + 1 < sequence.pixels.size(); i += 2) {
    std::int16_t code;
    std::memcpy(&code, &sequence.pixels[i], 2);
    const auto shifted = static_cast<std::uint16_t>(static_cast<int>(code) + 32768);
    std::memcpy(&sequence.pixels[i], &shifted, 2);
  }
  const std::string capture = dir.file("u16.igs.mha");
  core::writeSequence(sequence, capture);
  EXPECT_EQ(core::readSequence(capture).elementType, core::ElementType::UInt16);
  const auto result = runEchoreg({"detect", capture, "--out", dir.file("d.csv"), "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  EXPECT_GE(nlohmann::json::parse(result.out)["accepted"].get<int>(), 6);
}

}  // namespace
}  // namespace echoreg::cli
