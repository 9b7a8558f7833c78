// `echoreg study run`: the report (results/report.md, report.html, results.json) from the results
// the steps left (command_study_detail.hpp). A result that is not there is left out of the report,
// or marked failed.
#include "command_study_detail.hpp"

#include "csv_table.hpp"
#include "model_file.hpp"
#include "report.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/core/number_text.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <filesystem>

namespace echoreg::cli::detail {

namespace fs = std::filesystem;

namespace {

// Table 5.1: the calibration the sweeps use.
void reportCalibration(Report& report, nlohmann::json& numbers, const std::string& calibration,
                       const std::string& calibrationFigure) {
  const nlohmann::json cal = core::readJsonFile(calibration);
  report.heading("Calibration of the transducer (Table 5.1)");
  const auto& m = cal.at("matrix");
  report.table({"", "x (mm)", "y (mm)", "z (mm)", "RMS (mm)", "speed of sound (m/s)", "shots used"},
               {{"BeamToProbe translation", core::number(m[0][3].get<double>(), 2),
                 core::number(m[1][3].get<double>(), 2), core::number(m[2][3].get<double>(), 2),
                 core::number(cal.value("rms_mm", 0.0), 3),
                 core::number(cal.value("speed_of_sound_mps", 0.0), 1),
                 fmt::format("{}", cal.value("shots_used", 0))}});
  numbers["calibration"] = {{"beam_to_probe_mm", {m[0][3], m[1][3], m[2][3]}},
                            {"rms_mm", cal.value("rms_mm", 0.0)},
                            {"speed_of_sound_mps", cal.value("speed_of_sound_mps", 0.0)},
                            {"shots_used", cal.value("shots_used", 0)}};
  if (fs::exists(calibrationFigure)) {
    report.figure("figures/calibration.png",
                  "Calibration points on the sphere, coloured by their distance to it "
                  "(green < 0.5 mm, yellow 0.5-1.0 mm, red > 1.0 mm), as Figs. 5.1-5.5.");
  }
}

// Table 5.2: the repeatability of the calibration over the manifest's sessions.
void reportCalibrationSessions(Report& report, nlohmann::json& numbers,
                               const StudyManifest& manifest,
                               const std::vector<ManifestCalibrationSession>& sessions,
                               const std::vector<std::string>& calibrations, StudyReads& read) {
  // x, y, z (mm), RMS (mm), condition number, speed of sound (m/s) of each session calibrated.
  std::vector<std::array<double, 6>> values;
  std::vector<std::vector<std::string>> rows;
  nlohmann::json entries = nlohmann::json::array();
  for (std::size_t k = 0; k < calibrations.size(); ++k) {
    const std::string shots = fs::path(sessions[k].capture).filename().string();
    if (!fs::exists(calibrations[k])) {
      rows.push_back({fmt::format("{}", k + 1), shots, "—", "—", "—", "—", "—", "—", "—"});
      continue;
    }
    const nlohmann::json cal = core::readJsonFile(calibrations[k]);
    const auto& m = cal.at("matrix");
    const std::array<double, 6> v = {m[0][3].get<double>(),
                                     m[1][3].get<double>(),
                                     m[2][3].get<double>(),
                                     cal.value("rms_mm", 0.0),
                                     cal.value("condition_number", 0.0),
                                     cal.value("speed_of_sound_mps", 0.0)};
    values.push_back(v);
    rows.push_back({fmt::format("{}", k + 1), shots, core::number(v[0], 2), core::number(v[1], 2),
                    core::number(v[2], 2), core::number(v[3], 3), core::number(v[4], 2),
                    core::number(v[5], 1), fmt::format("{}", cal.value("shots_used", 0))});
    entries.push_back({{"session", k + 1},
                       {"sphere_capture", sessions[k].sphereCapture},
                       {"capture", sessions[k].capture},
                       {"calibration", calibrations[k]},
                       {"beam_to_probe_mm", {v[0], v[1], v[2]}},
                       {"rms_mm", v[3]},
                       {"condition_number", v[4]},
                       {"speed_of_sound_mps", v[5]},
                       {"shots_used", cal.value("shots_used", 0)}});
  }
  nlohmann::json table = {{"sessions", entries}};
  if (!values.empty()) {
    std::array<double, 6> mean{}, low = values.front(), high = values.front();
    for (const auto& v : values) {
      for (std::size_t i = 0; i < v.size(); ++i) {
        mean[i] += v[i] / static_cast<double>(values.size());
        low[i] = std::min(low[i], v[i]);
        high[i] = std::max(high[i], v[i]);
      }
    }
    std::array<double, 6> spread{};
    for (std::size_t i = 0; i < spread.size(); ++i)
      spread[i] = high[i] - low[i];
    const auto summary = [&](const std::string& name, const std::array<double, 6>& v) {
      rows.push_back({name, "", core::number(v[0], 2), core::number(v[1], 2), core::number(v[2], 2),
                      core::number(v[3], 3), core::number(v[4], 2), core::number(v[5], 1), ""});
      return nlohmann::json{{"beam_to_probe_mm", {v[0], v[1], v[2]}},
                            {"rms_mm", v[3]},
                            {"condition_number", v[4]},
                            {"speed_of_sound_mps", v[5]}};
    };
    table["mean"] = summary("mean", mean);
    table["spread"] = summary("spread (max - min)", spread);
  }
  // A simulated study knows the probe's true BeamToProbe.
  if (const std::string truthFile = read(manifest.truth.transforms);
      !truthFile.empty() && fs::exists(truthFile)) {
    const nlohmann::json truth = core::readJsonFile(truthFile);
    if (truth.contains("BeamToProbe")) {
      const auto& t = truth.at("BeamToProbe");
      const std::array<double, 3> offset = {
          t.at(0).at(3).get<double>(), t.at(1).at(3).get<double>(), t.at(2).at(3).get<double>()};
      rows.push_back({"truth (simulation)", "", core::number(offset[0], 2),
                      core::number(offset[1], 2), core::number(offset[2], 2), "", "", "", ""});
      table["truth_beam_to_probe_mm"] = offset;
    }
  }
  report.heading("Repeatability of the calibration (Table 5.2)");
  report.paragraph(fmt::format(
      "The probe calibrated in each of the manifest's {} sessions (the bath set up anew), the "
      "speed of sound fitted: BeamToProbe's translation, the RMS of the echoes' distances to the "
      "sphere, the condition number of the fit (lower: the shots spread better) and the fitted "
      "speed of sound. The sweeps use session 1's calibration.",
      calibrations.size()));
  report.table({"session", "shots", "x (mm)", "y (mm)", "z (mm)", "RMS (mm)", "condition number",
                "speed of sound (m/s)", "shots used"},
               rows);
  numbers["calibration_sessions"] = table;
}

// Segmentation accuracy against the simulation's truth (within the model's slab).
void reportSegmentation(Report& report, nlohmann::json& numbers, const StudyManifest& manifest,
                        const std::vector<BoneRun>& boneRuns, StudyReads& read) {
  std::vector<std::vector<std::string>> rows;
  nlohmann::json seg = nlohmann::json::object();
  for (const BoneRun& run : boneRuns) {
    if (!run.segmented || !fs::exists(run.model))
      continue;
    const auto truthEntry = manifest.truth.model.find(run.name);
    const std::string truthModel =
        truthEntry == manifest.truth.model.end() ? std::string() : read(truthEntry->second);
    if (truthModel.empty() || !fs::exists(truthModel))
      continue;
    const core::TriangleMesh model = readModelFile(run.model);
    const core::TriangleMesh truth = readModelFile(truthModel);
    const auto box = core::bounds(model);
    segmentation::SurfaceComparisonOptions options;
    options.zMinMm = box[0].z() + 2.0;  // the model is closed at its scan's ends
    options.zMaxMm = box[1].z() - 2.0;
    const segmentation::SurfaceComparison c = segmentation::compareSurfaces(model, truth, options);
    rows.push_back({run.name, core::number(c.meanMm, 3), core::number(c.p95Mm, 3),
                    core::number(c.maxMm, 2), core::number(c.dice, 4)});
    seg[run.name] = {{"mean_surface_distance_mm", c.meanMm},
                     {"p95_mm", c.p95Mm},
                     {"max_mm", c.maxMm},
                     {"dice", c.dice},
                     {"z_range_mm", {options.zMinMm, options.zMaxMm}}};
  }
  if (!rows.empty()) {
    report.heading("Segmentation of the CT");
    report.paragraph(
        "Each bone grown from the manifest's seed and refined by the CT's own "
        "iso-surface (echoreg segment --auto), compared with the simulation's true "
        "surface over the scanned knee group (2 mm inside its ends).");
    report.table({"bone", "mean surface distance (mm)", "95th percentile (mm)", "max (mm)", "Dice"},
                 rows);
    numbers["segmentation"] = seg;
  }
}

// An evaluation's table of errors, into the report and as JSON.
nlohmann::json evaluationTable(Report& report, const std::string& csv) {
  const CsvTable table = readCsvTable(csv);
  std::vector<std::string> header;
  for (const std::string& h : table.header) {
    std::string name = h;
    if (name.rfind("target_", 0) == 0)
      name = "error at " + name.substr(7);
    for (const char* unit : {"_mm", "_deg"}) {
      const auto at = name.rfind(unit);
      if (at != std::string::npos && at + std::string(unit).size() == name.size()) {
        name = name.substr(0, at) + (std::string(unit) == "_mm" ? " (mm)" : " (deg)");
      }
    }
    header.push_back(name);
  }
  std::vector<std::vector<std::string>> rows;
  nlohmann::json json = nlohmann::json::array();
  for (const auto& row : table.rows) {
    std::vector<std::string> cells{row[0] == "mean_abs" ? "mean of absolute values" : row[0]};
    nlohmann::json entry = {{"estimate", row[0]}};
    for (std::size_t c = 1; c < row.size(); ++c) {
      const double v = parseCsvNumber(row[c], csv, 0, table.header[c]);
      cells.push_back(core::number(v, 2));
      entry[table.header[c]] = v;
    }
    rows.push_back(cells);
    json.push_back(entry);
  }
  report.table(header, rows);
  return json;
}

// Registrations: each bone's results and its errors (Tables 5.3-5.7).
void reportRegistrations(Report& report, nlohmann::json& numbers,
                         const std::vector<BoneRun>& boneRuns, const std::string& results) {
  nlohmann::json registrations = nlohmann::json::object();
  for (const BoneRun& run : boneRuns) {
    report.heading("Registration of the " + run.name);
    std::vector<std::vector<std::string>> rows;
    nlohmann::json list = nlohmann::json::array();
    std::vector<std::string> files = run.ultrasound;
    if (!run.mechanical.empty())
      files.push_back(run.mechanical);
    for (const std::string& file : files) {
      const std::string name = fs::path(file).stem().string();
      if (!fs::exists(file)) {
        rows.push_back({name, "failed", "", "", "", "", ""});
        list.push_back({{"name", name}, {"failed", true}});
        continue;
      }
      const nlohmann::json r = core::readJsonFile(file);
      rows.push_back({name, r.value("converged", false) ? "yes" : "NO",
                      core::number(r.value("rms_mm", 0.0), 3),
                      fmt::format("{}", r.value("points_used", 0)),
                      fmt::format("{}", r.value("points_rejected", 0)),
                      core::number(r.value("speed_of_sound_scale", 1.0), 4),
                      fmt::format("{}", r.value("iterations", 0))});
      list.push_back({{"name", name},
                      {"file", fs::relative(file, results).generic_string()},
                      {"converged", r.value("converged", false)},
                      {"rms_mm", r.value("rms_mm", 0.0)},
                      {"points_used", r.value("points_used", 0)},
                      {"points_rejected", r.value("points_rejected", 0)},
                      {"speed_of_sound_scale", r.value("speed_of_sound_scale", 1.0)},
                      {"iterations", r.value("iterations", 0)},
                      {"matrix", r.at("matrix")}});
    }
    report.paragraph(
        fmt::format("Model: {}{}.", fs::path(run.model).lexically_normal().generic_string(),
                    run.segmented ? " (segmented from the CT)" : " (given by the manifest)"));
    report.table({"registration", "converged", "RMS (mm, Eq. 4.4)", "points used",
                  "points rejected", "speed-of-sound scale", "iterations"},
                 rows);
    nlohmann::json entry = {{"registrations", list}};
    if (!run.evaluationMechanical.empty() && fs::exists(run.evaluationMechanical)) {
      report.paragraph(
          "Ultrasound against the mechanical-probe registration (Eq. 4.5, in CT space: "
          "translations along CT x, y, z of the knee centre, rotations about them):");
      entry["against_mechanical"] = evaluationTable(report, run.evaluationMechanical);
    }
    if (!run.evaluationTruth.empty() && fs::exists(run.evaluationTruth)) {
      report.paragraph("Against the simulation's true registration:");
      entry["against_truth"] = evaluationTable(report, run.evaluationTruth);
    }
    if (!run.figure.empty() && fs::exists(run.figure)) {
      report.figure(
          fs::relative(run.figure, results).generic_string(),
          fmt::format("The {}'s ultrasound points mapped by the reference registration "
                      "(Eq. 4.6), coloured by their distance to the model: green < 3 mm, "
                      "yellow 3-5 mm, red > 5 mm (Figs. 5.6-5.9, 5.30-5.35); the patella, "
                      "when the study has it, translucent blue.",
                      run.name));
    }
    registrations[run.name] = entry;
  }
  if (!boneRuns.empty())
    numbers["registrations"] = registrations;
}

void reportDetectionRates(Report& report, nlohmann::json& numbers, const StudyManifest& manifest,
                          const std::vector<DetectionRate>& detectionRates) {
  // Truth per frame of each capture: should a correct detector accept it?
  const CsvTable truth = readCsvTable(manifest.truth.shots);
  const int capCol = truth.column("capture"), frameCol = truth.column("frame"),
            acceptCol = truth.column("should_accept");
  std::map<std::pair<std::string, std::string>, bool> shouldAccept;
  for (const auto& row : truth.rows) {
    shouldAccept[{row[static_cast<std::size_t>(capCol)], row[static_cast<std::size_t>(frameCol)]}] =
        row[static_cast<std::size_t>(acceptCol)] == "1";
  }
  std::vector<std::vector<std::string>> rows;
  nlohmann::json rates = nlohmann::json::array();
  for (const DetectionRate& d : detectionRates) {
    if (!fs::exists(d.csv))
      continue;
    const CsvTable detected = readCsvTable(d.csv);
    const int f = detected.column("frame"), st = detected.column("status"),
              why = detected.column("reason");
    const std::string name = fs::path(d.capture).filename().string();
    int bone = 0, notBone = 0, falseNegative = 0, falsePositive = 0;
    for (const auto& row : detected.rows) {
      if (row[static_cast<std::size_t>(why)] == "invalid-pose")
        continue;
      const auto it = shouldAccept.find({name, row[static_cast<std::size_t>(f)]});
      if (it == shouldAccept.end())
        continue;
      const bool accepted = row[static_cast<std::size_t>(st)] == "accepted";
      if (it->second) {
        ++bone;
        falseNegative += accepted ? 0 : 1;
      } else {
        ++notBone;
        falsePositive += accepted ? 1 : 0;
      }
    }
    const double fn = bone > 0 ? 100.0 * falseNegative / bone : 0.0;
    const double fp = notBone > 0 ? 100.0 * falsePositive / notBone : 0.0;
    rows.push_back({d.bone, d.setting, fmt::format("{}", bone), fmt::format("{}", notBone),
                    core::number(fn, 1), core::number(fp, 1)});
    rates.push_back({{"bone", d.bone},
                     {"setting", d.setting},
                     {"bone_frames", bone},
                     {"other_frames", notBone},
                     {"false_negative_pct", fn},
                     {"false_positive_pct", fp}});
  }
  if (!rows.empty()) {
    report.heading("Detection rates (Table 6.1)");
    report.paragraph(
        "Each A-line judged without the inter-signal filters, under the dissertation's "
        "chain at three low-pass cutoffs and under the study's preset (the default's capture "
        "context looks at the A-lines before each one), against the simulation's truth: false "
        "negatives among the frames a correct detector should accept, false positives among "
        "the others.");
    report.table({"bone", "setting", "bone frames", "other frames", "false negatives (%)",
                  "false positives (%)"},
                 rows);
    numbers["detection_rates"] = rates;
  }
}

void reportSignals(Report& report, const SignalsPlan& signals, const std::string& results) {
  const std::vector<std::pair<std::string, std::string>>& signalFigures = signals.signalFigures;
  const std::string& residualFigure = signals.residualFigure;
  if (!signalFigures.empty() || !residualFigure.empty())
    report.heading("Signals and statistics");
  for (const auto& [file, caption] : signalFigures) {
    if (fs::exists(file))
      report.figure(fs::relative(file, results).generic_string(), caption);
  }
  if (!residualFigure.empty() && fs::exists(residualFigure)) {
    report.figure(fs::relative(residualFigure, results).generic_string(),
                  "Distances of each bone's ultrasound points (those the registration used) to its "
                  "model after registration, with the one-way ANOVA between the bones (as Figs. "
                  "6.1, 6.3, 6.7-6.9).");
  }
}

void reportSteps(Report& report, nlohmann::json& numbers,
                 const std::vector<StepOutcome>& outcomes) {
  report.heading("Steps");
  report.paragraph(
      "Each step is one echoreg command; a step whose command line and input files "
      "did not change since the last run is up to date and shows its last time.");
  std::vector<std::vector<std::string>> rows;
  nlohmann::json stepsJson = nlohmann::json::array();
  std::vector<std::vector<std::string>> notes;
  for (const StepOutcome& s : outcomes) {
    std::string note = s.message;
    for (char& c : note)
      c = c == '\n' ? ' ' : c;
    if (note.empty() && !s.notes.empty())
      note = fmt::format("{} note{} (below)", s.notes.size(), s.notes.size() == 1 ? "" : "s");
    rows.push_back({s.title, statusName(s.status), core::number(s.seconds, 2), note});
    stepsJson.push_back({{"id", s.id},
                         {"title", s.title},
                         {"status", statusName(s.status)},
                         {"seconds", s.seconds},
                         {"notes", s.notes}});
    for (const std::string& n : s.notes)
      notes.push_back({s.title, n});
  }
  report.table({"step", "status", "time (s)", "message"}, rows);
  if (!notes.empty()) {
    // What the commands said of their results (a bone separated at a joint's sphere, boundaries
    // along thick slices, an assumed sampling frequency...): lost when only the results are read.
    report.paragraph("What the steps' commands noted about their results:");
    report.table({"step", "note"}, notes);
  }
  numbers["steps"] = stepsJson;
}

// Provenance: every path in the results is relative to the study folder; what was read from
// outside it is listed, so that a copy of the folder alone is known to be incomplete.
void reportProvenance(Report& report, nlohmann::json& numbers, const std::set<std::string>& outside,
                      const StudyParams& params, const StudyOptions& o) {
  const std::string& paramsFile = params.file;
  const std::string& paramsPreset = params.preset;
  const TunableSettings& paramsSettings = params.settings;
  const std::vector<std::string> outsideList(outside.begin(), outside.end());
  numbers["provenance"] = {{"paths", "relative to the study folder"},
                           {"read_outside_study", outsideList}};
  // The sweeps' detection parameters of this run (--params: its preset and settings, not its
  // path), so that runs of one study with other parameters (a sweep's points) tell apart.
  numbers["provenance"]["detection_params"] =
      paramsFile.empty()
          ? nlohmann::json(nullptr)
          : nlohmann::json{{"preset", paramsPreset.empty() ? nlohmann::json(nullptr)
                                                           : nlohmann::json(paramsPreset)},
                           {"settings", settingsJson(paramsSettings)}};
  // The solver of the registrations from ultrasound (--method, --loss: a sweep's point).
  numbers["provenance"]["solver"] = solverJson(o.method, o.loss);
  // Which echoreg made these numbers (echoreg study compare lists it per study).
  numbers["echoreg_version"] = ECHOREG_VERSION;
  report.heading("Provenance");
  report.paragraph(fmt::format(
      "Registrations from ultrasound: method {}{} (study run --method, --loss); the reference "
      "from the mechanical probe: register's defaults.",
      o.method,
      numbers["provenance"]["solver"]["loss"].is_null() ? std::string(" (no loss)")
                                                        : ", loss " + o.loss));
  if (outside.empty()) {
    report.paragraph(
        "Every input was read inside the study folder; the paths in the results are "
        "relative to it.");
  } else {
    std::string list;
    for (const std::string& path : outside)
      list += (list.empty() ? "" : ", ") + path;
    report.paragraph(
        fmt::format("Read outside the study folder (a copy of the folder alone does "
                    "not hold them): {}. The other paths in the results are relative "
                    "to the study folder.",
                    list));
  }
}

// Every result the study was asked for is there, or the study says which are not and fails:
// returns which are missing (empty when none is, or when the study stopped).
std::string reportMissing(Report& report, nlohmann::json& numbers,
                          const std::vector<StepOutcome>& outcomes, const std::string& failure) {
  std::vector<std::string> missing;
  for (const StepOutcome& s : outcomes) {
    if (s.status != StepOutcome::Status::Failed && s.status != StepOutcome::Status::Skipped)
      continue;
    const std::string firstLine = s.message.substr(0, s.message.find('\n'));
    missing.push_back(fmt::format("{} ({}: {})", s.title,
                                  s.status == StepOutcome::Status::Failed ? "failed" : "skipped",
                                  firstLine));
  }
  std::string incomplete;
  if (failure.empty() && !missing.empty()) {
    incomplete = fmt::format("{} requested result{} missing:", missing.size(),
                             missing.size() == 1 ? " is" : "s are");
    for (const std::string& m : missing)
      incomplete += "\n  " + m;
    report.paragraph("The study is incomplete: " + incomplete);
    numbers["missing"] = missing;
  }
  return incomplete;
}

}  // namespace

StudyReport writeStudyReport(const StudyContext& ctx, const std::string& studyDir,
                             const std::vector<ManifestCalibrationSession>& sessions,
                             const CalibrationPlan& calibrationPlan,
                             const std::vector<BoneRun>& boneRuns, const SignalsPlan& signals,
                             const StudyProgress& progress, StudyReads& read,
                             std::chrono::steady_clock::time_point started) {
  const StudyManifest& manifest = ctx.manifest;
  const std::string& results = ctx.results;
  const std::string& calibration = calibrationPlan.calibrations.front();
  const std::vector<std::string>& calibrations = calibrationPlan.calibrations;
  const std::string& failure = progress.failure;
  Report report;
  nlohmann::json numbers;
  fs::path studyPath = fs::absolute(studyDir).lexically_normal();
  if (studyPath.filename().empty())
    studyPath = studyPath.parent_path();  // "S/"
  const std::string studyName = studyPath.filename().string();
  report.heading("Study report: " + studyName, 1);
  const nlohmann::json& generator = manifest.generator;
  if (generator.is_object()) {
    report.paragraph(fmt::format(
        "Simulated by {} (preset {}, seed {}, size {}).", generator.value("tool", std::string("?")),
        generator.value("preset", std::string("?")), generator.value("seed", 0),
        generator.value("size", std::string("?"))));
  }
  if (fs::exists(calibration))
    reportCalibration(report, numbers, calibration, calibrationPlan.figure);
  if (calibrations.size() >= 2)
    reportCalibrationSessions(report, numbers, manifest, sessions, calibrations, read);
  reportSegmentation(report, numbers, manifest, boneRuns, read);
  reportRegistrations(report, numbers, boneRuns, results);
  if (!signals.detectionRates.empty())
    reportDetectionRates(report, numbers, manifest, signals.detectionRates);
  reportSignals(report, signals, results);
  report.heading("For 3D Slicer");
  report.paragraph(
      "Models (.vtp) in results/models (or the manifest's), transforms as .tfm beside "
      "each JSON in results/registrations (drag onto the model's transform), "
      "the evaluation targets as .mrk.json in results/.");
  reportSteps(report, numbers, progress.outcomes);
  const double total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  numbers["seconds"] = total;
  if (!failure.empty()) {
    report.paragraph("The study stopped: " + failure);
    numbers["failure"] = failure;
  }
  reportProvenance(report, numbers, read.outside(), ctx.params, ctx.options);
  std::string incomplete = reportMissing(report, numbers, progress.outcomes, failure);
  {
    core::AtomicFile md(results + "/report.md");
    md.stream() << report.markdown();
    md.commit();
    core::AtomicFile html(results + "/report.html");
    html.stream() << report.html("Study report: " + studyName);
    html.commit();
    core::AtomicFile json(results + "/results.json");
    json.stream() << numbers.dump(2) << "\n";
    json.commit();
  }
  return {std::move(numbers), incomplete};
}

}  // namespace echoreg::cli::detail
