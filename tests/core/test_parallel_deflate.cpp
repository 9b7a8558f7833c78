// One zlib stream deflated in blocks on several threads (core/parallel_deflate.hpp): zlib's own
// bytes for one block, the same bytes on any number of threads, a stream zlib's inflate and
// MetaIO's reader (VTK's vtkMetaImageReader, as in 3D Slicer) read whole, and about the size of
// one thread's stream.
#include "echoreg/core/parallel_deflate.hpp"

#include "echoreg/core/sequence.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::core {
namespace {

// A-line-like bytes: a decaying echo pattern with noise (compressible, not trivially).
std::vector<std::uint8_t> alines(std::size_t bytes, std::uint32_t seed) {
  std::vector<std::uint8_t> out(bytes);
  std::uint32_t state = seed;
  for (std::size_t i = 0; i < bytes; ++i) {
    state = state * 1664525u + 1013904223u;
    const std::size_t sample = i % 4096;
    const int echo = sample > 1800 && sample < 1860 ? 90 : 0;
    const int noise = static_cast<int>((state >> 24) & 0x0fu);
    out[i] = static_cast<std::uint8_t>(128 + echo - static_cast<int>(sample / 64) + noise);
  }
  return out;
}

std::vector<std::uint8_t> deflated(const std::vector<std::uint8_t>& input,
                                   ParallelDeflateOptions options) {
  std::vector<std::uint8_t> out;
  const std::uint64_t size = deflateParallel(
      input.size(),
      [&](std::uint64_t offset, std::uint8_t* to, std::size_t bytes) {
        std::memcpy(to, input.data() + offset, bytes);
      },
      [&](const std::uint8_t* data, std::size_t bytes) {
        out.insert(out.end(), data, data + bytes);
      },
      options);
  EXPECT_EQ(size, out.size());
  return out;
}

std::vector<std::uint8_t> inflated(const std::vector<std::uint8_t>& stream, std::size_t bytes) {
  std::vector<std::uint8_t> out(bytes + 1);
  uLongf size = static_cast<uLongf>(out.size());
  EXPECT_EQ(uncompress(out.data(), &size, stream.data(), static_cast<uLong>(stream.size())), Z_OK);
  out.resize(size);
  return out;
}

std::vector<std::uint8_t> zlibOneShot(const std::vector<std::uint8_t>& input, int level) {
  std::vector<std::uint8_t> out(compressBound(static_cast<uLong>(input.size())));
  uLongf size = static_cast<uLongf>(out.size());
  EXPECT_EQ(compress2(out.data(), &size, input.data(), static_cast<uLong>(input.size()), level),
            Z_OK);
  out.resize(size);
  return out;
}

TEST(ParallelDeflate, OneBlockIsZlibsOwnStream) {
  for (const std::size_t bytes : {std::size_t{0}, std::size_t{1}, std::size_t{100000}}) {
    const std::vector<std::uint8_t> input = alines(bytes, 3);
    for (const int level : {1, 6, 9}) {
      ParallelDeflateOptions options;
      options.level = level;
      EXPECT_EQ(deflated(input, options), zlibOneShot(input, level))
          << bytes << " bytes, level " << level;
    }
  }
}

TEST(ParallelDeflate, ManyBlocksAreOneStreamWithTheSameBytesOnAnyNumberOfThreads) {
  const std::vector<std::uint8_t> input = alines(3'000'000 + 17, 5);
  ParallelDeflateOptions options;
  options.blockBytes = 200'000;  // 16 blocks, the last one short
  options.threads = 1;
  const std::vector<std::uint8_t> one = deflated(input, options);
  EXPECT_EQ(inflated(one, input.size()), input);
  for (const int threads : {2, 3, 8}) {
    options.threads = threads;
    EXPECT_EQ(deflated(input, options), one) << threads << " threads";
  }
  // The dictionaries keep it near one thread's stream (a block boundary costs a few bytes).
  const std::vector<std::uint8_t> single = zlibOneShot(input, 1);
  EXPECT_LT(static_cast<double>(one.size()), 1.005 * static_cast<double>(single.size()));
  EXPECT_NE(one, single);  // not a single block: the cuts are there
}

TEST(ParallelDeflate, RefusesBadOptionsAndPassesOnTheReadersError) {
  const std::vector<std::uint8_t> input = alines(1000, 1);
  ParallelDeflateOptions options;
  options.level = 10;
  EXPECT_THROW(deflated(input, options), std::invalid_argument);
  options.level = 1;
  options.blockBytes = 1000;
  EXPECT_THROW(deflated(input, options), std::invalid_argument);
  options.blockBytes = 100'000;
  options.threads = 2;
  EXPECT_THROW(deflateParallel(
                   1'000'000,
                   [](std::uint64_t offset, std::uint8_t*, std::size_t) {
                     if (offset > 500'000)
                       throw std::runtime_error("the disk went away");
                   },
                   [](const std::uint8_t*, std::size_t) {}, options),
               std::runtime_error);
}

// writeSequence's .mha of 12 MB of pixels (three 4 MiB blocks) reads back with our reader and
// with VTK's vtkMetaImageReader (MetaIO, the reader of ITK and 3D Slicer).
TEST(ParallelDeflate, AMultiBlockMhaReadsBackHereAndInVtksMetaImageReader) {
  const test::TempDir dir;
  Sequence sequence;
  sequence.elementType = ElementType::UInt8;
  sequence.frameSize = {4096, 1};
  const std::size_t frames = 3000;
  sequence.pixels = alines(4096 * frames, 9);
  for (std::size_t i = 0; i < frames; ++i) {
    SequenceFrame frame;
    frame.timestampS = 0.01 * static_cast<double>(i);
    sequence.frames.push_back(frame);
  }
  const std::string path = dir.file("big.igs.mha");
  writeSequence(sequence, path);
  EXPECT_EQ(readSequence(path).pixels, sequence.pixels);

  if (!std::filesystem::exists("/usr/bin/python3") ||
      std::system("/usr/bin/python3 -c 'import vtk' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "/usr/bin/python3 with vtk is absent: skipping the check with VTK's reader";
  const std::string script = dir.file("read.py");
  {
    std::ofstream out(script);
    out << "import sys, vtk\n"
           "from vtk.util.numpy_support import vtk_to_numpy\n"
           "r = vtk.vtkMetaImageReader()\n"
           "r.SetFileName(sys.argv[1])\n"
           "r.Update()\n"
           "a = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars())\n"
           "open(sys.argv[2], 'wb').write(a.tobytes())\n"
           "print(r.GetOutput().GetDimensions())\n";
  }
  const std::string raw = dir.file("vtk.raw");
  const std::string command = "/usr/bin/python3 '" + script + "' '" + path + "' '" + raw + "' > '" +
                              dir.file("vtk.out") + "' 2>&1";
  if (std::system(command.c_str()) != 0) {
    std::ifstream log(dir.file("vtk.out"));
    FAIL() << "VTK's reader failed: " << log.rdbuf();
  }
  std::ifstream in(raw, std::ios::binary);
  const std::vector<std::uint8_t> pixels((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  EXPECT_EQ(pixels.size(), sequence.pixels.size());
  EXPECT_TRUE(pixels == sequence.pixels) << "VTK's reader gives other pixels";
}

}  // namespace
}  // namespace echoreg::core
