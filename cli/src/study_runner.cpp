#include "study_runner.hpp"

#include "echoreg/cli/cli.hpp"
#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>
#include <ostream>
#include <sstream>

namespace echoreg::cli {

namespace fs = std::filesystem;

const char* statusName(StepOutcome::Status status) {
  switch (status) {
    case StepOutcome::Status::Ran:
      return "ran";
    case StepOutcome::Status::UpToDate:
      return "up to date";
    case StepOutcome::Status::Failed:
      return "FAILED";
    case StepOutcome::Status::Skipped:
      return "skipped";
  }
  return "";
}

namespace {

constexpr std::uint64_t kFnvOffset = 1469598103934665603ULL;
constexpr std::uint64_t kFnvPrime = 1099511628211ULL;

void mix(std::uint64_t& h, const char* data, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= kFnvPrime;
  }
}

void mixFile(std::uint64_t& h, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw core::FileError(path, std::string("cannot be opened: ") + std::strerror(errno));
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    mix(h, buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad())
    throw core::FileError(path, "cannot be read");
}

}  // namespace

std::uint64_t bytesHash(std::string_view bytes) {
  std::uint64_t h = kFnvOffset;
  mix(h, bytes.data(), bytes.size());
  return h;
}

std::string shownInStudy(const std::string& folder, const std::string& file) {
  return fs::path(file).is_absolute() || folder.empty()
             ? file
             : (fs::path(folder) / file).generic_string();
}

std::uint64_t contentHash(const std::string& path, const std::string& why) {
  std::uint64_t h = kFnvOffset;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (status.type() == fs::file_type::not_found)
    throw core::FileError(path, fmt::format("is missing ({})", why));
  if (ec)
    throw core::FileError(path, "cannot be accessed: " + ec.message());
  if (fs::is_directory(status)) {
    std::vector<fs::path> files;
    for (fs::recursive_directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->is_regular_file())
        files.push_back(it->path());
    }
    if (ec)
      throw core::FileError(path, "cannot be listed: " + ec.message());
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      const std::string relative = fs::relative(file, path).generic_string();
      mix(h, relative.data(), relative.size());
      mixFile(h, file.string());
    }
    return h;
  }
  // A FIFO or a device would block the read or never end.
  if (!fs::is_regular_file(status))
    throw core::FileError(path, "is not a regular file or a folder");
  mixFile(h, path);
  return h;
}

StudyRunner::StudyRunner(std::string stateFile, bool force, std::string shownFolder)
    : stateFile_(std::move(stateFile)), shownFolder_(std::move(shownFolder)), force_(force) {
  std::ifstream in(stateFile_);
  if (!in)
    return;
  try {
    const nlohmann::json doc = nlohmann::json::parse(in);
    for (const auto& [id, entry] : doc.at("steps").items()) {
      state_.push_back(
          {id, Entry{entry.at("hash").get<std::string>(), entry.at("seconds").get<double>(),
                     entry.value("outputs", std::vector<std::string>()),
                     entry.value("notes", std::vector<std::string>())}});
    }
  } catch (const std::exception&) {
    state_.clear();  // an unreadable state only means every step runs again
  }
}

StudyRunner::Entry* StudyRunner::find(const std::string& id) {
  for (auto& [key, entry] : state_) {
    if (key == id)
      return &entry;
  }
  return nullptr;
}

namespace {

// The hashes of a step's outputs now ("" for one that is missing or unreadable).
std::vector<std::string> outputHashes(const StudyStep& step) {
  std::vector<std::string> hashes;
  for (const std::string& output : step.outputs) {
    std::error_code ec;
    std::string hash;
    if (fs::is_regular_file(output, ec)) {
      try {
        hash = fmt::format("{:016x}", contentHash(output, "an output of the study"));
      } catch (const core::FileError&) {
        hash.clear();
      }
    }
    hashes.push_back(hash);
  }
  return hashes;
}

// What a command that succeeded told its user on its error output: its lines in its own words
// ("echoreg segment: note: ...", "echoreg register: warning: ..."), not progress.
std::vector<std::string> notesIn(const std::string& errorOutput) {
  std::vector<std::string> notes;
  std::istringstream lines(errorOutput);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("echoreg ", 0) == 0)
      notes.push_back(line);
  }
  return notes;
}

