// The simulated study's anatomical landmarks touched with the stylus, and their picks in the CT
// (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/core/mesh_locator.hpp"

#include <cmath>

namespace echoreg::simulation::detail {

// ----- anatomical landmarks touched with the stylus ----------------------------------------
void StudyBuilder::landmarks() {
  core::Rng rng = core::Rng::derive(o_.seed, "landmarks");
  CaptureWriter writer("landmarks.igs.mha", scene_.tracker, o_.seed);
  const Knee& knee = specimen_.knee();
  struct Spec {
    std::string name;
    BoneId bone;
    double sigmaMm;  // tangential localisation error (Yau et al.: epicondyles are the worst)
    bool throughSkin;
  };
  const std::vector<Spec> specs{{"medial_epicondyle", BoneId::Femur, 3.0, false},
                                {"lateral_epicondyle", BoneId::Femur, 3.0, false},
                                {"medial_malleolus", BoneId::Tibia, 1.5, true},
                                {"lateral_malleolus", BoneId::Fibula, 1.5, true}};
  double t = nextStart();
  const double start = t;
  nlohmann::json truth = nlohmann::json::array();
  std::vector<std::pair<std::string, Eigen::Vector3d>> truePoints;
  core::Rng picks = core::Rng::derive(o_.seed, "ct-picks");
  for (const Spec& spec : specs) {
    const Bone& bone = knee.bone(spec.bone);
    const Eigen::Vector3d landmark = bone.landmarks.at(spec.name);
    std::size_t boneIndex = 0;
    for (std::size_t b = 0; b < knee.bones.size(); ++b) {
      if (knee.bones[b].id == spec.bone)
        boneIndex = b;
    }
    const core::ClosestPoint c = specimen_.locator(boneIndex).closest(landmark);
    Eigen::Vector3d normal =
        (landmark - c.point).norm() > 1e-3
            ? Eigen::Vector3d((landmark - c.point).normalized())
            : core::triangleNormal(specimen_.locator(boneIndex).mesh(), c.triangle);
    // The user feels for the landmark: off by a tangential error.
    const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
    const Eigen::Vector3d guess =
        c.point + rng.normal(0, spec.sigmaMm) * e1 + rng.normal(0, spec.sigmaMm) * e2;
    const core::ClosestPoint onBone = specimen_.locator(boneIndex).closest(guess);
    Eigen::Vector3d touched = onBone.point + kSharpTipRadiusMm * normal;
    if (spec.throughSkin && o_.preset == SpecimenKind::Cadaver) {
      // Percutaneous: the tip rests on the skin above the bone.
      for (double d = 0.0; d < 40.0; d += 0.2) {
        if (specimen_.legField(onBone.point + d * normal) > 0) {
          touched = onBone.point + (d + kSharpTipRadiusMm) * normal;
          break;
        }
      }
    }
    const Eigen::Vector3d axis =
        tiltAbout(normal, rng.uniform(5, 30) * kDeg, rng.uniform(0, 2 * kPi)) * -normal;
    const int first = static_cast<int>(writer.frames());
    SmoothNoise tremor(rng, 0.15, 6.0, 12.0);
    for (int f = 0; f < sizes_.landmarkDwellFrames; ++f, t += 1.0 / kFrameRateHz) {
      addStylusFrame(writer, t, start, touched + tremor.at(t), axis, 0.0);
    }
    const int last = static_cast<int>(writer.frames()) - 1;
    // Moving to the next landmark: the tip lifted 40-80 mm away, one second.
    const Eigen::Vector3d away = touched + rng.uniform(40, 80) * normal;
    for (int f = 0; f < 100; ++f, t += 1.0 / kFrameRateHz) {
      const double s = std::sin(kPi * f / 100.0);
      addStylusFrame(writer, t, start, touched + s * (away - touched), axis, 0.0);
    }
    truth.push_back({{"name", spec.name},
                     {"bone", std::string(boneName(spec.bone))},
                     {"true_ct", vectorJson(landmark)},
                     {"touched_tip_centre_ct", vectorJson(touched)},
                     {"first_frame", first},
                     {"last_frame", last},
                     {"localisation_sigma_mm", spec.sigmaMm}});
    truePoints.push_back({spec.name, landmark});
    // What a user picks on the CT: within a voxel or so of the true landmark.
    ctLandmarks_.push_back(
        {spec.name, landmark + Eigen::Vector3d(picks.normal(0, 0.7), picks.normal(0, 0.7),
                                               picks.normal(0, 0.7))});
  }
  const Eigen::Vector3d hip = knee.hipCentre;
  truePoints.push_back({"hip_centre", hip});
  ctLandmarks_.push_back(
      {"hip_centre",
       hip + Eigen::Vector3d(picks.normal(0, 0.5), picks.normal(0, 0.5), picks.normal(0, 0.5))});
  saveCapture(writer);
  manifest_["landmarks"]["capture"] = "captures/" + writer.name();
  nlohmann::json order = nlohmann::json::array();
  for (const Spec& spec : specs)
    order.push_back(spec.name);
  manifest_["landmarks"]["order"] = order;
  manifest_["landmarks"]["ct"] = "ct/landmarks.mrk.json";
  landmarkTruth_ = truth;
  trueLandmarks_ = truePoints;
}

}  // namespace echoreg::simulation::detail
