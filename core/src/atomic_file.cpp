#include "echoreg/core/atomic_file.hpp"

#include "echoreg/core/error.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace echoreg::core {

AtomicFile::AtomicFile(std::string targetPath) : targetPath_(std::move(targetPath)) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(targetPath_, ec)) {
    throw FileError(targetPath_, "is a directory, expected a file name to write");
  }
  temporaryPath_ = targetPath_ + ".tmp-" + std::to_string(::getpid());
  stream_.open(temporaryPath_, std::ios::binary | std::ios::trunc);
  if (!stream_) {
    throw FileError(targetPath_, std::string("cannot be written: ") + std::strerror(errno));
  }
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    stream_.close();
    std::remove(temporaryPath_.c_str());
  }
}

void AtomicFile::commit() {
  stream_.flush();
  const bool good = static_cast<bool>(stream_);
  stream_.close();
  if (!good || stream_.fail()) {
    std::remove(temporaryPath_.c_str());
    committed_ = true;
    throw FileError(targetPath_, "writing failed (disk full or I/O error)");
  }
  if (std::rename(temporaryPath_.c_str(), targetPath_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temporaryPath_.c_str());
    committed_ = true;
    throw FileError(targetPath_, "cannot be replaced: " + reason);
  }
  committed_ = true;
}

}  // namespace echoreg::core
