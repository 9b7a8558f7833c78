// `echoreg study compare` over copies of the fixture study run once: the error tables against
// the means the test computes from each results.json, the ANOVA between groups against
// core::oneWayAnova on the residual files, the merged results.json with each study's
// provenance, the same bytes on a second run, and bad inputs that name the file and write nothing.
#include "study_checks.hpp"

#include "cli_test_support.hpp"
#include "csv_table.hpp"
#include "test_support.hpp"

#include "echoreg/core/statistics.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

std::string bytesOf(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// The inliers' abs_residual_mm of a study's residual file; with `shiftMm`, the file rewritten
/// with every inlier's distance grown by it (a second group that truly differs).
std::vector<double> inlierResiduals(const std::string& csv, double shiftMm = 0.0) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "point,residual_mm,abs_residual_mm,inlier");
  std::ostringstream rewritten;
  rewritten << line << "\n";
  std::vector<double> values;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = cli::splitCsvLine(line);
    EXPECT_EQ(cells.size(), 4U) << line;
    double value = std::stod(cells[2]);
    if (cells[3] == "1") {
      value += shiftMm;
      values.push_back(value);
    }
    rewritten << cells[0] << "," << cells[1] << "," << value << "," << cells[3] << "\n";
  }
  in.close();
  if (shiftMm != 0.0)
    std::ofstream(csv) << rewritten.str();
  return values;
}

/// Mean of |column| over a bone's ultrasound registrations in one study's results.json.
double meanAbs(const nlohmann::json& rows, const std::string& column) {
  double sum = 0.0;
  int n = 0;
  for (const auto& row : rows) {
    const std::string estimate = row.at("estimate").get<std::string>();
    if (estimate == "mean_abs" || estimate.find("_mechanical") != std::string::npos)
      continue;
    sum += std::abs(row.at(column).get<double>());
    ++n;
  }
  EXPECT_GT(n, 0);
  return sum / n;
}

