// Private declarations of the simulated study (generateStudy, study.cpp), shared by its pieces
// (not installed):
//   - study_builder.cpp: the theatre (camera, leg pose, trackers), the captures' frames and files,
//     and the protocol in order (StudyBuilder::writeCaptures);
//   - one file per protocol step: study_calibration.cpp (the sphere sessions), study_pivot.cpp,
//     study_ultrasound.cpp, study_mechanical.cpp, study_landmarks.cpp, study_hip_rotation.cpp;
//   - the writers of the truth (study_truth.cpp) and of the manifest (study_manifest.cpp).
#pragma once

#include "echoreg/core/random.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/simulation/pulse_echo.hpp"
#include "echoreg/simulation/study.hpp"
#include "echoreg/simulation/tracking.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace echoreg::simulation::detail {

using Iso = Eigen::Isometry3d;

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

Iso fromRotationTranslation(const Eigen::Matrix3d& r, const Eigen::Vector3d& t);

nlohmann::json matrixJson(const Iso& m);

nlohmann::json vectorJson(const Eigen::Vector3d& v);

void writeText(const std::string& path, const std::string& text);

// Writes a 3D Slicer markups file (.mrk.json) of named points, LPS.
void writeMarkups(const std::string& path,
                  const std::vector<std::pair<std::string, Eigen::Vector3d>>& points);

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
    core::SequenceFrame noisy, exact;
    noisy.timestampS = timeS;
    exact.timestampS = timeS;
    core::Rng rng = core::Rng::derive(seed_, "tracking:" + name_, measured_.frames.size());
    for (const TrackedPose& pose : poses) {
      const Measurement m = tracker_.measure(pose.truth, *pose.marker, rng, true);
      core::TrackedTransform t;
      t.matrix = m.markerToTracker.matrix();
      t.status = m.valid ? "OK" : "INVALID";
      noisy.transforms[pose.name] = t;
      core::TrackedTransform e;
      e.matrix = pose.truth.matrix();
      e.status = tracker_.visible(pose.truth, *pose.marker) ? "OK" : "INVALID";
      exact.transforms[pose.name] = e;
    }
    measured_.frames.push_back(std::move(noisy));
    truth_.frames.push_back(std::move(exact));
  }

  core::Sequence& measured() { return measured_; }
  core::Sequence& truth() { return truth_; }
  std::size_t frames() const { return measured_.frames.size(); }

 private:
  std::string name_;
  const OpticalTracker& tracker_;
  std::uint64_t seed_;
  core::Sequence measured_;
  core::Sequence truth_;
};

// A probe (or stylus) frame whose long axis (z) is `axis`, rolled about it so that its marker
// (facing -x) looks at `camera`, then `roll` radians more. All in one frame.
Eigen::Matrix3d facingPoint(const Eigen::Vector3d& axis, const Eigen::Vector3d& at,
                            const Eigen::Vector3d& camera, double roll);

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
void applyWaterSpeed(BeamPath& path, double waterSpeedMps);

double meanSpeed(const BeamPath& path, double depthMm);

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
void simulateShots(core::Sequence& capture, const std::string& name,
                   const std::vector<PendingShot>& shots, const Scene& scene, TraceFn trace,
                   std::vector<ShotTruth>& truths, const StudyProgress& progress,
                   const std::string& step) {
  const int samples = scene.receiver.samples;
  const bool wide = scene.receiver.adc == AdcFormat::Int16Left12;
  capture.elementType = wide ? core::ElementType::Int16 : core::ElementType::UInt8;
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

struct Sizes {
  int framesPerBone, calibrationShots, spherePoints, framesPerSpherePoint, pivotFrames, hipFrames,
      mechanicalPoints, framesPerMechanicalPoint, landmarkDwellFrames;
  double meshResolutionMm;
};

Sizes sizesFor(const StudyOptions& o);

// The captures of every step of the protocol, with what each step's truth and manifest entries
// need.
class StudyBuilder {
 public:
  StudyBuilder(const StudyOptions& options, const Specimen& specimen, std::string root,
               const StudyProgress& progress);

  void writeCaptures(StudySummary& summary);

  nlohmann::json manifestCaptures() const { return manifest_; }
  const Scene& scene() const { return scene_; }
  const std::vector<std::pair<std::string, Eigen::Vector3d>>& ctLandmarks() const {
    return ctLandmarks_;
  }

 private:
  void setUpScene();

  // One frame of a stylus capture: the tip's centre at `tipCt` with its long axis along
  // `axisCt`, turned toward the camera (then `roll` rad), and the bone markers, at time t.
  void addStylusFrame(CaptureWriter& writer, double t, double start, const Eigen::Vector3d& tipCt,
                      const Eigen::Vector3d& axisCt, double roll);

  std::string capturePath(const std::string& name) const { return root_ + "/captures/" + name; }

  // `assumedSpeedMps` > 0: an A-line capture recorded with that speed of sound in its header.
  void saveCapture(CaptureWriter& writer, double assumedSpeedMps = 0.0);

  double nextStart();

  // The protocol's steps, each in its own file.
  void calibration(int index);                                     // study_calibration.cpp
  void pivot();                                                    // study_pivot.cpp
  void ultrasound(BoneId bone, int index, StudySummary& summary);  // study_ultrasound.cpp
  void mechanical(BoneId bone, bool blunt);                        // study_mechanical.cpp
  void landmarks();                                                // study_landmarks.cpp
  void hipRotation();                                              // study_hip_rotation.cpp

  void recordShots(const std::string& capture, const std::vector<ShotTruth>& truths);
  void writeShotsCsv();  // study_truth.cpp

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

// The truth of the study (root/truth: transforms, models, landmarks, calibration, points).
void writeTruth(const std::string& root, const StudyOptions& options, const Knee& knee,
                const StudyBuilder& builder);

// The study's manifest (root/study.json).
void writeManifest(const std::string& root, const StudyOptions& options, const Knee& knee,
                   const StudyBuilder& builder);

}  // namespace echoreg::simulation::detail
