// `echoreg study run` over several calibration sessions of one probe (Table 5.2): every session of
// calibration.sessions calibrated as its own step, the repeatability table in the report and in
// results.json, the same bytes on a fresh run, and a session whose capture is missing refused
// before anything is written, naming the session and the file.
#include "study_checks.hpp"

#include "cli_test_support.hpp"
#include "file_bytes.hpp"
#include "test_support.hpp"

#include "echoreg/simulation/study.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::fileBytes;
using test::runEchoreg;

// The report's Table 5.2 section: from its heading to the next heading.
std::string table52Section(const std::string& report) {
  const auto start = report.find("## Repeatability of the calibration (Table 5.2)");
  if (start == std::string::npos)
    return "";
  return report.substr(start, report.find("\n## ", start + 1) - start);
}

// A small study of three calibration sessions, its bones left without sweeps or mechanical
// probe so that the run is the pivot and the calibrations.
std::string simulateCalibrationStudy(const test::TempDir& dir) {
  StudyOptions options;
  options.size = StudySize::Small;
  options.seed = 2008;
  options.framesPerBone = 20;
  options.calibrations = 3;
  const std::string study = dir.file("study");
  generateStudy(options, study);
  nlohmann::json manifest = readJson(study + "/study.json");
  for (auto& [name, bone] : manifest["bones"].items()) {
    static_cast<void>(name);
    for (const char* key :
         {"ultrasound", "mechanical", "mechanical_blunt", "hip_rotation", "segment"})
      bone.erase(key);
  }
  std::ofstream(study + "/study.json") << manifest.dump(2);
  return study;
}

