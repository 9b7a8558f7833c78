// `echoreg study sweep SWEEP.json --out DIR`: a parameter sweep (issue 16). The sweep file names
// a base (a study folder, or the simulator's options) and parameters with their values; every
// combination is a point, run as its own study (`study run` in a folder of its own that links the
// base study's files), whose numbers become one row of DIR/results.jsonl. Seeds of simulated
// studies are derived from the base seed and the simulator's parameters, so the same sweep file
// gives the same bytes. Each point's row is written atomically when its study has run, and a
// point with a row is not run again: a killed sweep resumes where it stopped. Shards (--shard I/N,
// --point ID, --study ID) let a scheduler (Snakemake, Slurm, GNU parallel) run points apart.
// The format and the layout of DIR are in docs/many-studies.md.
#include "command_register.hpp"
#include "commands.hpp"
#include "detection_params.hpp"
#include "study_runner.hpp"

#include "echoreg/cli/cli.hpp"
#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/sequence.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;

struct SweepOptions {
  std::string file;
  std::string out;
  std::string shard;
  std::string point;
  std::string study;
  bool plan = false;
};

/// A sweep file that cannot be run: usage (exit 2), nothing written.
class SweepFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The simulator's options a sweep may fix or vary (echoreg simulate's flags without dashes);
/// `seed` is the base's only (the points' seeds are derived), `out` and `json` are the sweep's.
const std::set<std::string> kSimulateOptions = {"preset",          "size",
                                                "flexion",         "standoff",
                                                "speed-of-sound",  "water-temperature",
                                                "fibula-in-tibia", "femur-regions",
                                                "tissue-scale",    "soft-tissue-scale",
                                                "probe-frequency", "adc",
                                                "frames-per-bone", "registrations",
                                                "calibrations",    "bone"};
/// Options that are flags without a value: true gives the flag, false leaves it out.
const std::set<std::string> kSimulateFlags = {"fibula-in-tibia"};

std::string shortHash(const std::string& bytes) {
  return fmt::format("{:016x}", bytesHash(bytes)).substr(0, 12);
}

/// One simulated study of the sweep (simulate bases only).
struct SweepStudy {
  std::string id;          ///< "s-" and 12 hex digits of its options' hash
  std::uint64_t seed = 0;  ///< derived from the base seed, the options and the replicate
  nlohmann::json options;  ///< simulate's options without seed, as JSON values
};

/// One combination of the parameters.
struct SweepPoint {
  std::string id;             ///< "p-" and 12 hex digits of its definition's hash
  nlohmann::json parameters;  ///< the sweep's keys and this point's values
  int study = -1;             ///< index into Sweep::studies; -1: the base study folder
  nlohmann::json detect;      ///< the point's --params object for study run (may be empty)
  /// The point's solver, study run's --method and --loss: {"method", "loss"}, either or both
  /// (empty: register's defaults).
  nlohmann::json solver;
};

struct Sweep {
  std::string file;
  std::string baseStudy;     ///< a study base: its folder (absolute)
  std::string baseManifest;  ///< its study.json's hash, part of every point's definition
  std::vector<SweepStudy> studies;
  std::vector<SweepPoint> points;
  bool givenModels = false;  ///< study run --given-models: the manifest's models, no segmentation
  /// Combinations that are the same run as an earlier point (register.loss with method plain,
  /// which has no loss): not points of their own.
  std::size_t sameRun = 0;
};

/// A JSON value as a command-line value: strings as they are, numbers as JSON writes them.
std::string flagValue(const nlohmann::json& value) {
  return value.is_string() ? value.get<std::string>() : value.dump();
}

/// simulate's command line for `options` (and the seed when given), into --out `out`.
std::vector<std::string> simulateArgs(const nlohmann::json& options, const std::string& out,
                                      std::optional<std::uint64_t> seed) {
  std::vector<std::string> args = {"simulate", "--out", out};
  if (seed)
    args.insert(args.end(), {"--seed", std::to_string(*seed)});
  for (const auto& [name, value] : options.items()) {
    if (kSimulateFlags.count(name) != 0) {
      if (value.get<bool>())
        args.push_back("--" + name);
    } else {
      args.insert(args.end(), {"--" + name, flagValue(value)});
    }
  }
  return args;
}

