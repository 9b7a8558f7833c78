#include "echoreg/simulation/study.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/filters/MeshIO.h"
#include "echoreg/simulation/ct.hpp"
#include "echoreg/simulation/pulse_echo.hpp"
#include "echoreg/simulation/tracking.hpp"
#include "temporary_folder.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <thread>
#include <tuple>

namespace echoreg::simulation {

namespace fs = std::filesystem;
using Iso = Eigen::Isometry3d;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kFrameRateHz = 100.0;
constexpr double kSphereRadiusMm = 25.4;
constexpr double kCalibrationTipRadiusMm = 1.5;  // the acustar probe's spherical tip
constexpr double kSharpTipRadiusMm = 0.5;
constexpr double kBluntTipRadiusMm = 3.0;
constexpr double kCartilageMm = 2.0;  // under the blunt tip on the articular surface
// The calibration software assumes distilled water at a cool temperature, as the dissertation's
// did (section 4.2.2: 1450 m/s), whatever the bath's true temperature.
constexpr double kCalibrationAssumedSpeedMps = 1450.0;

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
  AtomicFile file(path);
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

// ---------------------------------------------------------------------------------------------
// The theatre: camera, leg pose, trackers, and the captures' frames.

struct TrackedPose {
  std::string name;  // e.g. "ProbeToTracker"
  Iso truth;
  const MarkerGeometry* marker;
};

class CaptureWriter {
 public:
  CaptureWriter(std::string name, const OpticalTracker& tracker, std::uint64_t seed)
      : name_(std::move(name)), tracker_(tracker), seed_(seed) {}

  const std::string& name() const { return name_; }

  void addFrame(double timeS, const std::vector<TrackedPose>& poses) {
    SequenceFrame noisy, exact;
    noisy.timestampS = timeS;
    exact.timestampS = timeS;
    core::Rng rng = core::Rng::derive(seed_, "tracking:" + name_, measured_.frames.size());
    for (const TrackedPose& pose : poses) {
      const Measurement m = tracker_.measure(pose.truth, *pose.marker, rng, true);
      TrackedTransform t;
      t.matrix = m.markerToTracker.matrix();
      t.status = m.valid ? "OK" : "INVALID";
      noisy.transforms[pose.name] = t;
      TrackedTransform e;
      e.matrix = pose.truth.matrix();
      e.status = tracker_.visible(pose.truth, *pose.marker) ? "OK" : "INVALID";
      exact.transforms[pose.name] = e;
    }
    measured_.frames.push_back(std::move(noisy));
    truth_.frames.push_back(std::move(exact));
  }

  Sequence& measured() { return measured_; }
  Sequence& truth() { return truth_; }
  std::size_t frames() const { return measured_.frames.size(); }

 private:
  std::string name_;
  const OpticalTracker& tracker_;
  std::uint64_t seed_;
  Sequence measured_;
  Sequence truth_;
};

// A probe (or stylus) frame whose long axis (z) is `axis`, rolled about it so that its marker
// (facing -x) looks at `camera`, then `roll` radians more. All in one frame.
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

struct Scene {
  const StudyOptions& options;
  const Specimen& specimen;
  OpticalTracker tracker;
  Eigen::Vector3d cameraCt;
  Iso ctToTracker0 = Iso::Identity();
  Iso femurToCt = Iso::Identity(), tibiaToCt = Iso::Identity();
  Iso beamToProbe = Iso::Identity(), stylusTipToStylus = Iso::Identity();
  MarkerGeometry probe = probeMarker(), stylus = stylusMarker();
  MarkerGeometry femurMarker = boneMarker("Femur"), tibiaMarker = boneMarker("Tibia");
  SmoothNoise swayTranslation, swayRotation;
  double assumedSpeedMps = 1540.0;
  double waterSpeedMps = 1482.0;
  Transducer transducer;
  Receiver receiver;

  Scene(const StudyOptions& o, const Specimen& s)
      : options(o), specimen(s), tracker(TrackerNoise{}, o.seed) {}