TEST(StudyCompare, TablesAndAnovaOverStudiesGroupedByAManifestValue) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string glove = dir.file("glove-a");
  fs::copy(fixture, glove, fs::copy_options::recursive);
  fs::remove_all(glove + "/results");
  // The manifest's models: no segmentation, the shortest whole study.
  const test::CommandResult run = runEchoreg({"study", "run", glove, "--given-models"});
  ASSERT_EQ(run.exitCode, 0) << run.err;

  // Three studies in two groups: a copy of the run study in the same group, and one whose
  // manifest says gel and whose points lie 0.5 mm further from the model.
  const std::string glove2 = dir.file("glove-b"), gel = dir.file("gel");
  fs::copy(glove, glove2, fs::copy_options::recursive);
  fs::copy(glove, gel, fs::copy_options::recursive);
  nlohmann::json manifest = readJson(gel + "/study.json");
  ASSERT_EQ(manifest["generator"]["standoff"], "glove");
  manifest["generator"]["standoff"] = "gel";
  std::ofstream(gel + "/study.json") << manifest.dump(2);
  std::vector<std::vector<double>> femurGroups(2);
  femurGroups[0] = inlierResiduals(glove + "/results/evaluation/femur_residuals.csv");
  const std::vector<double> same =
      inlierResiduals(glove2 + "/results/evaluation/femur_residuals.csv");
  femurGroups[0].insert(femurGroups[0].end(), same.begin(), same.end());
  femurGroups[1] = inlierResiduals(gel + "/results/evaluation/femur_residuals.csv", 0.5);
  ASSERT_GE(femurGroups[1].size(), 10U);

  const std::string out = dir.file("compare");
  test::CommandResult r = runEchoreg(
      {"study", "compare", glove, glove2, gel, "--out", out, "--group-by", "generator.standoff"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("3 studies in 2 groups"), std::string::npos) << r.out;
  for (const char* file : {"report.md", "report.html", "results.json",
                           "figures/femur_between_groups.png", "figures/tibia_between_groups.png"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + file)) << file;

  const nlohmann::json merged = readJson(out + "/results.json");
  const nlohmann::json studyResults = readJson(glove + "/results/results.json");
  EXPECT_EQ(merged["format"], "echoreg-study-compare");
  EXPECT_EQ(merged["group_by"], "generator.standoff");
  ASSERT_EQ(merged["studies"].size(), 3U);
  EXPECT_EQ(merged["studies"][0]["group"], "glove");
  EXPECT_EQ(merged["studies"][2]["group"], "gel");
  // Provenance: the manifest's bytes hashed (the edited one differs), its parameters, the
  // study's whole results.
  const nlohmann::json& provenance = merged["studies"][0]["provenance"];
  EXPECT_EQ(provenance["manifest_fnv1a64"].get<std::string>().size(), 16U);
  EXPECT_EQ(provenance["manifest_fnv1a64"], merged["studies"][1]["provenance"]["manifest_fnv1a64"]);
  EXPECT_NE(provenance["manifest_fnv1a64"], merged["studies"][2]["provenance"]["manifest_fnv1a64"]);
  EXPECT_EQ(provenance["parameters"]["generator"]["seed"], 7);
  // study run records the echoreg that made each study's numbers, and compare lists it.
  const std::string version = runEchoreg({"--version"}).out;
  ASSERT_TRUE(provenance["echoreg_version"].is_string()) << provenance.dump();
  EXPECT_NE(version.find(provenance["echoreg_version"].get<std::string>()), std::string::npos)
      << version;
  EXPECT_EQ(merged["studies"][2]["provenance"]["parameters"]["generator"]["standoff"], "gel");
  EXPECT_EQ(merged["studies"][0]["results"]["registrations"], studyResults["registrations"]);

  // Tables 5.3-5.7: each study's row is the mean of |error| over its ultrasound registrations;
  // the pooled row of a group of two identical studies is the same.
  for (const char* reference : {"against_mechanical", "against_truth"}) {
    for (const char* bone : {"femur", "tibia"}) {
      const nlohmann::json& rows = studyResults["registrations"][bone][reference];
      const nlohmann::json& table = merged["errors"][reference][bone];
      ASSERT_EQ(table.size(), 5U) << reference << " " << bone;  // 3 studies, 2 groups
      for (const char* column :
           {"tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg", "target_knee_centre_mm"}) {
        const double expected = meanAbs(rows, column);
        for (const auto& row : table) {
          EXPECT_NEAR(row["mean_abs_" + std::string(column)].get<double>(), expected, 1e-12)
              << reference << " " << bone << " " << column << " " << row["name"];
        }
      }
      EXPECT_EQ(table[0]["registrations"], 1);
      EXPECT_EQ(table[3]["name"], "all of glove");
      EXPECT_EQ(table[3]["registrations"], 2);
    }
  }

  // Between groups: the ANOVA over the residual files as the test reads them.
  const core::AnovaResult expected = core::oneWayAnova(femurGroups);
  const nlohmann::json& femur = merged["between_groups"]["femur"];
  EXPECT_EQ(femur["anova"]["df_between"], 1);
  EXPECT_EQ(femur["anova"]["df_within"], expected.dfWithin);
  EXPECT_NEAR(femur["anova"]["f"].get<double>(), expected.f, 1e-9 * expected.f);
  EXPECT_NEAR(femur["anova"]["p"].get<double>(), expected.pValue, 1e-12);
  EXPECT_LT(expected.pValue, 1e-3);  // 0.5 mm on points within a fraction of a mm
  EXPECT_EQ(femur["groups"][0]["n"], static_cast<int>(femurGroups[0].size()));
  EXPECT_EQ(femur["groups"][1]["group"], "gel");

  const std::string markdown = bytesOf(out + "/report.md");
  EXPECT_NE(markdown.find("femur: ultrasound against the mechanical-probe registration"),
            std::string::npos);
  EXPECT_NE(markdown.find("| all of gel | gel | 1 |"), std::string::npos);
  EXPECT_NE(markdown.find("figures/femur_between_groups.png"), std::string::npos);
  const std::string html = bytesOf(out + "/report.html");
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);

  // Same input, same bytes.
  const std::string again = dir.file("again");
  r = runEchoreg(
      {"study", "compare", glove, glove2, gel, "--out", again, "--group-by", "generator.standoff"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const char* file :
       {"report.md", "report.html", "results.json", "figures/femur_between_groups.png"})
    EXPECT_EQ(bytesOf(out + "/" + file), bytesOf(again + "/" + file)) << file;
}

