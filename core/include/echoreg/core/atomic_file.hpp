// Write-then-rename output files, so that a failed command leaves no partial output behind.
#pragma once

#include <fstream>
#include <string>

namespace echoreg::core {

/// An output file written under a temporary name beside the target ("TARGET.tmp-PID") and renamed
/// onto the target by commit(). If commit() is never called (an exception, an early return) the
/// destructor removes the temporary file, so the target is either complete or untouched.
class AtomicFile {
 public:
  /// Opens the temporary file for writing (binary). Throws FileError naming `targetPath` when the
  /// folder is missing or not writable, or when the target is a directory.
  explicit AtomicFile(std::string targetPath);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ofstream& stream() { return stream_; }
  const std::string& targetPath() const { return targetPath_; }
  const std::string& temporaryPath() const { return temporaryPath_; }

  /// Flushes, closes and renames onto the target. Throws FileError if writing failed.
  void commit();

 private:
  std::string targetPath_;
  std::string temporaryPath_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace echoreg::core