/// Checks simulate's options as simulate's own parser does, without running it; `where` names
/// them in the message.
void checkSimulateOptions(const std::string& file, const std::string& where,
                          const nlohmann::json& options) {
  for (const auto& [name, value] : options.items()) {
    if (kSimulateOptions.count(name) == 0) {
      throw SweepFileError(fmt::format(
          "{}: {}: \"{}\" is not an option of echoreg simulate a sweep can set (one of: {}; "
          "seeds are derived, see docs/many-studies.md)",
          file, where, name, fmt::join(kSimulateOptions, ", ")));
    }
    const bool flag = kSimulateFlags.count(name) != 0;
    if (flag ? !value.is_boolean() : !(value.is_string() || value.is_number())) {
      throw SweepFileError(fmt::format("{}: {}: \"{}\" must be {}, found {}", file, where, name,
                                       flag ? "true or false" : "a string or a number",
                                       value.dump()));
    }
  }
  CLI::App app{"echoreg"};
  addSimulateCommand(app);
  std::vector<std::string> args = simulateArgs(options, "unused", std::nullopt);
  std::reverse(args.begin(), args.end());
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw SweepFileError(fmt::format("{}: {}: {}", file, where, e.what()));
  }
}

/// Checks a point's detection parameters as `study run --params` will read them.
void checkDetect(const std::string& file, const std::string& where, const nlohmann::json& detect) {
  std::string preset;
  TunableSettings settings;
  try {
    const std::set<std::string> filled = mergeParams(detect, file, preset, settings);
    resolveParams(preset, settings, core::Sequence{}, ParamsSources{file, filled});
  } catch (const core::FileError& e) {
    throw SweepFileError(fmt::format("{}: {}: {}", file, where, e.problem()));
  } catch (const std::invalid_argument& e) {
    throw SweepFileError(fmt::format("{}: {}: {}", file, where, e.what()));
  }
}

/// The registration's solver options a sweep may vary: `register.KEY` is study run's --KEY.
const std::set<std::string> kSolverOptions = {"method", "loss"};

/// Checks a point's method or loss as study run's --method and --loss do (core's names).
void checkSolver(const std::string& file, const std::string& where, const std::string& name,
                 const nlohmann::json& value) {
  if (!value.is_string())
    throw SweepFileError(fmt::format("{}: {}: must be a string", file, where));
  try {
    solverJson(name == "method" ? value.get<std::string>() : RegisterOptions().method,
               name == "loss" ? value.get<std::string>() : RegisterOptions().loss);
  } catch (const std::invalid_argument& e) {
    throw SweepFileError(fmt::format("{}: {}: {}", file, where, e.what()));
  }
}