TEST(StudyCompare, BadInputsNameTheFileAndWriteNothing) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string study = dir.file("study");
  fs::create_directories(study + "/results");
  fs::copy_file(fixture + "/study.json", study + "/study.json");
  const std::string results = study + "/results/results.json";
  const std::string out = dir.file("out");

  auto expectError = [&](const std::vector<std::string>& args, const std::string& file,
                         const std::string& problem) {
    std::vector<std::string> all = {"study", "compare"};
    all.insert(all.end(), args.begin(), args.end());
    all.insert(all.end(), {"--out", out});
    const test::CommandResult r = runEchoreg(all);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << "a failed compare wrote " << out;
  };
  expectError({study}, results, "is missing: the study has not been run");
  std::ofstream(results) << "{\"registrations\": ";
  expectError({study}, results, "is not valid JSON");
  std::ofstream(results) << "{\"steps\": []}";
  expectError({study}, results, "has no \"registrations\" object");
  std::ofstream(results) << R"({"registrations": {"femur": {"against_mechanical": [
      {"estimate": "femur_ultrasound_1.json", "tx_mm": "0.4", "ty_mm": 0, "tz_mm": 0,
       "rx_deg": 0, "ry_deg": 0, "rz_deg": 0}]}}})";
  expectError({study}, results, "registrations/femur/against_mechanical: \"tx_mm\" is missing");
  std::ofstream(results) << R"({"registrations": {"../femur": {}}})";
  expectError({study}, results, "is not a bone's results");
  std::ofstream(results) << R"({"registrations": {"femur": {}}})";
  expectError({study, "--group-by", "generator.no_such_key"}, study + "/study.json",
              "has no \"generator.no_such_key\" to group by");
  expectError({study, dir.file("missing")}, dir.file("missing"), "is not a study folder");
  fs::remove(study + "/study.json");
  expectError({study}, study + "/study.json", "");

  // The same folder twice, and no folder: usage.
  test::CommandResult r = runEchoreg({"study", "compare", study, study, "--out", out});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("is given twice"), std::string::npos) << r.err;
  r = runEchoreg({"study", "compare", "--out", out});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// Table 5.2 pooled: each study's calibration sessions as its results.json lists them, then every
