// `echoreg study sweep`: a detection sweep over a copy of the fixture study run in two shards
// (the rows against each point's own results.json and against the study's Table 6.1 at the same
// cutoff), a second run that runs nothing, a point whose row was lost run again to the same bytes,
// a simulated sweep's derived seeds, a sweep of the registration's method run in two folders
// (different rows per method, the same bytes in both folders, each point's results.json the same
// apart from its times), and bad sweep files that name the file and key, exit 2 and write nothing.
#include "study_checks.hpp"

#include "cli_test_support.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

// A sweep point's id: "p-" and twelve lower-case hex digits. (Checked by hand: GCC 12's
// -Wmaybe-uninitialized misfires inside <regex> under -fsanitize=address at -O2.)
bool isPointId(const std::string& id) {
  return id.size() == 14 && id.compare(0, 2, "p-") == 0 &&
         id.find_first_not_of("0123456789abcdef", 2) == std::string::npos;
}

std::string bytesOf(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

std::vector<nlohmann::json> readJsonLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<nlohmann::json> rows;
  std::string line;
  while (std::getline(in, line))
    rows.push_back(nlohmann::json::parse(line));
  return rows;
}

/// The detection rates of `setting` for `bone` in a results.json's detection_rates.
nlohmann::json ratesOf(const nlohmann::json& rates, const std::string& bone,
                       const std::string& setting) {
  for (const nlohmann::json& row : rates) {
    if (row.at("bone") == bone && row.at("setting") == setting)
      return row;
  }
  ADD_FAILURE() << "no detection rates of " << bone << " under " << setting << ": " << rates;
  return {};
}

