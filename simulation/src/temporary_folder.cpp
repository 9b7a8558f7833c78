#include "temporary_folder.hpp"

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

namespace echoreg::simulation {

namespace fs = std::filesystem;

namespace {

// What the handler needs, prepared before it can run: execve's arguments are static, so the
// handler calls only async-signal-safe functions (fork, execve, waitpid, sigaction, raise).
constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};
char gPath[4096];
char gRm[] = "/bin/rm";
char gRf[] = "-rf";
char gDashes[] = "--";
char* gArgv[] = {gRm, gRf, gDashes, gPath, nullptr};
char* gEnv[] = {nullptr};
struct sigaction gPrevious[3];
volatile sig_atomic_t gActive = 0;

void removeAndReraise(int number) {
  if (gActive != 0) {
    gActive = 0;
    const pid_t child = fork();
    if (child == 0) {
      execve(gRm, gArgv, gEnv);
      _exit(127);
    }
    if (child > 0) {
      int status = 0;
      while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
      }
    }
  }
  struct sigaction fallback;
  std::memset(&fallback, 0, sizeof(fallback));
  fallback.sa_handler = nullptr;  // SIG_DFL
  sigemptyset(&fallback.sa_mask);
  sigaction(number, &fallback, nullptr);
  raise(number);  // the default action: the process ends with the signal, as it would have
}

bool processRuns(long pid) {
  return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
}

}  // namespace

int sweepStaleTemporaryFolders(const fs::path& target) {
  const std::string prefix = target.filename().string() + ".tmp-";
  std::error_code ec;
  int removed = 0;
  for (fs::directory_iterator it(target.parent_path(), ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0)
      continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9)
      continue;
    const long pid = std::stol(digits);
    if (pid == static_cast<long>(::getpid()) || processRuns(pid))
      continue;
    std::error_code e;
    if (it->is_directory(e) && fs::remove_all(it->path(), e) > 0 && !e)
      ++removed;
  }
  return removed;
}

TemporaryFolder::TemporaryFolder(const fs::path& target)
    : path_(target.parent_path() /
            (target.filename().string() + ".tmp-" + std::to_string(::getpid()))) {
  sweepStaleTemporaryFolders(target);
  std::error_code ec;
  fs::remove_all(path_, ec);
  const std::string text = path_.string();
  if (text.size() < sizeof(gPath) && gActive == 0) {
    std::memcpy(gPath, text.c_str(), text.size() + 1);
    struct sigaction action;
    std::memset(&action, 0, sizeof(action));
    action.sa_handler = removeAndReraise;
    sigemptyset(&action.sa_mask);
    for (std::size_t i = 0; i < 3; ++i)
      sigaction(kSignals[i], &action, &gPrevious[i]);
    gActive = 1;
    installed_ = true;
  }
}

TemporaryFolder::~TemporaryFolder() {
  if (installed_) {
    gActive = 0;
    for (std::size_t i = 0; i < 3; ++i)
      sigaction(kSignals[i], &gPrevious[i], nullptr);
  }
  if (!published_) {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
}

}  // namespace echoreg::simulation