// A typed step's work, its failures reported in the words `echoreg COMMAND` would use.
int runAction(const StudyStep& step, std::ostream& out, std::ostream& err) {
  const Streams streams{out, err, false};
  try {
    return step.action(streams);
  } catch (const std::bad_alloc&) {
    err << "echoreg " << step.command << ": out of memory\n";
  } catch (const nlohmann::json::exception& e) {
    err << "echoreg " << step.command
        << ": a JSON file holds a value of another type than expected: " << core::jsonProblem(e)
        << "\n";
  } catch (const std::exception& e) {
    err << "echoreg " << step.command << ": " << e.what() << "\n";
  }
  return 1;
}

}  // namespace

StepOutcome StudyRunner::run(const StudyStep& step, const Streams& streams, int index, int total) {
  StepOutcome outcome;
  outcome.id = step.id;
  outcome.title = step.title;
  std::uint64_t h = kFnvOffset;
  for (const std::string& arg : step.args)
    mix(h, arg.data(), arg.size() + 1);  // with the '\0'
  mix(h, step.request.data(), step.request.size());
  for (const std::string& input : step.inputs) {
    std::uint64_t part = 0;
    try {
      part = contentHash(input, fmt::format("step \"{}\" needs it", step.title));
    } catch (const core::FileError& e) {
      // Read from inside the study folder, named as the user names it.
      throw core::FileError(shownInStudy(shownFolder_, e.path()), e.problem());
    }
    mix(h, reinterpret_cast<const char*>(&part), sizeof part);
  }
  const std::string hash = fmt::format("{:016x}", h);
  Entry* previous = find(step.id);
  // Up to date only with every output present and as the step wrote it.
  bool outputsIntact = previous != nullptr && previous->outputHashes.size() == step.outputs.size();
  if (outputsIntact) {
    const std::vector<std::string> now = outputHashes(step);
    for (std::size_t i = 0; i < now.size(); ++i)
      outputsIntact = outputsIntact && !now[i].empty() && now[i] == previous->outputHashes[i];
  }
  const std::string counter =
      total > 0 ? fmt::format("[{}/{}]", index, total) : fmt::format("[{}]", index);
  if (!force_ && outputsIntact && previous != nullptr && previous->hash == hash) {
    outcome.status = StepOutcome::Status::UpToDate;
    outcome.seconds = previous->seconds;
    outcome.notes = previous->notes;
    if (streams.errIsTerminal)
      streams.err << fmt::format("{} {}: up to date\n", counter, step.title);
    return outcome;
  }
  if (streams.errIsTerminal)
    streams.err << fmt::format("{} {} ...", counter, step.title) << std::flush;
  std::ostringstream out;
  std::ostringstream err;
  const auto start = std::chrono::steady_clock::now();
  const int code = step.action ? runAction(step, out, err) : echoreg::cli::run(step.args, out, err);
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  outcome.output = out.str();
  if (code != 0) {
    outcome.status = StepOutcome::Status::Failed;
    outcome.message = err.str();
    if (outcome.message.empty())
      outcome.message = fmt::format("exit code {}", code);
    if (streams.errIsTerminal)
      streams.err << fmt::format(" FAILED ({:.1f} s)\n", outcome.seconds);
    if (previous != nullptr)
      previous->hash.clear();
    return outcome;
  }
  outcome.status = StepOutcome::Status::Ran;
  outcome.notes = notesIn(err.str());
  if (streams.errIsTerminal) {
    streams.err << fmt::format(" {:.2f} s\n", outcome.seconds);
    for (const std::string& note : outcome.notes)
      streams.err << "    " << note << "\n";
  }
  if (previous != nullptr) {
    *previous = Entry{hash, outcome.seconds, outputHashes(step), outcome.notes};
  } else {
    state_.push_back({step.id, Entry{hash, outcome.seconds, outputHashes(step), outcome.notes}});
  }
  return outcome;
}

void StudyRunner::save() const {
  nlohmann::json steps = nlohmann::json::object();
  for (const auto& [id, entry] : state_) {
    if (!entry.hash.empty())
      steps[id] = {{"hash", entry.hash},
                   {"seconds", entry.seconds},
                   {"outputs", entry.outputHashes},
                   {"notes", entry.notes}};
  }
  core::AtomicFile file(stateFile_);
  file.stream() << nlohmann::json{{"steps", steps}}.dump(2) << "\n";
  file.commit();
}

}  // namespace echoreg::cli
