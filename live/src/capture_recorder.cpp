#include "echoreg/live/capture_recorder.hpp"

#include "echoreg/core/error.hpp"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace echoreg::live {

std::string partialCapturePath(const std::string& path) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".partial" + p.extension().string())).string();
}

CaptureRecorder::CaptureRecorder(std::string path, Sequence layout, double flushIntervalS)
    : path_(std::move(path)),
      partialPath_(partialCapturePath(path_)),
      flushIntervalS_(flushIntervalS),
      sequence_(std::move(layout)) {
  sequence_.frames.clear();
  sequence_.pixels.clear();
  writer_ = std::thread([this] { writerLoop(); });
}

CaptureRecorder::~CaptureRecorder() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (writer_.joinable())
    writer_.join();
}

void CaptureRecorder::add(SequenceFrame frame, const std::uint8_t* pixels, std::size_t bytes) {
  const std::size_t expected = sequence_.samplesPerFrame() * elementSize(sequence_.elementType);
  if (bytes != expected) {
    throw std::invalid_argument(fmt::format(
        "a frame of {} bytes does not fit the recording's frames of {} bytes", bytes, expected));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  pendingFrames_.push_back(std::move(frame));
  pendingPixels_.insert(pendingPixels_.end(), pixels, pixels + bytes);
}

void CaptureRecorder::takePending() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (SequenceFrame& frame : pendingFrames_)
    sequence_.frames.push_back(std::move(frame));
  sequence_.pixels.insert(sequence_.pixels.end(), pendingPixels_.begin(), pendingPixels_.end());
  pendingFrames_.clear();
  pendingPixels_.clear();
}

void CaptureRecorder::writerLoop() {
  const auto interval = std::chrono::duration<double>(flushIntervalS_);
  std::size_t written = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, interval, [this] { return stop_; });
    if (stop_)
      break;
    lock.unlock();
    takePending();
    if (sequence_.frames.size() != written) {
      try {
        SequenceWriteOptions options;
        options.compress = false;  // the rewrite must stay quick
        writeSequence(sequence_, partialPath_, options);
        written = sequence_.frames.size();
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> problemLock(mutex_);
        writerProblem_ = e.what();
      }
    }
    lock.lock();
  }
}

std::string CaptureRecorder::writerProblem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writerProblem_;
}

std::size_t CaptureRecorder::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (writer_.joinable())
    writer_.join();
  takePending();
  writeSequence(sequence_, path_);
  std::error_code ignored;
  std::filesystem::remove(partialPath_, ignored);
  return sequence_.frames.size();
}

}  // namespace echoreg::live
