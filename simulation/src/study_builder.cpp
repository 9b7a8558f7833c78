// The simulated study's theatre (camera, leg pose, trackers), the captures' frames and files,
// and the protocol in order (study_detail.hpp).
#include "study_detail.hpp"

#include "echoreg/core/atomic_file.hpp"

#include <fmt/format.h>

#include <cmath>

namespace echoreg::simulation::detail {

Iso fromRotationTranslation(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  Iso m = Iso::Identity();
  m.linear() = r;
  m.translation() = t;
  return m;
}

nlohmann::json matrixJson(const Iso& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c)
      row.push_back(m.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json vectorJson(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

void writeText(const std::string& path, const std::string& text) {
  core::AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

// Writes a 3D Slicer markups file (.mrk.json) of named points, LPS.
void writeMarkups(const std::string& path,
                  const std::vector<std::pair<std::string, Eigen::Vector3d>>& points) {
  nlohmann::json controlPoints = nlohmann::json::array();
  int id = 1;
  for (const auto& [label, p] : points) {
    controlPoints.push_back({{"id", std::to_string(id++)},
                             {"label", label},
                             {"position", vectorJson(p)},
                             {"orientation", {-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0}},
                             {"selected", true},
                             {"locked", false},
                             {"visibility", true},
                             {"positionStatus", "defined"}});
  }
  nlohmann::json doc = {
      {"@schema",
       "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/"
       "Schema/markups-schema-v1.0.3.json#"},
      {"markups",
       {{{"type", "Fiducial"},
         {"coordinateSystem", "LPS"},
         {"coordinateUnits", "mm"},
         {"locked", false},
         {"labelFormat", "%N-%d"},
         {"controlPoints", controlPoints}}}}};
  writeText(path, doc.dump(2) + "\n");
}

Eigen::Matrix3d facingPoint(const Eigen::Vector3d& axis, const Eigen::Vector3d& at,
                            const Eigen::Vector3d& camera, double roll) {
  const Eigen::Vector3d z = axis.normalized();
  const Eigen::Vector3d toCamera = (camera - at).normalized();
  Eigen::Vector3d across = toCamera - toCamera.dot(z) * z;
  if (across.norm() < 1e-6)
    across = z.unitOrthogonal();
  const Eigen::Vector3d x = -across.normalized();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return r * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void applyWaterSpeed(BeamPath& path, double waterSpeedMps) {
  for (PathLayer& layer : path.layers) {
    if (layer.tissue == Tissue::Water)
      layer.speedMps = waterSpeedMps;
  }
}

double meanSpeed(const BeamPath& path, double depthMm) {
  double time = 0.0, length = 0.0;
  for (const PathLayer& layer : path.layers) {
    const double l = std::min(layer.lengthMm, depthMm - length);
    if (l <= 0)
      break;
    const double c = layer.speedMps > 0 ? layer.speedMps : properties(layer.tissue).speedMps;
    time += l / c;
    length += l;
  }
  return time > 0 ? length / time : 0.0;
}

Sizes sizesFor(const StudyOptions& o) {
  Sizes s = o.size == StudySize::Small ? Sizes{800, 300, 20, 15, 400, 500, 15, 20, 80, 1.2}
                                       : Sizes{3000, 1000, 40, 30, 1000, 1500, 40, 30, 150, 0.8};
  if (o.framesPerBone > 0)
    s.framesPerBone = o.framesPerBone;
  return s;
}

StudyBuilder::StudyBuilder(const StudyOptions& options, const Specimen& specimen, std::string root,
                           const StudyProgress& progress)
    : o_(options),
      specimen_(specimen),
      scene_(options, specimen),
      root_(std::move(root)),
      progress_(progress),
      sizes_(sizesFor(options)) {
  setUpScene();
}

void StudyBuilder::writeCaptures(StudySummary& summary) {
  for (int c = 1; c <= o_.calibrations; ++c)
    calibration(c);
  pivot();
  for (BoneId bone : {BoneId::Femur, BoneId::Tibia}) {
    for (int r = 1; r <= o_.registrations; ++r)
      ultrasound(bone, r, summary);
  }
  for (BoneId bone : {BoneId::Femur, BoneId::Tibia}) {
    mechanical(bone, false);
    mechanical(bone, true);
  }
  landmarks();
  if (o_.preset == SpecimenKind::Cadaver)
    hipRotation();
  writeShotsCsv();
  summary.captures = static_cast<int>(captureFiles_.size());
}

void StudyBuilder::setUpScene() {
  const Knee& knee = specimen_.knee();
  core::Rng rng = core::Rng::derive(o_.seed, "scene");
  scene_.assumedSpeedMps = o_.assumedSpeedOfSoundMps > 0
                               ? o_.assumedSpeedOfSoundMps
                               : (o_.preset == SpecimenKind::Phantom ? 1450.0 : 1540.0);
  scene_.waterSpeedMps = waterSpeedOfSoundMps(o_.waterTemperatureC);
  // The probe and the front end, the same for every A-line capture.
  if (o_.probeFrequencyHz > 0.0)
    scene_.transducer.centreFrequencyHz = o_.probeFrequencyHz;
  if (o_.adc == AdcFormat::Int16Left12) {
    // An in-vivo A-mode front end; its DC offset is one per study.
    core::Rng frontEnd = core::Rng::derive(o_.seed, "front-end");
    useInt16FrontEnd(scene_.transducer, scene_.receiver, frontEnd.uniform(50.0, 110.0));
  }
  const Eigen::Vector3d superior = (knee.hipCentre - knee.kneeCentre).normalized();
  const Eigen::Vector3d lateral = -knee.medialCt;
  // The camera stands 1.6 m from the knee, anterior, above and to the lateral side.
  scene_.cameraCt =
      knee.kneeCentre + 1600.0 * (knee.anteriorCt + 0.35 * superior + 0.45 * lateral).normalized();
  const Eigen::Vector3d z = (knee.kneeCentre - scene_.cameraCt).normalized();
  const Eigen::Vector3d x = z.cross(superior).normalized();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  const Iso trackerToCt = fromRotationTranslation(r, scene_.cameraCt);
  scene_.ctToTracker0 = trackerToCt.inverse();
  // Bone markers on pins: 150 mm from the knee along each bone, 70 mm out toward the camera.
  auto boneMarkerPose = [&](const Eigen::Vector3d& axisPoint) {
    const Eigen::Vector3d toCamera = (scene_.cameraCt - axisPoint).normalized();
    const Eigen::Vector3d position = axisPoint + 70.0 * toCamera;
    const Eigen::Vector3d mz = (scene_.cameraCt - position).normalized();
    const Eigen::Vector3d mx = superior.cross(mz).normalized();
    Eigen::Matrix3d m;
    m.col(0) = mx;
    m.col(1) = mz.cross(mx);
    m.col(2) = mz;
    return fromRotationTranslation(m, position);
  };
  scene_.femurToCt = boneMarkerPose(knee.kneeCentre + 150.0 * superior);
  scene_.tibiaToCt =
      boneMarkerPose(knee.kneeCentre + 150.0 * (knee.ankleCentre - knee.kneeCentre).normalized());
  // BeamToProbe like the dissertation's Table 5.1: the beam along the probe's long axis, its
  // origin 26 mm beside the marker's axis and 201 mm along it.
  scene_.beamToProbe = Iso::Identity();
  scene_.beamToProbe.translation() =
      Eigen::Vector3d(26.0, 1.2, 201.3) +
      Eigen::Vector3d(rng.normal(0, 0.3), rng.normal(0, 0.3), rng.normal(0, 0.3));
  scene_.stylusTipToStylus = Iso::Identity();
  scene_.stylusTipToStylus.translation() = Eigen::Vector3d(-0.8, 1.1, 161.7);
  core::Rng sway = core::Rng::derive(o_.seed, "leg-sway");
  const double swayScale = o_.preset == SpecimenKind::Cadaver ? 1.0 : 0.0;  // a phantom is clamped
  scene_.swayTranslation = SmoothNoise(sway, 0.4 * swayScale, 0.05, 0.4);
  scene_.swayRotation = SmoothNoise(sway, 0.2 * swayScale, 0.05, 0.4);
}

// One frame of a stylus capture: the tip's centre at `tipCt` with its long axis along
// `axisCt`, turned toward the camera (then `roll` rad), and the bone markers, at time t.
void StudyBuilder::addStylusFrame(CaptureWriter& writer, double t, double start,
                                  const Eigen::Vector3d& tipCt, const Eigen::Vector3d& axisCt,
                                  double roll) {
  const Iso ctToTracker = scene_.ctToTracker(t - start);
  const Eigen::Matrix3d r = scene_.facingCamera(axisCt, tipCt, roll);
  const Iso stylusToCt =
      fromRotationTranslation(r, tipCt - r * scene_.stylusTipToStylus.translation());
  std::vector<TrackedPose> poses = scene_.bonePoses(t - start, ctToTracker);
  poses.insert(poses.begin(), {"StylusToTracker", ctToTracker * stylusToCt, &scene_.stylus});
  writer.addFrame(t, poses);
}

// `assumedSpeedMps` > 0: an A-line capture recorded with that speed of sound in its header.
void StudyBuilder::saveCapture(CaptureWriter& writer, double assumedSpeedMps) {
  core::Sequence& measured = writer.measured();
  core::Sequence& truth = writer.truth();
  if (assumedSpeedMps > 0.0) {
    measured.acquisition.samplingFrequencyHz = scene_.receiver.samplingFrequencyHz;
    measured.acquisition.delayS = scene_.receiver.delayS;
    measured.acquisition.speedOfSoundMps = assumedSpeedMps;
    const double fc = scene_.transducer.centreFrequencyHz;
    measured.acquisition.transducer =
        fc == 9e6 ? std::string("Olympus V312 9 MHz 6.35 mm F25 (simulated)")
                  : fmt::format("single element {:g} MHz 6.35 mm F25 (simulated)", fc * 1e-6);
    if (o_.probeFrequencyHz > 0.0)
      measured.acquisition.transducerFrequencyHz = fc;
  }
  measured.extraHeader.push_back({"EchoregSimulated", "True"});
  truth.extraHeader.push_back({"EchoregSimulated", "True"});
  truth.extraHeader.push_back({"EchoregNoiseFree", "True"});
  core::writeSequence(measured, capturePath(writer.name()));
  core::writeSequence(truth, root_ + "/truth/captures/" + writer.name());
  captureFiles_.push_back(writer.name());
}

double StudyBuilder::nextStart() {
  const double start = clock_;
  clock_ += 600.0;  // each capture ten minutes after the previous one's start
  return start;
}

void StudyBuilder::recordShots(const std::string& capture, const std::vector<ShotTruth>& truths) {
  for (std::size_t i = 0; i < truths.size(); ++i)
    shotRows_.push_back({capture, i, truths[i]});
}

}  // namespace echoreg::simulation::detail
