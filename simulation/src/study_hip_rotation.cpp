// The simulated study's hip centre capture: the femur rotated about the hip (study_detail.hpp).
#include "study_detail.hpp"

#include <cmath>

namespace echoreg::simulation::detail {

// ----- the femur rotated about the hip -----------------------------------------------------
void StudyBuilder::hipRotation() {
  core::Rng rng = core::Rng::derive(o_.seed, "hip");
  CaptureWriter writer("hip_rotation.igs.mha", scene_.tracker, o_.seed);
  const Eigen::Vector3d hip = specimen_.knee().hipCentre;
  double t = nextStart();
  const double start = t;
  const double phase = rng.uniform(0, 2 * kPi);
  for (int f = 0; f < sizes_.hipFrames; ++f, t += 1.0 / kFrameRateHz) {
    const double s = static_cast<double>(f) / sizes_.hipFrames;
    // Circumduction: flexion-extension and abduction-adduction of up to 25 degrees, two turns.
    const double a = 20.0 * kDeg * std::sin(2 * kPi * 2 * s + phase);
    const double b = 15.0 * kDeg * std::cos(2 * kPi * 2 * s + phase);
    Iso rotate = Iso::Identity();
    rotate.linear() = (Eigen::AngleAxisd(a, specimen_.knee().medialCt) *
                       Eigen::AngleAxisd(b, specimen_.knee().anteriorCt))
                          .toRotationMatrix();
    rotate.translation() = hip - rotate.linear() * hip;
    const Iso ctToTracker = scene_.ctToTracker0 * rotate;
    writer.addFrame(t, scene_.bonePoses(t - start, ctToTracker));
  }
  saveCapture(writer);
  manifest_["bones"]["femur"]["hip_rotation"] = "captures/" + writer.name();
}

}  // namespace echoreg::simulation::detail
