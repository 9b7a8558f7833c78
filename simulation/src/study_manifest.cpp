// The simulated study's manifest, root/study.json (docs/formats.md) (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/core/mesh_locator.hpp"

#include <cmath>
#include <optional>

namespace echoreg::simulation::detail {

void writeManifest(const std::string& root, const StudyOptions& options, const Knee& knee,
                   const StudyBuilder& builder) {
  const Scene& scene = builder.scene();
  nlohmann::json manifest = builder.manifestCaptures();
  manifest["format"] = "echoreg-study";
  manifest["version"] = 1;
  manifest["generator"] = {
      {"tool", "echoreg simulate"},
      {"preset", std::string(presetName(options.preset))},
      {"seed", options.seed},
      {"size", options.size == StudySize::Small ? "small" : "full"},
      {"standoff", std::string(standoffName(options.standoff))},
      {"flexion_deg", options.flexionDeg},
      {"water_temperature_c", options.waterTemperatureC},
      {"tissue_scale", options.tissueScale},
      {"fibula_in_tibia_model", options.fibulaInTibiaModel},
      {"femur_regions", options.femurRegions == FemurRegions::All ? "all" : "epicondyles"}};
  // Written only when asked for: a default study's manifest stays as it was.
  if (options.underSkinScale != 1.0)
    manifest["generator"]["soft_tissue_scale"] = options.underSkinScale;
  if (options.osteophyteMm > 0.0)
    manifest["generator"]["osteophyte_mm"] = options.osteophyteMm;
  if (options.probeFrequencyHz > 0.0)
    manifest["generator"]["probe_frequency_hz"] = options.probeFrequencyHz;
  if (options.adc == AdcFormat::Int16Left12)
    manifest["generator"]["adc"] = "int16-12bit";
  manifest["ct"] = {{"dicom", "ct/series"}, {"landmarks", "ct/landmarks.mrk.json"}};
  manifest["detection"] = {
      {"preset", options.preset == SpecimenKind::Phantom ? "calibration" : "default"},
      {"speed_of_sound_mps", scene.assumedSpeedMps}};
  manifest["truth"] = {{"transforms", "truth/transforms.json"},
                       {"shots", "truth/shots.csv"},
                       {"femur", "truth/femur.vtp"},
                       {"tibia", "truth/tibia.vtp"},
                       {"fibula", "truth/fibula.vtp"},
                       {"patella", "truth/patella.vtp"},
                       {"landmarks", "truth/landmarks.mrk.json"},
                       {"calibration", "truth/calibration.json"},
                       {"points", "truth/points.json"},
                       {"captures", "truth/captures"}};
  manifest["bones"]["femur"]["model"] = "truth/femur.vtp";
  manifest["bones"]["tibia"]["model"] = "truth/tibia.vtp";
  // Where a user would click to segment each bone from the CT (`echoreg study run --segment`):
  // a point on the bone's long axis 25 mm from the joint line, inside the knee's 1 mm group.
  auto seedOf = [&](BoneId id, double dz) -> std::optional<Eigen::Vector3d> {
    const Bone& bone = knee.bone(id);
    const Eigen::Vector3d d = bone.axisDistal;
    const Eigen::Vector3d axis = bone.axisProximal - bone.axisDistal;
    if (std::abs(axis.z()) < 1e-6)
      return std::nullopt;
    const double t = (knee.kneeCentre.z() + dz - d.z()) / axis.z();
    const Eigen::Vector3d seed = d + t * axis;
    if (!core::MeshLocator(bone.mesh).inside(seed))
      return std::nullopt;
    return seed;
  };
  if (const auto seed = seedOf(BoneId::Femur, 25.0)) {
    manifest["bones"]["femur"]["segment"] = {{"seeds_ct", {vectorJson(*seed)}}};
  }
  if (const auto seed = seedOf(BoneId::Tibia, -25.0)) {
    nlohmann::json seeds = {vectorJson(*seed)};
    if (options.fibulaInTibiaModel) {
      if (const auto fibula = seedOf(BoneId::Fibula, -25.0))
        seeds.push_back(vectorJson(*fibula));
    }
    manifest["bones"]["tibia"]["segment"] = {{"seeds_ct", seeds},
                                             {"with_fibula", options.fibulaInTibiaModel}};
  }
  writeText(root + "/study.json", manifest.dump(2) + "\n");
}

}  // namespace echoreg::simulation::detail
