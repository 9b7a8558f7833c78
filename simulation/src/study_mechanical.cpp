// The simulated study's mechanical probe on the bone through the incision, the reference
// registration's points (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/core/mesh_locator.hpp"

#include <cmath>

namespace echoreg::simulation::detail {

// ----- mechanical probe on the bone through the incision --------------------------------
void StudyBuilder::mechanical(BoneId bone, bool blunt) {
  const std::string name =
      std::string(boneName(bone)) + (blunt ? "_mechanical_blunt.igs.mha" : "_mechanical.igs.mha");
  core::Rng rng = core::Rng::derive(o_.seed, "mechanical:" + name);
  CaptureWriter writer(name, scene_.tracker, o_.seed);
  const Knee& knee = specimen_.knee();
  std::size_t boneIndex = 0;
  for (std::size_t b = 0; b < knee.bones.size(); ++b) {
    if (knee.bones[b].id == bone)
      boneIndex = b;
  }
  const core::MeshLocator& locator = specimen_.locator(boneIndex);
  // Fig. 4.8 (a, b): the distal femur's anterior and condylar surfaces and the proximal tibia's
  // anterior rim, reachable through a medial parapatellar incision.
  const Segment segment = bone == BoneId::Femur ? Segment::Thigh : Segment::Shank;
  const double h0 = bone == BoneId::Femur ? 0.0 : 5.0, h1 = bone == BoneId::Femur ? 45.0 : 35.0;
  const double tipRadius = blunt ? kBluntTipRadiusMm : kSharpTipRadiusMm;
  const double cartilage = blunt ? kCartilageMm : 0.0;
  double t = nextStart();
  const double start = t;
  nlohmann::json points = nlohmann::json::array();
  for (int p = 0; p < sizes_.mechanicalPoints; ++p) {
    const double h = rng.uniform(h0, h1);
    const double theta = rng.uniform(-70.0, 70.0) * kDeg;
    const Eigen::Vector3d axis = specimen_.axisPoint(segment, h);
    const Eigen::Vector3d out = specimen_.radialDirection(segment, theta);
    const auto hit = locator.firstHit(axis + 150.0 * out, -out, 150.0);
    if (!hit)
      continue;
    const Eigen::Vector3d contact = hit->point + (cartilage + tipRadius) * hit->normal;
    const Eigen::Vector3d stylusAxis =
        tiltAbout(hit->normal, rng.uniform(0, 30) * kDeg, rng.uniform(0, 2 * kPi)) * -hit->normal;
    for (int f = 0; f < sizes_.framesPerMechanicalPoint; ++f, t += 1.0 / kFrameRateHz) {
      addStylusFrame(writer, t, start, contact, stylusAxis, rng.normal(0, 0.05));
    }
    points.push_back(
        {{"surface_ct", vectorJson(hit->point)}, {"tip_centre_ct", vectorJson(contact)}});
  }
  saveCapture(writer);
  const std::string key = blunt ? "mechanical_blunt" : "mechanical";
  manifest_["bones"][std::string(boneName(bone))][key] = "captures/" + name;
  manifest_["bones"][std::string(boneName(bone))][key + "_tip_radius_mm"] = tipRadius;
  mechanicalTruth_[name] = points;
}

}  // namespace echoreg::simulation::detail
