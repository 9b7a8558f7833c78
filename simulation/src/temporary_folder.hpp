// The temporary folder a study is generated in ("OUT.tmp-PID" beside OUT), removed however the
// process ends short of publishing it (issue 15, item 11): on an exception by the destructor, on
// SIGINT / SIGTERM / SIGHUP by a handler, and after a SIGKILL by the next run's sweep.
#pragma once

#include <filesystem>
#include <string>

namespace echoreg::simulation {

class TemporaryFolder {
 public:
  /// Sweeps the stale "TARGET.tmp-PID" folders beside `target` whose process is gone, then names
  /// (does not create) this process's one and installs the signal handlers. One at a time.
  explicit TemporaryFolder(const std::filesystem::path& target);
  /// Removes the folder unless published; restores the previous handlers.
  ~TemporaryFolder();
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// The folder was renamed onto the target: keep it.
  void published() { published_ = true; }

 private:
  std::filesystem::path path_;
  bool published_ = false;
  bool installed_ = false;
};

/// Removes the folders "TARGET.tmp-PID" beside `target` whose process PID no longer runs (a
/// SIGKILLed `echoreg simulate`). Returns how many were removed.
int sweepStaleTemporaryFolders(const std::filesystem::path& target);

}  // namespace echoreg::simulation