// session of a group together; a session without its offset is refused naming the file.
TEST(StudyCompare, PoolsTheCalibrationSessionsOfEachGroup) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  // x, y, z, RMS, condition, speed of each session, by study; a and b are glove, c gel.
  const std::vector<std::pair<std::string, std::vector<std::array<double, 6>>>> studies = {
      {"a", {{25.0, 1.0, 200.0, 0.1, 10.0, 1490.0}, {26.0, 1.5, 200.4, 0.2, 12.0, 1494.0}}},
      {"b",
       {{25.5, 0.5, 200.2, 0.3, 14.0, 1498.0},
        {27.0, 1.2, 200.1, 0.1, 11.0, 1492.0},
        {25.2, 1.1, 200.3, 0.1, 13.0, 1496.0}}},
      {"c", {{24.0, 2.0, 199.0, 0.5, 9.0, 1480.0}, {24.5, 2.5, 199.5, 0.4, 8.0, 1482.0}}}};
  std::vector<std::string> args = {"study", "compare"};
  for (const auto& [name, sessions] : studies) {
    const std::string study = dir.file(name);
    fs::create_directories(study + "/results");
    nlohmann::json manifest = readJson(fixture + "/study.json");
    manifest["generator"]["standoff"] = name == "c" ? "gel" : "glove";
    std::ofstream(study + "/study.json") << manifest.dump(2);
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& v : sessions) {
      rows.push_back({{"beam_to_probe_mm", {v[0], v[1], v[2]}},
                      {"rms_mm", v[3]},
                      {"condition_number", v[4]},
                      {"speed_of_sound_mps", v[5]}});
    }
    std::ofstream(study + "/results/results.json") << nlohmann::json{
        {"registrations", {{"femur", nlohmann::json::object()}}},
        {"calibration_sessions", {{"sessions", rows}}}}.dump();
    args.push_back(study);
  }
  const std::string out = dir.file("compare");
  args.insert(args.end(), {"--out", out, "--group-by", "generator.standoff"});
  test::CommandResult r = runEchoreg(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json pooled = readJson(out + "/results.json").at("calibration_sessions");
  ASSERT_EQ(pooled.size(), 5U);  // three studies, two groups
  EXPECT_EQ(pooled[1].at("name"), dir.file("b"));
  EXPECT_EQ(pooled[1].at("sessions"), 3);
  EXPECT_EQ(pooled[3].at("name"), "all of glove");
  EXPECT_EQ(pooled[3].at("sessions"), 5);
  // The glove group's five sessions: x from 25.0 to 27.0, mean 25.74; RMS mean 0.16.
  EXPECT_NEAR(pooled[3].at("mean_beam_to_probe_mm").at(0).get<double>(), 25.74, 1e-9);
  EXPECT_NEAR(pooled[3].at("spread_beam_to_probe_mm").at(0).get<double>(), 2.0, 1e-9);
  EXPECT_NEAR(pooled[3].at("spread_beam_to_probe_mm").at(2).get<double>(), 0.4, 1e-9);
  EXPECT_NEAR(pooled[3].at("mean_rms_mm").get<double>(), 0.16, 1e-9);
  EXPECT_NEAR(pooled[3].at("mean_condition_number").get<double>(), 12.0, 1e-9);
  EXPECT_EQ(pooled[4].at("name"), "all of gel");
  EXPECT_NEAR(pooled[4].at("mean_speed_of_sound_mps").get<double>(), 1481.0, 1e-9);
  const std::string report = bytesOf(out + "/report.md");
  EXPECT_NE(report.find("## Calibration sessions pooled (Table 5.2)"), std::string::npos);
  EXPECT_NE(report.find("| all of glove | glove | 5 | 25.74 |"), std::string::npos) << report;

  // A session without its offset: the file and the session named, nothing written.
  fs::remove_all(out);
  std::ofstream(dir.file("c") + "/results/results.json")
      << R"({"registrations": {"femur": {}}, "calibration_sessions": {"sessions": [
            {"beam_to_probe_mm": [24, 2, 199], "rms_mm": 0.5, "condition_number": 9,
             "speed_of_sound_mps": 1480}, {"rms_mm": 0.4}]}})";
  r = runEchoreg(args);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(dir.file("c") + "/results/results.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("calibration_sessions/sessions/1: \"beam_to_probe_mm\" is not [x, y, z]"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// Studies that share a manifest but ran with other detection parameters or another solver (a
// sweep's points) are told apart by the parameters in each one's provenance.
TEST(StudyCompare, ListsEachStudysDetectionParameters) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::vector<nlohmann::json> params = {
      nlohmann::json::parse(R"({"preset": null, "settings": {"cutoff": 0.01}})"),
      nlohmann::json::parse(R"({"preset": "shadow", "settings": {"cutoff": 0.02}})"),
      nlohmann::json(nullptr)};
  // The third as a study run before study run recorded its solver.
  const std::vector<nlohmann::json> solvers = {
      nlohmann::json::parse(R"({"method": "plain", "loss": null})"),
      nlohmann::json::parse(R"({"method": "robust", "loss": "tukey"})"), nlohmann::json(nullptr)};
  std::vector<std::string> args = {"study", "compare"};
  for (std::size_t i = 0; i < params.size(); ++i) {
    const std::string study = dir.file("p" + std::to_string(i));
    fs::create_directories(study + "/results");
    fs::copy_file(fixture + "/study.json", study + "/study.json");
    nlohmann::json provenance = {{"detection_params", params[i]}};
    if (!solvers[i].is_null())
      provenance["solver"] = solvers[i];
    std::ofstream(study + "/results/results.json") << nlohmann::json{
        {"registrations", {{"femur", nlohmann::json::object()}}},
        {"provenance", provenance}}.dump();
    args.push_back(study);
  }
  const std::string out = dir.file("compare");
  args.insert(args.end(), {"--out", out});
  const test::CommandResult r = runEchoreg(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json merged = readJson(out + "/results.json");
  for (std::size_t i = 0; i < params.size(); ++i) {
    const nlohmann::json& provenance = merged.at("studies").at(i).at("provenance");
    EXPECT_EQ(provenance.at("parameters").at("detection_params"), params[i]) << i;
    EXPECT_EQ(provenance.at("parameters").at("solver"), solvers[i]) << i;
    EXPECT_EQ(provenance.at("manifest_fnv1a64"),
              merged.at("studies").at(0).at("provenance").at("manifest_fnv1a64"));
  }
  const std::string report = bytesOf(out + "/report.md");
  EXPECT_NE(report.find("| cutoff 0.01 | plain |"), std::string::npos) << report;
  EXPECT_NE(report.find("| preset shadow, cutoff 0.02 | robust, tukey |"), std::string::npos)
      << report;
  EXPECT_NE(report.find("| - | not recorded |"), std::string::npos) << report;
  EXPECT_NE(report.find("detection parameters (study run --params)"), std::string::npos);
  EXPECT_NE(report.find("registration (study run --method, --loss)"), std::string::npos);
}

// A sweep's points differ in what they were run with, not in their manifests: --group-by reads a
// key study.json does not have from results.json (here the solver a sweep over register.method
// records), and names both files when neither has it.
TEST(StudyCompare, GroupsByAResultsValueWhereTheManifestHasNone) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  std::vector<std::string> args = {"study", "compare"};
  for (const char* method : {"plain", "robust", "robust"}) {
    const std::string study = dir.file("s" + std::to_string(args.size()));
    fs::create_directories(study + "/results");
    fs::copy_file(fixture + "/study.json", study + "/study.json");
    std::ofstream(study + "/results/results.json") << nlohmann::json{
        {"registrations", {{"femur", nlohmann::json::object()}}},
        {"provenance",
         {{"solver", {{"method", method}}}}}}.dump();
    args.push_back(study);
  }
  const std::string out = dir.file("compare");
  std::vector<std::string> grouped = args;
  grouped.insert(grouped.end(), {"--out", out, "--group-by", "provenance.solver.method"});
  const test::CommandResult r = runEchoreg(grouped);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("3 studies in 2 groups"), std::string::npos) << r.out;
  const nlohmann::json merged = readJson(out + "/results.json");
  EXPECT_EQ(merged.at("group_by"), "provenance.solver.method");
  EXPECT_EQ(merged.at("studies").at(0).at("group"), "plain") << merged.at("studies").dump();
  EXPECT_EQ(merged.at("studies").at(2).at("group"), "robust");

  const std::string none = dir.file("none");
  std::vector<std::string> missing = args;
  missing.insert(missing.end(), {"--out", none, "--group-by", "provenance.solver.loss"});
  const test::CommandResult bad = runEchoreg(missing);
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_NE(bad.err.find("has no \"provenance.solver.loss\" to group by, nor has "),
            std::string::npos)
      << bad.err;
  EXPECT_NE(bad.err.find("/results/results.json"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(none));
}

}  // namespace
}  // namespace echoreg::simulation
