// `echoreg study compare DIR... --out OUTDIR [--group-by KEY]`: one report over many studies that
// `study run` has finished (issue 16). It reads each DIR/results/results.json and DIR/study.json,
// never runs a step, and writes OUTDIR/report.md, report.html, results.json and the box plots
// between groups. Every input is read and every figure rendered before the first file is
// written, so a bad input leaves no output behind.
#include "commands.hpp"
#include "csv_table.hpp"
#include "report.hpp"
#include "study_manifest.hpp"
#include "study_runner.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/number_text.hpp"
#include "echoreg/core/statistics.hpp"
#include "echoreg/render/plot_figure.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace echoreg::cli {
namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::vector<std::string> dirs;
  std::string out;
  std::string groupBy;
};

/// One finished study as compare reads it.
struct StudyResults {
  std::string name;  ///< the folder as given on the command line, normalised
  std::string group;
  std::string resultsPath;
  std::string manifestPath;
  std::string manifestHash;  ///< FNV-1a of study.json's bytes, as `study run` hashes inputs
  nlohmann::json results;
  StudyManifest manifest;  ///< read and checked as `study run` reads it
};

/// The six components of Eq. 4.5 in the order of Tables 5.3-5.7.
const std::vector<std::string> kComponents = {"tx_mm",  "ty_mm",  "tz_mm",
                                              "rx_deg", "ry_deg", "rz_deg"};

/// The references a study evaluates its ultrasound registrations against, as results.json keys.
const std::vector<std::pair<std::string, std::string>> kReferences = {
    {"against_mechanical", "the mechanical-probe registration (Tables 5.3-5.7)"},
    {"against_truth", "the simulation's true registration"}};

/// "generator.standoff" -> the value at /generator/standoff of the manifest, as a label; a key the
/// manifest does not have is looked up in the study's results.json ("provenance.solver.method":
/// what the study was run with, such as a sweep's settings).
std::string groupLabel(const StudyResults& study, const std::string& key) {
  std::string pointer;
  std::size_t start = 0;
  while (start <= key.size()) {
    const std::size_t dot = std::min(key.find('.', start), key.size());
    pointer += "/" + key.substr(start, dot - start);
    start = dot + 1;
  }
  const nlohmann::json::json_pointer at(pointer);
  const bool inManifest = study.manifest.document.contains(at);
  if (!inManifest && !study.results.contains(at)) {
    throw core::FileError(
        study.manifestPath,
        fmt::format("has no \"{}\" to group by, nor has {} (--group-by {}; a dotted "
                    "path into study.json such as generator.standoff, or into "
                    "results.json such as provenance.solver.method)",
                    key, study.resultsPath, key));
  }
  const nlohmann::json& value = inManifest ? study.manifest.document.at(at) : study.results.at(at);
  if (value.is_string())
    return value.get<std::string>();
  if (value.is_object() || value.is_array()) {
    throw core::FileError(
        inManifest ? study.manifestPath : study.resultsPath,
        fmt::format("\"{}\" is not a single value to group by (--group-by)", key));
  }
  return value.dump();
}

