// The bytes libFuzzer gives, as the file the readers open (they read paths, not buffers).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace echoreg::fuzz {

/// The folder the inputs are written to: TMPDIR, else /tmp.
inline std::string tempFolder() {
  const char* folder = std::getenv("TMPDIR");
  return folder != nullptr ? folder : "/tmp";
}

inline void writeBytes(const std::string& path, const char* data, std::size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(data, static_cast<std::streamsize>(size));
}

/// Writes `data` to one file per process (under TMPDIR or /tmp) and returns its path.
inline std::string writeInput(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  const std::string path = tempFolder() + "/echoreg-fuzz-" + std::to_string(::getpid()) + ext;
  writeBytes(path, reinterpret_cast<const char*>(data), size);
  return path;
}

/// Between two files of an input that is a folder of files (fuzz_dicom's series).
constexpr std::string_view kNextFile = "\n--echoreg-fuzz-next-file--\n";

/// Writes `data` as a folder of files (one folder per process, emptied first): the parts between
/// kNextFile markers, at most `maxFiles` (the last one takes the rest), named file0`ext`,
/// file1`ext`, ... Returns the folder.
inline std::string writeFolderInput(const std::uint8_t* data, std::size_t size,
                                    const std::string& ext, int maxFiles) {
  const std::string folder = tempFolder() + "/echoreg-fuzz-" + std::to_string(::getpid()) + ".d";
  std::error_code ignored;
  std::filesystem::remove_all(folder, ignored);
  std::filesystem::create_directories(folder);
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  std::size_t begin = 0;
  for (int file = 0; file < maxFiles; ++file) {
    std::size_t end = bytes.find(kNextFile, begin);
    if (file == maxFiles - 1 || end == std::string_view::npos)
      end = bytes.size();
    writeBytes(folder + "/file" + std::to_string(file) + ext, bytes.data() + begin, end - begin);
    if (end == bytes.size())
      break;
    begin = end + kNextFile.size();
  }
  return folder;
}

}  // namespace echoreg::fuzz
