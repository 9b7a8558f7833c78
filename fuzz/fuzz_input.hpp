// The bytes libFuzzer gives, as the file the readers open (they read paths, not buffers).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

namespace echoreg::fuzz {

/// Writes `data` to one file per process (under TMPDIR or /tmp) and returns its path.
inline std::string writeInput(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  const char* folder = std::getenv("TMPDIR");
  const std::string path = std::string(folder != nullptr ? folder : "/tmp") + "/echoreg-fuzz-" +
                           std::to_string(::getpid()) + ext;
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace echoreg::fuzz