/// Reads and checks the sweep file and expands it into its studies and points. Throws
/// SweepFileError naming the file and the key.
Sweep readSweep(const std::string& file) {
  nlohmann::json doc;
  try {
    doc = core::readJsonFile(file, "sweep file");
  } catch (const core::FileError& e) {
    throw SweepFileError(e.what());
  }
  if (!doc.is_object())
    throw SweepFileError(file + ": must hold a JSON object (docs/many-studies.md)");
  for (const auto& [key, value] : doc.items()) {
    if (key != "study" && key != "simulate" && key != "parameters" && key != "given_models") {
      throw SweepFileError(
          fmt::format("{}: unknown key \"{}\" (a sweep has \"study\" or "
                      "\"simulate\", \"parameters\" and \"given_models\")",
                      file, key));
    }
  }
  const bool hasStudy = doc.contains("study");
  const bool hasSimulate = doc.contains("simulate");
  if (hasStudy == hasSimulate) {
    throw SweepFileError(
        fmt::format("{}: needs exactly one base: \"study\" (a study folder) or \"simulate\" (the "
                    "simulator's options)",
                    file));
  }
  Sweep sweep;
  sweep.file = file;
  if (doc.contains("given_models")) {
    if (!doc["given_models"].is_boolean())
      throw SweepFileError(file + ": \"given_models\" must be true or false");
    sweep.givenModels = doc["given_models"].get<bool>();
  }
  std::uint64_t baseSeed = 1;
  nlohmann::json baseOptions = nlohmann::json::object();
  if (hasStudy) {
    if (!doc["study"].is_string() || doc["study"].get<std::string>().empty())
      throw SweepFileError(file + ": \"study\" must be a study folder's path");
    // Relative to the sweep file, so that a sweep file travels with its study.
    const fs::path folder =
        fs::absolute(fs::path(file).parent_path() / doc["study"].get<std::string>())
            .lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(folder / "study.json", ec)) {
      throw SweepFileError(
          fmt::format("{}: \"study\": {} holds no study.json", file, folder.generic_string()));
    }
    sweep.baseStudy = folder.generic_string();
    sweep.baseManifest = fmt::format("{:016x}", contentHash((folder / "study.json").string(),
                                                            "the manifest of the study swept"));
  } else {
    const nlohmann::json& simulate = doc["simulate"];
    if (!simulate.is_object())
      throw SweepFileError(file + ": \"simulate\" must be an object of echoreg simulate's options");
    for (const auto& [name, value] : simulate.items()) {
      if (name == "seed") {
        if (!value.is_number_unsigned())
          throw SweepFileError(file + ": \"simulate\": \"seed\" must be a whole number >= 0");
        baseSeed = value.get<std::uint64_t>();
      } else {
        baseOptions[name] = value;
      }
    }
    checkSimulateOptions(file, "\"simulate\"", baseOptions);
  }
  if (!doc.contains("parameters") || !doc["parameters"].is_object() || doc["parameters"].empty()) {
    throw SweepFileError(fmt::format(
        "{}: \"parameters\" must be an object naming at least one parameter and its values "
        "(e.g. {{\"detect.cutoff\": [0.005, 0.01]}})",
        file));
  }
  // Keys in the file's JSON object order as nlohmann keeps it: sorted; the last varies fastest.
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> axes;
  for (const auto& [key, values] : doc["parameters"].items()) {
    const std::string where = fmt::format("\"parameters\": \"{}\"", key);
    if (!values.is_array() || values.empty())
      throw SweepFileError(fmt::format("{}: {} must be a non-empty list of values", file, where));
    for (std::size_t i = 0; i < values.size(); ++i) {
      for (std::size_t j = 0; j < i; ++j) {
        if (values[i] == values[j])
          throw SweepFileError(fmt::format("{}: {} lists {} twice", file, where, values[i].dump()));
      }
    }
    if (key == "replicate") {
      if (!hasSimulate)
        throw SweepFileError(fmt::format(
            "{}: {}: replicates need a \"simulate\" base (a study folder's data are fixed)", file,
            where));
      for (const nlohmann::json& v : values) {
        if (!v.is_number_unsigned())
          throw SweepFileError(
              fmt::format("{}: {}: {} is not a whole number >= 0", file, where, v.dump()));
      }
    } else if (key.rfind("simulate.", 0) == 0) {
      const std::string name = key.substr(9);
      if (!hasSimulate)
        throw SweepFileError(
            fmt::format("{}: {}: the simulator's options need a \"simulate\" base, not \"study\"",
                        file, where));
      if (name == "seed")
        throw SweepFileError(
            fmt::format("{}: {}: seeds are derived from the base seed and the parameters; sweep "
                        "\"replicate\" for more seeds",
                        file, where));
      if (baseOptions.contains(name))
        throw SweepFileError(fmt::format("{}: {}: \"{}\" is both fixed in \"simulate\" and swept",
                                         file, where, name));
      for (const nlohmann::json& v : values) {
        nlohmann::json options = baseOptions;
        options[name] = v;
        checkSimulateOptions(file, fmt::format("{} = {}", where, v.dump()), options);
      }
    } else if (key.rfind("detect.", 0) == 0) {
      const std::string name = key.substr(7);
      for (const nlohmann::json& v : values)
        checkDetect(file, fmt::format("{} = {}", where, v.dump()), {{name, v}});
    } else if (key.rfind("register.", 0) == 0 && kSolverOptions.count(key.substr(9)) != 0) {
      for (const nlohmann::json& v : values)
        checkSolver(file, fmt::format("{} = {}", where, v.dump()), key.substr(9), v);
    } else {
      throw SweepFileError(fmt::format(
          "{}: {}: a parameter is \"simulate.OPTION\" (echoreg simulate's), \"detect.KEY\" "
          "(a key of study run's --params, as echoreg detect's flags), \"register.method\", "
          "\"register.loss\" (study run's --method, --loss) or \"replicate\"",
          file, where));
    }
    axes.emplace_back(key, values.get<std::vector<nlohmann::json>>());
  }
  // The combinations, the last axis fastest.
  std::size_t count = 1;
  for (const auto& axis : axes) {
    count *= axis.second.size();
    if (count > 100000)
      throw SweepFileError(file + ": more than 100000 combinations; split the sweep");
  }
  std::vector<std::size_t> index(axes.size(), 0);
  std::set<std::string> pointIds;  // a combination that is an earlier point's run is not a point
  for (std::size_t n = 0; n < count; ++n) {
    SweepPoint point;
    point.parameters = nlohmann::json::object();
    point.detect = nlohmann::json::object();
    point.solver = nlohmann::json::object();
    nlohmann::json options = baseOptions;
    nlohmann::json replicate;
    for (std::size_t a = 0; a < axes.size(); ++a) {
      const std::string& key = axes[a].first;
      const nlohmann::json& value = axes[a].second[index[a]];
      point.parameters[key] = value;
      if (key == "replicate")
        replicate = value;
      else if (key.rfind("simulate.", 0) == 0)
        options[key.substr(9)] = value;
      else if (key.rfind("register.", 0) == 0)
        point.solver[key.substr(9)] = value;
      else
        point.detect[key.substr(7)] = value;
    }
    std::string studyKey = sweep.baseManifest;
    if (hasSimulate) {
      // The study's seed: from the base seed, the simulator's options and the replicate, not
      // from the detection or the solver (every setting of them sees the same data).
      const std::string definition = nlohmann::json{
          {"seed", baseSeed},
          {"simulate", options},
          {"replicate", replicate}}.dump();
      const std::string id = "s-" + shortHash(definition);
      const auto found = std::find_if(sweep.studies.begin(), sweep.studies.end(),
                                      [&](const SweepStudy& s) { return s.id == id; });
      if (found == sweep.studies.end()) {
        sweep.studies.push_back({id, bytesHash("seed " + definition) & 0xffffffffULL, options});
        point.study = static_cast<int>(sweep.studies.size()) - 1;
      } else {
        point.study = static_cast<int>(found - sweep.studies.begin());
      }
      studyKey = id;
    }
    // The plain ICP has no loss: a loss beside it changes nothing, so the combination is the
    // point without it (run once, one row).
    if (point.solver.contains("method") && point.solver.contains("loss") &&
        solverJson(point.solver["method"].get<std::string>(),
                   point.solver["loss"].get<std::string>())["loss"]
            .is_null()) {
      point.solver.erase("loss");
      point.parameters["register.loss"] = nullptr;
    }
    nlohmann::json definition = {
        {"study", studyKey}, {"detect", point.detect}, {"given_models", sweep.givenModels}};
    if (!point.solver.empty())
      definition["register"] = point.solver;  // absent before sweeps had it: same IDs as then
    point.id = "p-" + shortHash(definition.dump());
    if (!pointIds.insert(point.id).second)
      ++sweep.sameRun;
    else
      sweep.points.push_back(std::move(point));
    for (std::size_t a = axes.size(); a-- > 0;) {
      if (++index[a] < axes[a].second.size())
        break;
      index[a] = 0;
    }
  }
  return sweep;
}

