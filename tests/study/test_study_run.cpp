// `echoreg study run` on a copy of the fixture study: the whole job end to end (segmentation from
// the manifest's seeds, calibration, registrations, evaluation, figures, report), a second run
// that finds every step up to date, a change that re-runs exactly the steps downstream of it, and
// failures that name the step and the file.
#include "study_checks.hpp"

#include "cli_test_support.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <string>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

std::map<std::string, std::string> stepStatuses(const nlohmann::json& results) {
  std::map<std::string, std::string> statuses;
  for (const auto& step : results.at("steps")) {
    statuses[step.at("id").get<std::string>()] = step.at("status").get<std::string>();
  }
  return statuses;
}

// A step's notes in results.json, one per line.
std::string notesOf(const nlohmann::json& results, const std::string& id) {
  std::string notes;
  for (const auto& step : results.at("steps")) {
    if (step.at("id") == id) {
      for (const auto& n : step.at("notes"))
        notes += n.get<std::string>() + "\n";
    }
  }
  return notes;
}

double errorAt(const nlohmann::json& rows, const std::string& estimate, const std::string& column) {
  for (const auto& row : rows) {
    if (row.at("estimate") == estimate)
      return row.at(column).get<double>();
  }
  ADD_FAILURE() << "no row " << estimate;
  return 1e9;
}

TEST(StudyRun, RunsTheWholeStudyThenOnlyWhatAChangeAffects) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string study = dir.file("study");
  fs::copy(fixture, study, fs::copy_options::recursive);
  fs::remove_all(study + "/results");

  // 1. The whole job.
  test::CommandResult r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("results/report.html"), std::string::npos) << r.out;
  for (const char* file : {"report.md", "report.html", "results.json", "models/femur.vtp",
                           "models/tibia.vtp", "registrations/femur_ultrasound_1.tfm",
                           "figures/calibration.png", "figures/femur_registration.png",
                           "figures/tibia_registration.png", "figures/residuals.png"}) {
    EXPECT_TRUE(fs::is_regular_file(study + "/results/" + file)) << file;
  }
  const nlohmann::json first = readJson(study + "/results/results.json");
  for (const auto& [id, status] : stepStatuses(first))
    EXPECT_EQ(status, "ran") << id;
  // The numbers: segmentation against the truth, registrations against the truth at the knee.
  EXPECT_GT(first.at("segmentation").at("femur").at("dice").get<double>(), 0.99);
  EXPECT_GT(first.at("segmentation").at("tibia").at("dice").get<double>(), 0.99);
  for (const char* bone : {"femur", "tibia"}) {
    const nlohmann::json& truth = first.at("registrations").at(bone).at("against_truth");
    const double us =
        errorAt(truth, std::string(bone) + "_ultrasound_1.json", "target_knee_centre_mm");
    const double mech =
        errorAt(truth, std::string(bone) + "_mechanical.json", "target_knee_centre_mm");
    std::cout << bone << ": knee centre error, ultrasound " << us << " mm, mechanical " << mech
              << " mm\n";
    EXPECT_LT(us, 2.0) << bone;
    EXPECT_LT(mech, 1.5) << bone;
  }
  EXPECT_LT(first.at("calibration").at("rms_mm").get<double>(), 0.5);
  const std::string report = [&] {
    std::ifstream in(study + "/results/report.md");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(report.find("## Registration of the femur"), std::string::npos);
  EXPECT_NE(report.find("(Table 6.1)"), std::string::npos);
  EXPECT_NE(report.find("figures/femur_registration.png"), std::string::npos);
  // What the segmentation said of its model (the CT's slice groups: closed at the group's ends)
  // reaches the results and the report; it was dropped when the step succeeded.
  const std::string segmentNotes = notesOf(first, "segment-femur");
  EXPECT_NE(segmentNotes.find("echoreg segment: note: the CT has"), std::string::npos)
      << segmentNotes;
  EXPECT_NE(report.find("What the steps' commands noted about their results"), std::string::npos);
  EXPECT_NE(report.find(segmentNotes.substr(0, segmentNotes.find('\n'))), std::string::npos);
  EXPECT_NE(r.err.find("noted something about"), std::string::npos) << r.err;

  // 2. Nothing changed: every step is up to date, the outputs untouched.
  const auto modelTime = fs::last_write_time(study + "/results/models/femur.vtp");
  r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const auto& [id, status] : stepStatuses(readJson(study + "/results/results.json"))) {
    EXPECT_EQ(status, "up to date") << id;
  }
  EXPECT_EQ(fs::last_write_time(study + "/results/models/femur.vtp"), modelTime);
  EXPECT_EQ(notesOf(readJson(study + "/results/results.json"), "segment-femur"), segmentNotes);

  // 3. A different calibration window: the calibration and what depends on it run again; the
  // stylus pivot, the hip centre and the segmentations do not.
  nlohmann::json manifest = readJson(study + "/study.json");
  manifest["calibration"]["window_mm"] = {13.0, 35.0};
  std::ofstream(study + "/study.json") << manifest.dump(2);
  r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto third = stepStatuses(readJson(study + "/results/results.json"));
  for (const char* id : {"pivot-stylus", "pivot-hip", "segment-femur", "segment-tibia"}) {
    EXPECT_EQ(third.at(id), "up to date") << id;
  }
  for (const char* id : {"calibrate", "detect-femur-1", "register-femur-ultrasound-1"}) {
    EXPECT_EQ(third.at(id), "ran") << id;
  }

  // 4. Issue 15, item 10: damaged results are not trusted. A truncated registration JSON and an
  // emptied points CSV are rebuilt (byte-identical), and only their steps run again.
  const auto slurp = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string registration = study + "/results/registrations/femur_ultrasound_1.json";
  const std::string points = study + "/results/points/femur_ultrasound_1.csv";
  const std::string registrationBytes = slurp(registration), pointsBytes = slurp(points);
  fs::resize_file(registration, registrationBytes.size() / 2);
  std::ofstream(points, std::ios::trunc).close();
  r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto fourth = stepStatuses(readJson(study + "/results/results.json"));
  EXPECT_EQ(fourth.at("detect-femur-1"), "ran");
  EXPECT_EQ(fourth.at("register-femur-ultrasound-1"), "ran");
  for (const char* id : {"pivot-stylus", "calibrate", "detect-tibia-1",
                         "register-tibia-ultrasound-1", "register-femur-mechanical"}) {
    EXPECT_EQ(fourth.at(id), "up to date") << id;
  }
  EXPECT_EQ(slurp(registration), registrationBytes);
  EXPECT_EQ(slurp(points), pointsBytes);
}

