#include "cli_test_support.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace echoreg::cli {
namespace {

using test::runEchoreg;

TEST(CliInfo, AgilentRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(capture, "plus/Agilent_Scope_Recording_DP310.igs.nrrd");
  const auto result = runEchoreg({"info", capture, "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  const auto info = nlohmann::json::parse(result.out);
  EXPECT_EQ(info["frames"], 150);
  EXPECT_EQ(info["samples_per_frame"], 11350);
  EXPECT_EQ(info["element_type"], "int16");
  ASSERT_EQ(info["transforms"].size(), 1U);
  EXPECT_EQ(info["transforms"][0]["name"], "ZOffsetToTrackerTransform");
  EXPECT_EQ(info["transforms"][0]["valid_frames"], 150);
  EXPECT_DOUBLE_EQ(info["time_span_s"][0].get<double>(), 3.114000000000033);
  EXPECT_EQ(info["header"]["ultrasound image orientation"], "MFA");
}

TEST(CliInfo, TrackerOnlyLandmarkRecording) {
  ECHOREG_REQUIRE_SHARED_FILE(capture,
                              "plus/EightLandmarkPointsTrackedForPhantomRegistration.igs.mha");
  const auto result = runEchoreg({"info", capture, "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  const auto info = nlohmann::json::parse(result.out);
  EXPECT_EQ(info["frames"], 1000);
  EXPECT_EQ(info["samples_per_frame"], 0);
  EXPECT_EQ(info["element_type"], "none");
  ASSERT_EQ(info["transforms"].size(), 2U);
  for (const auto& t : info["transforms"])
    EXPECT_EQ(t["valid_frames"], 1000);
  EXPECT_NEAR(info["duration_s"].get<double>(), 347.0668714287492 - 280.4611428572264, 1e-9);

  const auto text = runEchoreg({"info", capture});
  EXPECT_NE(text.out.find("tracker-only capture: 1000 frames"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("StylusToTrackerTransform: 1000 of 1000 frames valid"),
            std::string::npos);
}

}  // namespace
}  // namespace echoreg::cli