  // The leg's pose in the camera's frame at time t: fixed, with a slow sway of the held leg.
  Iso ctToTracker(double timeS) const {
    const Eigen::Vector3d r = swayRotation.at(timeS) * kDeg;
    Iso sway = Iso::Identity();
    const Eigen::Vector3d pivot = specimen.knee().kneeCentre;
    sway.linear() = (Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()))
                        .toRotationMatrix();
    sway.translation() = pivot - sway.linear() * pivot + swayTranslation.at(timeS);
    return ctToTracker0 * sway;
  }

  std::vector<TrackedPose> bonePoses(double /*timeS*/, const Iso& ctToTrackerNow) const {
    return {{"FemurToTracker", ctToTrackerNow * femurToCt, &femurMarker},
            {"TibiaToTracker", ctToTrackerNow * tibiaToCt, &tibiaMarker}};
  }

  Eigen::Matrix3d facingCamera(const Eigen::Vector3d& axisCt, const Eigen::Vector3d& atCt,
                               double rollNoise) const {
    return facingPoint(axisCt, atCt, cameraCt, rollNoise);
  }
};

// Time of flight and mean speed of a path with the bath's water speed.
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

struct ShotTruth {
  std::string region;
  std::string bone = "none";
  bool shouldAccept = false;
  double depthMm = std::numeric_limits<double>::quiet_NaN();
  double speedMps = std::numeric_limits<double>::quiet_NaN();
  bool coupled = true;
  double incidenceDeg = std::numeric_limits<double>::quiet_NaN();
  double skinDepthMm = std::numeric_limits<double>::quiet_NaN();
  double snr = 0.0;
};

// One shot to compute: the beam in CT coordinates (or the sphere's frame) and its medium.
struct PendingShot {
  Eigen::Vector3d origin, direction;
  bool coupled = true;
  Tissue standoff = Tissue::Water;
  std::string region;
};