StudyResults loadStudy(const std::string& dir, const std::string& groupBy) {
  StudyResults study;
  study.name = fs::path(dir).lexically_normal().generic_string();
  while (study.name.size() > 1 && study.name.back() == '/')
    study.name.pop_back();
  study.resultsPath = (fs::path(dir) / "results" / "results.json").generic_string();
  study.manifestPath = (fs::path(dir) / "study.json").generic_string();
  if (!fs::is_directory(dir))
    throw core::FileError(dir, "is not a study folder (no such folder)");
  if (!fs::exists(study.resultsPath)) {
    throw core::FileError(study.resultsPath,
                          "is missing: the study has not been run (echoreg study run " + dir + ")");
  }
  study.results = core::readJsonFile(study.resultsPath);
  if (!study.results.is_object() || !study.results.contains("registrations") ||
      !study.results["registrations"].is_object()) {
    throw core::FileError(study.resultsPath,
                          "has no \"registrations\" object: not the results.json of a study run "
                          "that registered a bone");
  }
  for (const auto& [bone, entry] : study.results["registrations"].items()) {
    // Bone names become figure file names.
    const bool simple = !bone.empty() && std::all_of(bone.begin(), bone.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
    if (!simple || !entry.is_object()) {
      throw core::FileError(study.resultsPath,
                            fmt::format("registrations/\"{}\" is not a bone's results (a name of "
                                        "a-z, 0-9, _ and - holding an object)",
                                        bone));
    }
  }
  study.manifest = readStudyManifest(dir);
  study.manifestHash =
      fmt::format("{:016x}", contentHash(study.manifestPath, "the study's manifest"));
  study.group = groupBy.empty() ? study.name : groupLabel(study, groupBy);
  return study;
}

/// The number at `key` of one evaluation row, checked.
double rowValue(const StudyResults& study, const nlohmann::json& row, const std::string& where,
                const std::string& key) {
  const auto it = row.find(key);
  if (it == row.end() || !it->is_number() || !std::isfinite(it->get<double>())) {
    throw core::FileError(study.resultsPath,
                          fmt::format("{}: \"{}\" is missing or not a finite number", where, key));
  }
  return it->get<double>();
}

/// Mean absolute errors of one bone's ultrasound registrations against one reference (the
/// mechanical-probe registration itself, evaluated against the truth, is left out).
struct ErrorMeans {
  int registrations = 0;
  std::map<std::string, double> sumAbs;  ///< by component or target key
};

void addErrors(const StudyResults& study, const std::string& bone, const std::string& reference,
               ErrorMeans& means, std::set<std::string>& targets) {
  const nlohmann::json& entry = study.results["registrations"][bone];
  const auto list = entry.find(reference);
  if (list == entry.end())
    return;
  const std::string where = "registrations/" + bone + "/" + reference;
  if (!list->is_array())
    throw core::FileError(study.resultsPath, where + " is not a list");
  for (const nlohmann::json& row : *list) {
    if (!row.is_object() || !row.contains("estimate") || !row["estimate"].is_string())
      throw core::FileError(study.resultsPath, where + ": a row without its \"estimate\" name");
    const std::string estimate = row["estimate"].get<std::string>();
    // evaluate's summary row, and the mechanical registration itself evaluated against truth
    if (estimate == "mean_abs" || estimate.find("_mechanical") != std::string::npos)
      continue;
    ++means.registrations;
    for (const std::string& key : kComponents)
      means.sumAbs[key] += std::abs(rowValue(study, row, where, key));
    for (const auto& [key, value] : row.items()) {
      if (key.rfind("target_", 0) == 0) {
        targets.insert(key);
        means.sumAbs[key] += std::abs(rowValue(study, row, where, key));
      }
    }
  }
}

/// "target_knee_centre_mm" -> "knee centre (mm)".
std::string targetTitle(const std::string& key) {
  std::string name = key.substr(7);
  std::string unit;
  if (name.size() > 3 && name.compare(name.size() - 3, 3, "_mm") == 0) {
    name.resize(name.size() - 3);
    unit = " (mm)";
  }
  std::replace(name.begin(), name.end(), '_', ' ');
  return name + unit;
}

/// The inliers' absolute distances to the model after registration, as `study run` wrote them
/// (results/evaluation/BONE_residuals.csv); empty when the study has none.
std::vector<double> residuals(const StudyResults& study, const std::string& bone) {
  const std::string path =
      (fs::path(study.resultsPath).parent_path() / "evaluation" / (bone + "_residuals.csv"))
          .generic_string();
  if (!fs::exists(path))
    return {};
  const CsvTable table = readCsvTable(path);
  const int value = table.column("abs_residual_mm");
  const int inlier = table.column("inlier");
  if (value < 0 || inlier < 0)
    throw core::FileError(path, "has no \"abs_residual_mm\" and \"inlier\" columns");
  std::vector<double> values;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    if (table.rows[r][static_cast<std::size_t>(inlier)] != "1")
      continue;
    values.push_back(parseCsvNumber(table.rows[r][static_cast<std::size_t>(value)], path, r + 2,
                                    "abs_residual_mm"));
  }
  return values;
}

