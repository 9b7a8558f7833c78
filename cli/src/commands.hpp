// The subcommands, each registering its options on the CLI11 app and running its work.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <iosfwd>

namespace echoreg::cli {

/// Where a command writes: results to `out`, messages and progress to `err`.
struct Streams {
  std::ostream& out;
  std::ostream& err;
  bool errIsTerminal = false;
};

/// A registered command's work, called after parsing; returns the exit code.
using CommandAction = std::function<int(const Streams&)>;

CommandAction addInfoCommand(CLI::App& app);
CommandAction addDetectCommand(CLI::App& app);
CommandAction addSimulateCommand(CLI::App& app);
CommandAction addCalibrateCommand(CLI::App& app);
CommandAction addPivotCommand(CLI::App& app);
CommandAction addFigureCommand(CLI::App& app);
CommandAction addStudyCommand(CLI::App& app);
/// `study compare`, registered on the `study` command by addStudyCommand.
CommandAction addStudyCompareCommand(CLI::App& study);
/// `study sweep`, registered on the `study` command by addStudyCommand.
CommandAction addStudySweepCommand(CLI::App& study);
CommandAction addLandmarksCommand(CLI::App& app);
CommandAction addEvaluateCommand(CLI::App& app);
CommandAction addRegisterCommand(CLI::App& app);
CommandAction addSegmentCommand(CLI::App& app);
CommandAction addServeCommand(CLI::App& app);
CommandAction addLiveCommand(CLI::App& app);

}  // namespace echoreg::cli
