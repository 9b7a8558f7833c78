// The live recording streamed to disk: the final capture is byte for byte what writeSequence
// writes for the same frames; while the session runs (and after a crash) the partial files read
// as a capture of every frame flushed; a frame writeSequence would refuse is refused on add()
// without a gap in the recording; a folder that cannot be written fails finish() with the reason.
#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/live/capture_recorder.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <thread>

namespace echoreg::live {
namespace {

namespace fs = std::filesystem;

core::Sequence sweep(int frames) {
  test::DemoSweepOptions options;
  options.frames = frames;
  core::Sequence s = test::makeDemoSweep(options);
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    core::TrackedTransform femur;
    femur.matrix.topRightCorner<3, 1>() = Eigen::Vector3d(5.0, -3.0, 20.0 + 0.01 * double(f));
    s.frames[f].transforms["FemurToTracker"] = femur;
    s.frames[f].fields = {{"ImageStatus", "OK"}};
  }
  s.extraHeader.push_back({"UltrasoundImageOrientation", "MF"});
  return s;
}

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t frameBytes(const core::Sequence& s) {
  return s.samplesPerFrame() * core::elementSize(s.elementType);
}

void add(CaptureRecorder& recorder, const core::Sequence& s, std::size_t f) {
  recorder.add(s.frames[f], s.pixels.data() + f * frameBytes(s), frameBytes(s));
}

void expectSameFrames(const core::Sequence& got, const core::Sequence& want, std::size_t frames) {
  ASSERT_EQ(got.frames.size(), frames);
  EXPECT_EQ(got.frameSize, want.frameSize);
  EXPECT_EQ(got.elementType, want.elementType);
  ASSERT_EQ(got.pixels.size(), frames * frameBytes(want));
  EXPECT_TRUE(std::equal(got.pixels.begin(), got.pixels.end(), want.pixels.begin()));
  for (std::size_t f = 0; f < frames; ++f) {
    EXPECT_EQ(got.frames[f].timestampS, want.frames[f].timestampS) << f;
    EXPECT_EQ(got.frames[f].fields, want.frames[f].fields) << f;
    ASSERT_EQ(got.frames[f].transforms.size(), want.frames[f].transforms.size()) << f;
    for (const auto& [name, t] : want.frames[f].transforms) {
      EXPECT_EQ(got.frames[f].transforms.at(name).status, t.status) << f << " " << name;
      EXPECT_EQ(got.frames[f].transforms.at(name).matrix, t.matrix) << f << " " << name;
    }
  }
  EXPECT_EQ(got.acquisition.samplingFrequencyHz, want.acquisition.samplingFrequencyHz);
  EXPECT_EQ(got.extraHeader, want.extraHeader);
}

// Waits (bounded) until the partial capture holds `frames` frames.
bool waitForPartial(const CaptureRecorder& recorder, std::size_t frames) {
  for (int i = 0; i < 500; ++i) {
    if (fs::exists(recorder.partialPath())) {
      try {
        if (core::readSequence(recorder.partialPath()).frames.size() == frames)
          return true;
      } catch (const core::FileError&) {
        // Read while the writer was between its two writes: try again.
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

TEST(CaptureRecorder, FinalCaptureIsByteForByteWhatWriteSequenceWrites) {
  test::TempDir dir;
  const core::Sequence s =
      sweep(400);  // INVALID probe poses on frames 300-319, fields, header keys
  core::writeSequence(s, dir.file("whole.igs.mha"));
  {
    CaptureRecorder recorder(dir.file("rec.igs.mha"), s, 0.005);
    for (std::size_t f = 0; f < s.frames.size(); ++f) {
      add(recorder, s, f);
      if (f % 50 == 0)  // several flushes, each appending
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_EQ(recorder.finish(), 400U);
    EXPECT_FALSE(fs::exists(recorder.partialPath()));
    EXPECT_FALSE(fs::exists(recorder.partialDataPath()));
  }
  const std::string whole = bytesOf(dir.file("whole.igs.mha"));
  ASSERT_GT(whole.size(), 1000U);
  EXPECT_TRUE(bytesOf(dir.file("rec.igs.mha")) == whole);
  EXPECT_EQ(fs::file_size(dir.file("rec.igs.mha")), whole.size());
}

// Pixels over one compression block (4 MiB): the recording's pixels are deflated in blocks on
// several threads from the partial file, writeSequence's from memory; the bytes are the same, and
// they read back as the frames added.
TEST(CaptureRecorder, AMultiBlockRecordingIsStillWriteSequencesBytes) {
  test::TempDir dir;
  const core::Sequence s = sweep(2600);  // 10.6 MB of pixels: three blocks
  core::writeSequence(s, dir.file("whole.igs.mha"));
  {
    CaptureRecorder recorder(dir.file("rec.igs.mha"), s, 0.05);
    for (std::size_t f = 0; f < s.frames.size(); ++f)
      add(recorder, s, f);
    EXPECT_EQ(recorder.finish(), 2600U);
  }
  const std::string whole = bytesOf(dir.file("whole.igs.mha"));
  EXPECT_TRUE(bytesOf(dir.file("rec.igs.mha")) == whole);
  EXPECT_EQ(core::readSequence(dir.file("rec.igs.mha")).pixels, s.pixels);
}

TEST(CaptureRecorder, OtherFormatsReadBackAsTheFramesAdded) {
  test::TempDir dir;
  const core::Sequence s = sweep(60);
  CaptureRecorder recorder(dir.file("rec.nrrd"), s, 0.005);
  for (std::size_t f = 0; f < s.frames.size(); ++f)
    add(recorder, s, f);
  EXPECT_EQ(recorder.finish(), 60U);
  expectSameFrames(core::readSequence(dir.file("rec.nrrd")), s, 60);
}

TEST(CaptureRecorder, PartialCaptureReadsAsEveryFrameFlushedWhileItGrows) {
  test::TempDir dir;
  const core::Sequence s = sweep(120);
  CaptureRecorder recorder(dir.file("rec.igs.mha"), s, 0.01);
  EXPECT_EQ(recorder.partialPath(), dir.file("rec.igs.partial.mhd"));
  EXPECT_EQ(recorder.partialDataPath(), dir.file("rec.igs.partial.raw"));
  for (std::size_t f = 0; f < 50; ++f)
    add(recorder, s, f);
  ASSERT_TRUE(waitForPartial(recorder, 50));
  expectSameFrames(core::readSequence(recorder.partialPath()), s, 50);
  const auto headerBytes = fs::file_size(recorder.partialPath());
  for (std::size_t f = 50; f < 120; ++f)
    add(recorder, s, f);
  ASSERT_TRUE(waitForPartial(recorder, 120));
  expectSameFrames(core::readSequence(recorder.partialPath()), s, 120);
  EXPECT_GT(fs::file_size(recorder.partialPath()), headerBytes);
  EXPECT_EQ(fs::file_size(recorder.partialDataPath()), 120 * frameBytes(s));
  EXPECT_EQ(recorder.finish(), 120U);
}

TEST(CaptureRecorder, WithoutFinishThePartialCaptureKeepsEveryFrameAdded) {
  test::TempDir dir;
  const core::Sequence s = sweep(30);
  std::string partial;
  {
    // A long flush interval: the frames are still pending when the session fails.
    CaptureRecorder recorder(dir.file("rec.igs.mha"), s, 60.0);
    for (std::size_t f = 0; f < s.frames.size(); ++f)
      add(recorder, s, f);
    partial = recorder.partialPath();
  }
  EXPECT_FALSE(fs::exists(dir.file("rec.igs.mha")));
  expectSameFrames(core::readSequence(partial), s, 30);
}

TEST(CaptureRecorder, RefusesAFrameWriteSequenceWouldRefuseWithoutAGap) {
  test::TempDir dir;
  const core::Sequence s = sweep(10);
  CaptureRecorder recorder(dir.file("rec.igs.mha"), s, 0.005);
  add(recorder, s, 0);
  core::SequenceFrame bad = s.frames[1];
  bad.transforms["Probe=ToTracker"] = core::TrackedTransform{};
  EXPECT_THROW(recorder.add(bad, s.pixels.data(), frameBytes(s)), std::invalid_argument);
  bad = s.frames[1];
  bad.timestampS = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(recorder.add(bad, s.pixels.data(), frameBytes(s)), std::invalid_argument);
  EXPECT_THROW(recorder.add(s.frames[1], s.pixels.data(), frameBytes(s) - 1),
               std::invalid_argument);
  for (std::size_t f = 1; f < s.frames.size(); ++f)
    add(recorder, s, f);
  EXPECT_EQ(recorder.frames(), 10U);
  EXPECT_EQ(recorder.finish(), 10U);
  expectSameFrames(core::readSequence(dir.file("rec.igs.mha")), s, 10);
}

TEST(CaptureRecorder, AFolderThatCannotBeWrittenFailsFinishWithTheReason) {
  test::TempDir dir;
  fs::create_directory(dir.file("gone"));
  const core::Sequence s = sweep(5);
  CaptureRecorder recorder(dir.file("gone/rec.igs.mha"), s, 0.005);
  fs::remove(dir.file("gone"));
  for (std::size_t f = 0; f < s.frames.size(); ++f)
    add(recorder, s, f);
  try {
    recorder.finish();
    FAIL() << "finish() wrote into a removed folder";
  } catch (const core::FileError& e) {
    EXPECT_NE(std::string(e.what()).find("rec.igs.partial"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot be created"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(recorder.writerProblem().empty());
}

}  // namespace
}  // namespace echoreg::live
