// The simulated study's transducer calibration: a steel sphere in a water bath, touched with the
// stylus and shot at with the probe, one session per bath set up (study_detail.hpp).
#include "study_detail.hpp"

#include <cmath>
#include <optional>

namespace echoreg::simulation::detail {

namespace {

// The first hit of a ray with a sphere (centre c, radius r), t > 0.
std::optional<double> raySphere(const Eigen::Vector3d& o, const Eigen::Vector3d& u,
                                const Eigen::Vector3d& c, double r) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(u);
  const double disc = b * b - (oc.squaredNorm() - r * r);
  if (disc < 0)
    return std::nullopt;
  const double t = -b - std::sqrt(disc);
  if (t <= 0)
    return std::nullopt;
  return t;
}

}  // namespace

// ----- calibration: a steel sphere in a water bath ---------------------------------------
// Calibration session `index` (1, 2, ...): the bath set up anew, the same probe.
void StudyBuilder::calibration(int index) {
  const std::string suffix = index > 1 ? "_" + std::to_string(index) : std::string();
  core::Rng rng = core::Rng::derive(o_.seed, "calibration", static_cast<std::uint64_t>(index - 1));
  // The bath in the camera's frame: 1.5 m in front, below the line of sight.
  const Eigen::Vector3d centre(35.0 + rng.normal(0, 5), 60.0 + rng.normal(0, 5),
                               1500.0 + rng.normal(0, 20));
  const Eigen::Vector3d up =
      -Eigen::Vector3d(0.0, 1.0, 0.25).normalized();  // toward the camera side
  if (index == 1)
    sphereCentreTracker_ = centre;
  nlohmann::json session = {{"sphere_centre_tracker_mm", vectorJson(centre)}};
  // The sphere has no tracker: everything here is in the camera's frame (camera at the origin).
  auto faceCamera = [](const Eigen::Vector3d& axis, const Eigen::Vector3d& at, double roll) {
    return facingPoint(axis, at, Eigen::Vector3d::Zero(), roll);
  };
  auto onCap = [&](double maxAngle) {  // a direction within maxAngle of `up`
    const double cosMax = std::cos(maxAngle);
    const double c = rng.uniform(cosMax, 1.0);
    const double phi = rng.uniform(0, 2 * kPi);
    const Eigen::Vector3d a = up.unitOrthogonal(), b = up.cross(a);
    return Eigen::Vector3d(c * up + std::sqrt(1 - c * c) * (std::cos(phi) * a + std::sin(phi) * b));
  };

  // Stylus points on the sphere: the tip's centre at R + tip radius.
  {
    CaptureWriter writer("calibration_sphere_stylus" + suffix + ".igs.mha", scene_.tracker,
                         o_.seed);
    double t = nextStart();
    for (int p = 0; p < sizes_.spherePoints; ++p) {
      const Eigen::Vector3d n = onCap(75.0 * kDeg);
      const Eigen::Vector3d tip = centre + (kSphereRadiusMm + kCalibrationTipRadiusMm) * n;
      const Eigen::Vector3d axis =
          (tiltAbout(n, rng.uniform(0, 25) * kDeg, rng.uniform(0, 2 * kPi)) * -n);
      for (int f = 0; f < sizes_.framesPerSpherePoint; ++f, t += 1.0 / kFrameRateHz) {
        const Eigen::Vector3d wobble(rng.normal(0, 0.4), rng.normal(0, 0.4), 0.0);
        const Eigen::Matrix3d r =
            faceCamera(axis, tip, rng.normal(0, 0.1)) *
            Eigen::AngleAxisd(wobble.norm() * kDeg, wobble.normalized().norm() > 0
                                                        ? wobble.normalized()
                                                        : Eigen::Vector3d::UnitX())
                .toRotationMatrix();
        const Eigen::Vector3d position = tip - r * scene_.stylusTipToStylus.translation();
        writer.addFrame(
            t, {{"StylusToTracker", fromRotationTranslation(r, position), &scene_.stylus}});
      }
    }
    saveCapture(writer);
    session["sphere_capture"] = "captures/" + writer.name();
  }

  // A-line shots at the sphere from many directions, the probe moved smoothly between poses.
  {
    CaptureWriter writer("calibration_shots" + suffix + ".igs.mha", scene_.tracker, o_.seed);
    std::vector<PendingShot> shots;
    std::vector<Iso> beamPoses;
    // A good session: the operator moves on every ~0.1 s, aims off the centre on every side as
    // far as the echo survives (5.5 mm off is 12.5 degrees of incidence) and varies the
    // distance (18-32 mm, near the 25 mm focus): the lateral offset is only seen through the
    // sphere's curvature.
    const int keys = std::max(2, sizes_.calibrationShots / 10);
    std::vector<Iso> keyPoses;
    for (int k = 0; k < keys; ++k) {
      const Eigen::Vector3d n = onCap(50.0 * kDeg);
      const Eigen::Vector3d u = -n;
      const double offset = 5.5 * std::sqrt(rng.uniform());  // uniform over a disc
      const double azimuth = rng.uniform(0, 2 * kPi);
      const Eigen::Vector3d side = u.unitOrthogonal();
      const Eigen::Vector3d lateral = std::cos(azimuth) * side + std::sin(azimuth) * u.cross(side);
      const double distance = rng.uniform(18.0, 32.0);
      const Eigen::Vector3d origin = centre + offset * lateral - (kSphereRadiusMm + distance) * u;
      keyPoses.push_back(
          fromRotationTranslation(faceCamera(u, origin, rng.normal(0, 0.15)), origin));
    }
    const int perKey = std::max(1, sizes_.calibrationShots / keys);
    double t = nextStart();
    for (int k = 0; k + 1 < keys; ++k) {
      const Eigen::Quaterniond qa(keyPoses[static_cast<std::size_t>(k)].linear());
      const Eigen::Quaterniond qb(keyPoses[static_cast<std::size_t>(k + 1)].linear());
      for (int f = 0; f < perKey; ++f, t += 1.0 / kFrameRateHz) {
        // Hold for 60 % of the interval, then move to the next pose.
        const double s = std::clamp((static_cast<double>(f) / perKey - 0.6) / 0.4, 0.0, 1.0);
        const double w = s * s * (3 - 2 * s);
        Iso beam = Iso::Identity();
        beam.linear() = qa.slerp(w, qb).toRotationMatrix();
        beam.translation() = (1 - w) * keyPoses[static_cast<std::size_t>(k)].translation() +
                             w * keyPoses[static_cast<std::size_t>(k + 1)].translation();
        const Iso probeToTracker = beam * scene_.beamToProbe.inverse();
        writer.addFrame(t, {{"ProbeToTracker", probeToTracker, &scene_.probe}});
        shots.push_back({beam.translation(), beam.linear().col(2), true, Tissue::Water, "sphere"});
      }
    }
    std::vector<ShotTruth> truths;
    simulateShots(
        writer.measured(), writer.name(), shots, scene_,
        [&](const PendingShot& shot, BeamPath& path, ShotTruth& truth) {
          const auto hit = raySphere(shot.origin, shot.direction, centre, kSphereRadiusMm);
          if (!hit || *hit > 70.0) {
            path.layers = {{Tissue::Water, 1e6, 0.0}};
            return;
          }
          const Eigen::Vector3d point = shot.origin + *hit * shot.direction;
          const Eigen::Vector3d normal = (point - centre).normalized();
          const double incidence =
              std::acos(std::min(1.0, std::abs(normal.dot(shot.direction)))) / kDeg;
          path.layers = {{Tissue::Water, *hit, incidence}, {Tissue::Steel, 1e6, 0.0}};
          truth.bone = "sphere";
          truth.depthMm = *hit;
          truth.incidenceDeg = incidence;
        },
        truths, progress_, "calibration shots");
    saveCapture(writer, kCalibrationAssumedSpeedMps);
    recordShots(writer.name(), truths);
    session["capture"] = "captures/" + writer.name();
  }
  if (index == 1) {
    manifest_["calibration"]["sphere_capture"] = session["sphere_capture"];
    manifest_["calibration"]["capture"] = session["capture"];
  }
  manifest_["calibration"]["sessions"].push_back(
      {{"sphere_capture", session["sphere_capture"]}, {"capture", session["capture"]}});
  calibrationSessions_.push_back(session);
  manifest_["calibration"]["sphere_radius_mm"] = kSphereRadiusMm;
  manifest_["calibration"]["stylus_tip_radius_mm"] = kCalibrationTipRadiusMm;
  manifest_["calibration"]["speed_of_sound_mps"] = kCalibrationAssumedSpeedMps;
  // The window covers the sphere's echo at 18-32 mm and excludes the face-to-sphere multiple
  // (at twice the distance, from 36 mm on), as the dissertation's processing window did.
  manifest_["calibration"]["window_mm"] = {14.0, 34.0};
  // The dissertation's initial guess came from a CMM: the front face of the housing, a few mm
  // from the true beam origin.
  const Eigen::Vector3d initial =
      scene_.beamToProbe.translation() + Eigen::Vector3d(0.6, -0.4, -4.5);
  manifest_["calibration"]["initial_beam_to_probe_mm"] = vectorJson(initial);
  manifest_["calibration"]["stylus_tip_to_stylus"] = "truth/transforms.json#StylusTipToStylus";
}

}  // namespace echoreg::simulation::detail
