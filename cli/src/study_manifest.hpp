// The study manifest (DIR/study.json, docs/formats.md) as `echoreg study run` reads it: its size
// and its lists bounded, every value the study reads checked for its type before any step runs,
// and every path it names resolved against the study folder. Apart from command_study.cpp so that
// fuzz/fuzz_manifest reads manifests as the study does.
#pragma once

#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <system_error>
#include <utility>

namespace echoreg::cli {

// What a manifest may ask (issue 15, item 12), checked before any step: each registration is a
// detection and a solve of about half a second on a small study, so 10^6 of them ran past 240 s and
// 5.3 GB before anything was said. A study larger than these is better split into several.
constexpr std::size_t kMaxManifestBytes = 16u << 20;
constexpr std::size_t kMaxBones = 32;
constexpr std::size_t kMaxCapturesPerBone = 500;
constexpr std::size_t kMaxSeedsPerBone = 64;
constexpr std::size_t kMaxLandmarks = 256;

inline nlohmann::json readManifestJson(const std::string& path) {
  std::error_code sizeError;
  const std::uintmax_t bytes = std::filesystem::file_size(path, sizeError);
  if (!sizeError && bytes > kMaxManifestBytes) {
    throw FileError(path,
                    fmt::format("is {:.1f} MB, more than the {} MB a study manifest may be "
                                "(a manifest names files; it does not hold data)",
                                static_cast<double>(bytes) / (1 << 20), kMaxManifestBytes >> 20));
  }
  return echoreg::readJsonFile(path);
}

// The manifest, with every path resolved against the study folder and checked on use.
class Manifest {
 public:
  Manifest(std::string dir) : dir_(std::move(dir)), path_(dir_ + "/study.json") {
    if (!std::filesystem::is_directory(dir_))
      throw FileError(dir_, "is not a study folder");
    doc_ = readManifestJson(path_);
    // (value() on a document that is not an object, or a "format" that is not a string, threw
    // the JSON library's own message; found by fuzz/fuzz_manifest.)
    if (!doc_.is_object() || !doc_.contains("format") || doc_["format"] != "echoreg-study") {
      throw FileError(path_, "is not an echoreg study manifest (\"format\": \"echoreg-study\")");
    }
    validate();
  }
  const std::string& dir() const { return dir_; }
  const nlohmann::json& doc() const { return doc_; }
  /// The value at a JSON pointer, or null.
  nlohmann::json at(const std::string& pointer) const {
    const nlohmann::json::json_pointer p(pointer);
    return doc_.contains(p) ? doc_[p] : nlohmann::json();
  }
  /// A file named by the manifest at `pointer`, resolved; "" when absent and not required.
  std::string file(const std::string& pointer, bool required = true) const {
    const nlohmann::json v = at(pointer);
    if (v.is_null()) {
      if (required)
        throw FileError(path_, "names no " + pointer.substr(1));
      return "";
    }
    if (!v.is_string())
      throw FileError(path_, pointer.substr(1) + " is not a file name");
    return resolve(v.get<std::string>());
  }
  /// A manifest path as the study reads it: relative to the study folder, which is the working
  /// directory while the study runs (StudyFolder), so that no result embeds where the study lies
  /// and a study moved or copied gives the same bytes. A path that leaves the folder (absolute, or
  /// through "..") is allowed and listed in outside().
  std::string resolve(const std::string& relative) const {
    const auto hash = relative.find('#');  // "truth/transforms.json#Name" names a member
    const std::string name = hash == std::string::npos ? relative : relative.substr(0, hash);
    const std::filesystem::path path = std::filesystem::path(name).lexically_normal();
    if (path.is_absolute() || (!path.empty() && *path.begin() == "..")) {
      outside_.insert(path.generic_string());
    }
    return path.generic_string();
  }
  /// The files and folders read outside the study folder, for the report's provenance.
  const std::set<std::string>& outside() const { return outside_; }
  double number(const std::string& pointer) const {
    const nlohmann::json v = at(pointer);
    if (!v.is_number())
      throw FileError(path_, pointer.substr(1) + " is not a number");
    return v.get<double>();
  }

