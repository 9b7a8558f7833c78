#include "echoreg/core/error.hpp"
#include "echoreg/core/markups.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace {

using echoreg::core::Markup;
using echoreg::core::MarkupPoint;

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(Markups, RoundTripKeepsLabelsPositionsAndTypes) {
  echoreg::test::TempDir dir;
  Markup curve;
  curve.type = "ClosedCurve";
  curve.name = "femur slice 12";
  curve.points = {{"a", {1.5, -2.25, 3}}, {"b", {4, 5, -6.125}}};
  Markup fiducials;
  fiducials.points = {{"medial_epicondyle", {-40.5, 10, -470}}};
  echoreg::core::writeMarkups(dir.file("m.mrk.json"), {curve, fiducials});
  const auto read = echoreg::core::readMarkups(dir.file("m.mrk.json"));
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].type, "ClosedCurve");
  EXPECT_EQ(read[0].name, "femur slice 12");
  ASSERT_EQ(read[0].points.size(), 2u);
  EXPECT_EQ(read[0].points[1].label, "b");
  EXPECT_EQ(read[0].points[1].positionLps, Eigen::Vector3d(4, 5, -6.125));
  const auto points = echoreg::core::readMarkupPoints(dir.file("m.mrk.json"));
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].label, "medial_epicondyle");
}

TEST(Markups, RasFilesAreConvertedToLps) {
  echoreg::test::TempDir dir;
  writeText(dir.file("ras.mrk.json"),
            R"({"markups": [{"type": "Fiducial", "coordinateSystem": "RAS",
    "controlPoints": [{"label": "p", "position": [10, -20, 30]},
                      {"label": "skip", "position": [0, 0, 0], "positionStatus": "undefined"}]}]})");
  const auto points = echoreg::core::readMarkupPoints(dir.file("ras.mrk.json"));
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].positionLps, Eigen::Vector3d(-10, 20, 30));
}

TEST(Markups, BadFilesNameTheFileAndTheProblem) {
  echoreg::test::TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{not json", "not a JSON"},
      {R"({"points": []})", "no \"markups\" array"},
      {R"({"markups": [{"coordinateSystem": "IJK", "controlPoints": []}]})", "coordinate system"},
      {R"({"markups": [{"controlPoints": [{"position": [1, 2]}]}]})", "no position of 3 numbers"},
      {R"({"markups": [{"controlPoints": [{"position": [1, "a", 2]}]}]})", "not numeric"},
      {R"({"markups": [{"type": "Fiducial", "controlPoints": []}]})", "holds no landmark"},
  };
  int n = 0;
  for (const auto& [text, problem] : cases) {
    const std::string path = dir.file("bad" + std::to_string(n++) + ".mrk.json");
    writeText(path, text);
    try {
      echoreg::core::readMarkupPoints(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const echoreg::core::FileError& e) {
      EXPECT_EQ(e.path(), path);
      EXPECT_NE(std::string(e.what()).find(problem), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(echoreg::core::readMarkups(dir.file("missing.mrk.json")), echoreg::core::FileError);
}

}  // namespace