TEST(StudyCalibrations, EverySessionCalibratedIntoTable52ThenTheSameBytes) {
  test::TempDir dir;
  const std::string study = simulateCalibrationStudy(dir);
  test::CommandResult r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;

  // One calibration per session, the first the study's calibration.json.
  for (const char* file : {"calibration.json", "calibration_2.json", "calibration_3.json"})
    EXPECT_TRUE(fs::is_regular_file(study + "/results/" + file)) << file;
  EXPECT_FALSE(fs::exists(study + "/results/calibration_4.json"));

  const nlohmann::json truth = readJson(study + "/truth/transforms.json");
  const Eigen::Matrix4d beamToProbe = matrixFrom(truth.at("BeamToProbe"));
  const double bathMps = readJson(study + "/truth/calibration.json").at("water_speed_of_sound_mps");
  const nlohmann::json results = readJson(study + "/results/results.json");
  const nlohmann::json& table = results.at("calibration_sessions");
  const nlohmann::json& sessions = table.at("sessions");
  ASSERT_EQ(sessions.size(), 3U);
  std::array<double, 3> low{1e9, 1e9, 1e9}, high{-1e9, -1e9, -1e9}, mean{0, 0, 0};
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    const nlohmann::json& s = sessions[k];
    EXPECT_EQ(s.at("session"), k + 1);
    EXPECT_EQ(s.at("capture"),
              k == 0 ? std::string("captures/calibration_shots.igs.mha")
                     : "captures/calibration_shots_" + std::to_string(k + 1) + ".igs.mha");
    // Each session's offset within 0.6 mm of the probe's true one: the tracker's volumetric bias
    // (0.23 mm along the line of sight) is not averaged out by a session (docs/calibration.md).
    for (int i = 0; i < 3; ++i) {
      const double v = s.at("beam_to_probe_mm").at(static_cast<std::size_t>(i)).get<double>();
      EXPECT_NEAR(v, beamToProbe(i, 3), 0.6) << "session " << k + 1 << " axis " << i;
      low[static_cast<std::size_t>(i)] = std::min(low[static_cast<std::size_t>(i)], v);
      high[static_cast<std::size_t>(i)] = std::max(high[static_cast<std::size_t>(i)], v);
      mean[static_cast<std::size_t>(i)] += v / 3.0;
    }
    EXPECT_GT(s.at("rms_mm").get<double>(), 0.0);
    EXPECT_LT(s.at("rms_mm").get<double>(), 0.5);  // the dissertation's: 0.55-0.91 mm
    EXPECT_GE(s.at("condition_number").get<double>(), 1.0);
    EXPECT_LT(s.at("condition_number").get<double>(), 40.0);
    EXPECT_NEAR(s.at("speed_of_sound_mps").get<double>(), bathMps, 15.0);
    EXPECT_GT(s.at("shots_used").get<int>(), 100);
  }
  // The sessions are separate calibrations (the bath set up anew), and the summary rows are theirs.
  EXPECT_GT(high[0] - low[0] + high[1] - low[1] + high[2] - low[2], 0.01);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(table.at("mean").at("beam_to_probe_mm").at(i).get<double>(), mean[i], 1e-9);
    EXPECT_NEAR(table.at("spread").at("beam_to_probe_mm").at(i).get<double>(), high[i] - low[i],
                1e-9);
    EXPECT_NEAR(table.at("truth_beam_to_probe_mm").at(i).get<double>(),
                beamToProbe(static_cast<Eigen::Index>(i), 3), 1e-9);
  }
  // The report's table: one row per session, then mean, spread and the truth.
  const std::string section = table52Section(fileBytes(study + "/results/report.md"));
  ASSERT_FALSE(section.empty());
  EXPECT_NE(section.find("| 1 | calibration_shots.igs.mha | "), std::string::npos) << section;
  EXPECT_NE(section.find("| 3 | calibration_shots_3.igs.mha | "), std::string::npos) << section;
  EXPECT_NE(section.find("| spread (max - min) |"), std::string::npos) << section;
  EXPECT_NE(section.find("| truth (simulation) |"), std::string::npos) << section;
  const std::string html = fileBytes(study + "/results/report.html");
  EXPECT_NE(html.find("Repeatability of the calibration (Table 5.2)"), std::string::npos);
  EXPECT_NE(html.find("calibration_shots_2.igs.mha"), std::string::npos);

  // A second run finds every calibration up to date.
  r = runEchoreg({"study", "run", study});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // (The document is kept in a variable: a range-for over a member of a temporary reads freed
  // memory, as ASan found here.)
  const auto rerun = readJson(study + "/results/results.json");
  for (const auto& step : rerun.at("steps")) {
    const std::string id = step.at("id");
    if (id.rfind("calibrate", 0) == 0) {
      EXPECT_EQ(step.at("status"), "up to date") << id;
    }
  }
  // A fresh run gives the same bytes: the calibrations, the table in results.json and the report.
  const std::string copy = dir.file("copy");
  fs::copy(study, copy, fs::copy_options::recursive);
  fs::remove_all(copy + "/results");
  r = runEchoreg({"study", "run", copy});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const char* file : {"calibration.json", "calibration_2.json", "calibration_3.json"}) {
    EXPECT_TRUE(fileBytes(study + "/results/" + file) == fileBytes(copy + "/results/" + file))
        << file << " differs on a fresh run";
  }
  EXPECT_EQ(readJson(copy + "/results/results.json").at("calibration_sessions"), table);
  EXPECT_EQ(table52Section(fileBytes(copy + "/results/report.md")), section);

  // The sweeps' detection parameters of a run are in its provenance (not the --params path, which
  // lies outside the study): none without --params, the file's preset and settings with it.
  EXPECT_TRUE(results.at("provenance").at("detection_params").is_null());
  const std::string params = dir.file("params.json");
  std::ofstream(params) << R"({"preset": "default", "history": 3, "consistency-mm": 0.5})";
  r = runEchoreg({"study", "run", copy, "--params", params});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(readJson(copy + "/results/results.json").at("provenance").at("detection_params"),
            nlohmann::json::parse(
                R"({"preset": "default", "settings": {"history": 3, "consistency-mm": 0.5}})"));

  // A session whose capture is missing: refused before anything is written, naming the session
  // and the file.
  const std::string broken = dir.file("broken");
  fs::create_directories(broken);
  for (const char* part : {"study.json", "captures", "truth"})
    fs::copy(study + "/" + part, broken + "/" + part, fs::copy_options::recursive);
  fs::remove(broken + "/captures/calibration_shots_2.igs.mha");
  r = runEchoreg({"study", "run", broken});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find(broken +
                       "/captures/calibration_shots_2.igs.mha: is missing (the capture of "
                       "calibration session 2 of 3 in " +
                       broken + "/study.json)"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(broken + "/results"));
}

}  // namespace
}  // namespace echoreg::simulation
