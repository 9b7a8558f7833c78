// `echoreg pivot` and `echoreg calibrate` on the fixture study's captures, against its truth, and
// their refusals of bad data (exit 1, a message naming the file, no output).
#include "cli_test_support.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

class Calibrate : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fixtureStudy();
    if (root_.empty())
      GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
    manifest_ = readJson(root_ + "/study.json");
  }
  std::string path(const std::string& relative) const { return root_ + "/" + relative; }
  std::vector<std::string> calibrateArgs(const std::string& tip, const std::string& out) const {
    const nlohmann::json& c = manifest_.at("calibration");
    const nlohmann::json& initial = c.at("initial_beam_to_probe_mm");
    return {"calibrate",
            "--sphere-capture",
            path(c.at("sphere_capture")),
            "--stylus-tip-to-stylus",
            tip,
            "--capture",
            path(c.at("capture")),
            "--sphere-radius",
            "25.4",
            "--stylus-tip-radius",
            "1.5",
            "--initial",
            fmt(initial[0]),
            fmt(initial[1]),
            fmt(initial[2]),
            "--window-mm",
            "14",
            "34",
            "--out",
            out};
  }
  static std::string fmt(const nlohmann::json& v) { return std::to_string(v.get<double>()); }

  std::string root_;
  nlohmann::json manifest_;
  test::TempDir dir_;
};

