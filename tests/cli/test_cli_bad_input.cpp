// Every broken capture gets a clear error naming the file, exit code 1, and no output file.
#include "cli_test_support.hpp"
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/sequence.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

namespace echoreg::cli {
namespace {

using test::runEchoreg;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void spill(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

class CliBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    good_ = dir_.file("good.igs.mha");
    core::SequenceWriteOptions raw;
    raw.compress = false;
    core::writeSequence(test::makeDemoSweep({8}), good_, raw);
    core::SequenceWriteOptions zipped;
    core::writeSequence(test::makeDemoSweep({8}), dir_.file("zipped.igs.mha"), zipped);
    text_ = slurp(good_);
  }

  // Writes a variant of the good file with `from` replaced by `to` in the header.
  std::string variant(const std::string& name, const std::string& from, const std::string& to) {
    std::string bytes = text_;
    const std::size_t at = bytes.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos)
      bytes.replace(at, from.size(), to);
    const std::string path = dir_.file(name);
    spill(path, bytes);
    return path;
  }

  void expectRefused(const std::string& capture, const std::string& phrase) {
    const std::string csv = dir_.file("out.csv");
    for (const std::string& command : {std::string("detect"), std::string("info")}) {
      std::vector<std::string> args{command, capture};
      if (command == "detect")
        args.insert(args.end(), {"--out", csv});
      const auto result = runEchoreg(args);
      EXPECT_EQ(result.exitCode, 1) << command << " " << capture << "\n" << result.err;
      EXPECT_NE(result.err.find(capture), std::string::npos) << result.err;
      EXPECT_NE(result.err.find(phrase), std::string::npos)
          << "expected \"" << phrase << "\" in: " << result.err;
      EXPECT_FALSE(std::filesystem::exists(csv));
    }
  }

  test::TempDir dir_;
  std::string good_;
  std::string text_;
};

TEST_F(CliBadInput, GoodFileIsAccepted) {
  EXPECT_EQ(runEchoreg({"detect", good_, "--out", dir_.file("ok.csv")}).exitCode, 0);
  EXPECT_TRUE(std::filesystem::exists(dir_.file("ok.csv")));
}

TEST_F(CliBadInput, TruncatedData) {
  const std::string path = dir_.file("truncated.igs.mha");
  spill(path, text_.substr(0, text_.size() - 5000));
  expectRefused(path, "truncated");
}

TEST_F(CliBadInput, TruncatedHeader) {
  const std::string path = dir_.file("header.igs.mha");
  spill(path, text_.substr(0, 300));
  expectRefused(path, "ElementDataFile");
}

TEST_F(CliBadInput, WrongDimSize) {
  expectRefused(variant("dims.igs.mha", "DimSize = 4096 1 8", "DimSize = 4096 1"), "DimSize");
  expectRefused(variant("dims2.igs.mha", "DimSize = 4096 1 8", "DimSize = 4096 1 9"), "DimSize");
}

// Issue 15, item 8: "DimSize 0 1 800" with the pixels still after the header read as a
// tracker-only capture (every A-line dropped without a word).
TEST_F(CliBadInput, FramesWithoutSamplesButPixelsAfterTheHeader) {
  expectRefused(variant("nosamples.igs.mha", "DimSize = 4096 1 8", "DimSize = 0 1 8"),
                "DimSize 0 1 8 declares frames without samples (a tracker-only capture), but "
                "32768 bytes of data follow the header: is the header's DimSize wrong? (8 frames "
                "of 4096 uint8 samples would be 32768 bytes)");
  expectRefused(variant("norows.igs.mha", "DimSize = 4096 1 8", "DimSize = 4096 0 8"),
                "declares frames without samples");
}

TEST_F(CliBadInput, UnknownElementType) {
  expectRefused(variant("type.igs.mha", "ElementType = MET_UCHAR", "ElementType = MET_QUATERNION"),
                "MET_QUATERNION");
}

TEST_F(CliBadInput, NoElementDataFile) {
  expectRefused(variant("nodata.igs.mha", "ElementDataFile = LOCAL", "ElementDataFiel = LOCAL"),
                "ElementDataFile");
}

TEST_F(CliBadInput, CompressedDataThatDoesNotInflate) {
  std::string bytes = slurp(dir_.file("zipped.igs.mha"));
  const std::size_t data = bytes.find("ElementDataFile = LOCAL\n") + 24;
  for (std::size_t i = data + 10; i < bytes.size() && i < data + 200; ++i)
    bytes[i] = static_cast<char>(bytes[i] ^ 0x5A);
  const std::string path = dir_.file("corrupt.igs.mha");
  spill(path, bytes);
  expectRefused(path, "inflate");
}

TEST_F(CliBadInput, NanInATransform) {
  // The first matrix element of frame 0 ("1") becomes "nan".
  const std::string key = "Seq_Frame0000_ProbeToTrackerTransform = 1 ";
  expectRefused(variant("nan.igs.mha", key, "Seq_Frame0000_ProbeToTrackerTransform = nan "),
                "Seq_Frame0000_ProbeToTrackerTransform");
}

TEST_F(CliBadInput, TransformWithFifteenNumbers) {
  // Drop the last number (" 1") of frame 1's matrix.
  const std::string key = "Seq_Frame0001_ProbeToTrackerTransform = ";
  const std::size_t begin = text_.find(key);
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = text_.find('\n', begin);
  const std::string line = text_.substr(begin, end - begin);
  ASSERT_EQ(line.substr(line.size() - 2), " 1");
  expectRefused(variant("fifteen.igs.mha", line, line.substr(0, line.size() - 2)),
                key.substr(0, 37));
}

TEST_F(CliBadInput, EmptySequence) {
  const std::string header = text_.substr(0, text_.find("ElementDataFile = LOCAL\n") + 24);
  std::istringstream lines(header);
  std::string kept;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("Seq_Frame", 0) == 0)
      continue;
    kept += (line == "DimSize = 4096 1 8" ? std::string("DimSize = 4096 1 0") : line) + "\n";
  }
  const std::string path = dir_.file("empty.igs.mha");
  spill(path, kept);
  expectRefused(path, "no frames");
}

TEST_F(CliBadInput, DirectoryAndMissingFile) {
  expectRefused(dir_.path(), "directory");
  expectRefused(dir_.file("absent.igs.mha"), "absent.igs.mha");
}

TEST_F(CliBadInput, TrackerOnlyCaptureHasNoALinesToDetect) {
  ECHOREG_REQUIRE_SHARED_FILE(capture,
                              "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  const auto result = runEchoreg({"detect", capture, "--out", dir_.file("t.csv")});
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_NE(result.err.find("no A-lines"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.file("t.csv")));
}

}  // namespace
}  // namespace echoreg::cli
