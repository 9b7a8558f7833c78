// Checks of a simulated study read from its files only (shared by the study tests).
#pragma once

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/filters/mesh_io.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace echoreg::simulation {

/// The study the ctest fixture simulated (or ECHOREG_TEST_STUDY), "" when it is not there.
inline std::string fixtureStudy() {
  const char* over = std::getenv("ECHOREG_TEST_STUDY");
  const std::string root = over != nullptr ? over : ECHOREG_FIXTURE_STUDY_DIR;
  std::ifstream manifest(root + "/study.json");
  return manifest.good() ? root : std::string();
}

inline Eigen::Matrix4d matrixFrom(const nlohmann::json& rows) {
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      m(r, c) = rows.at(static_cast<std::size_t>(r)).at(static_cast<std::size_t>(c)).get<double>();
  }
  return m;
}

inline nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

struct ShotRow {
  std::string capture;
  int frame = 0;
  std::string bone;
  bool shouldAccept = false;
  double depthMm = 0.0;
  double speedMps = 0.0;
};

inline std::vector<ShotRow> readShots(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "capture,frame,bone,should_accept,true_depth_mm,true_speed_of_sound_mps");
  std::vector<ShotRow> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ','))
      cells.push_back(cell);
    while (cells.size() < 6)
      cells.emplace_back();
    ShotRow row;
    row.capture = cells[0];
    row.frame = std::stoi(cells[1]);
    row.bone = cells[2];
    row.shouldAccept = cells[3] == "1";
    row.depthMm = cells[4].empty() ? std::nan("") : std::stod(cells[4]);
    row.speedMps = cells[5].empty() ? std::nan("") : std::stod(cells[5]);
    rows.push_back(row);
  }
  return rows;
}

struct TruthCheck {
  int checked = 0;
  double worstMm = 0.0;
};

/// For every frame that should be accepted (bones, not the sphere), the true depth turned into a
/// point with the noise-free transforms and the true BoneToCT: its distance to the true surface.
inline TruthCheck checkTrueDepths(const std::string& root) {
  const nlohmann::json transforms = readJson(root + "/truth/transforms.json");
  const Eigen::Matrix4d beamToProbe = matrixFrom(transforms.at("BeamToProbe"));
  const std::map<std::string, Eigen::Matrix4d> boneToCt{
      {"femur", matrixFrom(transforms.at("FemurToCT"))},
      {"tibia", matrixFrom(transforms.at("TibiaToCT"))},
      {"fibula", matrixFrom(transforms.at("TibiaToCT"))},
      {"patella", matrixFrom(transforms.at("FemurToCT"))}};
  std::map<std::string, core::MeshLocator> surfaces;
  for (const char* bone : {"femur", "tibia", "fibula", "patella"}) {
    surfaces.emplace(bone, core::MeshLocator(filters::readMesh(root + "/truth/" + bone + ".vtp")));
  }
  std::map<std::string, core::Sequence> truthCaptures;
  TruthCheck check;
  for (const ShotRow& shot : readShots(root + "/truth/shots.csv")) {
    if (!shot.shouldAccept || shot.bone == "sphere")
      continue;
    if (!truthCaptures.count(shot.capture)) {
      truthCaptures[shot.capture] = core::readSequence(root + "/truth/captures/" + shot.capture);
    }
    const core::SequenceFrame& frame =
        truthCaptures[shot.capture].frames.at(static_cast<std::size_t>(shot.frame));
    const std::string marker =
        shot.bone == "femur" || shot.bone == "patella" ? "FemurToTracker" : "TibiaToTracker";
    const Eigen::Matrix4d probeToTracker = frame.transforms.at("ProbeToTracker").matrix;
    const Eigen::Matrix4d boneToTracker = frame.transforms.at(marker).matrix;
    const Eigen::Vector4d p = boneToCt.at(shot.bone) * boneToTracker.inverse() * probeToTracker *
                              beamToProbe * Eigen::Vector4d(0, 0, shot.depthMm, 1);
    check.worstMm = std::max(check.worstMm, surfaces.at(shot.bone).closest(p.head<3>()).distance);
    ++check.checked;
  }
  return check;
}

}  // namespace echoreg::simulation