nlohmann::json planJson(const Sweep& sweep) {
  nlohmann::json studies = nlohmann::json::array();
  for (const SweepStudy& s : sweep.studies)
    studies.push_back(
        {{"id", s.id}, {"seed", s.seed}, {"simulate", s.options}, {"folder", "studies/" + s.id}});
  nlohmann::json points = nlohmann::json::array();
  for (const SweepPoint& p : sweep.points) {
    points.push_back(
        {{"id", p.id},
         {"parameters", p.parameters},
         {"study", p.study < 0 ? nlohmann::json() : nlohmann::json(sweep.studies[p.study].id)},
         {"seed", p.study < 0 ? nlohmann::json() : nlohmann::json(sweep.studies[p.study].seed)},
         {"folder", "points/" + p.id},
         {"row", "rows/" + p.id + ".json"}});
  }
  nlohmann::json plan = {{"format", "echoreg-sweep-plan"},
                         {"base", sweep.baseStudy.empty() ? nlohmann::json("simulate")
                                                          : nlohmann::json(sweep.baseStudy)},
                         {"studies", studies},
                         {"points", points}};
  if (sweep.sameRun > 0)
    plan["same_run_combinations"] = sweep.sameRun;  // register.loss with method plain
  return plan;
}

/// A folder made under a temporary name and renamed into place, so that it exists whole or not
/// at all. When another process put it there first, theirs is kept.
template <typename Fill>
void makeFolderAtomically(const fs::path& target, Fill fill) {
  std::error_code ec;
  if (fs::exists(target, ec))
    return;
  const std::string prefix = fmt::format(".{}.tmp-", target.filename().string());
  const fs::path temporary = target.parent_path() / fmt::format("{}{}", prefix, ::getpid());
  // What a killed run left under a temporary name (its process is gone) is removed; a temporary
  // folder of a shard still running is not.
  for (const fs::directory_entry& e : fs::directory_iterator(target.parent_path(), ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) != 0)
      continue;
    const std::string pid = name.substr(
        prefix.size(), name.find_first_not_of("0123456789", prefix.size()) - prefix.size());
    if (pid.empty() || (::kill(static_cast<pid_t>(std::stol(pid)), 0) != 0 && errno == ESRCH))
      fs::remove_all(e.path(), ec);
  }
  fs::remove_all(temporary, ec);
  fs::create_directories(temporary.parent_path(), ec);
  if (ec)
    throw core::FileError(temporary.parent_path().string(), "cannot be created: " + ec.message());
  fill(temporary);
  fs::rename(temporary, target, ec);
  if (ec) {
    fs::remove_all(temporary);
    if (!fs::is_directory(target))
      throw core::FileError(target.string(), "cannot be created: " + ec.message());
  }
}

