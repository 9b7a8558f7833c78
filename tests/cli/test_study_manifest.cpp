// The typed study manifest (cli/src/study_manifest.hpp): every value the study and the comparison
// read, typed and with its file names as the study reads them, or a FileError naming the manifest
// and the key.
#include "study_manifest.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <string>

namespace echoreg::cli {
namespace {

// A manifest with a value of every kind the study reads, in a folder of its own.
nlohmann::json fullManifest() {
  return nlohmann::json::parse(R"({
    "format": "echoreg-study", "version": 1,
    "generator": {"tool": "test", "seed": 3},
    "ct": {"dicom": "ct/series/"},
    "calibration": {"sphere_capture": "captures/sphere.igs.mha",
                    "capture": "./captures/shots.igs.mha#Image",
                    "pivot_capture": "captures/../captures/pivot.igs.mha",
                    "sphere_radius_mm": 25.4, "stylus_tip_radius_mm": 1.5,
                    "speed_of_sound_mps": 1450, "window_mm": [14, 34],
                    "initial_beam_to_probe_mm": [26.6, 0.8, 196.8]},
    "bones": {"tibia": {"model": "truth/tibia.vtp", "ultrasound": ["a.mha", "b.mha"],
                        "segment": {"seeds_ct": [[1, 2, 3], [4, 5, 6]], "with_fibula": true}},
              "femur": {"initial": "/elsewhere/FemurToCT.json", "mechanical": "../m.mha",
                        "mechanical_tip_radius_mm": -1, "hip_rotation": "hip.mha"}},
    "landmarks": {"ct": "ct/l.mrk.json", "capture": "l.mha", "order": ["a", "b"]},
    "detection": {"preset": "shadow", "speed_of_sound_mps": 1540},
    "truth": {"shots": "truth/shots.csv", "patella": "truth/patella.vtp",
              "femur": "truth/femur.vtp", "fibula": "truth/fibula.vtp"}
  })");
}

StudyManifest readManifest(const test::TempDir& dir, const nlohmann::json& manifest) {
  std::ofstream(dir.file("study.json")) << manifest.dump(2);
  return readStudyManifest(dir.path());
}

TEST(StudyManifest, ReadsEveryValueTypedWithItsFilesAsTheStudyReadsThem) {
  test::TempDir dir;
  const StudyManifest m = readManifest(dir, fullManifest());
  EXPECT_EQ(m.path, dir.file("study.json"));
  EXPECT_EQ(m.calibration.sphereCapture, "captures/sphere.igs.mha");
  EXPECT_EQ(m.calibration.capture, "captures/shots.igs.mha");  // normalised, member dropped
  EXPECT_EQ(m.calibration.pivotCapture, "captures/pivot.igs.mha");
  EXPECT_EQ(m.calibration.sphereRadiusMm, 25.4);
  EXPECT_EQ(m.calibration.stylusTipRadiusMm, 1.5);
  EXPECT_EQ(m.calibration.speedOfSoundMps, 1450.0);
  EXPECT_EQ(m.calibration.windowMm, (std::array<double, 2>{14.0, 34.0}));
  EXPECT_EQ(m.calibration.initialBeamToProbeMm, (std::array<double, 3>{26.6, 0.8, 196.8}));
  EXPECT_EQ(m.ctDicom, "ct/series/");
  EXPECT_EQ(m.detection.preset, "shadow");
  EXPECT_EQ(m.detection.speedOfSoundMps, 1540.0);
  EXPECT_EQ(m.landmarks.order, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(m.generator.at("seed"), 3);

  // The bones by name, in the order the study runs them.
  ASSERT_EQ(m.bones.size(), 2U);
  EXPECT_EQ(m.bones[0].name, "femur");
  EXPECT_EQ(m.bones[1].name, "tibia");
  const ManifestBone* femur = m.bone("femur");
  ASSERT_NE(femur, nullptr);
  EXPECT_EQ(femur->model, "");
  EXPECT_EQ(femur->initial, "/elsewhere/FemurToCT.json");
  EXPECT_EQ(femur->mechanical, "../m.mha");
  EXPECT_EQ(femur->mechanicalTipRadiusMm, -1.0);  // the registration step refuses it, by name
  EXPECT_EQ(femur->hipRotation, "hip.mha");
  EXPECT_TRUE(femur->seedsCt.empty());
  EXPECT_FALSE(femur->withFibula);
  const ManifestBone* tibia = m.bone("tibia");
  ASSERT_NE(tibia, nullptr);
  EXPECT_EQ(tibia->ultrasound, (std::vector<std::string>{"a.mha", "b.mha"}));
  ASSERT_EQ(tibia->seedsCt.size(), 2U);
  EXPECT_EQ(tibia->seedsCt[1], (std::array<double, 3>{4.0, 5.0, 6.0}));
  EXPECT_TRUE(tibia->withFibula);
  EXPECT_EQ(tibia->mechanicalTipRadiusMm, 0.0);
  EXPECT_EQ(m.bone("patella"), nullptr);

  // The truth of the bones the study names; "fibula" is no bone of this study.
  EXPECT_EQ(m.truth.model.size(), 1U);
  EXPECT_EQ(m.truth.model.at("femur"), "truth/femur.vtp");
  EXPECT_EQ(m.truth.shots, "truth/shots.csv");
  EXPECT_EQ(m.truth.transforms, "");

  // A file the study needs and the manifest leaves out is named as the file spells it.
  EXPECT_EQ(m.require(tibia->model, "bones.tibia.model"), "truth/tibia.vtp");
  try {
    m.require(femur->model, "bones.femur.model");
    ADD_FAILURE() << "no model accepted";
  } catch (const core::FileError& e) {
    EXPECT_EQ(std::string(e.what()), dir.file("study.json") + ": names no bones.femur.model");
  }
  EXPECT_TRUE(outsideStudyFolder(femur->initial));
  EXPECT_TRUE(outsideStudyFolder(femur->mechanical));
  EXPECT_FALSE(outsideStudyFolder(m.calibration.pivotCapture));
}

TEST(StudyManifest, AValueOfTheWrongTypeIsRefusedNamingTheManifestAndTheKey) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"/bones/femur/model", "3"},
      {"/bones/tibia/ultrasound/1", "{\"file\": \"b.mha\"}"},
      {"/bones/tibia/segment/seeds_ct/0", "null"},
      {"/bones/tibia/segment/seeds_ct/1", "[1, 2]"},
      {"/calibration/sphere_radius_mm", "\"25.4\""},
      {"/truth/femur", "false"},
      {"/ct/dicom", "[\"ct\"]"}};
  const std::vector<std::string> expected{
      "bones.femur.model must be a file name, got 3",
      "bones.tibia.ultrasound must be a list of capture file names",
      "bones.tibia.segment.seeds_ct.0 must be [x, y, z] in mm, got null",
      "bones.tibia.segment.seeds_ct.1 must be [x, y, z] in mm, got [1,2]",
      "calibration.sphere_radius_mm must be a number, got \"25.4\"",
      "truth.femur must be a file name, got false",
      "ct.dicom must be a file name, got [\"ct\"]"};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    test::TempDir dir;
    nlohmann::json manifest = fullManifest();
    manifest[nlohmann::json::json_pointer(cases[i].first)] = nlohmann::json::parse(cases[i].second);
    try {
      readManifest(dir, manifest);
      ADD_FAILURE() << cases[i].first << " = " << cases[i].second << " accepted";
    } catch (const core::FileError& e) {
      EXPECT_EQ(e.path(), dir.file("study.json"));
      EXPECT_EQ(e.problem().rfind(expected[i], 0), 0U) << e.problem();
    }
  }
}

