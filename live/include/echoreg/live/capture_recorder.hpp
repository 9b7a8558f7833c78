// The recording of a live session as a PLUS capture, kept safe while it grows: a writer thread
// rewrites `<name>.partial<ext>` (atomically: temporary name, then rename) every flush interval
// with every frame received so far, so a crash loses at most that interval; finish() writes the
// capture under its own name and removes the partial file.
#pragma once

#include "echoreg/core/sequence.hpp"

#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::live {

class CaptureRecorder {
 public:
  /// `layout`: the element type, frame size, acquisition settings and header of the capture
  /// (its frames empty). Starts the writer thread.
  CaptureRecorder(std::string path, Sequence layout, double flushIntervalS = 1.0);
  /// Stops the writer; the partial file stays (finish() was not called: the session failed).
  ~CaptureRecorder();
  CaptureRecorder(const CaptureRecorder&) = delete;
  CaptureRecorder& operator=(const CaptureRecorder&) = delete;

  /// One frame: its metadata and samplesPerFrame() x elementSize bytes (none for tracker-only).
  /// Throws std::invalid_argument when the byte count does not fit the layout.
  void add(SequenceFrame frame, const std::uint8_t* pixels, std::size_t bytes);

  /// Writes the capture to its path and removes the partial file; returns the frames written.
  /// Throws FileError when it cannot be written (the partial file is then kept).
  std::size_t finish();

  const std::string& path() const { return path_; }
  const std::string& partialPath() const { return partialPath_; }
  /// The last error of the background writer ("" when none), e.g. a full disk.
  std::string writerProblem() const;

 private:
  void writerLoop();
  void takePending();

  std::string path_, partialPath_;
  double flushIntervalS_;
  Sequence sequence_;  ///< the writer's copy (the writer thread, then finish())
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<SequenceFrame> pendingFrames_;
  std::vector<std::uint8_t> pendingPixels_;
  bool stop_ = false;
  std::string writerProblem_;
  std::thread writer_;
};

/// `<stem>.partial<ext>` beside `path` (rec.igs.mha -> rec.igs.partial.mha).
std::string partialCapturePath(const std::string& path);

}  // namespace echoreg::live