TEST(StudyRun, FailuresNameTheStepAndTheFile) {
  test::TempDir dir;
  // Not a study.
  test::CommandResult r = runEchoreg({"study", "run", dir.path()});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("study.json"), std::string::npos) << r.err;
  std::ofstream(dir.file("study.json")) << R"({"format": "something else"})";
  r = runEchoreg({"study", "run", dir.path()});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("not an echoreg study manifest"), std::string::npos) << r.err;

  // A study whose calibration capture is broken: the calibration step fails, named with its file;
  // the report says where the study stopped.
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  const std::string study = dir.file("study");
  fs::create_directories(study + "/captures");
  fs::copy(fixture + "/study.json", study + "/study.json");
  fs::copy(fixture + "/captures/stylus_pivot.igs.mha", study + "/captures/stylus_pivot.igs.mha");
  fs::copy(fixture + "/captures/calibration_sphere_stylus.igs.mha",
           study + "/captures/calibration_sphere_stylus.igs.mha");
  std::ofstream(study + "/captures/calibration_shots.igs.mha") << "ObjectType = Image\nNDims = 3\n";
  r = runEchoreg({"study", "run", study});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("transducer calibration"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("calibration_shots.igs.mha"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_regular_file(study + "/results/report.md"));

  // With the calibration whole, the first required step whose input the study folder does not
  // hold stops the study; the input is named as every missing input is: "PATH: is missing (why)".
  fs::copy(fixture + "/captures/calibration_shots.igs.mha",
           study + "/captures/calibration_shots.igs.mha", fs::copy_options::overwrite_existing);
  r = runEchoreg({"study", "run", study});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("echoreg study: " + study + "/"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(": is missing (the study folder does not hold it; step \""),
            std::string::npos)
      << r.err;
  // And a missing capture of a calibration session, before anything runs, in the same words.
  fs::remove(study + "/captures/calibration_sphere_stylus.igs.mha");
  r = runEchoreg({"study", "run", study});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(study +
                       "/captures/calibration_sphere_stylus.igs.mha: is missing (the "
                       "sphere_capture of calibration session 1 of 1 in " +
                       study + "/study.json)"),
            std::string::npos)
      << r.err;
}

