#include "echoreg/core/error.hpp"
#include "echoreg/core/transform_file.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace echoreg::core {
namespace {

Eigen::Matrix4d someRigid() {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  m.translation() = Eigen::Vector3d(26.0, 1.2, 201.3);
  return m.matrix();
}

TEST(TransformFile, RoundTripKeepsMatrixFramesAndExtraKeys) {
  test::TempDir dir;
  TransformFile t;
  t.from = "Beam";
  t.to = "Probe";
  t.matrix = someRigid();
  t.extra["rms_mm"] = 0.42;
  const std::string tfm = writeTransformFile(dir.file("c.json"), t);
  EXPECT_EQ(tfm, dir.file("c.tfm"));
  const TransformFile back = readTransformFile(dir.file("c.json"), "Beam", "Probe");
  EXPECT_EQ(back.from, "Beam");
  EXPECT_EQ(back.to, "Probe");
  EXPECT_TRUE(back.matrix.isApprox(t.matrix, 1e-15));
  EXPECT_DOUBLE_EQ(back.extra.at("rms_mm").get<double>(), 0.42);
}

// The .tfm holds the inverse (ITK's resampling direction): parse it and compose.
TEST(TransformFile, SlicerTfmHoldsTheInverse) {
  const Eigen::Matrix4d m = someRigid();
  std::istringstream text(slicerTfmText(m));
  std::string line, parameters;
  while (std::getline(text, line)) {
    if (line.rfind("Parameters:", 0) == 0)
      parameters = line.substr(11);
  }
  std::istringstream values(parameters);
  Eigen::Matrix4d fromFile = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      values >> fromFile(r, c);
  }
  for (int r = 0; r < 3; ++r)
    values >> fromFile(r, 3);
  EXPECT_TRUE((fromFile * m).isApprox(Eigen::Matrix4d::Identity(), 1e-12));
  EXPECT_NE(slicerTfmText(m).find("AffineTransform_double_3_3"), std::string::npos);
}

TEST(TransformFile, AJsonNameEndingInTfmIsRefusedAndNothingWritten) {
  // Issue 15, item 9: the JSON and the .tfm beside it would be one file.
  test::TempDir dir;
  TransformFile t;
  t.matrix = someRigid();
  try {
    writeTransformFile(dir.file("pose.tfm"), t);
    ADD_FAILURE() << "a .tfm name was accepted for the JSON";
  } catch (const FileError& e) {
    EXPECT_EQ(e.path(), dir.file("pose.tfm"));
    EXPECT_NE(e.problem().find("ends in .tfm"), std::string::npos) << e.problem();
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(TransformFile, BadFilesNameTheFileAndTheProblem) {
  test::TempDir dir;
  auto refused = [&](const std::string& text, const std::string& expected,
                     const std::string& from = "", const std::string& to = "") {
    std::ofstream(dir.file("t.json")) << text;
    try {
      readTransformFile(dir.file("t.json"), from, to);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const FileError& e) {
      EXPECT_EQ(e.path(), dir.file("t.json"));
      EXPECT_NE(e.problem().find(expected), std::string::npos) << e.problem();
    }
  };
  refused("{", "not valid JSON");
  refused("[1, 2]", "JSON object");
  refused(R"({"matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]})", "4 rows of 4");
  refused(R"({"matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]})", "last row");
  refused(R"({"matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "not a rigid");
  refused(R"({"matrix": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "not a rigid");
  refused(R"({"matrix": [[1,0,0,"x"],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "finite number");
  refused(R"({"from": "Stylus", "matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
          "expected a Beam", "Beam", "Probe");
  EXPECT_THROW(readTransformFile(dir.file("missing.json")), FileError);
  // No partial output when the folder is missing.
  TransformFile t;
  EXPECT_THROW(writeTransformFile(dir.file("no/such/t.json"), t), FileError);
}

}  // namespace
}  // namespace echoreg::core
