// SIGINT ends a live command cleanly: while an InterruptScope lives, Ctrl-C sets a flag the
// command's loops check (every wait is bounded), and the previous handler comes back afterwards.
#pragma once

#include <atomic>
#include <csignal>

namespace echoreg::cli {

/// Set by SIGINT while an InterruptScope lives.
inline std::atomic<bool>& interruptRequested() {
  static std::atomic<bool> flag{false};
  return flag;
}

class InterruptScope {
 public:
  InterruptScope() {
    interruptRequested() = false;
    previous_ = std::signal(SIGINT, [](int) { interruptRequested() = true; });
  }
  ~InterruptScope() { std::signal(SIGINT, previous_); }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  void (*previous_)(int) = SIG_DFL;
};

}  // namespace echoreg::cli
