// The simulated study's ultrasound sweeps over one bone through the skin (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/core/mesh_locator.hpp"

#include <cmath>

namespace echoreg::simulation::detail {

namespace {

struct Region {
  std::string name;
  BoneId bone;
  Segment segment;
  double h0, h1;          // mm from the knee centre along the segment
  double theta0, theta1;  // degrees, 0 anterior, +90 lateral, -90 medial
  double weight;
};

std::vector<Region> ultrasoundRegionsUnclamped(BoneId bone, FemurRegions femurRegions) {
  // The areas the dissertation's Fig. 4.8 (c, d) shows reachable through the skin.
  if (bone == BoneId::Femur) {
    std::vector<Region> regions{
        {"medial_epicondyle", BoneId::Femur, Segment::Thigh, 12, 45, -115, -65, 0.3},
        {"lateral_epicondyle", BoneId::Femur, Segment::Thigh, 12, 45, 65, 115, 0.3}};
    if (femurRegions == FemurRegions::All) {
      regions.insert(regions.begin(), {"anterior_distal_femur", BoneId::Femur, Segment::Thigh, 60,
                                       130, -40, 40, 0.4});
    }
    return regions;
  }
  return {{"tibial_tubercle", BoneId::Tibia, Segment::Shank, 22, 42, -20, 20, 0.15},
          {"anteromedial_tibia", BoneId::Tibia, Segment::Shank, 45, 130, -75, -20, 0.35},
          {"medial_proximal_tibia", BoneId::Tibia, Segment::Shank, 8, 40, -115, -70, 0.2},
          {"lateral_proximal_tibia", BoneId::Tibia, Segment::Shank, 8, 45, 55, 110, 0.3}};
}

// The regions within `maxFromKneeMm` of the knee centre: the sweeps stay where the CT's knee
// group scans (a point beyond the scan has no model to match).
std::vector<Region> ultrasoundRegions(BoneId bone, FemurRegions femurRegions,
                                      double maxFromKneeMm) {
  std::vector<Region> regions;
  for (Region r : ultrasoundRegionsUnclamped(bone, femurRegions)) {
    r.h1 = std::min(r.h1, maxFromKneeMm);
    if (r.h1 - r.h0 >= 5.0)
      regions.push_back(r);
  }
  return regions;
}

std::string boneLabel(int boneIndex, const Knee& knee) {
  if (boneIndex < 0)
    return "none";
  return std::string(boneName(knee.bones[static_cast<std::size_t>(boneIndex)].id));
}

}  // namespace

// ----- ultrasound sweeps over one bone ---------------------------------------------------
// Registration `index` (1, 2, ...): the dissertation did five per bone and specimen.
void StudyBuilder::ultrasound(BoneId bone, int index, StudySummary& summary) {
  const std::string name = std::string(boneName(bone)) + "_ultrasound" +
                           (index > 1 ? "_" + std::to_string(index) : std::string()) + ".igs.mha";
  core::Rng rng = core::Rng::derive(o_.seed, "sweep:" + name);
  CaptureWriter writer(name, scene_.tracker, o_.seed);
  const bool phantom = o_.preset == SpecimenKind::Phantom;
  const Tissue standoffTissue = phantom                           ? Tissue::Water
                                : o_.standoff == Standoff::GelPad ? Tissue::GelPad
                                                                  : Tissue::Water;
  SmoothNoise tilt(rng, phantom ? 8.0 : 6.0, 0.05, 0.6);  // over water the operator aims less
  SmoothNoise tremor(rng, 0.15, 6.0, 12.0);
  SmoothNoise standoffDrift(rng, 1.0, 0.05, 0.3);
  SmoothNoise rollDrift(rng, 8.0, 0.05, 0.3);
  // Coupling: a two-state chain per frame (lost, regained) for each standoff.
  double lose = 0.0, regain = 1.0;
  if (!phantom) {
    if (o_.standoff == Standoff::GloveFinger)
      lose = 0.003, regain = 0.1;
    if (o_.standoff == Standoff::GelPad)
      lose = 0.01, regain = 0.05;
    // A bare flat face on curved skin: air gaps a third of the time (the dissertation found
    // signals without a standoff unusable, section 6.3.1).
    if (o_.standoff == Standoff::None)
      lose = 0.02, regain = 0.04;
  }
  const double nominalStandoff = phantom ? 22.0 : (o_.standoff == Standoff::None ? 0.0 : 10.0);

  // The knee group scans 80 mm (small) or 100 mm (full) either side of the joint line.
  const double scannedFromKneeMm = (o_.size == StudySize::Small ? 80.0 : 100.0) - 5.0;
  const std::vector<Region> regions = ultrasoundRegions(bone, o_.femurRegions, scannedFromKneeMm);
  std::size_t targetIndex = 0;
  for (std::size_t b = 0; b < specimen_.knee().bones.size(); ++b) {
    if (specimen_.knee().bones[b].id == bone)
      targetIndex = b;
  }
  double weightSum = 0.0;
  for (const Region& r : regions)
    weightSum += r.weight;
  std::vector<PendingShot> shots;
  double t = nextStart();
  const double start = t;
  bool coupled = true;
  for (const Region& region : regions) {
    const int frames =
        static_cast<int>(std::lround(sizes_.framesPerBone * region.weight / weightSum));
    // Spot by spot, as the dissertation's assistant collected a few dozen points per bone:
    // move to a new spot of the region in 0.2 s, hold it for 0.3 s while the system listens.
    constexpr int kMoveFrames = 20, kHoldFrames = 30;
    auto spot = [&]() {
      return Eigen::Vector2d(rng.uniform(region.h0, region.h1),
                             rng.uniform(region.theta0, region.theta1));
    };
    Eigen::Vector2d from = spot(), to = from;
    for (int f = 0; f < frames; ++f, t += 1.0 / kFrameRateHz) {
      const int phase = f % (kMoveFrames + kHoldFrames);
      if (phase == 0) {
        from = to;
        to = spot();
      }
      const double s = std::min(1.0, static_cast<double>(phase) / kMoveFrames);
      const Eigen::Vector2d at = from + (s * s * (3.0 - 2.0 * s)) * (to - from);
      const Eigen::Vector3d jitter = tremor.at(t - start);
      const double h = at.x() + jitter.x();
      const double theta = at.y() * kDeg + jitter.y() / 40.0;
      const Iso ctToTracker = scene_.ctToTracker(t - start);
      std::optional<SurfacePoint> surface = specimen_.surfacePoint(region.segment, h, theta);
      if (!surface)
        continue;
      if (rng.chance(coupled ? lose : regain))
        coupled = !coupled;
      // The operator watches the signal and tilts the probe toward the bone's normal: the beam
      // aims between the skin's normal and the normal of the bone beneath, then wanders.
      core::ClosestPoint below = specimen_.locator(targetIndex).closest(surface->point);
      for (std::size_t b = 0; b < specimen_.knee().bones.size(); ++b) {
        if (b == targetIndex)
          continue;
        const core::ClosestPoint other =
            specimen_.locator(b).closest(surface->point, below.distance);
        if (other.triangle >= 0 && other.distance < below.distance)
          below = other;
      }
      Eigen::Vector3d aim = surface->normal;
      if (below.distance > 1e-6) {
        aim = (0.5 * surface->normal + 0.5 * (surface->point - below.point).normalized())
                  .normalized();
      }
      const Eigen::Vector3d tiltNow = tilt.at(t - start);
      const Eigen::Vector3d e1 = aim.unitOrthogonal();
      const Eigen::Vector3d e2 = aim.cross(e1);
      const Eigen::Vector3d rotation = (tiltNow.x() * e1 + tiltNow.y() * e2) * kDeg;
      Eigen::Vector3d beamDirection = -aim;
      if (rotation.norm() > 0)
        beamDirection = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()) * beamDirection;
      const double standoff =
          std::max(0.0, nominalStandoff +
                            standoffDrift.at(t - start).x() * (nominalStandoff > 0 ? 1.0 : 0.0));
      // Without a standoff the face sits on the skin, pressing it by a fraction of a mm.
      const Eigen::Vector3d origin =
          surface->point - (standoff > 0 ? standoff : -0.3) * beamDirection;
      const Eigen::Matrix3d r =
          scene_.facingCamera(beamDirection, origin, rollDrift.at(t - start).x() * kDeg);
      const Iso beamToCt = fromRotationTranslation(r, origin);
      const Iso probeToTracker = ctToTracker * beamToCt * scene_.beamToProbe.inverse();
      std::vector<TrackedPose> poses = scene_.bonePoses(t - start, ctToTracker);
      poses.insert(poses.begin(), {"ProbeToTracker", probeToTracker, &scene_.probe});
      writer.addFrame(t, poses);
      shots.push_back({origin, beamDirection, coupled, standoffTissue, region.name});
    }
  }
  const double recordDepth =
      scene_.receiver.samples / scene_.receiver.samplingFrequencyHz * 1.7e6 / 2.0 +
      5.0;  // beyond what the fastest path reaches
  std::vector<ShotTruth> truths;
  simulateShots(
      writer.measured(), name, shots, scene_,
      [&](const PendingShot& shot, BeamPath& path, ShotTruth& truth) {
        BeamTrace trace =
            specimen_.traceBeam(shot.origin, shot.direction, shot.standoff, recordDepth);
        truth.bone = boneLabel(trace.boneIndex, specimen_.knee());
        if (trace.boneIndex >= 0) {
          truth.depthMm = trace.boneDepthMm;
          truth.incidenceDeg = trace.incidenceDeg;
        }
        truth.skinDepthMm = trace.skinDepthMm;
        path = std::move(trace.path);
        if (!shot.coupled) {
          // An air gap between the standoff and the skin: the beam stops there.
          const double gap =
              path.layers.empty() ? 5.0 : std::max(1.0, path.layers.front().lengthMm);
          path.layers = {{shot.standoff, gap, 0.0}, {Tissue::Air, 1e6, 0.0}};
          path.fasciaDepthsMm.clear();
        }
      },
      truths, progress_, std::string(boneName(bone)) + " ultrasound");
  saveCapture(writer, scene_.assumedSpeedMps);
  recordShots(name, truths);
  // Shares per region.
  for (const Region& region : regions) {
    RegionShare share;
    share.capture = name;
    share.region = region.name;
    for (const ShotTruth& truth : truths) {
      if (truth.region != region.name)
        continue;
      ++share.frames;
      share.shouldAccept += truth.shouldAccept ? 1 : 0;
      for (std::size_t b = 0; b < specimen_.knee().bones.size() && b < 4; ++b) {
        if (truth.bone == boneName(specimen_.knee().bones[b].id))
          ++share.onBone[b];
      }
    }
    summary.regions.push_back(share);
  }
  summary.ultrasoundFrames += static_cast<int>(truths.size());
  manifest_["bones"][std::string(boneName(bone))]["ultrasound"].push_back("captures/" + name);
}

}  // namespace echoreg::simulation::detail