TEST_F(Calibrate, PivotFindsTheStylusTipAndTheHipCentre) {
  test::CommandResult r = runEchoreg({"pivot", "--capture", path("captures/stylus_pivot.igs.mha"),
                                      "--out", dir_.file("tip.json"), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile tip =
      core::readTransformFile(dir_.file("tip.json"), "StylusTip", "Stylus");
  const core::TransformFile truth = core::readTransformFile(path("truth/StylusTipToStylus.json"));
  const double tipError =
      (tip.matrix.topRightCorner<3, 1>() - truth.matrix.topRightCorner<3, 1>()).norm();
  std::cout << "stylus tip error " << tipError << " mm, RMS " << tip.extra.at("rms_mm") << " mm\n";
  EXPECT_LT(tipError, 0.5);
  EXPECT_TRUE(fs::is_regular_file(dir_.file("tip.tfm")));

  r = runEchoreg({"pivot", "--capture", path("captures/hip_rotation.igs.mha"), "--marker",
                  "FemurToTracker", "--out", dir_.file("hip.json")});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile hip =
      core::readTransformFile(dir_.file("hip.json"), "HipCentre", "Femur");
  const nlohmann::json points = readJson(path("truth/points.json"));
  const Eigen::Vector4d hipCt(points.at("hip_centre_ct")[0], points.at("hip_centre_ct")[1],
                              points.at("hip_centre_ct")[2], 1.0);
  const Eigen::Matrix4d femurToCt = core::readTransformFile(path("truth/FemurToCT.json")).matrix;
  const Eigen::Vector3d hipInFemur = (femurToCt.inverse() * hipCt).head<3>();
  const double hipError = (hip.matrix.topRightCorner<3, 1>() - hipInFemur).norm();
  std::cout << "hip centre error " << hipError << " mm\n";
  EXPECT_LT(hipError, 2.0);
}

TEST_F(Calibrate, RecoversBeamToProbeAndTheBathsSpeedOfSound) {
  // The true tip isolates the beam calibration; the pivot's tip adds its own error, printed.
  ASSERT_EQ(runEchoreg({"pivot", "--capture", path("captures/stylus_pivot.igs.mha"), "--out",
                        dir_.file("pivot-tip.json")})
                .exitCode,
            0);
  fs::copy_file(path("truth/StylusTipToStylus.json"), dir_.file("tip.json"));
  const Eigen::Vector3d truth =
      core::readTransformFile(path("truth/BeamToProbe.json")).matrix.topRightCorner<3, 1>();
  const double water = readJson(path("truth/calibration.json")).at("water_speed_of_sound_mps");
  // As the dissertation did: 1450 m/s assumed in warmer water. The offset is biased along z.
  std::vector<std::string> args = calibrateArgs(dir_.file("tip.json"), dir_.file("c1450.json"));
  test::CommandResult r = runEchoreg(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile assumed =
      core::readTransformFile(dir_.file("c1450.json"), "Beam", "Probe");
  const Eigen::Vector3d biased = assumed.matrix.topRightCorner<3, 1>() - truth;
  // With the bath's true speed, and with the speed fitted.
  args = calibrateArgs(dir_.file("tip.json"), dir_.file("ctrue.json"));
  args.insert(args.end(), {"--speed-of-sound", std::to_string(water)});
  ASSERT_EQ(runEchoreg(args).exitCode, 0);
  const core::TransformFile known = core::readTransformFile(dir_.file("ctrue.json"));
  args = calibrateArgs(dir_.file("tip.json"), dir_.file("cfit.json"));
  args.push_back("--fit-speed-of-sound");
  ASSERT_EQ(runEchoreg(args).exitCode, 0);
  const core::TransformFile fitted = core::readTransformFile(dir_.file("cfit.json"));
  const double knownError = (known.matrix.topRightCorner<3, 1>() - truth).norm();
  const double fittedError = (fitted.matrix.topRightCorner<3, 1>() - truth).norm();
  const double fittedSpeed = fitted.extra.at("speed_of_sound_mps");
  std::cout << "assumed 1450 (true " << water << "): offset error (" << biased.transpose()
            << ") mm, RMS " << assumed.extra.at("rms_mm") << " mm, condition "
            << assumed.extra.at("condition_number") << "\n"
            << "true speed: error " << knownError << " mm, RMS " << known.extra.at("rms_mm")
            << "; fitted speed " << fittedSpeed << " m/s: error " << fittedError << " mm\n";
  const Eigen::Vector3d sphereCentre(known.extra.at("sphere_center_mm")[0].get<double>(),
                                     known.extra.at("sphere_center_mm")[1].get<double>(),
                                     known.extra.at("sphere_center_mm")[2].get<double>());
  const nlohmann::json trueCentre =
      readJson(path("truth/calibration.json")).at("sphere_centre_tracker_mm");
  std::cout << "sphere centre error "
            << (sphereCentre - Eigen::Vector3d(trueCentre[0], trueCentre[1], trueCentre[2])).norm()
            << " mm; true-speed offset error ("
            << (known.matrix.topRightCorner<3, 1>() - truth).transpose() << ") mm\n";
  // 1450 instead of ~1494 m/s shortens every depth by 3 %: the beam origin moves out along z.
  EXPECT_GT(biased.z() - (known.matrix(2, 3) - truth.z()), 0.4) << "the speed error must show";
  // The tracker's volumetric bias (0.23 mm along the line of sight, as a Polaris) does not
  // average out over one session: the study's calibrations land within 0.6 mm. Random noise
  // alone gives < 0.3 mm (tests/core/test_beam_calibration.cpp).
  EXPECT_LT(knownError, 0.6);
  EXPECT_LT(fittedError, 0.6);
  EXPECT_NEAR(fittedSpeed, water, 5.0);
  EXPECT_TRUE(fs::is_regular_file(dir_.file("cfit.tfm")));
  args = calibrateArgs(dir_.file("pivot-tip.json"), dir_.file("cpivot.json"));
  args.push_back("--fit-speed-of-sound");
  ASSERT_EQ(runEchoreg(args).exitCode, 0);
  std::cout << "with the pivot's tip: error "
            << (core::readTransformFile(dir_.file("cpivot.json")).matrix.topRightCorner<3, 1>() -
                truth)
                   .norm()
            << " mm\n";
  EXPECT_GT(fitted.extra.at("shots_used").get<int>(), 100);
  EXPECT_EQ(fitted.extra.at("shots").size(),
            fitted.extra.at("shots_used").get<std::size_t>() +
                fitted.extra.at("shots_rejected_by_reason").value("outlier", 0));
}

core::Sequence subset(const core::Sequence& sequence, std::size_t first, std::size_t count) {
  core::Sequence out = sequence;
  out.frames.assign(sequence.frames.begin() + static_cast<std::ptrdiff_t>(first),
                    sequence.frames.begin() + static_cast<std::ptrdiff_t>(first + count));
  const std::size_t bytes = sequence.samplesPerFrame() * core::elementSize(sequence.elementType);
  out.pixels.assign(sequence.pixels.begin() + static_cast<std::ptrdiff_t>(first * bytes),
                    sequence.pixels.begin() + static_cast<std::ptrdiff_t>((first + count) * bytes));
  return out;
}

// Issue 15, items 4 and 5: a calibration that converged but is implausible (a start 50 mm off
// that lands on the sphere's far side, a wrong stylus tip, a ball tip of 1 m) is refused by the
// quality gate and not written; a bad --speed-of-sound is refused rather than replaced.
TEST_F(Calibrate, QualityGateRefusesImplausibleCalibrationsWritingNothing) {
  ASSERT_EQ(runEchoreg({"pivot", "--capture", path("captures/stylus_pivot.igs.mha"), "--out",
                        dir_.file("tip.json")})
                .exitCode,
            0);
  const std::string out = dir_.file("out.json");
  auto expectRefused = [&](const std::vector<std::string>& args, const std::string& words) {
    const test::CommandResult r = runEchoreg(args);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << "expected \"" << words << "\" in " << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(dir_.file("out.tfm")));
    return r.err;
  };
  const std::vector<std::string> good = calibrateArgs(dir_.file("tip.json"), out);
  // The initial guess 50 mm off along the beam, and absurdly far.
  std::vector<std::string> farOff = good;
  farOff[14] = std::to_string(std::stod(farOff[14]) + 50.0);
  expectRefused(farOff, out + ": not written: the calibration of");
  std::vector<std::string> absurd = good;
  absurd[14] = "1e6";
  expectRefused(absurd, "do not determine");  // refused before the gate: condition number
  // A ball tip of 1 m (the fit of the stylus points refuses it), and of 2 cm (the gate does).
  std::vector<std::string> ball = good;
  ball[10] = "1000";
  expectRefused(ball, "the stylus points give no sphere");
  ball[10] = "5";  // 3.5 mm too large: accepted at an RMS of 0.61 mm, 4 mm off along z
  expectRefused(ball, "the stylus points lie on a sphere of radius");
  ball[10] = "20";
  expectRefused(ball, "mm RMS off the sphere (above 1.50 mm): check --stylus-tip-to-stylus");
  // An identity StylusTipToStylus: the marker's origin, not the tip, on the sphere.
  core::TransformFile identity;
  identity.from = "StylusTip";
  identity.to = "Stylus";
  core::writeTransformFile(dir_.file("identity.json"), identity, false);
  std::vector<std::string> noTip = calibrateArgs(dir_.file("identity.json"), out);
  expectRefused(noTip, "mm RMS off the sphere");
  // The thresholds are the user's: the good calibration, refused under a 0.01 mm RMS limit.
  std::vector<std::string> strict = good;
  strict.insert(strict.end(), {"--max-rms", "0.01"});
  expectRefused(strict, "RMS off the sphere (above 0.01 mm)");
  // A bad --speed-of-sound is refused, not replaced by the header's.
  for (const char* speed : {"0", "-1450", "nan", "1e308"}) {
    std::vector<std::string> bad = good;
    bad.insert(bad.end(), {"--speed-of-sound", speed});
    expectRefused(bad, "--speed-of-sound must be the bath's speed of sound within 1350-1700 m/s");
  }
  // And the good one passes the gate.
  const test::CommandResult r = runEchoreg(good);
  EXPECT_EQ(r.exitCode, 0) << r.err;
}

TEST_F(Calibrate, RefusesBadDataWithoutWritingAnything) {
  ASSERT_EQ(runEchoreg({"pivot", "--capture", path("captures/stylus_pivot.igs.mha"), "--out",
                        dir_.file("tip.json")})
                .exitCode,
            0);
  const nlohmann::json& c = manifest_.at("calibration");
  auto expectRefused = [&](std::vector<std::string> args, const std::string& file,
                           const std::string& words) {
    const test::CommandResult r = runEchoreg(args);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_.file("out.json")));
    EXPECT_FALSE(fs::exists(dir_.file("out.tfm")));
  };
  auto args = [&](const std::string& sphere, const std::string& shots) {
    std::vector<std::string> a = calibrateArgs(dir_.file("tip.json"), dir_.file("out.json"));
    a[2] = sphere;
    a[6] = shots;
    return a;
  };
  const std::string shots = path(c.at("capture"));
  const std::string sphere = path(c.at("sphere_capture"));
  // A sphere capture without stylus poses.
  expectRefused(args(shots, shots), shots, "has no StylusToTracker");
  // Every stylus pose INVALID.
  core::Sequence invalid = core::readSequence(sphere);
  for (core::SequenceFrame& f : invalid.frames)
    f.transforms.at("StylusToTracker").status = "INVALID";
  core::writeSequence(invalid, dir_.file("invalid.igs.mha"));
  expectRefused(args(dir_.file("invalid.igs.mha"), shots), dir_.file("invalid.igs.mha"), "INVALID");
  // A negative radius.
  std::vector<std::string> negative = args(sphere, shots);
  negative[8] = "-25.4";
  const test::CommandResult r = runEchoreg(negative);
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_NE(r.err.find("--sphere-radius"), std::string::npos) << r.err;
  // Fewer shots than parameters.
  const core::Sequence all = core::readSequence(shots);
  core::writeSequence(subset(all, 0, 3), dir_.file("three.igs.mha"));
  expectRefused(args(sphere, dir_.file("three.igs.mha")), dir_.file("three.igs.mha"), "shots");
  // Every shot from one direction: the frames of one held pose.
  core::writeSequence(subset(all, 0, 15), dir_.file("one-direction.igs.mha"));
  expectRefused(args(sphere, dir_.file("one-direction.igs.mha")),
                dir_.file("one-direction.igs.mha"), "determine");
}

