// The engine of `echoreg study run`: a study is a list of steps, each a typed request (a function
// and the request as JSON) or, for the steps not yet typed, an echoreg command line, with the
// files it reads and writes. A step runs again only when its request (or command line) or the
// content of a file it reads changed, or an output is missing (the state is kept in
// results/.study-state.json), so re-running after a change redoes exactly what the change affects:
// outputs are deterministic, so a step whose inputs come out byte-identical stops the chain there.
#pragma once

#include "commands.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace echoreg::cli {

struct StudyStep {
  StudyStep() = default;
  StudyStep(std::string stepId, std::string stepTitle, std::vector<std::string> commandLine,
            std::vector<std::string> reads, std::vector<std::string> writes, bool isRequired)
      : id(std::move(stepId)),
        title(std::move(stepTitle)),
        args(std::move(commandLine)),
        inputs(std::move(reads)),
        outputs(std::move(writes)),
        required(isRequired) {}

  std::string id;                    ///< unique, e.g. "register-femur-ultrasound-1"
  std::string title;                 ///< for progress and the report
  std::vector<std::string> args;     ///< an echoreg command line (without "echoreg"), or empty
  std::vector<std::string> inputs;   ///< files or folders read (folders: every file in them)
  std::vector<std::string> outputs;  ///< files written
  bool required = true;              ///< a failed optional step is reported, the study goes on
  /// A typed step (instead of `args`): the command it stands for ("register", for messages),
  /// its request as JSON (with the inputs' bytes, the key of the re-run cache) and its work,
  /// which returns the exit code and throws for bad input as the command would.
  std::string command;
  std::string request;
  std::function<int(const Streams&)> action;
};

struct StepOutcome {
  std::string id;
  std::string title;
  enum class Status { Ran, UpToDate, Failed, Skipped } status = Status::Skipped;
  double seconds = 0.0;  ///< of the last actual run (kept from the state when up to date)
  std::string message;   ///< the command's error output when it failed
  std::string output;    ///< the command's standard output of this run
  /// The command's notes and warnings (its error output's "echoreg CMD: note: ..." and
  /// "...: warning: ..." lines) when it succeeded; kept with the state, so an up-to-date step
  /// still has them.
  std::vector<std::string> notes;
};

const char* statusName(StepOutcome::Status status);

/// 64-bit FNV-1a of a file's bytes (folders: of their files' relative names and bytes, sorted).
/// Throws FileError naming the path when it cannot be read, in the study's one wording: "PATH: is
/// missing (WHY)", else "PATH: PROBLEM" (cannot be opened, listed or read; not a file or folder).
std::uint64_t contentHash(const std::string& path, const std::string& why);

/// `file` as the user names it: a relative path (read from inside the study folder) under
/// `folder`, the study folder as the user gave it; an absolute one, or any with no folder, as is.
std::string shownInStudy(const std::string& folder, const std::string& file);

/// 64-bit FNV-1a of `bytes` (the same hash as contentHash's of a file holding them).
std::uint64_t bytesHash(std::string_view bytes);

class StudyRunner {
 public:
  /// `stateFile` keeps each step's input hash and time between runs. `shownFolder` is the study
  /// folder as the user named it (the steps' relative paths are read from inside it): messages
  /// name an input under it.
  StudyRunner(std::string stateFile, bool force, std::string shownFolder = "");

  /// Runs the step unless it is up to date. Returns the outcome; never throws for the step's
  /// own failure (that is the outcome), but throws FileError for an input that is missing or
  /// cannot be read ("S/captures/x.igs.mha: is missing (step \"T\" needs it)").
  StepOutcome run(const StudyStep& step, const Streams& streams, int index, int total);

  /// Writes the state (atomically).
  void save() const;

 private:
  std::string stateFile_;
  std::string shownFolder_;
  bool force_ = false;
  struct Entry {
    std::string hash;
    double seconds = 0.0;
    /// The hash of each output as the step wrote it (in the step's order): a damaged, truncated
    /// or emptied output no longer matches, and the step runs again.
    std::vector<std::string> outputHashes;
    std::vector<std::string> notes;  ///< StepOutcome::notes of the run that wrote the outputs
  };
  std::vector<std::pair<std::string, Entry>> state_;
  Entry* find(const std::string& id);
};

}  // namespace echoreg::cli
