// The study manifest (DIR/study.json, docs/formats.md "study.json") as one typed value,
// StudyManifest: read and checked once by readStudyManifest (its size and its lists bounded, every
// value the study reads checked for its type before any step runs, every file name made relative
// to the study folder), then used through its fields by `study run`, `study compare` and
// fuzz/fuzz_manifest. No command reads the manifest's JSON by pointer.
#pragma once

#include "echoreg/core/error.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::cli {

// What a manifest may ask (issue 15, item 12), checked before any step: each registration is a
// detection and a solve of about half a second on a small study, so 10^6 of them ran past 240 s and
// 5.3 GB before anything was said. A study larger than these is better split into several.
constexpr std::size_t kMaxManifestBytes = 16u << 20;
constexpr std::size_t kMaxBones = 32;
constexpr std::size_t kMaxCapturesPerBone = 500;
constexpr std::size_t kMaxSeedsPerBone = 64;
constexpr std::size_t kMaxLandmarks = 256;
constexpr std::size_t kMaxCalibrationSessions = 64;

// File names below are as the study reads them: relative to the study folder (the working
// directory while it runs, so that no result embeds where the study lies), lexically normal, a
// "#member" suffix dropped; "" when the manifest leaves them out. Whether a file is needed is the
// study's to say (StudyManifest::require), since that depends on what it runs.

/// One bone, bones.<name>.
struct ManifestBone {
  std::string name;     ///< 1 to 64 letters, digits, _ or - (it names the bone's result files)
  std::string model;    ///< model: the bone's model in CT, when the CT is not segmented
  std::string initial;  ///< initial: a <Bone>ToCT transform to start from, without landmarks
  std::vector<std::string> ultrasound;  ///< ultrasound: the sweeps, each a registration
  std::string mechanical;               ///< mechanical: the stylus on the exposed bone
  double mechanicalTipRadiusMm = 0.0;   ///< mechanical_tip_radius_mm (not checked for sign here)
  std::string hipRotation;              ///< hip_rotation: the leg circling about the hip (femur)
  std::vector<std::array<double, 3>> seedsCt;  ///< segment.seeds_ct, LPS mm
  bool withFibula = false;  ///< segment.with_fibula: the 2nd seed is the fibula's
};

/// One calibration session of the probe (the bath set up anew), calibration.sessions[i].
struct ManifestCalibrationSession {
  std::string sphereCapture;  ///< sphere_capture: the stylus on the sphere
  std::string capture;        ///< capture: the A-line shots at the sphere
};

struct ManifestCalibration {
  std::string pivotCapture;   ///< pivot_capture: the stylus pivoting in a divot
  std::string sphereCapture;  ///< sphere_capture: the stylus on the sphere (sessions[0]'s)
  std::string capture;        ///< capture: the A-line shots at the sphere (sessions[0]'s)
  /// sessions: every calibration session (Table 5.2), the first the one the sweeps use; empty when
  /// the manifest gives only sphere_capture and capture (one session).
  std::vector<ManifestCalibrationSession> sessions;
  std::optional<double> sphereRadiusMm;     ///< sphere_radius_mm
  std::optional<double> stylusTipRadiusMm;  ///< stylus_tip_radius_mm
  std::optional<double> speedOfSoundMps;    ///< speed_of_sound_mps (> 0): the bath's, assumed
  std::optional<std::array<double, 3>> initialBeamToProbeMm;  ///< initial_beam_to_probe_mm
  std::optional<std::array<double, 2>> windowMm;              ///< window_mm [MIN, MAX]
};

struct ManifestDetection {
  std::optional<std::string> preset;      ///< preset of echoreg detect
  std::optional<double> speedOfSoundMps;  ///< speed_of_sound_mps (> 0) the sweeps assume
};

struct ManifestLandmarks {
  std::string ct;                  ///< ct: the landmarks picked on the CT (Slicer markups)
  std::string capture;             ///< capture: the stylus dwelling on each, in `order`
  std::vector<std::string> order;  ///< order: the landmarks' names in touch order
};

/// A simulated study's truth (truth.*), for the evaluation.
struct ManifestTruth {
  std::string transforms;                    ///< transforms
  std::string shots;                         ///< shots: per frame, should it be accepted
  std::string patella;                       ///< patella: context in the femur's figure
  std::map<std::string, std::string> model;  ///< truth.<bone>: a bone's true surface, by bone
};

struct StudyManifest {
  std::string dir;   ///< the study folder as the user gave it
  std::string path;  ///< dir + "/study.json", the name every message gives
  ManifestCalibration calibration;
  std::vector<ManifestBone> bones;  ///< at least one, by name
  std::string ctDicom;              ///< ct.dicom: the CT series folder
  ManifestLandmarks landmarks;
  ManifestDetection detection;
  ManifestTruth truth;
  /// generator: who made the study, free-form key/values reported as they are (null if absent).
  nlohmann::json generator;
  /// The file as read, for what is free-form by design: study compare's --group-by (a dotted path
  /// of the user's choosing) and its provenance, which quotes the manifest's own sections.
  nlohmann::json document;

  /// The bone of that name, or null.
  const ManifestBone* bone(const std::string& name) const;
  /// `file` when the manifest gives it; else FileError naming the manifest and `key` (dotted, as
  /// the file spells it: "calibration.pivot_capture").
  const std::string& require(const std::string& file, const std::string& key) const;
};

/// Reads DIR/study.json and checks it (docs/formats.md): FileError naming the folder (not a
/// folder) or the manifest and the key (not a manifest, an unknown version, no bones, a value of
/// the wrong type, a list longer than its bound).
StudyManifest readStudyManifest(const std::string& dir);

/// Whether a manifest's file name leaves the study folder (absolute, or through ".."): such a file
/// is read, and listed in the study's provenance, since a copy of the folder alone lacks it.
bool outsideStudyFolder(const std::string& file);

}  // namespace echoreg::cli
