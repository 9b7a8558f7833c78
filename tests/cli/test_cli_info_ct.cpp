// `echoreg info` on a CT: a DICOM folder or file.
#include "cli_test_support.hpp"
#include "echoreg/simulation/ct.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

namespace echoreg::cli {
namespace {

using test::runEchoreg;

// 2 slices at 5 mm, 3 at 1 mm (after a gap), 4 x 3 pixels of 0.5 mm; HU from -1024 to 3071.
void writeSmallSeries(const std::string& folder) {
  core::CtImage v = core::axialCtImage(4, 3, 0.5, {-1.0, 2.0}, {{"g", {10, 15, 30, 31, 32}, 1.0}});
  v.hu.assign(60, 0);
  v.hu[0] = -1024;
  v.hu[59] = 3071;
  simulation::DicomSeriesInfo info;
  info.uidSeed = 3;
  simulation::writeDicomSeries(folder, v, info);
}

TEST(CliInfoCt, JsonHasTheDocumentedKeys) {
  test::TempDir dir;
  const std::string folder = dir.file("ct");
  writeSmallSeries(folder);
  const auto result = runEchoreg({"info", folder, "--json"});
  ASSERT_EQ(result.exitCode, 0) << result.err;
  const auto info = nlohmann::json::parse(result.out);
  std::vector<std::string> keys;  // in the printed order
  const auto ordered = nlohmann::ordered_json::parse(result.out);
  for (const auto& item : ordered.items())
    keys.push_back(item.key());
  EXPECT_EQ(keys,
            (std::vector<std::string>{"kind", "dimensions", "spacing_mm", "origin_mm", "direction",
                                      "hu_range", "slice_groups", "series_instance_uid", "modality",
                                      "folder", "files", "first_file", "last_file", "warnings"}));
  EXPECT_EQ(info["kind"], "ct");
  EXPECT_EQ(info["dimensions"], nlohmann::json({4, 3, 5}));
  EXPECT_EQ(info["spacing_mm"][0], 0.5);
  EXPECT_EQ(info["spacing_mm"][1], 0.5);
  EXPECT_NEAR(info["spacing_mm"][2].get<double>(), 1.0, 1e-9);  // the smallest step
  EXPECT_EQ(info["origin_mm"], nlohmann::json({-1.0, 2.0, 10.0}));
  EXPECT_EQ(info["direction"], nlohmann::json({1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}));
  EXPECT_EQ(info["hu_range"], nlohmann::json({-1024, 3071}));
  ASSERT_EQ(info["slice_groups"].size(), 2U);
  EXPECT_EQ(info["slice_groups"][0]["count"], 2);
  EXPECT_NEAR(info["slice_groups"][0]["spacing_mm"].get<double>(), 5.0, 1e-9);
  EXPECT_EQ(info["slice_groups"][1]["count"], 3);
  EXPECT_NEAR(info["slice_groups"][1]["spacing_mm"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(info["series_instance_uid"], simulation::derivedDicomUid(3, "series"));
  EXPECT_EQ(info["files"], 5);

  // One file of it is a one-slice CT; the text output says the same things.
  const auto single = runEchoreg({"info", folder + "/IM000003.dcm", "--json"});
  ASSERT_EQ(single.exitCode, 0) << single.err;
  EXPECT_EQ(nlohmann::json::parse(single.out)["dimensions"], nlohmann::json({4, 3, 1}));
  const auto text = runEchoreg({"info", folder});
  ASSERT_EQ(text.exitCode, 0) << text.err;
  EXPECT_NE(text.out.find("4 x 3 pixels, 5 slices"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("slice groups: 2 at 5 mm; 3 at 1 mm;"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("HU range -1024 to 3071"), std::string::npos) << text.out;

  // --series picks by UID; an unknown one is refused naming the folder.
  const auto wrong = runEchoreg({"info", folder, "--series", "1.2.3"});
  EXPECT_EQ(wrong.exitCode, 1);
  EXPECT_NE(wrong.err.find(folder), std::string::npos) << wrong.err;
  EXPECT_NE(wrong.err.find("has no series 1.2.3"), std::string::npos) << wrong.err;
}

TEST(CliInfoCt, BadFolderExitsOneNamingIt) {
  test::TempDir dir;
  const std::string folder = dir.file("ct");
  writeSmallSeries(folder);
  std::filesystem::remove(folder + "/IM000004.dcm");  // 30, 31, (32 gone): fine, still groups
  std::filesystem::copy_file(folder + "/IM000003.dcm", folder + "/again.dcm");
  const auto result = runEchoreg({"info", folder, "--json"});
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_NE(result.err.find("echoreg info: " + folder + ": duplicate slice position"),
            std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("again.dcm"), std::string::npos) << result.err;

  std::filesystem::create_directory(dir.file("empty"));
  const auto empty = runEchoreg({"info", dir.file("empty")});
  EXPECT_EQ(empty.exitCode, 1);
  EXPECT_NE(empty.err.find(dir.file("empty") + ": is a directory with no DICOM image"),
            std::string::npos)
      << empty.err;
}

}  // namespace
}  // namespace echoreg::cli
