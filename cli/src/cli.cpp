#include "echoreg/cli/cli.hpp"

#include "commands.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"

#include <unistd.h>

#include <iostream>
#include <map>
#include <new>
#include <stdexcept>

namespace echoreg::cli {

int run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CLI::App app{
      "echoreg: register bones to CT with tracked A-mode ultrasound (Mozes 2008).\n"
      "Commands: info, detect, simulate, calibrate, pivot, segment, landmarks, register, "
      "evaluate,\n"
      "figure, study, serve, live. `echoreg study run DIR` is the main job: a study folder into a "
      "report.",
      "echoreg"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "echoreg " ECHOREG_VERSION);
  app.footer(
      "Exit codes: 0 success, 1 the work failed (the message names the file), 2 wrong usage.");

  std::map<std::string, CommandAction> actions;
  actions["info"] = addInfoCommand(app);
  actions["detect"] = addDetectCommand(app);
  actions["simulate"] = addSimulateCommand(app);
  actions["calibrate"] = addCalibrateCommand(app);
  actions["pivot"] = addPivotCommand(app);
  actions["figure"] = addFigureCommand(app);
  actions["study"] = addStudyCommand(app);
  actions["landmarks"] = addLandmarksCommand(app);
  actions["evaluate"] = addEvaluateCommand(app);
  actions["register"] = addRegisterCommand(app);
  actions["segment"] = addSegmentCommand(app);
  actions["serve"] = addServeCommand(app);
  actions["live"] = addLiveCommand(app);

  // An unknown command is named as such (CLI11 would say "A subcommand is required").
  if (!args.empty() && !args.front().empty() && args.front()[0] != '-' &&
      actions.count(args.front()) == 0) {
    std::string known;
    for (const auto& [name, action] : actions)
      known += (known.empty() ? "" : ", ") + name;
    err << "echoreg: unknown command '" << args.front() << "' (commands: " << known
        << "; echoreg --help)\n";
    return 2;
  }
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e, out, err);
    return code == 0 ? 0 : 2;
  } catch (const std::logic_error&) {
    // Debian's CLI11 converts a flag's value it does not know (--causal=maybe) with std::stoll,
    // whose std::invalid_argument ("stoll") escapes its own error handling.
    std::string given;
    for (const std::string& arg : args) {
      if (arg.rfind("--", 0) == 0 && arg.find('=') != std::string::npos)
        given += (given.empty() ? "" : ", ") + arg;
    }
    err << "echoreg: a flag's value is not true, false, on, off, yes, no, 1 or 0"
        << (given.empty() ? std::string() : " (given: " + given + ")") << "; echoreg --help\n";
    return 2;
  }

  const Streams streams{out, err, &err == &std::cerr && ::isatty(STDERR_FILENO) != 0};
  for (CLI::App* sub : app.get_subcommands()) {
    try {
      return actions.at(sub->get_name())(streams);
    } catch (const std::bad_alloc&) {
      err << "echoreg " << sub->get_name()
          << ": out of memory: an input file or a flag asks for more memory than this machine "
             "has (a size or a count too large)\n";
      return 1;
    } catch (const nlohmann::json::exception& e) {
      // A reader that did not check a value's type: at least no "[json.exception...]" code.
      err << "echoreg " << sub->get_name()
          << ": a JSON file holds a value of another type than expected: " << core::jsonProblem(e)
          << "\n";
      return 1;
    } catch (const std::exception& e) {  // FileError names the file; the rest name the value
      err << "echoreg " << sub->get_name() << ": " << e.what() << "\n";
      return 1;
    }
  }
  return 2;
}

int run(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return run(args, std::cout, std::cerr);
}

}  // namespace echoreg::cli
