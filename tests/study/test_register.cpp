// `echoreg register` on the fixture study: femur and tibia from their ultrasound captures with
// the truth calibration and models, started from the two landmarks each bone has (epicondyles,
// malleoli; the rotation about their line searched), against truth/FemurToCT.json and
// TibiaToCT.json at the knee centre. Also the CSV input, the hybrid with the stylus points,
// and refusals.
#include "cli_test_support.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/mesh_io.h"
#include "study_checks.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

namespace echoreg::simulation {
namespace {

namespace fs = std::filesystem;
using test::runEchoreg;

class Register : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fixtureStudy();
    if (root_.empty())
      GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
    const nlohmann::json points = readJson(root_ + "/truth/points.json");
    for (int k = 0; k < 3; ++k)
      knee_[k] = points.at("knee_centre_ct")[static_cast<std::size_t>(k)].get<double>();
    // The hip centre from the leg's rotation: the femur's third landmark (with the two
    // epicondyles alone the rotation about their line is ambiguous, see FemurFromTwoLandmarks...).
    hip_ = dir_.file("hip.json");
    const test::CommandResult r =
        runEchoreg({"pivot", "--capture", path("captures/hip_rotation.igs.mha"), "--marker",
                    "FemurToTracker", "--out", hip_});
    ASSERT_EQ(r.exitCode, 0) << r.err;
  }
  std::string path(const std::string& relative) const { return root_ + "/" + relative; }
  std::vector<std::string> args(const std::string& bone, const std::string& out,
                                bool withHip = true) const {
    const std::string lower = bone == "Femur" ? "femur" : "tibia";
    std::vector<std::string> a = {"register",
                                  "--model",
                                  path("truth/" + lower + ".vtp"),
                                  "--bone",
                                  bone,
                                  "--capture",
                                  path("captures/" + lower + "_ultrasound.igs.mha"),
                                  "--calibration",
                                  path("truth/BeamToProbe.json"),
                                  "--landmarks-ct",
                                  path("ct/landmarks.mrk.json"),
                                  "--landmarks-capture",
                                  path("captures/landmarks.igs.mha"),
                                  "--stylus-tip-to-stylus",
                                  path("truth/StylusTipToStylus.json"),
                                  "--landmark-labels",
                                  bone == "Femur" ? "medial_epicondyle,lateral_epicondyle"
                                                  : "medial_malleolus,lateral_malleolus",
                                  "--out",
                                  out};
    if (bone == "Femur" && withHip) {
      a.push_back("--hip-centre");
      a.push_back(hip_);
    }
    return a;
  }
  // Distance at the knee centre (mm) and rotation angle (deg) of an estimate against the truth.
  std::pair<double, double> error(const std::string& estimateFile, const std::string& bone) const {
    const core::TransformFile estimate = core::readTransformFile(estimateFile, bone, "CT");
    const core::TransformFile truth = core::readTransformFile(path("truth/" + bone + "ToCT.json"));
    const Eigen::Matrix4d e = truth.matrix.inverse() * estimate.matrix;
    const Eigen::Vector4d k(knee_.x(), knee_.y(), knee_.z(), 1.0);
    const double distance = (estimate.matrix * (truth.matrix.inverse() * k) - k).head<3>().norm();
    const double angle =
        Eigen::AngleAxisd(Eigen::Matrix3d(e.topLeftCorner<3, 3>())).angle() * 57.29577951308232;
    return {distance, angle};
  }

  std::string root_;
  std::string hip_;
  Eigen::Vector3d knee_ = Eigen::Vector3d::Zero();
  test::TempDir dir_;
};

