// The simulated study's pivot calibration of the stylus tip (study_detail.hpp).
#include "study_detail.hpp"

#include <cmath>

namespace echoreg::simulation::detail {

// ----- pivot calibration of the stylus tip --------------------------------------------
void StudyBuilder::pivot() {
  core::Rng rng = core::Rng::derive(o_.seed, "pivot");
  CaptureWriter writer("stylus_pivot.igs.mha", scene_.tracker, o_.seed);
  const Eigen::Vector3d tip(-60.0, 40.0, 1450.0);  // a divot on the table, camera frame
  const Eigen::Vector3d up = -Eigen::Vector3d(0.0, 1.0, 0.25).normalized();
  double t = nextStart();
  const double phase = rng.uniform(0, 2 * kPi);
  for (int f = 0; f < sizes_.pivotFrames; ++f, t += 1.0 / kFrameRateHz) {
    // Circles of 15-35 degrees about the vertical, two turns.
    const double s = static_cast<double>(f) / sizes_.pivotFrames;
    const double tilt = (25.0 + 10.0 * std::sin(2 * kPi * s * 3)) * kDeg;
    const double azimuth = phase + 2 * kPi * 2 * s;
    const Eigen::Vector3d axis =
        tiltAbout(up, tilt, azimuth) * -up;  // from the marker toward the tip
    const Eigen::Matrix3d r = facingPoint(axis, tip, Eigen::Vector3d::Zero(), 0.0);
    const Eigen::Vector3d position = tip - r * scene_.stylusTipToStylus.translation();
    writer.addFrame(t, {{"StylusToTracker", fromRotationTranslation(r, position), &scene_.stylus}});
  }
  saveCapture(writer);
  manifest_["calibration"]["pivot_capture"] = "captures/" + writer.name();
}

}  // namespace echoreg::simulation::detail