 private:
  // "/bones/femur/ultrasound" -> "bones.femur.ultrasound", as the user reads the file.
  static std::string dotted(const std::string& pointer) {
    std::string name = pointer.substr(1);
    std::replace(name.begin(), name.end(), '/', '.');
    return name;
  }
  [[noreturn]] void wrongType(const std::string& pointer, const std::string& expected) const {
    throw FileError(
        path_, fmt::format("{} must be {}, got {}", dotted(pointer), expected, at(pointer).dump()));
  }
  // A value the manifest may leave out, but of the right type when given.
  void optionalNumber(const std::string& pointer, bool positive = false) const {
    const nlohmann::json v = at(pointer);
    if (v.is_null())
      return;
    if (!v.is_number() || (positive && !(v.get<double>() > 0.0)))
      wrongType(pointer, positive ? "a number > 0" : "a number");
  }
  void optionalNumbers(const std::string& pointer, std::size_t count,
                       const std::string& expected) const {
    const nlohmann::json v = at(pointer);
    if (v.is_null())
      return;
    if (!v.is_array() || v.size() != count ||
        !std::all_of(v.begin(), v.end(), [](const nlohmann::json& x) { return x.is_number(); }))
      wrongType(pointer, expected);
  }
  void optionalString(const std::string& pointer) const {
    const nlohmann::json v = at(pointer);
    if (!v.is_null() && !v.is_string())
      wrongType(pointer, "a string");
  }
  void optionalStrings(const std::string& pointer, const std::string& expected) const {
    const nlohmann::json v = at(pointer);
    if (v.is_null())
      return;
    if (!v.is_array() ||
        !std::all_of(v.begin(), v.end(), [](const nlohmann::json& x) { return x.is_string(); }))
      wrongType(pointer, expected);
  }

  // A list the study runs through, bounded: "bones.femur.ultrasound lists 1000000 captures, more
  // than the 500 registrations ...".
  void atMost(const std::string& pointer, std::size_t most, const std::string& what,
              const std::string& why) const {
    const nlohmann::json v = at(pointer);
    if (v.is_array() && v.size() > most) {
      throw FileError(path_, fmt::format("{} lists {} {}, more than the {} {}", dotted(pointer),
                                         v.size(), what, most, why));
    }
  }

  // Every value the study reads, checked before any step runs (docs/formats.md, "study.json"):
  // the version, the bones, and the type of each optional value, so that none is silently ignored.
  void validate() const {
    const nlohmann::json version = at("/version");
    if (!version.is_null() && version != nlohmann::json(1)) {
      throw FileError(path_, fmt::format("\"version\": {} is not a manifest version this echoreg "
                                         "reads (1)",
                                         version.dump()));
    }
    const nlohmann::json bones = at("/bones");
    if (!bones.is_object() || bones.empty()) {
      throw FileError(path_,
                      "names no bones (\"bones\": {\"femur\": {...}, ...}): nothing to "
                      "register");
    }
    if (bones.size() > kMaxBones) {
      throw FileError(path_, fmt::format("names {} bones, more than the {} a study may register "
                                         "(split the study)",
                                         bones.size(), kMaxBones));
    }
    optionalNumber("/calibration/stylus_tip_radius_mm");
    optionalNumber("/calibration/speed_of_sound_mps", true);
    optionalNumbers("/calibration/initial_beam_to_probe_mm", 3, "[X, Y, Z] in mm");
    optionalNumbers("/calibration/window_mm", 2, "[MIN, MAX] in mm");
    optionalString("/detection/preset");
    optionalNumber("/detection/speed_of_sound_mps", true);
    optionalStrings("/landmarks/order", "a list of landmark names");
    atMost("/landmarks/order", kMaxLandmarks, "landmarks", "a registration's landmarks");
    for (const auto& [bone, entry] : bones.items()) {
      // A bone's name names its result files (results/models/NAME.vtp, ...) and is looked up as
      // a JSON pointer: "../x" wrote outside the results, "a~b" threw the JSON library's message.
      const bool plain =
          !bone.empty() && bone.size() <= 64 && std::all_of(bone.begin(), bone.end(), [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
          });
      if (!plain) {
        throw FileError(path_, fmt::format("bones: {} is not a bone name (1 to 64 letters, digits, "
                                           "_ or -: it names the bone's result files)",
                                           nlohmann::json(bone).dump()));
      }
      const std::string key = "/bones/" + bone;
      if (!entry.is_object())
        wrongType(key, "an object");
      optionalStrings(key + "/ultrasound", "a list of capture file names");
      atMost(key + "/ultrasound", kMaxCapturesPerBone, "captures",
             "registrations a study may run per bone (each capture is a detection and a "
             "registration; split the study)");
      optionalNumber(key + "/mechanical_tip_radius_mm");
      const nlohmann::json fibula = at(key + "/segment/with_fibula");
      if (!fibula.is_null() && !fibula.is_boolean())
        wrongType(key + "/segment/with_fibula", "true or false");
      const nlohmann::json seeds = at(key + "/segment/seeds_ct");
      if (seeds.is_null())
        continue;
      if (!seeds.is_array())
        wrongType(key + "/segment/seeds_ct", "a list of seeds [x, y, z]");
      atMost(key + "/segment/seeds_ct", kMaxSeedsPerBone, "seeds",
             "seeds a bone's segmentation takes");
      for (std::size_t i = 0; i < seeds.size(); ++i)
        optionalNumbers(fmt::format("{}/segment/seeds_ct/{}", key, i), 3, "[x, y, z] in mm");
    }
  }

  std::string dir_;
  std::string path_;
  nlohmann::json doc_;
  mutable std::set<std::string> outside_;
};

}  // namespace echoreg::cli
