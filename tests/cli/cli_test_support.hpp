// Runs echoreg commands in-process and captures their output.
#pragma once

#include "echoreg/cli/cli.hpp"

#include <sstream>
#include <string>
#include <vector>

namespace echoreg::test {

struct CommandResult {
  int exitCode = -1;
  std::string out;
  std::string err;
};

inline CommandResult runEchoreg(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  CommandResult result;
  result.exitCode = echoreg::cli::run(args, out, err);
  result.out = out.str();
  result.err = err.str();
  return result;
}

}  // namespace echoreg::test
