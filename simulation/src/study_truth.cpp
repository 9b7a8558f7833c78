// The simulated study's truth: root/truth (transforms, models, landmarks, calibration, points
// and the shots' truth) (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/filters/mesh_io.h"

#include <fmt/format.h>

#include <cmath>
#include <tuple>

namespace echoreg::simulation::detail {

void StudyBuilder::writeShotsCsv() {
  std::string main = "capture,frame,bone,should_accept,true_depth_mm,true_speed_of_sound_mps\n";
  std::string detail =
      "capture,frame,region,bone,coupled,incidence_deg,skin_depth_mm,echo_to_clutter\n";
  auto number = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.4f}", v) : std::string();
  };
  for (const ShotRow& row : shotRows_) {
    const ShotTruth& s = row.truth;
    main += fmt::format("{},{},{},{},{},{}\n", row.capture, row.frame, s.bone,
                        s.shouldAccept ? 1 : 0, number(s.depthMm), number(s.speedMps));
    detail += fmt::format("{},{},{},{},{},{},{},{}\n", row.capture, row.frame, s.region, s.bone,
                          s.coupled ? 1 : 0, number(s.incidenceDeg), number(s.skinDepthMm),
                          number(s.snr));
  }
  writeText(root_ + "/truth/shots.csv", main);
  writeText(root_ + "/truth/shots_detail.csv", detail);
}

void writeTruth(const std::string& root, const StudyOptions& options, const Knee& knee,
                const StudyBuilder& builder) {
  const Scene& scene = builder.scene();
  nlohmann::json transforms = {{"BeamToProbe", matrixJson(scene.beamToProbe)},
                               {"FemurToCT", matrixJson(scene.femurToCt)},
                               {"TibiaToCT", matrixJson(scene.tibiaToCt)},
                               {"StylusTipToStylus", matrixJson(scene.stylusTipToStylus)}};
  writeText(root + "/truth/transforms.json", transforms.dump(2) + "\n");
  // The same transforms as single transform files (docs/formats.md "Transforms"), which the
  // commands take with --beam-to-probe, --stylus-tip-to-stylus, --initial.
  const std::vector<std::tuple<std::string, std::string, std::string, Iso>> singles{
      {"BeamToProbe.json", "Beam", "Probe", scene.beamToProbe},
      {"StylusTipToStylus.json", "StylusTip", "Stylus", scene.stylusTipToStylus},
      {"FemurToCT.json", "Femur", "CT", scene.femurToCt},
      {"TibiaToCT.json", "Tibia", "CT", scene.tibiaToCt}};
  for (const auto& [file, from, to, matrix] : singles) {
    const nlohmann::json single = {{"from", from}, {"to", to}, {"matrix", matrixJson(matrix)}};
    writeText(root + "/truth/" + file, single.dump(2) + "\n");
  }
  for (const Bone& bone : knee.bones) {
    core::TriangleMesh mesh = bone.mesh;
    if (bone.id == BoneId::Tibia && options.fibulaInTibiaModel) {
      const core::TriangleMesh& fibula = knee.bone(BoneId::Fibula).mesh;
      const int offset = static_cast<int>(mesh.vertices.size());
      mesh.vertices.insert(mesh.vertices.end(), fibula.vertices.begin(), fibula.vertices.end());
      for (auto tri : fibula.triangles) {
        for (int& i : tri)
          i += offset;
        mesh.triangles.push_back(tri);
      }
    }
    filters::writeMesh(root + "/truth/" + std::string(boneName(bone.id)) + ".vtp", mesh);
  }
  writeMarkups(root + "/truth/landmarks.mrk.json", builder.trueLandmarks_);
  nlohmann::json calibration = {
      {"sphere_centre_tracker_mm", vectorJson(builder.sphereCentreTracker_)},
      {"sessions", builder.calibrationSessions_},
      {"sphere_radius_mm", kSphereRadiusMm},
      {"stylus_tip_radius_mm", kCalibrationTipRadiusMm},
      {"water_temperature_c", options.waterTemperatureC},
      {"water_speed_of_sound_mps", scene.waterSpeedMps},
      {"assumed_speed_of_sound_mps", scene.assumedSpeedMps}};
  writeText(root + "/truth/calibration.json", calibration.dump(2) + "\n");
  nlohmann::json extra = {{"landmarks", builder.landmarkTruth_},
                          {"hip_centre_ct", vectorJson(knee.hipCentre)},
                          {"knee_centre_ct", vectorJson(knee.kneeCentre)},
                          {"ankle_centre_ct", vectorJson(knee.ankleCentre)},
                          {"mechanical_points", builder.mechanicalTruth_}};
  writeText(root + "/truth/points.json", extra.dump(1) + "\n");
}

}  // namespace echoreg::simulation::detail
