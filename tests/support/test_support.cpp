#include "test_support.hpp"

#include "file_bytes.hpp"

#include <unistd.h>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace echoreg::test {

namespace fs = std::filesystem;

std::string sharedDataDir() {
  std::error_code ec;
  const fs::path dir(ECHOREG_SHARED_DATA_DIR);
  return fs::is_directory(dir, ec) ? fs::canonical(dir, ec).string() : std::string();
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string sharedDataFile(const std::string& relativePath) {
  const std::string dir = sharedDataDir();
  if (dir.empty())
    return {};
  std::error_code ec;
  const fs::path file = fs::path(dir) / relativePath;
  return fs::exists(file, ec) ? file.string() : std::string();
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  const char* base = std::getenv("ECHOREG_TEST_TMP");
  fs::path root = base ? fs::path(base) : fs::temp_directory_path() / "echoreg-tests";
  fs::path dir = root / ("t" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  fs::remove_all(dir);
  fs::create_directories(dir);
  path_ = dir.string();
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

}  // namespace echoreg::test
