// Helpers shared by the test programs: the shared-data folder and fresh temporary folders.
#pragma once

#include <stdexcept>
#include <string>

namespace echoreg::test {

/// What `call()` throws as std::invalid_argument, or "" when it throws nothing.
template <typename Call>
std::string thrownMessage(Call call) {
  try {
    call();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

/// The folder of ../shared/data, or "" when it is absent (tests then GTEST_SKIP with a message).
std::string sharedDataDir();

/// Path of a file under ../shared/data, or "" when the folder or the file is absent.
std::string sharedDataFile(const std::string& relativePath);

/// A new empty folder for one test, removed when the object goes out of scope.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

}  // namespace echoreg::test

/// Skips the current test with a message when a shared data file is missing; binds its path.
#define ECHOREG_REQUIRE_SHARED_FILE(var, relative)                                            \
  const std::string var = ::echoreg::test::sharedDataFile(relative);                          \
  if (var.empty()) {                                                                          \
    GTEST_SKIP() << "../shared/data/" << (relative) << " is absent: skipping this real-data " \
                 << "test";                                                                   \
  }
