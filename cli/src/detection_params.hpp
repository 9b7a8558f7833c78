// The detection's parameters from one place, for every command that detects (`detect`,
// `register`, `calibrate`, `live`, the study's sweeps): one table of tunables, each a flag and a
// --params key with its help group and where it lands in DetectionParams, and one resolver.
// Precedence: flags > --params file > the command's own defaults > capture header > --preset.
// Apart from the commands also so that fuzz/fuzz_params reads --params files as they do.
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

namespace echoreg::cli {

// A value of one tunable, as typed on the command line or in a --params file.
using TunableValue = std::variant<int, double, std::string, bool, std::vector<double>>;

// One tunable of the chain: its flag (and, without the dashes, its key in --params files), its
// help group and text, its type (the alternative held by `type`), where it lands, and the range
// its flag is checked against where the flag is parsed (exit 2 naming the flag), when it has one.
struct Tunable {
  const char* name;
  const char* group;
  std::string help;
  TunableValue type;
  std::function<void(core::DetectionParams&, const TunableValue&)> apply;
  std::optional<std::array<double, 2>> flagRange = std::nullopt;
};

// Every tunable, in the order they are applied. "preset" is applied before all of them (it sets
// the starting point), then the capture header, then these.
const std::vector<Tunable>& tunables();

// The tunables given so far, by name; flags first, then a --params file fills the rest.
using TunableSettings = std::map<std::string, TunableValue>;

/// Registers every tunable but those named in `except` (which the command declares itself) as a
/// flag of `cmd`, storing what is given into `settings`.
void addTunableFlags(CLI::App* cmd, TunableSettings& settings,
                     const std::set<std::string>& except = {});

/// Fills the tunables (and the preset) not given as flags from a --params file; returns the names
/// it filled. Throws FileError naming the file for a file that is not a JSON object, an unknown
/// key, or a value of the wrong type.
std::set<std::string> mergeParamsFile(const std::string& file, std::string& preset,
                                      TunableSettings& settings);

/// As mergeParamsFile, for parameters already read (a sweep's point, docs/many-studies.md); errors
/// name `source` as the file.
std::set<std::string> mergeParams(const nlohmann::json& params, const std::string& source,
                                  std::string& preset, TunableSettings& settings);

/// Where the settings came from, for messages: `fromFile` names those of `paramsFile`, the others
/// were flags.
struct ParamsSources {
  std::string paramsFile;
  std::set<std::string> fromFile;
};

/// The parameters of `preset` (default when empty), then the capture header's acquisition values,
/// then `settings`, validated. A value that is refused names where it was given: a flag
/// (std::invalid_argument "--speed-of-sound 0: speed of sound must be ...") or the --params file
/// (FileError). Values refused only together throw std::invalid_argument without a name.
core::DetectionParams resolveParams(const std::string& preset, const TunableSettings& settings,
                                    const core::Sequence& sequence,
                                    const ParamsSources& sources = {});

/// The settings as a JSON object (the study's cache key).
nlohmann::json settingsJson(const TunableSettings& settings);

/// Where a capture's sampling frequency comes from: "given" (the settings: a flag or --params),
/// "header" (the capture's) or "assumed" (the preset's). Every depth, and every length the
/// detector takes in mm, scales with it.
std::string samplingFrequencySource(const TunableSettings& settings,
                                    const core::Sequence& sequence);

/// The warning for an assumed sampling frequency of `hz` for `capture`, naming the flag.
std::string assumedSamplingFrequencyWarning(const std::string& capture, double hz);

}  // namespace echoreg::cli
