// The echoreg command line: `echoreg <command> [options]`.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace echoreg::cli {

/// Runs one command line. Exit codes: 0 success, 1 failure of the work (the message names the
/// file and the problem), 2 wrong usage. Output goes to `out`, messages to `err`.
int run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// The process entry point: run() on argv with std::cout and std::cerr.
int run(int argc, char** argv);

}  // namespace echoreg::cli