int runCompare(const CompareOptions& o, const Streams& streams) {
  std::set<std::string> seen;
  for (const std::string& dir : o.dirs) {
    if (!seen.insert(fs::weakly_canonical(dir).string()).second)
      throw std::invalid_argument("study folder " + dir + " is given twice");
  }
  if (fs::exists(o.out) && !fs::is_directory(o.out))
    throw core::FileError(o.out, "is not a folder (--out)");

  std::vector<StudyResults> studies;
  for (const std::string& dir : o.dirs)
    studies.push_back(loadStudy(dir, o.groupBy));
  std::vector<std::string> groups;  // in order of first appearance
  for (const StudyResults& s : studies) {
    if (std::find(groups.begin(), groups.end(), s.group) == groups.end())
      groups.push_back(s.group);
  }
  std::set<std::string> bones;
  for (const StudyResults& s : studies) {
    for (const auto& [bone, entry] : s.results["registrations"].items())
      bones.insert(bone);
  }

  Report report;
  nlohmann::json merged = {
      {"format", "echoreg-study-compare"},
      {"echoreg_version", ECHOREG_VERSION},
      {"group_by", o.groupBy.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.groupBy)}};
  const std::string title = fmt::format("Comparison of {} studies", studies.size());
  report.heading(title, 1);
  report.paragraph(fmt::format(
      "Studies grouped by {}. Each study's numbers are those its own study run wrote "
      "to results/results.json; nothing is recomputed but the means and the statistics between "
      "groups.",
      o.groupBy.empty() ? "folder (each study its own group)" : "`" + o.groupBy + "`"));

  // Provenance first: which study, which manifest, which parameters.
  report.heading("Studies");
  std::vector<std::vector<std::string>> studyRows;
  nlohmann::json studyList = nlohmann::json::array();
  for (const StudyResults& s : studies) {
    const nlohmann::json version = s.results.value("echoreg_version", nlohmann::json(nullptr));
    const nlohmann::json& generator = s.manifest.generator;
    std::string parameters;
    if (generator.is_object()) {
      for (const auto& [key, value] : generator.items()) {
        if (key != "tool")
          parameters += (parameters.empty() ? "" : ", ") + key + " " +
                        (value.is_string() ? value.get<std::string>() : value.dump());
      }
    }
    // The detection parameters the study ran with (study run --params: a sweep's point), which
    // its manifest does not show.
    const nlohmann::json provenance = s.results.value("provenance", nlohmann::json(nullptr));
    const nlohmann::json detectionParams =
        provenance.is_object() ? provenance.value("detection_params", nlohmann::json(nullptr))
                               : nlohmann::json(nullptr);
    std::string detection;
    if (detectionParams.is_object()) {
      const nlohmann::json preset = detectionParams.value("preset", nlohmann::json(nullptr));
      if (preset.is_string())
        detection = "preset " + preset.get<std::string>();
      const nlohmann::json settings = detectionParams.value("settings", nlohmann::json(nullptr));
      if (settings.is_object()) {
        for (const auto& [key, value] : settings.items()) {
          detection += (detection.empty() ? "" : ", ") + key + " " +
                       (value.is_string() ? value.get<std::string>() : value.dump());
        }
      }
    }
    // The solver of its registrations from ultrasound (study run --method, --loss); null for
    // studies run before study run recorded it.
    const nlohmann::json solver = provenance.is_object()
                                      ? provenance.value("solver", nlohmann::json(nullptr))
                                      : nlohmann::json(nullptr);
    std::string solverText = "not recorded";
    if (solver.is_object() && solver.value("method", nlohmann::json()).is_string()) {
      solverText = solver["method"].get<std::string>();
      if (solver.value("loss", nlohmann::json()).is_string())
        solverText += ", " + solver["loss"].get<std::string>();
    }
    studyRows.push_back({s.name, s.group, s.manifestHash,
                         version.is_string() ? version.get<std::string>() : "not recorded",
                         parameters.empty() ? "-" : parameters, detection.empty() ? "-" : detection,
                         solverText});
    studyList.push_back(
        {{"name", s.name},
         {"group", s.group},
         {"provenance",
          {{"results", s.resultsPath},
           {"manifest", s.manifestPath},
           {"manifest_fnv1a64", s.manifestHash},
           {"echoreg_version", version},
           {"parameters",
            {{"generator", generator},
             {"detection", s.manifest.document.value("detection", nlohmann::json(nullptr))},
             {"registration", s.manifest.document.value("registration", nlohmann::json(nullptr))},
             {"detection_params", detectionParams},
             {"solver", solver}}}}},
         {"results", s.results}});
  }
  report.table(
      {"study", "group", "manifest (FNV-1a 64)", "echoreg", "simulation parameters",
       "detection parameters (study run --params)", "registration (study run --method, --loss)"},
      studyRows);
  merged["studies"] = studyList;

  // Tables 5.3-5.7 side by side: one row per study, then one per group pooling its studies.
  nlohmann::json errorTables = nlohmann::json::object();
  for (const auto& [reference, referenceTitle] : kReferences) {
    for (const std::string& bone : bones) {
      std::set<std::string> targets;
      std::vector<std::pair<std::string, ErrorMeans>> perStudy;
      for (const StudyResults& s : studies) {
        ErrorMeans m;
        if (s.results["registrations"].contains(bone))
          addErrors(s, bone, reference, m, targets);
        perStudy.emplace_back(s.group, m);
      }
      std::vector<std::string> keys = kComponents;
      keys.insert(keys.end(), targets.begin(), targets.end());
      std::vector<std::string> header = {"study",      "group",      "registrations",
                                         "|tx| (mm)",  "|ty| (mm)",  "|tz| (mm)",
                                         "|rx| (deg)", "|ry| (deg)", "|rz| (deg)"};
      for (const std::string& t : targets)
        header.push_back(targetTitle(t));
      std::vector<std::vector<std::string>> rows;
      nlohmann::json tableJson = nlohmann::json::array();
      auto addRow = [&](const std::string& name, const std::string& group, const ErrorMeans& m) {
        std::vector<std::string> cells = {name, group, fmt::format("{}", m.registrations)};
        nlohmann::json row = {{"name", name}, {"group", group}, {"registrations", m.registrations}};
        for (const std::string& key : keys) {
          const auto it = m.sumAbs.find(key);
          if (m.registrations == 0 || it == m.sumAbs.end()) {
            cells.push_back("-");
            continue;
          }
          const double mean = it->second / m.registrations;
          cells.push_back(core::number(mean, 2));
          row["mean_abs_" + key] = mean;
        }
        rows.push_back(cells);
        tableJson.push_back(row);
      };
      bool any = false;
      for (std::size_t i = 0; i < studies.size(); ++i) {
        addRow(studies[i].name, perStudy[i].first, perStudy[i].second);
        any = any || perStudy[i].second.registrations > 0;
      }
      if (!any)
        continue;
      if (groups.size() < studies.size()) {
        for (const std::string& group : groups) {
          ErrorMeans pooled;
          for (const auto& [g, m] : perStudy) {
            if (g != group)
              continue;
            pooled.registrations += m.registrations;
            for (const auto& [key, sum] : m.sumAbs)
              pooled.sumAbs[key] += sum;
          }
          addRow("all of " + group, group, pooled);
        }
      }
      report.heading(fmt::format("{}: ultrasound against {}", bone, referenceTitle));
      report.paragraph(
          "Mean of the absolute errors over each study's ultrasound registrations (Eq. 4.5: "
          "translations along and rotations about CT x, y, z at the knee centre; target errors "
          "as distances).");
      report.table(header, rows);
      errorTables[reference][bone] = tableJson;
    }
  }
  merged["errors"] = errorTables;

  // Calibration (Table 5.1) of each study side by side.
  {
    std::vector<std::vector<std::string>> rows;
    for (const StudyResults& s : studies) {
      const nlohmann::json c = s.results.value("calibration", nlohmann::json(nullptr));
      if (!c.is_object())
        continue;
      const std::string where = "calibration";
      rows.push_back({s.name, s.group, core::number(rowValue(s, c, where, "rms_mm"), 3),
                      core::number(rowValue(s, c, where, "speed_of_sound_mps"), 1),
                      fmt::format("{}", rowValue(s, c, where, "shots_used"))});
    }
    if (!rows.empty()) {
      report.heading("Calibration of each study (Table 5.1)");
      report.table({"study", "group", "RMS (mm)", "speed of sound (m/s)", "shots used"}, rows);
    }
  }

  // Table 5.2 pooled: each study's calibration sessions, then every session of a group together
  // (the spread of one probe over more sessions than one study holds).
  {
    using Session = std::array<double, 6>;  // x, y, z (mm), RMS (mm), condition, speed (m/s)
    std::vector<std::pair<std::string, std::vector<Session>>> perStudy;  // group, sessions
    for (const StudyResults& s : studies) {
      std::vector<Session> sessions;
      const nlohmann::json table = s.results.value("calibration_sessions", nlohmann::json(nullptr));
      if (table.is_object() && table.contains("sessions") && table["sessions"].is_array()) {
        for (std::size_t k = 0; k < table["sessions"].size(); ++k) {
          const nlohmann::json& row = table["sessions"][k];
          const std::string where = fmt::format("calibration_sessions/sessions/{}", k);
          const nlohmann::json offset = row.value("beam_to_probe_mm", nlohmann::json(nullptr));
          if (!offset.is_array() || offset.size() != 3 ||
              !std::all_of(offset.begin(), offset.end(), [](const nlohmann::json& v) {
                return v.is_number() && std::isfinite(v.get<double>());
              })) {
            throw core::FileError(s.resultsPath,
                                  where + ": \"beam_to_probe_mm\" is not [x, y, z] in mm");
          }
          sessions.push_back({offset[0].get<double>(), offset[1].get<double>(),
                              offset[2].get<double>(), rowValue(s, row, where, "rms_mm"),
                              rowValue(s, row, where, "condition_number"),
                              rowValue(s, row, where, "speed_of_sound_mps")});
        }
      }
      perStudy.emplace_back(s.group, std::move(sessions));
    }
    std::vector<std::vector<std::string>> rows;
    nlohmann::json pooledJson = nlohmann::json::array();
    auto addRow = [&](const std::string& name, const std::string& group,
                      const std::vector<Session>& sessions) {
      if (sessions.empty())
        return;
      Session mean{}, low = sessions.front(), high = sessions.front();
      for (const Session& v : sessions) {
        for (std::size_t i = 0; i < v.size(); ++i) {
          mean[i] += v[i] / static_cast<double>(sessions.size());
          low[i] = std::min(low[i], v[i]);
          high[i] = std::max(high[i], v[i]);
        }
      }
      rows.push_back({name, group, fmt::format("{}", sessions.size()), core::number(mean[0], 2),
                      core::number(mean[1], 2), core::number(mean[2], 2),
                      core::number(high[0] - low[0], 2), core::number(high[1] - low[1], 2),
                      core::number(high[2] - low[2], 2), core::number(mean[3], 3),
                      core::number(mean[4], 2), core::number(mean[5], 1)});
      pooledJson.push_back(
          {{"name", name},
           {"group", group},
           {"sessions", sessions.size()},
           {"mean_beam_to_probe_mm", {mean[0], mean[1], mean[2]}},
           {"spread_beam_to_probe_mm", {high[0] - low[0], high[1] - low[1], high[2] - low[2]}},
           {"mean_rms_mm", mean[3]},
           {"mean_condition_number", mean[4]},
           {"mean_speed_of_sound_mps", mean[5]}});
    };
    for (std::size_t i = 0; i < studies.size(); ++i)
      addRow(studies[i].name, perStudy[i].first, perStudy[i].second);
    if (!rows.empty() && groups.size() < studies.size()) {
      for (const std::string& group : groups) {
        std::vector<Session> pooled;
        for (const auto& [g, sessions] : perStudy) {
          if (g == group)
            pooled.insert(pooled.end(), sessions.begin(), sessions.end());
        }
        addRow("all of " + group, group, pooled);
      }
    }
    if (!rows.empty()) {
      report.heading("Calibration sessions pooled (Table 5.2)");
      report.paragraph(
          "Each study's calibration sessions (studies of two or more), then every session of a "
          "group together: the mean BeamToProbe translation, its spread (max - min) over the "
          "sessions, and the mean RMS, condition number and fitted speed of sound.");
      report.table({"study", "group", "sessions", "x (mm)", "y (mm)", "z (mm)", "spread x (mm)",
                    "spread y (mm)", "spread z (mm)", "RMS (mm)", "condition number",
                    "speed of sound (m/s)"},
                   rows);
      merged["calibration_sessions"] = pooledJson;
    }
  }

  // Table 6.1 pooled by group: frames summed, rates over the pooled frames.
  {
    struct Counts {
      double bone = 0, other = 0, falseNegative = 0, falsePositive = 0;
    };
    std::map<std::tuple<std::size_t, std::string, std::string>, Counts> pooled;
    for (const StudyResults& s : studies) {
      const nlohmann::json rates = s.results.value("detection_rates", nlohmann::json::array());
      const std::size_t groupIndex = static_cast<std::size_t>(
          std::find(groups.begin(), groups.end(), s.group) - groups.begin());
      for (const nlohmann::json& r : rates) {
        const std::string where = "detection_rates";
        if (!r.is_object() || !r.value("bone", nlohmann::json()).is_string() ||
            !r.value("setting", nlohmann::json()).is_string())
          throw core::FileError(s.resultsPath, where + ": a row without its bone and setting");
        Counts& c =
            pooled[{groupIndex, r["bone"].get<std::string>(), r["setting"].get<std::string>()}];
        const double bone = rowValue(s, r, where, "bone_frames");
        const double other = rowValue(s, r, where, "other_frames");
        c.bone += bone;
        c.other += other;
        c.falseNegative += bone * rowValue(s, r, where, "false_negative_pct") / 100.0;
        c.falsePositive += other * rowValue(s, r, where, "false_positive_pct") / 100.0;
      }
    }
    if (!pooled.empty()) {
      std::vector<std::vector<std::string>> rows;
      nlohmann::json json = nlohmann::json::array();
      for (const auto& [key, c] : pooled) {
        const auto& [groupIndex, bone, setting] = key;
        const double fn = c.bone > 0 ? 100.0 * c.falseNegative / c.bone : 0.0;
        const double fp = c.other > 0 ? 100.0 * c.falsePositive / c.other : 0.0;
        rows.push_back({groups[groupIndex], bone, setting, core::number(c.bone, 0),
                        core::number(c.other, 0), core::number(fn, 1), core::number(fp, 1)});
        json.push_back({{"group", groups[groupIndex]},
                        {"bone", bone},
                        {"setting", setting},
                        {"bone_frames", c.bone},
                        {"other_frames", c.other},
                        {"false_negative_pct", fn},
                        {"false_positive_pct", fp}});
      }
      report.heading("Detection rates pooled by group (Table 6.1)");
      report.table({"group", "bone", "setting", "bone frames", "other frames",
                    "false negatives (%)", "false positives (%)"},
                   rows);
      merged["detection_rates"] = json;
    }
  }

  // Box plots between groups with the one-way ANOVA (Figs. 6.1, 6.3, 6.7-6.9): each bone's
  // ultrasound points' distances to the model after registration, pooled per group.
  std::vector<std::pair<std::string, render::RgbImage>> figures;
  nlohmann::json anova = nlohmann::json::object();
  report.heading("Between groups");
  for (const std::string& bone : bones) {
    std::vector<render::BoxGroup> boxGroups;
    std::vector<std::string> without;
    for (const std::string& group : groups) {
      render::BoxGroup g{group, {}};
      for (const StudyResults& s : studies) {
        if (s.group != group)
          continue;
        const std::vector<double> values = residuals(s, bone);
        if (values.empty())
          without.push_back(s.name);
        g.values.insert(g.values.end(), values.begin(), values.end());
      }
      if (!g.values.empty())
        boxGroups.push_back(std::move(g));
    }
    nlohmann::json entry = {{"value", "abs_residual_mm of the inlier points"}};
    nlohmann::json summaries = nlohmann::json::array();
    for (const render::BoxGroup& g : boxGroups) {
      const core::BoxSummary b = core::boxSummary(g.values);
      summaries.push_back({{"group", g.label},
                           {"n", b.count},
                           {"mean", b.mean},
                           {"median", b.median},
                           {"q1", b.q1},
                           {"q3", b.q3}});
    }
    entry["groups"] = summaries;
    std::string anovaText;
    if (boxGroups.size() >= 2) {
      std::vector<std::vector<double>> values;
      for (const render::BoxGroup& g : boxGroups)
        values.push_back(g.values);
      try {
        const core::AnovaResult a = core::oneWayAnova(values);
        entry["anova"] = {
            {"f", a.f}, {"df_between", a.dfBetween}, {"df_within", a.dfWithin}, {"p", a.pValue}};
        anovaText = fmt::format("one-way ANOVA F({}, {}) = {:.3g}, p = {:.3g}", a.dfBetween,
                                a.dfWithin, a.f, a.pValue);
      } catch (const std::invalid_argument& e) {
        entry["anova"] = {{"undefined", e.what()}};
        anovaText = std::string("one-way ANOVA undefined: ") + e.what();
      }
    } else {
      anovaText = "one group only: no ANOVA";
      entry["anova"] = {{"undefined", anovaText}};
    }
    anova[bone] = entry;
    if (boxGroups.empty()) {
      report.paragraph(fmt::format("No study has the {}'s residuals.", bone));
      continue;
    }
    const std::string image = "figures/" + bone + "_between_groups.png";
    figures.emplace_back(
        image,
        render::renderBoxPlot(boxGroups, "Distances to the " + bone + " model", "|distance| (mm)"));
    std::string caption = fmt::format(
        "The {}'s ultrasound points (the inliers of each registration) at their distance to "
        "the model after registration, pooled per group ({}).",
        bone, anovaText);
    if (!without.empty()) {
      std::string list;
      for (const std::string& name : without)
        list += (list.empty() ? "" : ", ") + name;
      caption += " Without residuals: " + list + ".";
    }
    report.figure(image, caption);
  }
  merged["between_groups"] = anova;

  // Everything is read and rendered: now write, each file atomically.
  fs::create_directories(fs::path(o.out) / "figures");
  core::AtomicFile md((fs::path(o.out) / "report.md").string());
  md.stream() << report.markdown();
  core::AtomicFile html((fs::path(o.out) / "report.html").string());
  html.stream() << report.html(title);
  core::AtomicFile json((fs::path(o.out) / "results.json").string());
  json.stream() << merged.dump(2) << "\n";
  for (const auto& [image, pixels] : figures)
    render::writePng((fs::path(o.out) / image).string(), pixels);
  md.commit();
  html.commit();
  json.commit();
  streams.out << fmt::format(
      "study compare: {} studies in {} groups, report in {}\n", studies.size(), groups.size(),
      fs::absolute(fs::path(o.out) / "report.html").lexically_normal().string());
  return 0;
}

}  // namespace