// Issue 15, item 5: a manifest value of the wrong type, no bones or an unknown version is
// refused before any step runs (nothing written), naming the value as the file spells it.
TEST(StudyRun, RefusesManifestsWithWrongValuesBeforeAnyStep) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  const nlohmann::json good = readJson(fixture + "/study.json");
  const std::vector<std::pair<std::function<void(nlohmann::json&)>, std::string>> cases{
      {[](nlohmann::json& m) { m["detection"]["speed_of_sound_mps"] = "1450"; },
       "detection.speed_of_sound_mps must be a number > 0, got \"1450\""},
      {[](nlohmann::json& m) {
         m["calibration"]["window_mm"] = {1, 2, 3};
       },
       "calibration.window_mm must be [MIN, MAX] in mm, got [1,2,3]"},
      {[](nlohmann::json& m) { m["calibration"]["initial_beam_to_probe_mm"] = "26 1 197"; },
       "calibration.initial_beam_to_probe_mm must be [X, Y, Z] in mm"},
      {[](nlohmann::json& m) { m["bones"]["femur"]["ultrasound"] = "captures/femur.igs.mha"; },
       "bones.femur.ultrasound must be a list of capture file names"},
      {[](nlohmann::json& m) {
         m["landmarks"]["order"] = {"a", 2};
       },
       "landmarks.order must be a list of landmark names"},
      {[](nlohmann::json& m) { m["bones"] = nlohmann::json::object(); }, "names no bones"},
      {[](nlohmann::json& m) { m.erase("bones"); }, "names no bones"},
      {[](nlohmann::json& m) { m["version"] = 99; },
       "\"version\": 99 is not a manifest version this echoreg reads (1)"},
      // Issue 15, item 12: what a manifest may ask is bounded (10^6 registrations ran past 240 s
      // and 5.3 GB).
      {[](nlohmann::json& m) {
         m["bones"]["femur"]["ultrasound"] =
             std::vector<std::string>(1000000, "captures/femur_sweep_1.igs.mha");
       },
       "is 40.1 MB, more than the 16 MB a study manifest may be"},
      {[](nlohmann::json& m) {
         m["bones"]["femur"]["ultrasound"] =
             std::vector<std::string>(1000, "captures/femur_sweep_1.igs.mha");
       },
       "bones.femur.ultrasound lists 1000 captures, more than the 500 registrations a study "
       "may run per bone"},
      {[](nlohmann::json& m) {
         for (int b = 0; b < 40; ++b)
           m["bones"]["bone" + std::to_string(b)] = m["bones"]["femur"];
       },
       "names 42 bones, more than the 32 a study may register"},
      {[](nlohmann::json& m) {
         m["bones"]["femur"]["segment"]["seeds_ct"] =
             std::vector<std::vector<double>>(65, {1.0, 2.0, 3.0});
       },
       "bones.femur.segment.seeds_ct lists 65 seeds, more than the 64"},
      {[](nlohmann::json& m) { m["padding"] = std::string(17u << 20, ' '); },
       "is 17.0 MB, more than the 16 MB a study manifest may be"}};
  for (const auto& [spoil, words] : cases) {
    test::TempDir dir;
    nlohmann::json manifest = good;
    spoil(manifest);
    std::ofstream(dir.file("study.json")) << manifest.dump(2);
    const test::CommandResult r = runEchoreg({"study", "run", dir.path()});
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find(dir.file("study.json") + ": " + words), std::string::npos)
        << "expected \"" << words << "\" in " << r.err;
    EXPECT_FALSE(fs::exists(dir.file("results"))) << words;
  }
}