// --params: the detection's parameters from the table every command that detects shares. A window
// given in the file is the same calibration as --window-mm; a speed of sound in it outside the
// gate's range is refused naming the file, nothing written.
TEST_F(Calibrate, ParamsFileGivesTheDetectionsParameters) {
  fs::copy_file(path("truth/StylusTipToStylus.json"), dir_.file("tip.json"));
  const test::CommandResult flags =
      runEchoreg(calibrateArgs(dir_.file("tip.json"), dir_.file("flags.json")));
  ASSERT_EQ(flags.exitCode, 0) << flags.err;
  std::vector<std::string> args = calibrateArgs(dir_.file("tip.json"), dir_.file("params.json"));
  args.erase(args.end() - 5, args.end() - 2);  // "--window-mm", "14", "34"
  ASSERT_EQ(args[args.size() - 2], "--out");
  std::ofstream(dir_.file("window.json")) << R"({"window-mm": [14, 34]})";
  args.insert(args.end() - 2, {"--params", dir_.file("window.json")});
  const test::CommandResult file = runEchoreg(args);
  ASSERT_EQ(file.exitCode, 0) << file.err;
  const nlohmann::json a = readJson(dir_.file("flags.json"));
  const nlohmann::json b = readJson(dir_.file("params.json"));
  EXPECT_EQ(a.at("matrix"), b.at("matrix"));
  EXPECT_EQ(a.at("shots"), b.at("shots"));

  std::ofstream(dir_.file("fast.json")) << R"({"speed-of-sound": 1900})";
  args = calibrateArgs(dir_.file("tip.json"), dir_.file("fast-out.json"));
  args.insert(args.end() - 2, {"--params", dir_.file("fast.json")});
  const test::CommandResult fast = runEchoreg(args);
  EXPECT_EQ(fast.exitCode, 1);
  EXPECT_NE(fast.err.find(dir_.file("fast.json")), std::string::npos) << fast.err;
  EXPECT_NE(fast.err.find("speed-of-sound"), std::string::npos) << fast.err;
  EXPECT_FALSE(fs::exists(dir_.file("fast-out.json")));
}

}  // namespace
}  // namespace echoreg::simulation