// calibration.sessions (Table 5.2): every session's captures, the first the one the sweeps use;
// a session without both captures, or a first session other than sphere_capture and capture, is
// refused naming the key.
TEST(StudyManifest, ReadsTheCalibrationSessionsAndRefusesInconsistentOnes) {
  nlohmann::json manifest = fullManifest();
  manifest["calibration"].erase("sphere_capture");
  manifest["calibration"].erase("capture");
  manifest["calibration"]["sessions"] = nlohmann::json::parse(R"([
      {"sphere_capture": "captures/sphere.igs.mha", "capture": "./captures/shots.igs.mha"},
      {"sphere_capture": "captures/sphere_2.igs.mha", "capture": "captures/shots_2.igs.mha"}])");
  {
    test::TempDir dir;
    const StudyManifest m = readManifest(dir, manifest);
    ASSERT_EQ(m.calibration.sessions.size(), 2U);
    EXPECT_EQ(m.calibration.sessions[1].sphereCapture, "captures/sphere_2.igs.mha");
    EXPECT_EQ(m.calibration.sessions[1].capture, "captures/shots_2.igs.mha");
    // The first session is the calibration's sphere_capture and capture.
    EXPECT_EQ(m.calibration.sphereCapture, "captures/sphere.igs.mha");
    EXPECT_EQ(m.calibration.capture, "captures/shots.igs.mha");
  }
  {
    test::TempDir dir;  // without sessions: none listed, the one pair is the study's session
    const StudyManifest m = readManifest(dir, fullManifest());
    EXPECT_TRUE(m.calibration.sessions.empty());
  }
  const std::vector<std::pair<std::string, std::string>> cases{
      {"/calibration/sessions/1", R"({"capture": "captures/shots_2.igs.mha"})"},
      {"/calibration/sessions/0/capture", "7"},
      {"/calibration/sessions", "[]"},
      {"/calibration/sessions", R"("captures/shots.igs.mha")"},
      {"/calibration/capture", R"("captures/shots_2.igs.mha")"}};
  const std::vector<std::string> expected{
      "calibration.sessions.1 must be {\"sphere_capture\": FILE, \"capture\": FILE}",
      "calibration.sessions.0.capture must be a file name, got 7",
      "calibration.sessions must be a list of sessions",
      "calibration.sessions must be a list of sessions",
      "calibration.sphere_capture and calibration.capture must be the first of "
      "calibration.sessions"};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    test::TempDir dir;
    nlohmann::json bad = manifest;
    bad[nlohmann::json::json_pointer(cases[i].first)] = nlohmann::json::parse(cases[i].second);
    try {
      readManifest(dir, bad);
      ADD_FAILURE() << cases[i].first << " = " << cases[i].second << " accepted";
    } catch (const core::FileError& e) {
      EXPECT_EQ(e.path(), dir.file("study.json"));
      EXPECT_EQ(e.problem().rfind(expected[i], 0), 0U) << e.problem();
    }
  }
  test::TempDir dir;
  nlohmann::json many = manifest;
  many["calibration"]["sessions"] = nlohmann::json::array();
  for (std::size_t i = 0; i <= kMaxCalibrationSessions; ++i)
    many["calibration"]["sessions"].push_back(manifest["calibration"]["sessions"][0]);
  try {
    readManifest(dir, many);
    ADD_FAILURE() << "65 sessions accepted";
  } catch (const core::FileError& e) {
    EXPECT_EQ(e.problem().rfind("calibration.sessions lists 65 sessions, more than the 64", 0), 0U)
        << e.problem();
  }
}

}  // namespace
}  // namespace echoreg::cli
