#include "echoreg/live/capture_recorder.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/parallel_deflate.hpp"
#include "echoreg/core/sequence.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace echoreg::live {

namespace {

constexpr std::size_t kChunkBytes = std::size_t{1} << 20;

std::string systemError() {
  return std::strerror(errno);
}

int openForWriting(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    throw core::FileError(path, "cannot be created: " + systemError());
  return fd;
}

void closeFd(int& fd) {
  if (fd >= 0)
    ::close(fd);
  fd = -1;
}

// Writes every byte at `offset` (or at the end of the file when offset is negative).
void writeAll(int fd, const std::string& path, const void* data, std::size_t bytes,
              std::int64_t offset = -1) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  while (bytes > 0) {
    const ssize_t n =
        offset < 0 ? ::write(fd, p, bytes) : ::pwrite(fd, p, bytes, static_cast<off_t>(offset));
    if (n < 0) {
      if (errno == EINTR)
        continue;
      throw core::FileError(path, "cannot be written: " + systemError());
    }
    p += n;
    bytes -= static_cast<std::size_t>(n);
    if (offset >= 0)
      offset += n;
  }
}

// Reads up to `bytes` at `offset`; returns the count (0 at the end of the file).
std::size_t readAt(int fd, const std::string& path, std::uint8_t* out, std::size_t bytes,
                   std::uint64_t offset) {
  while (true) {
    const ssize_t n = ::pread(fd, out, bytes, static_cast<off_t>(offset));
    if (n >= 0)
      return static_cast<std::size_t>(n);
    if (errno != EINTR)
      throw core::FileError(path, "cannot be read back: " + systemError());
  }
}

// Copies [begin, end) of `fd` to `out`.
void copyRange(int fd, const std::string& path, std::uint64_t begin, std::uint64_t end,
               std::ostream& out, std::vector<std::uint8_t>& buffer) {
  buffer.resize(kChunkBytes);
  while (begin < end) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::uint64_t>(kChunkBytes, end - begin));
    const std::size_t got = readAt(fd, path, buffer.data(), want, begin);
    if (got == 0)
      throw core::FileError(path, "ended early while it was copied into the recording");
    out.write(reinterpret_cast<const char*>(buffer.data()), static_cast<std::streamsize>(got));
    begin += got;
  }
}

// zlib-compresses the whole of `fd` into `outFd` as writeSequence compresses a capture's pixels
// (core::deflateParallel: one zlib stream at kPixelCompressionLevel, in blocks on every core, the
// same bytes as writeSequence's). Returns the compressed size.
std::uint64_t deflateFile(int fd, const std::string& path, int outFd, const std::string& outPath) {
  const off_t size = ::lseek(fd, 0, SEEK_END);
  if (size < 0)
    throw core::FileError(path, "cannot be read back: " + systemError());
  core::ParallelDeflateOptions options;
  options.level = core::kPixelCompressionLevel;
  return core::deflateParallel(
      static_cast<std::uint64_t>(size),
      [&](std::uint64_t offset, std::uint8_t* out, std::size_t bytes) {
        while (bytes > 0) {
          const std::size_t got = readAt(fd, path, out, bytes, offset);
          if (got == 0)
            throw core::FileError(path, "ended early while it was compressed into the recording");
          out += got;
          offset += got;
          bytes -= got;
        }
      },
      [&](const std::uint8_t* data, std::size_t bytes) { writeAll(outFd, outPath, data, bytes); },
      options);
}

bool isMha(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".mha";
}

}  // namespace

std::string partialCapturePath(const std::string& path) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".partial.mhd")).string();
}

CaptureRecorder::CaptureRecorder(std::string path, core::Sequence layout, double flushIntervalS)
    : path_(std::move(path)),
      partialPath_(partialCapturePath(path_)),
      partialDataPath_(std::filesystem::path(partialPath_).replace_extension(".raw").string()),
      flushIntervalS_(flushIntervalS),
      layout_(std::move(layout)) {
  layout_.frames.clear();
  layout_.pixels.clear();
  frameBytes_ = layout_.samplesPerFrame() * core::elementSize(layout_.elementType);
  core::metaImageHeaderStart(layout_, std::nullopt, std::nullopt);  // refuses a bad header now
  writer_ = std::thread([this] { writerLoop(); });
}

CaptureRecorder::~CaptureRecorder() {
  stopWriter();
  try {
    flush();
  } catch (const std::exception&) {
    // The session is failing already; what was flushed before stays.
  }
  closeFd(headerFd_);
  closeFd(dataFd_);
}