// Measured on the seed-7 fixture (robust, Huber, speed of sound fitted): femur 0.87 mm / 0.43 deg,
// tibia 0.88 mm / 2.1 deg at the knee centre, speed-of-sound scale 0.982 for both (the tissue's
// 1512 m/s against the 1540 m/s assumed); without the scale 1.29 mm and 1.09 mm.
TEST_F(Register, FemurAndTibiaFromTheirCapturesMatchTheTruth) {
  for (const std::string bone : {"Femur", "Tibia"}) {
    const std::string out = dir_.file(bone + "ToCT.json");
    std::vector<std::string> a = args(bone, out);
    a.push_back("--fit-speed-of-sound");
    a.push_back("--json");
    const test::CommandResult r = runEchoreg(a);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto [knee, rotation] = error(out, bone);
    const core::TransformFile written = core::readTransformFile(out, bone, "CT");
    const double scale = written.extra.at("speed_of_sound_scale").get<double>();
    std::cout << bone << ": knee centre " << knee << " mm, rotation " << rotation << " deg, scale "
              << scale << ", " << written.extra.at("points_used") << " points used, "
              << written.extra.at("points_rejected") << " rejected, RMS "
              << written.extra.at("rms_mm") << " mm\n";
    EXPECT_LT(knee, 1.5) << bone;
    EXPECT_LT(rotation, 3.0) << bone;
    EXPECT_NEAR(scale, 1512.0 / 1540.0, 0.01) << bone;
    EXPECT_TRUE(written.extra.at("converged").get<bool>());
    // The tibia starts from its two malleoli: the result says the rotation about their line
    // rests on the surface; the femur has its hip centre as a third landmark.
    EXPECT_EQ(written.extra.at("warnings").size(), bone == "Tibia" ? 1u : 0u) << bone;
    EXPECT_EQ(written.extra.at("sources").at(0).at("sampling_frequency_source"), "header");
    EXPECT_EQ(written.extra.at("rms_over"), "inliers");
    EXPECT_GT(written.extra.at("points_used").get<int>(), 50);
    EXPECT_TRUE(fs::is_regular_file(dir_.file(bone + "ToCT.tfm")));
  }
}

// A capture whose header holds no sampling frequency (PLUS's Agilent recording holds none): the
// preset's 50 MHz is assumed and said, on stderr and in the result's warnings and sources, since
// every depth scales with it; --sampling-frequency gives it.
TEST_F(Register, AnAssumedSamplingFrequencyIsSaid) {
  core::Sequence capture = core::readSequence(path("captures/femur_ultrasound.igs.mha"));
  const double hz = *capture.acquisition.samplingFrequencyHz;
  capture.acquisition.samplingFrequencyHz.reset();
  const std::string stripped = dir_.file("femur_no_rate.igs.mha");
  core::writeSequence(capture, stripped);
  std::vector<std::string> a = args("Femur", dir_.file("FemurToCT.json"));
  *std::find(a.begin(), a.end(), path("captures/femur_ultrasound.igs.mha")) = stripped;
  const test::CommandResult assumed = runEchoreg(a);
  const std::string words = stripped +
                            " gives no sampling frequency and none was given: assumed 50 MHz; "
                            "every depth scales with it (--sampling-frequency)";
  EXPECT_NE(assumed.err.find("echoreg register: warning: " + words), std::string::npos)
      << assumed.err;
  const core::TransformFile written = core::readTransformFile(dir_.file("FemurToCT.json"));
  EXPECT_EQ(written.extra.at("warnings").at(0), words);
  EXPECT_EQ(written.extra.at("sources").at(0).at("sampling_frequency_source"), "assumed");

  a.insert(a.end(), {"--sampling-frequency", fmt::format("{:.17g}", hz)});
  const test::CommandResult given = runEchoreg(a);
  ASSERT_EQ(given.exitCode, 0) << given.err;
  EXPECT_EQ(given.err.find("assumed"), std::string::npos) << given.err;
  const core::TransformFile again = core::readTransformFile(dir_.file("FemurToCT.json"));
  EXPECT_EQ(again.extra.at("warnings").size(), 0u);
  EXPECT_EQ(again.extra.at("sources").at(0).at("sampling_frequency_source"), "given");
  EXPECT_EQ(again.extra.at("sources").at(0).at("sampling_frequency_hz"), hz);
}

// The hip centre (pivot of the femur's marker) as a third landmark: the start is the paired-point
// registration of the epicondyles and the hip (measured: knee 0.84 mm, FRE 1.9 mm).
TEST_F(Register, HipCentreMakesAPairedPointStart) {
  const std::string out = dir_.file("FemurToCT.json");
  std::vector<std::string> a = args("Femur", out);
  a.push_back("--fit-speed-of-sound");
  const test::CommandResult r = runEchoreg(a);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile result = core::readTransformFile(out, "Femur", "CT");
  EXPECT_EQ(result.extra.at("start").at("method"), "paired-point");
  EXPECT_EQ(result.extra.at("starts").get<int>(), 1);
  EXPECT_LT(error(out, "Femur").first, 1.5);
}