CommandAction addStudyCompareCommand(CLI::App& study) {
  auto o = std::make_shared<CompareOptions>();
  CLI::App* cmd = study.add_subcommand(
      "compare",
      "One report over studies that `study run` has finished: the registration errors of each\n"
      "study and bone side by side (Tables 5.3-5.7, mean of absolute values), calibration\n"
      "(Table 5.1), the calibration sessions pooled by study and group (Table 5.2), detection\n"
      "rates pooled by group (Table 6.1), box plots of the points'\n"
      "distances between groups with the one-way ANOVA (Figs. 6.1, 6.3, 6.7-6.9), and one\n"
      "results.json with each study's results and provenance. Writes OUTDIR/report.md,\n"
      "report.html, results.json and figures/ (docs/many-studies.md). Reads only; exits 1\n"
      "naming the file when a study's results.json or study.json is missing or invalid.");
  cmd->add_option("dirs", o->dirs, "Study folders (each holds study.json and results/)")
      ->required();
  cmd->add_option("--out", o->out, "Folder to write the report into (created)")->required();
  cmd->add_option("--group-by", o->groupBy,
                  "Group studies by a manifest value, a dotted path into study.json such as\n"
                  "generator.standoff or detection.speed_of_sound_mps, or, where study.json\n"
                  "has no such key, into results/results.json, such as\n"
                  "provenance.solver.method (default: each study its own group)");
  return [o](const Streams& streams) { return runCompare(*o, streams); };
}

}  // namespace echoreg::cli