// Issue 15, item 6: a study whose requested results are missing (a registration skipped for a
// capture the folder lacks, one failed on a negative tip radius) exits 1 and says which, in the
// report and on stderr, and no longer blames "an earlier step" when none failed.
TEST(StudyRun, MissingRequestedResultsFailTheStudyAndAreNamed) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string study = dir.file("study");
  fs::copy(fixture, study, fs::copy_options::recursive);
  fs::remove_all(study + "/results");
  nlohmann::json manifest = readJson(study + "/study.json");
  const std::string mechanical = manifest["bones"]["femur"]["mechanical"].get<std::string>();
  fs::remove(study + "/" + mechanical);
  manifest["bones"]["tibia"]["mechanical_tip_radius_mm"] = -1.0;
  std::ofstream(study + "/study.json") << manifest.dump(2);

  const test::CommandResult r = runEchoreg({"study", "run", study, "--given-models"});
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_NE(r.out.find("study incomplete: report in"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("2 requested results are missing"), std::string::npos) << r.err;
  EXPECT_NE(
      r.err.find("femur registration from the mechanical probe (reference) (skipped: " + study +
                 "/" + mechanical + ": is missing (the study folder does not hold it))"),
      std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("tibia registration from the mechanical probe (reference) (failed: "),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("--stylus-tip-radius"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("an earlier step failed"), std::string::npos) << r.err;
  const nlohmann::json results = readJson(study + "/results/results.json");
  EXPECT_EQ(results.at("missing").size(), 2u);
  const auto statuses = stepStatuses(results);
  EXPECT_EQ(statuses.at("register-femur-mechanical"), "skipped");
  EXPECT_EQ(statuses.at("register-tibia-mechanical"), "FAILED");
  EXPECT_EQ(statuses.at("register-femur-ultrasound-1"), "ran");
  std::ifstream in(study + "/results/report.md");
  const std::string report(std::istreambuf_iterator<char>(in), {});
  EXPECT_NE(report.find("The study is incomplete: 2 requested results are missing"),
            std::string::npos);
}

}  // namespace
}  // namespace echoreg::simulation

namespace echoreg::simulation {
namespace {

// Drops every "seconds" member (timings differ from run to run) so the rest compares exactly.
void dropTimings(nlohmann::json& value) {
  if (value.is_object()) {
    value.erase("seconds");
    for (auto& [key, member] : value.items())
      dropTimings(member);
  } else if (value.is_array()) {
    for (auto& member : value)
      dropTimings(member);
  }
}

std::string bytesOf(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Issue 15: results do not embed where the study lies. The fixture copied to two folders, each
// run on its own, gives the same bytes in every result (the report's and results.json's timings
// aside), none names either folder, and a file read from outside the study is listed in the
// report's provenance.
TEST(StudyRun, AStudyCopiedElsewhereGivesTheSameResultsAndNamesWhatItReadOutside) {
  const std::string fixture = fixtureStudy();
  if (fixture.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const std::string outsideLandmarks = dir.file("shared-landmarks.mrk.json");
  const std::vector<std::string> studies{dir.file("site-a/study"), dir.file("site-b/copy/study")};
  for (const std::string& study : studies) {
    fs::create_directories(fs::path(study).parent_path());
    fs::copy(fixture, study, fs::copy_options::recursive);
    fs::remove_all(study + "/results");
    nlohmann::json manifest = readJson(study + "/study.json");
    const std::string landmarks = manifest["landmarks"]["ct"].get<std::string>();
    if (!fs::exists(outsideLandmarks))
      fs::copy_file(study + "/" + landmarks, outsideLandmarks);
    fs::remove(study + "/" + landmarks);
    manifest["landmarks"]["ct"] = outsideLandmarks;
    std::ofstream(study + "/study.json") << manifest.dump(2);
    const test::CommandResult r = runEchoreg({"study", "run", study});
    ASSERT_EQ(r.exitCode, 0) << r.err;
  }
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(studies[0] + "/results")) {
    if (!entry.is_regular_file())
      continue;
    const fs::path relative = fs::relative(entry.path(), studies[0]);
    const std::string name = relative.filename().string();
    const std::string a = bytesOf(entry.path());
    const std::string b = bytesOf(fs::path(studies[1]) / relative);
    for (const std::string& study : studies) {
      EXPECT_EQ(a.find(study), std::string::npos) << relative << " names " << study;
      EXPECT_EQ(b.find(study), std::string::npos) << relative << " names " << study;
    }
    if (name == ".study-state.json" || name == "report.md" || name == "report.html")
      continue;  // the cache and the reports carry the steps' times
    if (name == "results.json") {
      nlohmann::json ja = nlohmann::json::parse(a), jb = nlohmann::json::parse(b);
      dropTimings(ja);
      dropTimings(jb);
      EXPECT_EQ(ja, jb);
      EXPECT_EQ(ja["provenance"]["read_outside_study"], nlohmann::json::array({outsideLandmarks}));
    } else {
      EXPECT_TRUE(a == b) << relative << " differs between the two copies";
    }
    ++compared;
  }
  EXPECT_GT(compared, 20);
  const std::string report = bytesOf(studies[1] + "/results/report.md");
  EXPECT_NE(report.find("Read outside the study folder (a copy of the folder alone does not hold "
                        "them): " +
                        outsideLandmarks),
            std::string::npos)
      << report;
}

}  // namespace
}  // namespace echoreg::simulation