void CaptureRecorder::add(const core::SequenceFrame& frame, const std::uint8_t* pixels,
                          std::size_t bytes) {
  if (bytes != frameBytes_) {
    throw std::invalid_argument(fmt::format(
        "a frame of {} bytes does not fit the recording's frames of {} bytes", bytes, frameBytes_));
  }
  // Only this thread adds, so added_ does not change until the frame is appended below.
  std::size_t index = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    index = added_;
  }
  const std::string lines = core::metaImageFrameLines(frame, index);
  std::lock_guard<std::mutex> lock(mutex_);
  pendingLines_ += lines;
  pendingPixels_.insert(pendingPixels_.end(), pixels, pixels + bytes);
  ++pendingFrames_;
  ++added_;
}

std::size_t CaptureRecorder::frames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return added_;
}

void CaptureRecorder::flush() {
  std::size_t frames = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames = pendingFrames_;
    flushLines_.clear();
    flushPixels_.clear();
    std::swap(flushLines_, pendingLines_);
    std::swap(flushPixels_, pendingPixels_);
    pendingFrames_ = 0;
  }
  if (frames == 0 || failed_)
    return;
  try {
    if (headerFd_ < 0) {
      dataFd_ = openForWriting(partialDataPath_);
      headerFd_ = openForWriting(partialPath_);
      const std::string start = core::metaImageHeaderStart(layout_, std::nullopt, std::nullopt);
      writeAll(headerFd_, partialPath_, start.data(), start.size(), 0);
      frameLinesBegin_ = frameLinesEnd_ = start.size();
    }
    // The pixels first, then the header that declares them, in one write over its old last
    // lines (DimSize grows, so the new lines are never shorter than the old).
    writeAll(dataFd_, partialDataPath_, flushPixels_.data(), flushPixels_.size());
    const std::size_t frameLineBytes = flushLines_.size();
    flushLines_ += core::metaImageDimSizeLine(layout_, flushed_ + frames);
    flushLines_ +=
        "ElementDataFile = " + std::filesystem::path(partialDataPath_).filename().string() + "\n";
    writeAll(headerFd_, partialPath_, flushLines_.data(), flushLines_.size(),
             static_cast<std::int64_t>(frameLinesEnd_));
    frameLinesEnd_ += frameLineBytes;
    flushed_ += frames;
  } catch (const std::exception& e) {
    failed_ = true;
    std::lock_guard<std::mutex> lock(mutex_);
    writerProblem_ = e.what();
  }
}

void CaptureRecorder::writerLoop() {
  const auto interval = std::chrono::duration<double>(flushIntervalS_);
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, interval, [this] { return stop_; });
    if (stop_)
      break;
    lock.unlock();
    flush();
    lock.lock();
  }
}

void CaptureRecorder::stopWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (writer_.joinable())
    writer_.join();
}

std::string CaptureRecorder::writerProblem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writerProblem_;
}

void CaptureRecorder::writeFinal() {
  if (!isMha(path_)) {
    // Other formats (.mhd, .nrrd) are converted from the partial capture in memory.
    core::writeSequence(core::readSequence(partialPath_), path_);
    return;
  }
  const std::string compressedPath =
      std::filesystem::path(partialPath_).replace_extension(".zraw").string();
  int compressedFd = openForWriting(compressedPath);
  struct Cleanup {
    int& fd;
    const std::string& path;
    ~Cleanup() {
      closeFd(fd);
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  } cleanup{compressedFd, compressedPath};
  const std::uint64_t compressedBytes =
      deflateFile(dataFd_, partialDataPath_, compressedFd, compressedPath);
  core::AtomicFile file(path_);
  file.stream() << core::metaImageHeaderStart(layout_, flushed_, compressedBytes);
  std::vector<std::uint8_t> buffer;
  copyRange(headerFd_, partialPath_, frameLinesBegin_, frameLinesEnd_, file.stream(), buffer);
  file.stream() << "ElementDataFile = LOCAL\n";
  copyRange(compressedFd, compressedPath, 0, compressedBytes, file.stream(), buffer);
  file.commit();
}

std::size_t CaptureRecorder::finish() {
  stopWriter();
  flush();
  if (failed_)
    throw core::FileError(partialPath_, "the recording could not be written: " + writerProblem());
  if (flushed_ == 0)
    throw core::FileError(path_, "the sequence has no frames");
  writeFinal();
  closeFd(headerFd_);
  closeFd(dataFd_);
  std::error_code ignored;
  std::filesystem::remove(partialPath_, ignored);
  std::filesystem::remove(partialDataPath_, ignored);
  return flushed_;
}

}  // namespace echoreg::live