TEST(StudySweep, DetectionSweepRunsInShardsResumesAndGivesTheSameBytes) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string study = dir.file("study");
  fs::copy(fixture, study, fs::copy_options::recursive);
  fs::remove_all(study + "/results");
  const std::string sweepFile = dir.file("sweep.json");
  // The study relative to the sweep file; the manifest's models (no segmentation).
  std::ofstream(sweepFile) << R"({"study": "study", "given_models": true,
      "parameters": {"detect.preset": ["mozes2008"], "detect.cutoff": [0.005, 0.02]}})";
  const std::string out = dir.file("out");

  // The plan: two points, in the order of the values, writing nothing.
  test::CommandResult r = runEchoreg({"study", "sweep", sweepFile, "--out", out, "--plan"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json plan = nlohmann::json::parse(r.out);
  ASSERT_EQ(plan["points"].size(), 2U);
  EXPECT_EQ(plan["points"][0]["parameters"]["detect.cutoff"], 0.005);
  EXPECT_EQ(plan["points"][1]["parameters"]["detect.cutoff"], 0.02);
  EXPECT_TRUE(plan["studies"].empty());
  const std::string first = plan["points"][0]["id"], second = plan["points"][1]["id"];
  EXPECT_TRUE(isPointId(first)) << first;
  EXPECT_NE(first, second);
  EXPECT_FALSE(fs::exists(out));

  // The second shard first: its point's row, no table yet.
  r = runEchoreg({"study", "sweep", sweepFile, "--out", out, "--shard", "2/2"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("shard 2/2: 1 points ran, 0 were done; 1 of 2 points"), std::string::npos)
      << r.out;
  EXPECT_TRUE(fs::is_regular_file(out + "/rows/" + second + ".json"));
  EXPECT_FALSE(fs::exists(out + "/rows/" + first + ".json"));
  EXPECT_FALSE(fs::exists(out + "/results.jsonl"));
  // The first shard finishes the sweep and writes the table.
  r = runEchoreg({"study", "sweep", sweepFile, "--out", out, "--shard", "1/2"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("shard 1/2: 1 points ran, 0 were done; 2 rows in"), std::string::npos)
      << r.out;
  const std::vector<nlohmann::json> rows = readJsonLines(out + "/results.jsonl");
  ASSERT_EQ(rows.size(), 2U);
  const std::vector<std::string> ids = {first, second};
  const std::vector<double> cutoffs = {0.005, 0.02};
  for (std::size_t i = 0; i < 2; ++i) {
    const nlohmann::json& row = rows[i];
    EXPECT_EQ(row["point"], ids[i]);
    EXPECT_EQ(row["parameters"]["detect.cutoff"], cutoffs[i]);
    EXPECT_TRUE(row["seed"].is_null());
    EXPECT_FALSE(row.contains("seconds"));  // times would break the same bytes
    // The point is a study of its own, linking the data, holding its detection parameters.
    const std::string folder = out + "/points/" + ids[i];
    EXPECT_TRUE(fs::is_symlink(folder + "/study.json"));
    EXPECT_EQ(readJson(folder + "/sweep-params.json"),
              (nlohmann::json{{"preset", "mozes2008"}, {"cutoff", cutoffs[i]}}));
    const nlohmann::json results = readJson(folder + "/results/results.json");
    // The dissertation's single-signal chain leaves registrations unconverged on this study:
    // the row says so, as the study does.
    EXPECT_EQ(row["status"], results.contains("missing") ? "incomplete" : "done");
    EXPECT_EQ(row.value("missing", nlohmann::json()), results.value("missing", nlohmann::json()));
    EXPECT_EQ(row["registrations"], results["registrations"]);
    EXPECT_EQ(row["calibration"], results["calibration"]);
    EXPECT_EQ(row["detection_rates"], results["detection_rates"]);
    // The point's own detection is the dissertation's chain at its cutoff: its Table 6.1 row
    // equals the study's fixed "mozes2008, cutoff C" row.
    for (const char* bone : {"femur", "tibia"}) {
      nlohmann::json own = ratesOf(row["detection_rates"], bone, "mozes2008 (the study's)");
      nlohmann::json fixed = ratesOf(row["detection_rates"], bone,
                                     i == 0 ? "mozes2008, cutoff 0.005" : "mozes2008, cutoff 0.02");
      own.erase("setting");
      fixed.erase("setting");
      EXPECT_EQ(own, fixed) << bone;
    }
  }
  // The cutoff changed the detection.
  EXPECT_NE(ratesOf(rows[0]["detection_rates"], "femur", "mozes2008 (the study's)"),
            ratesOf(rows[1]["detection_rates"], "femur", "mozes2008 (the study's)"));
  const std::string table = bytesOf(out + "/results.jsonl");

  // A second run does nothing and writes the same bytes.
  r = runEchoreg({"study", "sweep", sweepFile, "--out", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("sweep: 0 points ran, 2 were done"), std::string::npos) << r.out;
  EXPECT_EQ(bytesOf(out + "/results.jsonl"), table);

  // A run killed while it made the first point's folder: its temporary folder is left (its
  // process gone), the point has no folder, no row. That point alone runs again, same bytes.
  fs::remove(out + "/rows/" + first + ".json");
  fs::remove(out + "/results.jsonl");
  fs::remove_all(out + "/points/" + first);
  const std::string stale = out + "/points/." + first + ".tmp-999999999";
  fs::create_directories(stale);
  std::ofstream(stale + "/study.json") << "{";
  r = runEchoreg({"study", "sweep", sweepFile, "--out", out, "--point", first});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("sweep: point " + first + " ran"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out + "/results.jsonl"));  // --point does not gather
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::is_regular_file(out + "/points/" + first + "/results/results.json"));
  r = runEchoreg({"study", "sweep", sweepFile, "--out", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("sweep: 0 points ran, 2 were done"), std::string::npos) << r.out;
  EXPECT_EQ(bytesOf(out + "/results.jsonl"), table);
}

/// A results.json without its wall-clock times (the run's and each step's "seconds"): what
/// differs between two runs of the same study.
nlohmann::json withoutTimes(nlohmann::json results) {
  results.erase("seconds");
  for (nlohmann::json& step : results["steps"])
    step.erase("seconds");
  return results;
}

TEST(StudySweep, MethodSweepGivesARowPerMethodAndTheSameBytesInAnotherFolder) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  // The same sweep in two folders at different depths: a copy of the study beside each sweep
  // file, one cutoff (so each point has a --params file), the two methods of register.
  const std::vector<std::string> roots = {dir.file("a"), dir.file("b/one/deeper")};
  for (const std::string& root : roots) {
    fs::create_directories(root);
    fs::copy(fixture, root + "/study", fs::copy_options::recursive);
    fs::remove_all(root + "/study/results");
    std::ofstream(root + "/sweep.json") << R"({"study": "study", "given_models": true,
        "parameters": {"register.method": ["plain", "robust"], "detect.cutoff": [0.01]}})";
  }
  std::vector<std::string> tables;
  for (const std::string& root : roots) {
    const test::CommandResult r =
        runEchoreg({"study", "sweep", root + "/sweep.json", "--out", root + "/out"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("sweep: 2 points ran, 0 were done"), std::string::npos) << r.out;
    tables.push_back(bytesOf(root + "/out/results.jsonl"));
  }
  // Same sweep, same bytes, wherever it lies: no absolute path in the rows.
  EXPECT_EQ(tables[0], tables[1]);
  EXPECT_EQ(tables[0].find(dir.path()), std::string::npos) << tables[0];

  const std::vector<nlohmann::json> rows = readJsonLines(roots[0] + "/out/results.jsonl");
  ASSERT_EQ(rows.size(), 2U);
  EXPECT_EQ(rows[0]["parameters"]["register.method"], "plain");
  EXPECT_EQ(rows[1]["parameters"]["register.method"], "robust");
  // The solver as each point's study recorded it: plain uses no loss, robust register's default.
  EXPECT_EQ(rows[0]["solver"], (nlohmann::json{{"method", "plain"}, {"loss", nullptr}}));
  EXPECT_EQ(rows[1]["solver"], (nlohmann::json{{"method", "robust"}, {"loss", "huber"}}));
  EXPECT_EQ(rows[0]["data"], "../study");  // relative to the sweep's folder
  EXPECT_NE(rows[0]["point"], rows[1]["point"]);
  // The data and the detection are the same for both points; the registrations are not.
  EXPECT_EQ(rows[0]["detection_rates"], rows[1]["detection_rates"]);
  EXPECT_EQ(rows[0]["calibration"], rows[1]["calibration"]);
  for (const char* bone : {"femur", "tibia"}) {
    const nlohmann::json& plain = rows[0]["registrations"][bone]["registrations"];
    const nlohmann::json& robust = rows[1]["registrations"][bone]["registrations"];
    ASSERT_TRUE(plain.is_array()) << bone;
    ASSERT_EQ(plain.size(), robust.size()) << bone;
    int ultrasound = 0, mechanical = 0;
    for (std::size_t k = 0; k < plain.size(); ++k) {
      const std::string name = plain[k]["name"];
      ASSERT_EQ(robust[k]["name"], name);
      if (name.find("_ultrasound_") != std::string::npos) {
        ++ultrasound;
        EXPECT_NE(plain[k]["matrix"], robust[k]["matrix"]) << name;
      } else {
        // The reference from the mechanical probe keeps register's defaults: the same in both.
        ++mechanical;
        EXPECT_EQ(plain[k], robust[k]) << name;
      }
    }
    EXPECT_GE(ultrasound, 1) << bone;
    EXPECT_EQ(mechanical, 1) << bone;
  }
  for (const nlohmann::json& row : rows) {
    const std::string point = row["point"];
    // The registration files say which method ran.
    const nlohmann::json femur = readJson(roots[0] + "/out/points/" + point +
                                          "/results/registrations/femur_ultrasound_1.json");
    EXPECT_EQ(femur["method"], row["parameters"]["register.method"]);
    // Each point is a study run in two folders: its results.json is the same but for the times.
    const nlohmann::json a = readJson(roots[0] + "/out/points/" + point + "/results/results.json");
    const nlohmann::json b = readJson(roots[1] + "/out/points/" + point + "/results/results.json");
    EXPECT_EQ(a["provenance"]["solver"], row["solver"]);
    EXPECT_TRUE(a.contains("seconds"));
    EXPECT_EQ(withoutTimes(a).dump(2), withoutTimes(b).dump(2)) << point;
    EXPECT_EQ(a.dump().find(dir.path()), std::string::npos) << point;
  }

  // study run's own --method and --loss are register's: the same names, the same checks.
  for (const auto& [flag, value, problem] : std::vector<std::array<std::string, 3>>{
           {"--method", "icp", "unknown registration method \"icp\" (plain or robust)"},
           {"--loss", "l2", "unknown loss \"l2\" (huber, cauchy, tukey or trim)"}}) {
    const test::CommandResult r = runEchoreg({"study", "run", roots[0] + "/study", flag, value});
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_NE(r.err.find(flag), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(roots[0] + "/study/results"));
  }
}

TEST(StudySweep, SimulatedStudiesGetSeedsDerivedFromTheirParameters) {
  test::TempDir dir;
  const std::string sweepFile = dir.file("sweep.json");
  const auto planOf = [&](const std::string& text) {
    std::ofstream(sweepFile) << text;
    const test::CommandResult r =
        runEchoreg({"study", "sweep", sweepFile, "--out", dir.file("out"), "--plan"});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return nlohmann::json::parse(r.out);
  };
  const std::string grid = R"({"simulate": {"size": "small", "seed": 5},
      "parameters": {"simulate.standoff": ["glove", "gel"], "replicate": [1, 2],
                     "detect.preset": ["mozes2008"], "detect.cutoff": [0.005, 0.02]}})";
  const nlohmann::json plan = planOf(grid);
  // 2 x 2 studies, each detected at 2 cutoffs; the detection does not change the data.
  ASSERT_EQ(plan["points"].size(), 8U);
  ASSERT_EQ(plan["studies"].size(), 4U);
  std::set<std::uint64_t> seeds;
  for (const nlohmann::json& s : plan["studies"])
    seeds.insert(s["seed"].get<std::uint64_t>());
  EXPECT_EQ(seeds.size(), 4U);
  // Keys sorted, the last varying fastest: detect.cutoff, detect.preset, replicate, standoff.
  EXPECT_EQ(plan["points"][0]["parameters"]["simulate.standoff"], "glove");
  EXPECT_EQ(plan["points"][1]["parameters"]["simulate.standoff"], "gel");
  EXPECT_EQ(plan["points"][0]["study"], plan["points"][4]["study"]);  // cutoffs share data
  EXPECT_NE(plan["points"][0]["id"], plan["points"][4]["id"]);
  EXPECT_EQ(plan["points"][0]["seed"], plan["points"][4]["seed"]);
  // Same file, same plan; another base seed, other seeds.
  EXPECT_EQ(planOf(grid), plan);
  std::string other = grid;
  other.replace(other.find("\"seed\": 5"), 9, "\"seed\": 6");
  EXPECT_NE(planOf(other)["studies"][0]["seed"], plan["studies"][0]["seed"]);
  EXPECT_FALSE(fs::exists(dir.file("out")));

  // One simulated point, run: the study is simulated with the derived seed and its options.
  std::ofstream(sweepFile) << R"({"simulate": {"size": "small", "seed": 5,
      "frames-per-bone": 100}, "given_models": true,
      "parameters": {"simulate.standoff": ["gel"]}})";
  const std::string out = dir.file("out");
  const test::CommandResult p = runEchoreg({"study", "sweep", sweepFile, "--out", out, "--plan"});
  ASSERT_EQ(p.exitCode, 0) << p.err;
  const nlohmann::json one = nlohmann::json::parse(p.out);
  const test::CommandResult r = runEchoreg({"study", "sweep", sweepFile, "--out", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json manifest =
      readJson(out + "/" + one["studies"][0]["folder"].get<std::string>() + "/study.json");
  EXPECT_EQ(manifest["generator"]["seed"], one["studies"][0]["seed"]);
  EXPECT_EQ(manifest["generator"]["standoff"], "gel");
  const std::vector<nlohmann::json> rows = readJsonLines(out + "/results.jsonl");
  ASSERT_EQ(rows.size(), 1U);
  EXPECT_EQ(rows[0]["seed"], one["studies"][0]["seed"]);
  EXPECT_EQ(rows[0]["registrations"],
            readJson(out + "/points/" + one["points"][0]["id"].get<std::string>() +
                     "/results/results.json")["registrations"]);
}

// The plain ICP has no loss: crossed with register.loss it is one point, not one per loss.
TEST(StudySweep, PlainMethodIsOnePointWhateverTheLoss) {
  test::TempDir dir;
  const std::string sweepFile = dir.file("sweep.json");
  std::ofstream(sweepFile) << R"({"simulate": {"size": "small", "seed": 5},
      "parameters": {"register.method": ["plain", "robust"],
                     "register.loss": ["huber", "cauchy"]}})";
  const test::CommandResult r =
      runEchoreg({"study", "sweep", sweepFile, "--out", dir.file("out"), "--plan"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json plan = nlohmann::json::parse(r.out);
  ASSERT_EQ(plan["points"].size(), 3U) << plan.dump(2);
  EXPECT_EQ(plan["same_run_combinations"], 1);
  std::set<std::string> ids;
  for (const nlohmann::json& point : plan["points"])
    ids.insert(point["id"].get<std::string>());
  EXPECT_EQ(ids.size(), 3U);
  // Keys sorted, the last (register.method) fastest: plain (no loss), robust huber, robust cauchy.
  EXPECT_EQ(plan["points"][0]["parameters"]["register.method"], "plain");
  EXPECT_TRUE(plan["points"][0]["parameters"]["register.loss"].is_null());
  EXPECT_EQ(plan["points"][1]["parameters"]["register.loss"], "huber");
  EXPECT_EQ(plan["points"][2]["parameters"]["register.loss"], "cauchy");
  EXPECT_EQ(plan["points"][2]["parameters"]["register.method"], "robust");
}

TEST(StudySweep, BadSweepFilesNameTheKeyExitTwoAndWriteNothing) {
  test::TempDir dir;
  const std::string sweepFile = dir.file("sweep.json");
  const std::string out = dir.file("out");
  fs::create_directories(dir.file("study"));
  std::ofstream(dir.file("study/study.json")) << "{}";
  auto expectRefused = [&](const std::string& text, const std::string& problem,
                           const std::vector<std::string>& extra = {}) {
    std::ofstream(sweepFile) << text;
    std::vector<std::string> args = {"study", "sweep", sweepFile, "--out", out};
    args.insert(args.end(), extra.begin(), extra.end());
    const test::CommandResult r = runEchoreg(args);
    EXPECT_EQ(r.exitCode, 2) << text << "\n" << r.err;
    EXPECT_NE(r.err.find(sweepFile + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << text << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << "a refused sweep wrote " << out;
  };
  expectRefused("{\"study\": ", "is not a JSON sweep file");
  expectRefused("[1]", "must hold a JSON object");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutoff": [0.01]}, "x": 1})",
                "unknown key \"x\"");
  expectRefused(R"({"parameters": {"detect.cutoff": [0.01]}})", "needs exactly one base");
  expectRefused(R"({"study": "nowhere", "parameters": {"detect.cutoff": [0.01]}})",
                "nowhere holds no study.json");
  expectRefused(R"({"study": "study"})", "\"parameters\" must be an object");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutoff": 0.01}})",
                "\"parameters\": \"detect.cutoff\" must be a non-empty list");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutoff": [0.01, 0.01]}})",
                "lists 0.01 twice");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutof": [0.01]}})",
                "\"detect.cutof\" = 0.01: unknown parameter \"cutof\"");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutoff": [0.01, 3]}})",
                "\"detect.cutoff\" = 3: parameter \"cutoff\" = 3: cutoff must be in (0, 1)");
  expectRefused(R"({"study": "study", "parameters": {"detect.cutoff": ["low"]}})",
                "parameter \"cutoff\" must be a number");
  expectRefused(R"({"study": "study", "parameters": {"simulate.standoff": ["gel"]}})",
                "the simulator's options need a \"simulate\" base");
  expectRefused(R"({"study": "study", "parameters": {"replicate": [1]}})",
                "replicates need a \"simulate\" base");
  expectRefused(R"({"study": "study", "parameters": {"registration.loss": ["huber"]}})",
                "a parameter is \"simulate.OPTION\"");
  expectRefused(R"({"study": "study", "parameters": {"register.seed": [1, 2]}})",
                "\"register.method\", \"register.loss\"");
  expectRefused(R"({"study": "study", "parameters": {"register.method": ["robust", "icp"]}})",
                "\"register.method\" = \"icp\": unknown registration method \"icp\" (plain or "
                "robust)");
  expectRefused(R"({"study": "study", "parameters": {"register.loss": ["huber", "l1"]}})",
                "\"register.loss\" = \"l1\": unknown loss \"l1\" (huber, cauchy, tukey or trim)");
  expectRefused(R"({"study": "study", "parameters": {"register.loss": [1]}})",
                "\"register.loss\" = 1: must be a string");
  expectRefused(R"({"simulate": {"standoff": "foam"}, "parameters": {"replicate": [1]}})",
                "\"simulate\": --standoff: foam not in {glove,gel,none}");
  expectRefused(R"({"simulate": {"seed": -1}, "parameters": {"replicate": [1]}})",
                "\"seed\" must be a whole number >= 0");
  expectRefused(R"({"simulate": {"out": "x"}, "parameters": {"replicate": [1]}})",
                "\"out\" is not an option of echoreg simulate a sweep can set");
  expectRefused(R"({"simulate": {}, "parameters": {"simulate.flexion": [30, 120]}})",
                "\"simulate.flexion\" = 120: --flexion");
  expectRefused(R"({"simulate": {}, "parameters": {"simulate.seed": [1, 2]}})",
                "seeds are derived");
  expectRefused(
      R"({"simulate": {"standoff": "gel"}, "parameters": {"simulate.standoff": ["glove"]}})",
      "is both fixed in \"simulate\" and swept");
  expectRefused(R"({"simulate": {}, "parameters": {"replicate": [-1]}})",
                "-1 is not a whole number >= 0");
  expectRefused(R"({"study": "study", "given_models": 1, "parameters": {"detect.cutoff": [0.01]}})",
                "\"given_models\" must be true or false");
  // The options: a shard or a point that is not there.
  const std::string good = R"({"study": "study", "parameters": {"detect.cutoff": [0.01]}})";
  for (const std::string shard : {"0/2", "3/2", "1", "1/0", "a/b", "1/2x"}) {
    std::ofstream(sweepFile) << good;
    const test::CommandResult r =
        runEchoreg({"study", "sweep", sweepFile, "--out", out, "--shard", shard});
    EXPECT_EQ(r.exitCode, 2) << shard;
    EXPECT_NE(r.err.find("--shard " + shard + ": expected I/N"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  const test::CommandResult r =
      runEchoreg({"study", "sweep", sweepFile, "--out", out, "--point", "p-000000000000"});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--point p-000000000000: " + sweepFile + " has no such point"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace echoreg::simulation