// The dissertation's femur from its two epicondyles alone (finding (b) in docs/registration.md):
// the rotation about their line is searched from 12 starts, and on this fixture two of them end
// 46 degrees apart at nearly the same cost. That is reported, not returned as a registration.
TEST_F(Register, FemurFromTwoLandmarksAloneIsReportedAmbiguous) {
  const std::string out = dir_.file("FemurToCT.json");
  const test::CommandResult r = runEchoreg(args("Femur", out, false));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("cannot tell the two poses apart"), std::string::npos) << r.err;
  const core::TransformFile written = core::readTransformFile(out, "Femur", "CT");
  EXPECT_FALSE(written.extra.at("converged").get<bool>());
}

TEST_F(Register, HybridWithTheStylusAndTheCsvInput) {
  // The detect CSV route: points in the Femur frame, then registered from the truth as start.
  const std::string csv = dir_.file("femur_points.csv");
  test::CommandResult r =
      runEchoreg({"detect", path("captures/femur_ultrasound.igs.mha"), "--out", csv, "--pose",
                  "ProbeToTracker", "--reference", "FemurToTracker", "--beam-to-probe",
                  path("truth/BeamToProbe.json"), "--history", "1"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string out = dir_.file("FemurToCT.json");
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", csv, "--initial",
                  path("truth/FemurToCT.json"), "--out", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_LT(error(out, "Femur").first, 2.0);
  // Hybrid: the same ultrasound plus the sharp stylus on the bone (0.5 mm tip, study manifest).
  std::vector<std::string> a = args("Femur", out);
  for (const char* extra : {"--stylus-points", "captures/femur_mechanical.igs.mha"})
    a.push_back(extra);
  a.back() = path(a.back());
  for (const char* extra : {"--stylus-tip-radius", "0.5", "--fit-speed-of-sound"})
    a.push_back(extra);
  r = runEchoreg(a);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile hybrid = core::readTransformFile(out, "Femur", "CT");
  // The simulator held the stylus on 12 points for 0.2 s each; on 4 of them the stylus is
  // hidden from the camera (INVALID), so 8 dwells at most (7 found: one hold jitters apart).
  EXPECT_GE(hybrid.extra.at("stylus_points").get<int>(), 6);
  EXPECT_LE(hybrid.extra.at("stylus_points").get<int>(), 8);
  const auto [knee, rotation] = error(out, "Femur");
  std::cout << "hybrid femur: knee centre " << knee << " mm, rotation " << rotation << " deg\n";
  EXPECT_LT(knee, 1.5);
}

// A CSV with the beams (ox..dz, depth_mm): 60 vertices of the truth model in the Femur frame,
// each seen from 15 mm along its own slanted direction; read back, the speed fit leaves the scale
// at 1.
TEST_F(Register, CsvWithBeamsFitsTheSpeedOfSound) {
  const core::TriangleMesh mesh = filters::readMesh(path("truth/femur.vtp"));
  Eigen::Isometry3d truth;
  truth.matrix() = core::readTransformFile(path("truth/FemurToCT.json")).matrix;
  const Eigen::Isometry3d toFemur = truth.inverse();
  const Eigen::Vector3d knee = knee_;
  std::ofstream csv(dir_.file("beams.csv"));
  csv << "x,y,z,ox,oy,oz,dx,dy,dz,depth_mm\n";
  csv.precision(17);
  int written = 0;
  for (std::size_t v = 0; v < mesh.vertices.size() && written < 60; v += 97) {
    if ((mesh.vertices[v] - knee).norm() > 80.0)
      continue;
    const Eigen::Vector3d p = toFemur * mesh.vertices[v];
    // Directions that differ from beam to beam: with parallel beams a speed-of-sound scale and a
    // translation along them would be the same thing (the registration reports that undetermined).
    const Eigen::Vector3d u = Eigen::Vector3d(0.3 + 0.4 * std::sin(0.7 * written),
                                              -0.5 + 0.4 * std::cos(1.3 * written), 0.81)
                                  .normalized();
    const Eigen::Vector3d o = p - 15.0 * u;
    csv << p.x() << ',' << p.y() << ',' << p.z() << ',' << o.x() << ',' << o.y() << ',' << o.z()
        << ',' << u.x() << ',' << u.y() << ',' << u.z() << ",15\n";
    ++written;
  }
  csv.close();
  ASSERT_EQ(written, 60);
  const std::string out = dir_.file("FemurToCT.json");
  const test::CommandResult r = runEchoreg(
      {"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("beams.csv"),
       "--initial", path("truth/FemurToCT.json"), "--fit-speed-of-sound", "--out", out});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const core::TransformFile result = core::readTransformFile(out, "Femur", "CT");
  EXPECT_NEAR(result.extra.at("speed_of_sound_scale").get<double>(), 1.0, 1e-6);
  EXPECT_LT(error(out, "Femur").first, 1e-3);
}

TEST_F(Register, RefusesBadInput) {
  const std::string out = dir_.file("bad.json");
  // Usage: no points, no start.
  test::CommandResult r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--initial",
                                      path("truth/FemurToCT.json"), "--out", out});
  EXPECT_EQ(r.exitCode, 2);
  // An open model.
  std::ofstream(dir_.file("open.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir_.file("p.csv")) << "x,y,z\n1,2,3\n4,5,6\n7,8,10\n";
  r = runEchoreg({"register", "--model", dir_.file("open.obj"), "--points", dir_.file("p.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("open.obj"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("boundary"), std::string::npos) << r.err;
  // Too few points, a bad number.
  std::ofstream(dir_.file("two.csv")) << "x,y,z\n1,2,3\n4,5,6\n";
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("two.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("at least 3"), std::string::npos) << r.err;
  std::ofstream(dir_.file("nan.csv")) << "x,y,z\n1,2,3\n4,five,6\n";
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("nan.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("line 3: column y is not a number"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // Points nowhere near the bone: written, but not converged, exit 1.
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("p.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("not converged"), std::string::npos) << r.err;
  ASSERT_TRUE(fs::exists(out));
  EXPECT_FALSE(core::readTransformFile(out).extra.at("converged").get<bool>());
  // Half a beam, and a beam direction that is not unit.
  std::ofstream(dir_.file("half.csv")) << "x,y,z,ox,oy,oz\n1,2,3,0,0,0\n";
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("half.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out + "2"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("not all of ox,oy,oz,dx,dy,dz,depth_mm"), std::string::npos) << r.err;
  std::ofstream(dir_.file("long.csv"))
      << "x,y,z,ox,oy,oz,dx,dy,dz,depth_mm\n0,0,20,0,0,0,0,0,2,10\n";
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("long.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", out + "2"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("line 2: beam direction dx,dy,dz is not unit"), std::string::npos) << r.err;
  // A speed-of-sound fit without beams.
  r = runEchoreg({"register", "--model", path("truth/femur.vtp"), "--points", dir_.file("p.csv"),
                  "--initial", path("truth/FemurToCT.json"), "--out", dir_.file("bad2.json"),
                  "--fit-speed-of-sound"});
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("beams"), std::string::npos) << r.err;
}

// Issue 15, item 2: every probe pose scaled by 1.01 used to register "converged" with a 5.8 mm
// error at the hip instead of 3.0; such poses are refused, naming the capture, frame and
// transform, and nothing is written.
TEST_F(Register, RefusesProbePosesThatAreNotRigid) {
  core::Sequence capture = core::readSequence(path("captures/femur_ultrasound.igs.mha"));
  int first = -1;
  for (std::size_t f = 0; f < capture.frames.size(); ++f) {
    core::TrackedTransform& probe = capture.frames[f].transforms.at("ProbeToTracker");
    probe.matrix.topLeftCorner<3, 3>() *= 1.01;
    if (first < 0 && probe.valid())
      first = static_cast<int>(f);
  }
  const std::string scaled = dir_.file("scaled.igs.mha");
  core::writeSequence(capture, scaled);
  const std::string out = dir_.file("FemurToCT.json");
  std::vector<std::string> a = args("Femur", out);
  a[6] = scaled;
  const test::CommandResult r = runEchoreg(a);
  EXPECT_EQ(r.exitCode, 1) << r.err;
  EXPECT_NE(r.err.find(scaled + ": frame " + std::to_string(first) +
                       ": its ProbeToTrackerTransform is not a rigid pose"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("a scale, shear or reflection"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir_.file("FemurToCT.tfm")));
}

}  // namespace
}  // namespace echoreg::simulation