// Acoustic shots of a capture, traced and simulated in parallel (each frame its own random
// stream), appended to the capture's pixels in frame order.
template <class TraceFn>
void simulateShots(Sequence& capture, const std::string& name,
                   const std::vector<PendingShot>& shots, const Scene& scene, TraceFn trace,
                   std::vector<ShotTruth>& truths, const StudyProgress& progress,
                   const std::string& step) {
  const int samples = scene.receiver.samples;
  const bool wide = scene.receiver.adc == AdcFormat::Int16Left12;
  capture.elementType = wide ? ElementType::Int16 : ElementType::UInt8;
  capture.frameSize = {samples, 1};
  const std::size_t frameBytes = static_cast<std::size_t>(samples) * (wide ? 2 : 1);
  capture.pixels.assign(shots.size() * frameBytes, 0);
  truths.assign(shots.size(), ShotTruth{});
  std::atomic<std::size_t> next{0};
  std::atomic<std::size_t> done{0};
  auto work = [&]() {
    for (std::size_t i = next++; i < shots.size(); i = next++) {
      core::Rng rng = core::Rng::derive(scene.options.seed, "aline:" + name, i);
      ShotTruth truth;
      BeamPath path;
      trace(shots[i], path, truth);
      applyWaterSpeed(path, scene.waterSpeedMps);
      const ALine line = simulateALine(path, scene.transducer, scene.receiver, rng);
      if (wide) {
        std::memcpy(capture.pixels.data() + i * frameBytes, line.int16Samples.data(), frameBytes);
      } else {
        std::copy(line.samples.begin(), line.samples.end(),
                  capture.pixels.begin() + static_cast<std::ptrdiff_t>(i * frameBytes));
      }
      truth.region = shots[i].region;
      truth.coupled = shots[i].coupled;
      truth.shouldAccept = line.targetClear && shots[i].coupled && truth.bone != "none";
      if (truth.bone != "none")
        truth.speedMps = meanSpeed(path, truth.depthMm);
      truth.snr =
          line.clutterRmsAtTarget > 0 ? line.targetEchoAmplitude / line.clutterRmsAtTarget : 0.0;
      truths[i] = truth;
      ++done;
    }
  };
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back(work);
  if (progress) {
    while (done.load() < shots.size()) {
      progress(step, static_cast<double>(done.load()) / static_cast<double>(shots.size()));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  for (std::thread& t : pool)
    t.join();
}

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

std::string boneLabel(int boneIndex, const Knee& knee) {
  if (boneIndex < 0)
    return "none";
  return std::string(boneName(knee.bones[static_cast<std::size_t>(boneIndex)].id));
}

}  // namespace

std::string_view presetName(SpecimenKind kind) {
  return kind == SpecimenKind::Phantom ? "phantom" : "cadaver";
}

std::string_view standoffName(Standoff standoff) {
  switch (standoff) {
    case Standoff::GloveFinger:
      return "glove";
    case Standoff::GelPad:
      return "gel";
    case Standoff::None:
      return "none";
  }
  return "glove";
}

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Sizes {
  int framesPerBone, calibrationShots, spherePoints, framesPerSpherePoint, pivotFrames, hipFrames,
      mechanicalPoints, framesPerMechanicalPoint, landmarkDwellFrames;
  double meshResolutionMm;
};

Sizes sizesFor(const StudyOptions& o) {
  Sizes s = o.size == StudySize::Small ? Sizes{800, 300, 20, 15, 400, 500, 15, 20, 80, 1.2}
                                       : Sizes{3000, 1000, 40, 30, 1000, 1500, 40, 30, 150, 0.8};
  if (o.framesPerBone > 0)
    s.framesPerBone = o.framesPerBone;
  return s;
}

class StudyBuilder {
 public:
  StudyBuilder(const StudyOptions& options, const Specimen& specimen, std::string root,
               const StudyProgress& progress)
      : o_(options),
        specimen_(specimen),
        scene_(options, specimen),
        root_(std::move(root)),
        progress_(progress),
        sizes_(sizesFor(options)) {
    setUpScene();
  }

  void writeCaptures(StudySummary& summary) {
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

  nlohmann::json manifestCaptures() const { return manifest_; }
  const Scene& scene() const { return scene_; }
  const std::vector<std::pair<std::string, Eigen::Vector3d>>& ctLandmarks() const {
    return ctLandmarks_;
  }

 private:
  void setUpScene() {
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
    scene_.cameraCt = knee.kneeCentre +
                      1600.0 * (knee.anteriorCt + 0.35 * superior + 0.45 * lateral).normalized();
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
    const double swayScale =
        o_.preset == SpecimenKind::Cadaver ? 1.0 : 0.0;  // a phantom is clamped
    scene_.swayTranslation = SmoothNoise(sway, 0.4 * swayScale, 0.05, 0.4);
    scene_.swayRotation = SmoothNoise(sway, 0.2 * swayScale, 0.05, 0.4);
  }

  // One frame of a stylus capture: the tip's centre at `tipCt` with its long axis along
  // `axisCt`, turned toward the camera (then `roll` rad), and the bone markers, at time t.
  void addStylusFrame(CaptureWriter& writer, double t, double start, const Eigen::Vector3d& tipCt,
                      const Eigen::Vector3d& axisCt, double roll) {
    const Iso ctToTracker = scene_.ctToTracker(t - start);
    const Eigen::Matrix3d r = scene_.facingCamera(axisCt, tipCt, roll);
    const Iso stylusToCt =
        fromRotationTranslation(r, tipCt - r * scene_.stylusTipToStylus.translation());
    std::vector<TrackedPose> poses = scene_.bonePoses(t - start, ctToTracker);
    poses.insert(poses.begin(), {"StylusToTracker", ctToTracker * stylusToCt, &scene_.stylus});
    writer.addFrame(t, poses);
  }

  std::string capturePath(const std::string& name) const { return root_ + "/captures/" + name; }

  // `assumedSpeedMps` > 0: an A-line capture recorded with that speed of sound in its header.
  void saveCapture(CaptureWriter& writer, double assumedSpeedMps = 0.0) {
    Sequence& measured = writer.measured();
    Sequence& truth = writer.truth();
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
    writeSequence(measured, capturePath(writer.name()));
    writeSequence(truth, root_ + "/truth/captures/" + writer.name());
    captureFiles_.push_back(writer.name());
  }

  double nextStart() {
    const double start = clock_;
    clock_ += 600.0;  // each capture ten minutes after the previous one's start
    return start;
  }

  // ----- calibration: a steel sphere in a water bath ---------------------------------------
  // Calibration session `index` (1, 2, ...): the bath set up anew, the same probe.
  void calibration(int index) {
    const std::string suffix = index > 1 ? "_" + std::to_string(index) : std::string();
    core::Rng rng =
        core::Rng::derive(o_.seed, "calibration", static_cast<std::uint64_t>(index - 1));
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
      return Eigen::Vector3d(c * up +
                             std::sqrt(1 - c * c) * (std::cos(phi) * a + std::sin(phi) * b));
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
        const Eigen::Vector3d lateral =
            std::cos(azimuth) * side + std::sin(azimuth) * u.cross(side);
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
          shots.push_back(
              {beam.translation(), beam.linear().col(2), true, Tissue::Water, "sphere"});
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

  // ----- pivot calibration of the stylus tip --------------------------------------------
  void pivot() {
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
      writer.addFrame(t,
                      {{"StylusToTracker", fromRotationTranslation(r, position), &scene_.stylus}});
    }
    saveCapture(writer);
    manifest_["calibration"]["pivot_capture"] = "captures/" + writer.name();
  }

  // ----- ultrasound sweeps over one bone ---------------------------------------------------
  // Registration `index` (1, 2, ...): the dissertation did five per bone and specimen.
  void ultrasound(BoneId bone, int index, StudySummary& summary) {
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

  // ----- mechanical probe on the bone through the incision --------------------------------
  void mechanical(BoneId bone, bool blunt) {
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

  // ----- anatomical landmarks touched with the stylus ----------------------------------------
  void landmarks() {
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

  // ----- the femur rotated about the hip -----------------------------------------------------
  void hipRotation() {
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

  void recordShots(const std::string& capture, const std::vector<ShotTruth>& truths) {
    for (std::size_t i = 0; i < truths.size(); ++i)
      shotRows_.push_back({capture, i, truths[i]});
  }

  void writeShotsCsv() {
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

 public:
  nlohmann::json landmarkTruth_;
  std::vector<std::pair<std::string, Eigen::Vector3d>> trueLandmarks_;
  std::map<std::string, nlohmann::json> mechanicalTruth_;
  Eigen::Vector3d sphereCentreTracker_ = Eigen::Vector3d::Zero();
  nlohmann::json calibrationSessions_ = nlohmann::json::array();

 private:
  struct ShotRow {
    std::string capture;
    std::size_t frame;
    ShotTruth truth;
  };
  const StudyOptions& o_;
  const Specimen& specimen_;
  Scene scene_;
  std::string root_;
  const StudyProgress& progress_;
  Sizes sizes_;
  double clock_ = 1000.0;
  nlohmann::json manifest_;
  std::vector<std::string> captureFiles_;
  std::vector<ShotRow> shotRows_;
  std::vector<std::pair<std::string, Eigen::Vector3d>> ctLandmarks_;
};

}  // namespace

StudySummary generateStudy(const StudyOptions& options, const std::string& folder,
                           const StudyProgress& progress) {
  std::error_code ec;
  if (fs::exists(folder, ec)) {
    if (!fs::is_directory(folder, ec))
      throw FileError(folder, "exists and is not a folder");
    if (!fs::is_empty(folder, ec))
      throw FileError(folder, "exists and is not empty");
  }
  const fs::path target = fs::absolute(folder);
  const fs::path parent = target.parent_path();
  if (!fs::is_directory(parent, ec)) {
    throw FileError(folder, "its parent folder " + parent.string() + " does not exist");
  }
  if (!(options.underSkinScale > 0.0 && options.underSkinScale <= 1.0)) {
    throw std::invalid_argument("soft tissue scale must be in (0, 1], got " +
                                std::to_string(options.underSkinScale));
  }
  if (!(options.osteophyteMm >= 0.0 && options.osteophyteMm <= 8.0)) {
    throw std::invalid_argument("osteophytes must be within 0 to 8 mm, got " +
                                std::to_string(options.osteophyteMm));
  }
  if (options.osteophyteMm > 0.0 && options.meshFiles.count(BoneId::Femur) != 0) {
    throw std::invalid_argument(
        "osteophytes need the procedural femur (they are grown on its shape), not a mesh file");
  }
  if (options.probeFrequencyHz != 0.0 &&
      !(options.probeFrequencyHz >= 1e6 && options.probeFrequencyHz <= 20e6)) {
    throw std::invalid_argument("probe frequency must be in [1, 20] MHz, got " +
                                std::to_string(options.probeFrequencyHz) + " Hz");
  }
  // Sweeps the stale temporary folders of killed runs; this one's is removed on any early end.
  TemporaryFolder cleanup(target);
  for (const auto& [bone, file] : options.meshFiles) {
    (void)bone;
    if (!fs::is_regular_file(file, ec))
      throw FileError(file, "no such mesh file");
  }
  const fs::path temporary = cleanup.path();
  for (const char* sub : {"", "/ct", "/captures", "/truth", "/truth/captures"}) {
    fs::create_directories(temporary.string() + sub, ec);
    if (ec)
      throw FileError(temporary.string() + sub, "cannot create folder: " + ec.message());
  }
  const std::string root = temporary.string();
  const Sizes sizes = sizesFor(options);
  StudySummary summary;
  summary.folder = target.string();
  auto report = [&](const std::string& step, double fraction) {
    if (progress)
      progress(step, fraction);
  };

  // Bones.
  auto stepStart = Clock::now();
  report("bones", 0.0);
  KneeOptions kneeOptions;
  kneeOptions.flexionDeg = options.flexionDeg;
  kneeOptions.meshResolutionMm = sizes.meshResolutionMm;
  kneeOptions.seed = options.seed;
  kneeOptions.meshFiles = options.meshFiles;
  kneeOptions.osteophyteMm = options.osteophyteMm;
  Knee knee = buildKnee(kneeOptions);
  summary.stepSeconds.push_back({"bones", secondsSince(stepStart)});

  // Leg.
  stepStart = Clock::now();
  SoftTissueOptions tissue;
  tissue.thicknessScale = options.tissueScale;
  tissue.underSkinScale = options.underSkinScale;
  tissue.seed = options.seed;
  const Specimen specimen(knee, options.preset, tissue, [&](double f) { report("leg", f); });
  summary.stepSeconds.push_back({"leg", secondsSince(stepStart)});

  // Captures.
  stepStart = Clock::now();
  StudyBuilder builder(options, specimen, root, progress);
  builder.writeCaptures(summary);
  summary.stepSeconds.push_back({"captures", secondsSince(stepStart)});

  // CT.
  stepStart = Clock::now();
  const Eigen::Vector2d centre =
      (0.5 * (knee.hipCentre + knee.kneeCentre)).head<2>() * 0.5 + knee.kneeCentre.head<2>() * 0.5;
  const CtProtocol protocol =
      options.size == StudySize::Small
          ? smallProtocol(knee.hipCentre.z(), knee.kneeCentre.z(), knee.ankleCentre.z(), centre)
          : dissertationProtocol(knee.hipCentre.z(), knee.kneeCentre.z(), knee.ankleCentre.z(),
                                 centre);
  const CtVolume volume =
      synthesizeCt(specimen, protocol, options.seed, [&](double f) { report("ct", f); });
  DicomSeriesInfo dicom;
  dicom.patientId = fmt::format("ECHOREG-{}-{}", presetName(options.preset), options.seed);
  dicom.studyDescription = fmt::format("echoreg simulated {} study", presetName(options.preset));
  dicom.seriesDescription = "Leg CT: hip 5 mm, knee 1 mm, ankle 5 mm";
  dicom.uidSeed = core::Rng::derive(options.seed, presetName(options.preset),
                                    options.size == StudySize::Small ? 1 : 2)
                      .next();
  writeDicomSeries(root + "/ct/series", volume, dicom);
  writeMarkups(root + "/ct/landmarks.mrk.json", builder.ctLandmarks());
  summary.ctSlices = static_cast<int>(volume.sliceZMm.size());
  summary.ctSize = {volume.columns, volume.rows};
  summary.stepSeconds.push_back({"ct", secondsSince(stepStart)});

  // Truth.
  stepStart = Clock::now();
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
  summary.stepSeconds.push_back({"truth", secondsSince(stepStart)});

  // Manifest.
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

  // Publish.
  if (fs::exists(target, ec))
    fs::remove(target, ec);  // empty (checked above)
  fs::rename(temporary, target, ec);
  if (ec)
    throw FileError(folder, "could not be written: " + ec.message());
  cleanup.published();
  return summary;
}

}  // namespace echoreg::simulation