/// Runs echoreg in this process; its standard output is returned, its messages go to `err`.
int runEchoreg(const std::vector<std::string>& args, std::ostream& err) {
  std::ostringstream out;
  return run(args, out, err);
}

void simulateStudy(const Sweep& sweep, const SweepStudy& study, const fs::path& out,
                   const Streams& streams) {
  makeFolderAtomically(out / "studies" / study.id, [&](const fs::path& temporary) {
    streams.err << fmt::format("sweep: simulating {} (seed {})\n", study.id, study.seed);
    // simulate wants a folder that does not exist or is empty.
    fs::remove(temporary);
    if (runEchoreg(simulateArgs(study.options, temporary.string(), study.seed), streams.err) != 0)
      throw core::FileError(sweep.file, fmt::format("the simulation of study {} failed", study.id));
  });
}

/// The point's study folder: links to every entry of its data study but results/, and the
/// point's detection parameters.
fs::path pointFolder(const Sweep& sweep, const SweepPoint& point, const fs::path& out) {
  const fs::path data = point.study < 0
                            ? fs::path(sweep.baseStudy)
                            : fs::absolute(out / "studies" / sweep.studies[point.study].id);
  const fs::path folder = out / "points" / point.id;
  makeFolderAtomically(folder, [&](const fs::path& temporary) {
    fs::create_directories(temporary);
    std::vector<fs::path> entries;
    for (const fs::directory_entry& e : fs::directory_iterator(data)) {
      const std::string name = e.path().filename().string();
      if (name != "results" && name.front() != '.')
        entries.push_back(e.path());
    }
    std::sort(entries.begin(), entries.end());
    for (const fs::path& entry : entries) {
      // Relative links, so that the sweep's folder can be moved with its studies.
      fs::create_symlink(fs::relative(entry, fs::absolute(folder)), temporary / entry.filename());
    }
    if (!point.detect.empty()) {
      std::ofstream params(temporary / "sweep-params.json", std::ios::binary);
      params << point.detect.dump(2) << "\n";
      if (!params)
        throw core::FileError((temporary / "sweep-params.json").string(), "cannot be written");
    }
  });
  return folder;
}

