// The study manifest, read and checked once (study_manifest.hpp).
#include "study_manifest.hpp"

#include "echoreg/core/json_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <system_error>
#include <utility>

namespace echoreg::cli {

namespace {

using Json = nlohmann::json;

Json readManifestJson(const std::string& path) {
  std::error_code sizeError;
  const std::uintmax_t bytes = std::filesystem::file_size(path, sizeError);
  if (!sizeError && bytes > kMaxManifestBytes) {
    throw core::FileError(
        path, fmt::format("is {:.1f} MB, more than the {} MB a study manifest may be "
                          "(a manifest names files; it does not hold data)",
                          static_cast<double>(bytes) / (1 << 20), kMaxManifestBytes >> 20));
  }
  return echoreg::core::readJsonFile(path);
}

// A manifest's file name as the study reads it (study_manifest.hpp).
std::string resolve(const std::string& relative) {
  const auto hash = relative.find('#');  // "truth/transforms.json#Name" names a member
  const std::string name = hash == std::string::npos ? relative : relative.substr(0, hash);
  return std::filesystem::path(name).lexically_normal().generic_string();
}

// Reads one manifest's values by JSON pointer, each checked for its type; a wrong one is refused
// naming it as the user reads the file ("bones.femur.ultrasound must be ..., got ...").
class Reader {
 public:
  Reader(std::string path, Json doc) : path_(std::move(path)), doc_(std::move(doc)) {}

  /// The value at a JSON pointer, or null.
  Json at(const std::string& pointer) const {
    const Json::json_pointer p(pointer);
    return doc_.contains(p) ? doc_[p] : Json();
  }
  const Json& doc() const { return doc_; }
  const std::string& path() const { return path_; }

  [[noreturn]] void wrongType(const std::string& pointer, const std::string& expected) const {
    throw core::FileError(
        path_, fmt::format("{} must be {}, got {}", dotted(pointer), expected, at(pointer).dump()));
  }
  std::optional<double> number(const std::string& pointer, bool positive = false) const {
    const Json v = at(pointer);
    if (v.is_null())
      return std::nullopt;
    if (!v.is_number() || (positive && !(v.get<double>() > 0.0)))
      wrongType(pointer, positive ? "a number > 0" : "a number");
    return v.get<double>();
  }
  template <std::size_t N>
  std::optional<std::array<double, N>> numbers(const std::string& pointer,
                                               const std::string& expected) const {
    const Json v = at(pointer);
    if (v.is_null())
      return std::nullopt;
    if (!v.is_array() || v.size() != N ||
        !std::all_of(v.begin(), v.end(), [](const Json& x) { return x.is_number(); }))
      wrongType(pointer, expected);
    std::array<double, N> values{};
    for (std::size_t i = 0; i < N; ++i)
      values[i] = v[i].get<double>();
    return values;
  }
  std::optional<std::string> string(const std::string& pointer) const {
    const Json v = at(pointer);
    if (v.is_null())
      return std::nullopt;
    if (!v.is_string())
      wrongType(pointer, "a string");
    return v.get<std::string>();
  }
  std::vector<std::string> strings(const std::string& pointer, const std::string& expected) const {
    const Json v = at(pointer);
    if (v.is_null())
      return {};
    if (!v.is_array() ||
        !std::all_of(v.begin(), v.end(), [](const Json& x) { return x.is_string(); }))
      wrongType(pointer, expected);
    return v.get<std::vector<std::string>>();
  }
  /// A file the manifest names, resolved; "" when absent.
  std::string file(const std::string& pointer) const {
    const Json v = at(pointer);
    if (v.is_null())
      return "";
    if (!v.is_string())
      wrongType(pointer, "a file name");
    return resolve(v.get<std::string>());
  }
  // A list the study runs through, bounded: "bones.femur.ultrasound lists 1000000 captures, more
  // than the 500 registrations ...".
  void atMost(const std::string& pointer, std::size_t most, const std::string& what,
              const std::string& why) const {
    const Json v = at(pointer);
    if (v.is_array() && v.size() > most) {
      throw core::FileError(path_, fmt::format("{} lists {} {}, more than the {} {}",
                                               dotted(pointer), v.size(), what, most, why));
    }
  }

 private:
  // "/bones/femur/ultrasound" -> "bones.femur.ultrasound", as the user reads the file.
  static std::string dotted(const std::string& pointer) {
    std::string name = pointer.substr(1);
    std::replace(name.begin(), name.end(), '/', '.');
    return name;
  }

