// The recording of a live session as a PLUS capture, streamed to disk as it grows, so that memory
// stays flat however long the session runs and a crash loses at most the last flush interval.
//
// While the session runs the recording is a detached MetaImage, `<stem>.partial.mhd` (the header)
// with `<stem>.partial.raw` (the pixels), both only ever appended to: every flush interval a writer
// thread appends the new frames' pixels to the .raw, then rewrites the header's last lines in one
// write: the new frames' per-frame keys, then `DimSize` and `ElementDataFile` (the reader takes
// DimSize anywhere before ElementDataFile). After a crash the pair reads as a capture of every
// frame flushed (docs/live.md says what to do in the rare case the crash fell between the two
// writes). finish() writes the capture under its own name, exactly as writeSequence would have
// written the same frames (a .mha is streamed: no frame is held in memory), renames it into place
// and removes the partial files.
#pragma once

#include "echoreg/core/sequence.hpp"

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::live {

class CaptureRecorder {
 public:
  /// `layout`: the element type, frame size, acquisition settings and header of the capture
  /// (its frames and pixels are ignored). Starts the writer thread; the partial files appear at
  /// the first flush with a frame. Throws std::invalid_argument for a header writeSequence refuses.
  CaptureRecorder(std::string path, core::Sequence layout, double flushIntervalS = 1.0);
  /// Flushes what is pending and stops the writer; the partial files stay (finish() was not
  /// called: the session failed).
  ~CaptureRecorder();
  CaptureRecorder(const CaptureRecorder&) = delete;
  CaptureRecorder& operator=(const CaptureRecorder&) = delete;

  /// One frame: its metadata and samplesPerFrame() x elementSize bytes. Call from one thread.
  /// Throws std::invalid_argument (and records nothing) when the byte count does not fit the
  /// layout or writeSequence would refuse the frame (a name that would not read back, a number
  /// that is not finite).
  void add(const core::SequenceFrame& frame, const std::uint8_t* pixels, std::size_t bytes);

  /// Flushes, writes the capture to its path (temporary name, then rename) and removes the
  /// partial files; returns the frames written. Throws FileError when it cannot be written or an
  /// earlier flush failed (the partial files are then kept).
  std::size_t finish();

  const std::string& path() const { return path_; }
  /// The partial header (`<stem>.partial.mhd`) and its data file (`<stem>.partial.raw`).
  const std::string& partialPath() const { return partialPath_; }
  const std::string& partialDataPath() const { return partialDataPath_; }
  /// Frames added so far.
  std::size_t frames() const;
  /// The last error of the background writer ("" when none), e.g. a full disk.
  std::string writerProblem() const;

 private:
  void writerLoop();
  void stopWriter();
  /// Appends the pending frames to the partial files (the writer thread, then finish()).
  void flush();
  void writeFinal();

  std::string path_, partialPath_, partialDataPath_;
  double flushIntervalS_;
  core::Sequence layout_;  ///< frames and pixels empty
  std::size_t frameBytes_ = 0;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::size_t added_ = 0;     ///< frames added (under mutex_)
  std::string pendingLines_;  ///< per-frame keys not yet flushed (under mutex_)
  std::vector<std::uint8_t> pendingPixels_;
  std::size_t pendingFrames_ = 0;
  bool stop_ = false;
  std::string writerProblem_;

  // Only the flushing thread (the writer, then finish()) touches these.
  int headerFd_ = -1, dataFd_ = -1;
  std::uint64_t frameLinesBegin_ = 0;  ///< offset of frame 0's keys in the partial header
  std::uint64_t frameLinesEnd_ = 0;    ///< offset of the DimSize/ElementDataFile lines
  std::size_t flushed_ = 0;            ///< frames in the partial files
  bool failed_ = false;
  std::string flushLines_;  ///< the writer's swap buffers (capacity reused)
  std::vector<std::uint8_t> flushPixels_;

  std::thread writer_;
};

/// `<stem>.partial.mhd` beside `path` (rec.igs.mha -> rec.igs.partial.mhd).
std::string partialCapturePath(const std::string& path);

}  // namespace echoreg::live
