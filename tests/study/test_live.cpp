// `echoreg serve` of the fixture study's femur sweep into `echoreg live` on loopback: the session's
// result equals `echoreg register` on the same capture (0.01 mm at the knee centre, 0.01 deg),
// its recording holds every served frame, and the registration refined live ends on the same pose.
#include "cli_test_support.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/live/connection.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <future>
#include <iostream>

namespace echoreg::simulation {
namespace {

using test::runEchoreg;

TEST(Live, ServedFemurSweepRegistersAsRegisterDoes) {
  const std::string root = fixtureStudy();
  if (root.empty())
    GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  test::TempDir dir;
  const auto path = [&](const std::string& relative) { return root + "/" + relative; };
  const std::string hip = dir.file("hip.json");
  ASSERT_EQ(runEchoreg({"pivot", "--capture", path("captures/hip_rotation.igs.mha"), "--marker",
                        "FemurToTracker", "--out", hip})
                .exitCode,
            0);
  const std::vector<std::string> shared{"--model",
                                        path("truth/femur.vtp"),
                                        "--bone",
                                        "Femur",
                                        "--calibration",
                                        path("truth/BeamToProbe.json"),
                                        "--landmarks-ct",
                                        path("ct/landmarks.mrk.json"),
                                        "--landmarks-capture",
                                        path("captures/landmarks.igs.mha"),
                                        "--stylus-tip-to-stylus",
                                        path("truth/StylusTipToStylus.json"),
                                        "--landmark-labels",
                                        "medial_epicondyle,lateral_epicondyle",
                                        "--hip-centre",
                                        hip};
  const std::string capture = path("captures/femur_ultrasound.igs.mha");
  std::vector<std::string> reg{"register", "--capture", capture, "--out",
                               dir.file("register.json")};
  reg.insert(reg.end(), shared.begin(), shared.end());
  const test::CommandResult offline = runEchoreg(reg);
  ASSERT_EQ(offline.exitCode, 0) << offline.err;

  int port = 0;
  {
    live::Listener probe("127.0.0.1", 0);
    port = probe.port();
  }
  auto server = std::async(std::launch::async, [&] {
    return runEchoreg(
        {"serve", capture, "--port", std::to_string(port), "--rate", "max", "--wait", "20"});
  });
  std::vector<std::string> liveArgs{"live",
                                    "--connect",
                                    "127.0.0.1:" + std::to_string(port),
                                    "--record",
                                    dir.file("recorded.igs.mha"),
                                    "--session-json",
                                    dir.file("session.json"),
                                    "--idle-timeout",
                                    "10",
                                    "--out",
                                    dir.file("live.json")};
  liveArgs.insert(liveArgs.end(), shared.begin(), shared.end());
  const test::CommandResult live = runEchoreg(liveArgs);
  const test::CommandResult served = server.get();
  ASSERT_EQ(served.exitCode, 0) << served.err;
  ASSERT_EQ(live.exitCode, 0) << live.err;

  const core::TransformFile a = core::readTransformFile(dir.file("register.json"), "Femur", "CT");
  const core::TransformFile b = core::readTransformFile(dir.file("live.json"), "Femur", "CT");
  const nlohmann::json points = readJson(root + "/truth/points.json");
  Eigen::Vector4d knee(0, 0, 0, 1);
  for (int k = 0; k < 3; ++k)
    knee[k] = points.at("knee_centre_ct")[static_cast<std::size_t>(k)].get<double>();
  const Eigen::Matrix4d difference = b.matrix * a.matrix.inverse();
  const double kneeMm = (difference * knee - knee).head<3>().norm();
  const double angleDeg =
      Eigen::AngleAxisd(Eigen::Matrix3d(difference.topLeftCorner<3, 3>())).angle() * 180.0 / M_PI;
  const nlohmann::json session = readJson(dir.file("session.json"));
  std::cout << "live vs register: " << kneeMm << " mm at the knee, " << angleDeg << " deg; "
            << session.at("accepted") << " echoes accepted live, latency median "
            << session.at("latency_ms").at("median") << " ms, p99 "
            << session.at("latency_ms").at("p99") << " ms, " << session.at("registration_updates")
            << " updates (" << session.at("registration_runs") << " while the points came, "
            << session.at("registration_rate_hz") << " Hz), the longest fit "
            << session.at("registration_longest_fit_s") << " s\n";
  EXPECT_LT(kneeMm, 0.01);
  EXPECT_LT(angleDeg, 0.01);
  EXPECT_EQ(a.extra.at("points_used"), b.extra.at("points_used"));
  // live's result comes from the points it detected as the A-lines came, in register's format.
  const nlohmann::json& offlineSource = a.extra.at("sources").at(0);
  const nlohmann::json& liveSource = b.extra.at("sources").at(0);
  EXPECT_EQ(liveSource.at("detected"), "live");
  EXPECT_EQ(liveSource.at("frames"), offlineSource.at("frames"));
  EXPECT_EQ(liveSource.at("accepted"), offlineSource.at("accepted"));
  EXPECT_EQ(liveSource.at("speed_of_sound_mps"), offlineSource.at("speed_of_sound_mps"));
  EXPECT_EQ(b.extra.at("points").size(), a.extra.at("points").size());

  const core::Sequence original = core::readSequence(capture);
  const core::Sequence recorded = core::readSequence(dir.file("recorded.igs.mha"));
  ASSERT_EQ(recorded.frames.size(), original.frames.size());
  EXPECT_EQ(recorded.pixels, original.pixels);
  for (std::size_t f = 0; f < original.frames.size(); ++f)
    ASSERT_EQ(recorded.frames[f].timestampS, original.frames[f].timestampS) << "frame " << f;

  // The registration refined while the points came converged, on the final pose.
  ASSERT_TRUE(session.contains("live_registration")) << live.err;
  EXPECT_TRUE(session.at("live_registration").at("converged").get<bool>());
  const Eigen::Matrix4d liveMatrix = matrixFrom(session.at("live_registration").at("matrix"));
  const double liveKneeMm = ((liveMatrix * a.matrix.inverse()) * knee - knee).head<3>().norm();
  std::cout << "live registration (last update, " << session.at("live_registration").at("points")
            << " points) vs register: " << liveKneeMm << " mm at the knee\n";
  // The points found frame by frame are those of the offline chain here, so the fit is too.
  EXPECT_LT(liveKneeMm, 0.01);
}

}  // namespace
}  // namespace echoreg::simulation