  std::string path_;
  Json doc_;
};

// calibration.sessions: a list of {"sphere_capture": FILE, "capture": FILE}, the first the
// session the sweeps use; calibration.sphere_capture and capture, when given beside it, must be
// the first session's (else which one calibrates the sweeps would be a guess).
void readCalibrationSessions(const Reader& reader, ManifestCalibration& calibration) {
  const std::string key = "/calibration/sessions";
  const Json sessions = reader.at(key);
  if (sessions.is_null())
    return;
  if (!sessions.is_array() || sessions.empty())
    reader.wrongType(key, "a list of sessions, each {\"sphere_capture\": FILE, \"capture\": FILE}");
  reader.atMost(key, kMaxCalibrationSessions, "sessions", "calibrations a study may run");
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    const std::string entry = fmt::format("{}/{}", key, i);
    ManifestCalibrationSession session;
    if (sessions[i].is_object()) {
      session.sphereCapture = reader.file(entry + "/sphere_capture");
      session.capture = reader.file(entry + "/capture");
    }
    if (session.sphereCapture.empty() || session.capture.empty())
      reader.wrongType(entry, "{\"sphere_capture\": FILE, \"capture\": FILE}");
    calibration.sessions.push_back(std::move(session));
  }
  const ManifestCalibrationSession& first = calibration.sessions.front();
  if ((!calibration.sphereCapture.empty() && calibration.sphereCapture != first.sphereCapture) ||
      (!calibration.capture.empty() && calibration.capture != first.capture)) {
    throw core::FileError(reader.path(),
                          "calibration.sphere_capture and calibration.capture must be the first of "
                          "calibration.sessions (the session the sweeps use) when both are given");
  }
  calibration.sphereCapture = first.sphereCapture;
  calibration.capture = first.capture;
}

// A bone's name names its result files (results/models/NAME.vtp, ...) and is looked up as a JSON
// pointer: "../x" wrote outside the results, "a~b" threw the JSON library's pointer message.
bool plainBoneName(const std::string& bone) {
  return !bone.empty() && bone.size() <= 64 && std::all_of(bone.begin(), bone.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

ManifestBone readBone(const Reader& reader, const std::string& bone) {
  const std::string key = "/bones/" + bone;
  if (!reader.at(key).is_object())
    reader.wrongType(key, "an object");
  ManifestBone entry;
  entry.name = bone;
  entry.ultrasound = reader.strings(key + "/ultrasound", "a list of capture file names");
  reader.atMost(key + "/ultrasound", kMaxCapturesPerBone, "captures",
                "registrations a study may run per bone (each capture is a detection and a "
                "registration; split the study)");
  for (std::string& capture : entry.ultrasound)
    capture = resolve(capture);
  entry.mechanicalTipRadiusMm = reader.number(key + "/mechanical_tip_radius_mm").value_or(0.0);
  const Json fibula = reader.at(key + "/segment/with_fibula");
  if (!fibula.is_null() && !fibula.is_boolean())
    reader.wrongType(key + "/segment/with_fibula", "true or false");
  entry.withFibula = fibula == Json(true);
  const Json seeds = reader.at(key + "/segment/seeds_ct");
  if (!seeds.is_null()) {
    if (!seeds.is_array())
      reader.wrongType(key + "/segment/seeds_ct", "a list of seeds [x, y, z]");
    reader.atMost(key + "/segment/seeds_ct", kMaxSeedsPerBone, "seeds",
                  "seeds a bone's segmentation takes");
    for (std::size_t i = 0; i < seeds.size(); ++i) {
      const std::string seed = fmt::format("{}/segment/seeds_ct/{}", key, i);
      const auto point = reader.numbers<3>(seed, "[x, y, z] in mm");
      if (!point)
        reader.wrongType(seed, "[x, y, z] in mm");
      entry.seedsCt.push_back(*point);
    }
  }
  entry.model = reader.file(key + "/model");
  entry.initial = reader.file(key + "/initial");
  entry.mechanical = reader.file(key + "/mechanical");
  entry.hipRotation = reader.file(key + "/hip_rotation");
  return entry;
}

}  // namespace

const ManifestBone* StudyManifest::bone(const std::string& name) const {
  const auto found = std::find_if(bones.begin(), bones.end(),
                                  [&name](const ManifestBone& b) { return b.name == name; });
  return found == bones.end() ? nullptr : &*found;
}

const std::string& StudyManifest::require(const std::string& file, const std::string& key) const {
  if (file.empty())
    throw core::FileError(path, "names no " + key);
  return file;
}

bool outsideStudyFolder(const std::string& file) {
  const std::filesystem::path path(file);
  return path.is_absolute() || (!path.empty() && *path.begin() == "..");
}

StudyManifest readStudyManifest(const std::string& dir) {
  if (!std::filesystem::is_directory(dir))
    throw core::FileError(dir, "is not a study folder");
  StudyManifest manifest;
  manifest.dir = dir;
  manifest.path = dir + "/study.json";
  const Reader reader(manifest.path, readManifestJson(manifest.path));
  // (value() on a document that is not an object, or a "format" that is not a string, threw the
  // JSON library's own message; found by fuzz/fuzz_manifest.)
  const Json& doc = reader.doc();
  if (!doc.is_object() || !doc.contains("format") || doc["format"] != "echoreg-study") {
    throw core::FileError(manifest.path,
                          "is not an echoreg study manifest (\"format\": \"echoreg-study\")");
  }
  // Every value the study reads, checked before any step runs (docs/formats.md, "study.json"):
  // the version, the bones, and the type of each optional value, so that none is silently ignored.
  const Json version = reader.at("/version");
  if (!version.is_null() && version != Json(1)) {
    throw core::FileError(manifest.path,
                          fmt::format("\"version\": {} is not a manifest version this "
                                      "echoreg reads (1)",
                                      version.dump()));
  }
  const Json bones = reader.at("/bones");
  if (!bones.is_object() || bones.empty()) {
    throw core::FileError(
        manifest.path, "names no bones (\"bones\": {\"femur\": {...}, ...}): nothing to register");
  }
  if (bones.size() > kMaxBones) {
    throw core::FileError(manifest.path, fmt::format("names {} bones, more than the {} a study may "
                                                     "register (split the study)",
                                                     bones.size(), kMaxBones));
  }
  ManifestCalibration& calibration = manifest.calibration;
  calibration.stylusTipRadiusMm = reader.number("/calibration/stylus_tip_radius_mm");
  calibration.speedOfSoundMps = reader.number("/calibration/speed_of_sound_mps", true);
  calibration.initialBeamToProbeMm =
      reader.numbers<3>("/calibration/initial_beam_to_probe_mm", "[X, Y, Z] in mm");
  calibration.windowMm = reader.numbers<2>("/calibration/window_mm", "[MIN, MAX] in mm");
  manifest.detection.preset = reader.string("/detection/preset");
  manifest.detection.speedOfSoundMps = reader.number("/detection/speed_of_sound_mps", true);
  manifest.landmarks.order = reader.strings("/landmarks/order", "a list of landmark names");
  reader.atMost("/landmarks/order", kMaxLandmarks, "landmarks", "a registration's landmarks");
  for (const auto& [bone, entry] : bones.items()) {
    static_cast<void>(entry);
    if (!plainBoneName(bone)) {
      throw core::FileError(
          manifest.path,
          fmt::format("bones: {} is not a bone name (1 to 64 letters, digits, _ or -: "
                      "it names the bone's result files)",
                      Json(bone).dump()));
    }
    manifest.bones.push_back(readBone(reader, bone));
  }
  calibration.pivotCapture = reader.file("/calibration/pivot_capture");
  calibration.sphereCapture = reader.file("/calibration/sphere_capture");
  calibration.capture = reader.file("/calibration/capture");
  readCalibrationSessions(reader, calibration);
  calibration.sphereRadiusMm = reader.number("/calibration/sphere_radius_mm");
  manifest.ctDicom = reader.file("/ct/dicom");
  manifest.landmarks.ct = reader.file("/landmarks/ct");
  manifest.landmarks.capture = reader.file("/landmarks/capture");
  manifest.truth.transforms = reader.file("/truth/transforms");
  manifest.truth.shots = reader.file("/truth/shots");
  manifest.truth.patella = reader.file("/truth/patella");
  // (Only in an object: a bone named by digits is an index into an array, and a long one threw
  // the JSON library's range error.)
  for (const ManifestBone& bone : manifest.bones) {
    if (!reader.at("/truth").is_object())
      break;
    if (std::string model = reader.file("/truth/" + bone.name); !model.empty())
      manifest.truth.model[bone.name] = std::move(model);
  }
  manifest.generator = reader.at("/generator");
  manifest.document = doc;
  return manifest;
}

}  // namespace echoreg::cli