/// The row of a point: its parameters and the numbers of its study's results.json (not the
/// times, so that the same sweep gives the same bytes). Folders are relative to `out`, the
/// sweep's folder: a copy of a sweep elsewhere gives the same bytes.
nlohmann::json pointRow(const Sweep& sweep, const SweepPoint& point, const fs::path& out,
                        const nlohmann::json& results) {
  nlohmann::json row = {
      {"point", point.id},
      {"parameters", point.parameters},
      {"study", "points/" + point.id},
      {"data", point.study < 0 ? fs::relative(sweep.baseStudy, fs::absolute(out)).generic_string()
                               : "studies/" + sweep.studies[point.study].id},
      {"seed",
       point.study < 0 ? nlohmann::json() : nlohmann::json(sweep.studies[point.study].seed)},
      {"status", results.contains("missing") ? "incomplete" : "done"}};
  for (const char* key : {"missing", "echoreg_version", "calibration", "segmentation",
                          "registrations", "detection_rates"}) {
    if (results.contains(key))
      row[key] = results[key];
  }
  // The solver the point's registrations used, as its study recorded it.
  if (results.contains("provenance") && results["provenance"].contains("solver"))
    row["solver"] = results["provenance"]["solver"];
  return row;
}

/// Runs one point unless its row is there; returns true when it ran.
bool runPoint(const Sweep& sweep, const SweepPoint& point, const fs::path& out,
              const Streams& streams) {
  const fs::path rowPath = out / "rows" / (point.id + ".json");
  std::error_code ec;
  if (fs::is_regular_file(rowPath, ec))
    return false;  // written atomically when its study had run: done
  if (point.study >= 0)
    simulateStudy(sweep, sweep.studies[point.study], out, streams);
  const fs::path folder = pointFolder(sweep, point, out);
  streams.err << fmt::format("sweep: point {} {}\n", point.id, point.parameters.dump());
  std::vector<std::string> args = {"study", "run", folder.string()};
  if (!point.detect.empty())
    args.insert(args.end(), {"--params", (folder / "sweep-params.json").string()});
  if (sweep.givenModels)
    args.push_back("--given-models");
  for (const auto& [name, value] : point.solver.items())
    args.insert(args.end(), {"--" + name, value.get<std::string>()});
  const fs::path resultsPath = folder / "results" / "results.json";
  fs::remove(resultsPath, ec);  // so that a study that wrote none is not read from before
  const int code = runEchoreg(args, streams.err);
  if (!fs::is_regular_file(resultsPath, ec))
    throw core::FileError(folder.string(), "the point's study run wrote no results/results.json");
  const nlohmann::json results = core::readJsonFile(resultsPath.string());
  if (results.contains("failure")) {
    throw core::FileError(folder.string(),
                          "the point's study stopped: " + results["failure"].get<std::string>());
  }
  if (code != 0 && !results.contains("missing"))
    throw core::FileError(folder.string(), "the point's study run failed");
  fs::create_directories(rowPath.parent_path(), ec);
  core::AtomicFile row(rowPath.string());
  row.stream() << pointRow(sweep, point, out, results).dump() << "\n";
  row.commit();
  return true;
}

/// Writes DIR/results.jsonl when every point has its row: the rows in the sweep's order.
/// Returns how many points have none yet.
std::size_t gather(const Sweep& sweep, const fs::path& out) {
  std::string lines;
  std::size_t missing = 0;
  for (const SweepPoint& point : sweep.points) {
    const fs::path rowPath = out / "rows" / (point.id + ".json");
    std::ifstream in(rowPath, std::ios::binary);
    if (!in) {
      ++missing;
      continue;
    }
    std::string line;
    std::getline(in, line);
    lines += line + "\n";
  }
  if (missing == 0) {
    core::AtomicFile table((out / "results.jsonl").string());
    table.stream() << lines;
    table.commit();
  }
  return missing;
}

