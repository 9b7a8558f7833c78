// The detection's parameters from one place, for every command that detects (`detect`,
// `register`, the study's sweeps): one table of tunables, each a flag and a --params key with
// its help group and where it lands in DetectionParams, and one resolver. Precedence: flags >
// --params file > the command's own defaults > capture header > --preset.
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <map>
#include <set>
#include <string>
#include <variant>
#include <vector>

namespace echoreg::cli {

/// A value of one tunable, as typed on the command line or in a --params file.
using TunableValue = std::variant<int, double, std::string, bool, std::vector<double>>;

/// The tunables given, by name (the flag without its dashes).
using TunableSettings = std::map<std::string, TunableValue>;

/// Registers every tunable but those named in `except` (which the command declares itself) as a
/// flag of `cmd`, storing what is given into `settings`.
void addTunableFlags(CLI::App* cmd, TunableSettings& settings,
                     const std::set<std::string>& except = {});

/// Fills the tunables not given as flags from a --params file (and `preset` when not given);
/// unknown keys, wrong types and unreadable files are FileErrors naming the file.
void mergeParamsFile(const std::string& file, std::string& preset, TunableSettings& settings);

/// The parameters: the preset ("" = default), the capture header's acquisition settings, then
/// the settings. std::invalid_argument for an unknown preset or bad values.
DetectionParams resolveParams(const std::string& preset, const TunableSettings& settings,
                              const Sequence& sequence);

/// The settings as a JSON object (the study's cache key).
nlohmann::json settingsJson(const TunableSettings& settings);

}  // namespace echoreg::cli