int runSweep(const SweepOptions& o, const Streams& streams) {
  Sweep sweep;
  int shard = 0;
  int shards = 1;
  const SweepPoint* only = nullptr;
  const SweepStudy* onlyStudy = nullptr;
  try {
    sweep = readSweep(o.file);
    const int modes = (o.plan ? 1 : 0) + (o.shard.empty() ? 0 : 1) + (o.point.empty() ? 0 : 1) +
                      (o.study.empty() ? 0 : 1);
    if (modes > 1)
      throw SweepFileError("give one of --plan, --shard, --point, --study");
    if (!o.shard.empty()) {
      char slash = 0;
      std::istringstream in(o.shard);
      if (!(in >> shard >> slash >> shards) || slash != '/' || !in.eof() || shards < 1 ||
          shard < 1 || shard > shards) {
        throw SweepFileError(
            fmt::format("--shard {}: expected I/N with 1 <= I <= N (e.g. --shard 2/4)", o.shard));
      }
      --shard;
    }
    if (!o.point.empty()) {
      for (const SweepPoint& p : sweep.points)
        only = p.id == o.point ? &p : only;
      if (only == nullptr)
        throw SweepFileError(
            fmt::format("--point {}: {} has no such point (--plan lists them)", o.point, o.file));
    }
    if (!o.study.empty()) {
      for (const SweepStudy& s : sweep.studies)
        onlyStudy = s.id == o.study ? &s : onlyStudy;
      if (onlyStudy == nullptr)
        throw SweepFileError(fmt::format(
            "--study {}: {} simulates no such study (--plan lists them)", o.study, o.file));
    }
  } catch (const SweepFileError& e) {
    streams.err << "echoreg study sweep: " << e.what() << "\n";
    return 2;
  }
  if (o.plan) {
    streams.out << planJson(sweep).dump(2) << "\n";
    return 0;
  }
  const fs::path out(o.out);
  if (onlyStudy != nullptr) {
    simulateStudy(sweep, *onlyStudy, out, streams);
    streams.out << fmt::format("sweep: study {} in {}\n", onlyStudy->id,
                               (out / "studies" / onlyStudy->id).string());
    return 0;
  }
  if (only != nullptr) {
    const bool ran = runPoint(sweep, *only, out, streams);
    streams.out << fmt::format("sweep: point {} {}\n", only->id, ran ? "ran" : "was done already");
    return 0;
  }
  if (sweep.sameRun > 0) {
    streams.err << fmt::format(
        "echoreg study sweep: {} combination{} of register.loss with register.method plain "
        "(which has no loss) run once, as the point without the loss\n",
        sweep.sameRun, sweep.sameRun == 1 ? "" : "s");
  }
  int ran = 0;
  int done = 0;
  for (std::size_t i = 0; i < sweep.points.size(); ++i) {
    if (static_cast<int>(i % static_cast<std::size_t>(shards)) != shard)
      continue;
    (runPoint(sweep, sweep.points[i], out, streams) ? ran : done) += 1;
  }
  const std::size_t missing = gather(sweep, out);
  const std::string what =
      shards > 1 ? fmt::format("shard {}/{}", shard + 1, shards) : std::string("sweep");
  if (missing == 0) {
    streams.out << fmt::format("{}: {} points ran, {} were done; {} rows in {}\n", what, ran, done,
                               sweep.points.size(), (out / "results.jsonl").string());
  } else {
    streams.out << fmt::format(
        "{}: {} points ran, {} were done; {} of {} points of other shards have no row yet, "
        "results.jsonl is written when they do\n",
        what, ran, done, missing, sweep.points.size());
  }
  return 0;
}

}  // namespace

CommandAction addStudySweepCommand(CLI::App& study) {
  CLI::App* cmd = study.add_subcommand(
      "sweep",
      "Runs a parameter sweep (docs/many-studies.md): every combination of the sweep file's\n"
      "parameters (detection settings, the registration's method and loss, the simulator's\n"
      "options, replicates) is a point, run as its own study in OUT/points/ID; its numbers are a\n"
      "row of OUT/results.jsonl (in the sweep's order, written once every point has its row).\n"
      "Simulated studies get seeds derived from the base seed and their parameters: the same\n"
      "sweep file gives the same bytes. A point with a row is not run again, so a killed sweep\n"
      "resumes. A bad sweep file exits 2, naming the key, and nothing is written.");
  auto o = std::make_shared<SweepOptions>();
  cmd->add_option("sweep", o->file, "Sweep file (JSON)")->required();
  cmd->add_option("--out", o->out, "Folder of the sweep's studies and rows (created)")->required();
  cmd->add_option("--shard", o->shard,
                  "I/N: run only the points I, I+N, I+2N, ... (1-based; a Slurm array task's "
                  "share); results.jsonl is written by whichever shard finishes the last row");
  cmd->add_option("--point", o->point, "Run only this point (an ID of --plan), not gathering");
  cmd->add_option("--study", o->study, "Only simulate this study (an ID of --plan)");
  cmd->add_flag("--plan", o->plan,
                "Print the points and simulated studies with their IDs and seeds as JSON; run "
                "nothing, write nothing");
  return [o](const Streams& streams) { return runSweep(*o, streams); };
}

}  // namespace echoreg::cli
