// `echoreg info FILE [--json]`: what a capture holds, or what a CT series (a DICOM folder or
// file) holds.
#include "commands.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/segmentation/dicom_series.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <ostream>
#include <stdexcept>

namespace echoreg::cli {

namespace {

struct InfoOptions {
  std::string path;
  std::string series;
  bool json = false;
};

// A folder, a .dcm / .dicom file, or a file with the DICOM preamble ("DICM" at byte 128) is a CT.
bool looksLikeCt(const std::string& path) {
  if (std::filesystem::is_directory(path))
    return true;
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".dcm" || extension == ".dicom")
    return true;
  std::ifstream in(path, std::ios::binary);
  char magic[132] = {};
  return in.read(magic, sizeof magic) && std::string(magic + 128, 4) == "DICM";
}

nlohmann::ordered_json vector3(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

// The CT description. spacing_mm[2] is the slice spacing of a uniform series; for several slice
// groups it is the smallest step between consecutive slices (what resampleUniform uses by
// default), and slice_groups gives every group's own spacing; for one slice it is 1.
nlohmann::ordered_json describeCt(const segmentation::DicomSeriesRead& read) {
  const core::CtImage& image = read.image;
  double sliceSpacing = 1.0;
  if (image.uniform()) {
    sliceSpacing = image.sliceSpacingMm();
  } else {
    sliceSpacing = std::numeric_limits<double>::infinity();
    for (std::size_t k = 1; k < image.slicePositionsMm.size(); ++k) {
      sliceSpacing =
          std::min(sliceSpacing, image.slicePositionsMm[k] - image.slicePositionsMm[k - 1]);
    }
  }
  std::int16_t low = 0, high = 0;
  if (!image.hu.empty()) {
    const auto [minIt, maxIt] = std::minmax_element(image.hu.begin(), image.hu.end());
    low = *minIt;
    high = *maxIt;
  }
  nlohmann::ordered_json info;
  info["kind"] = "ct";
  info["dimensions"] = {image.dimensions[0], image.dimensions[1], image.dimensions[2]};
  info["spacing_mm"] = {image.pixelSpacingMm.x(), image.pixelSpacingMm.y(), sliceSpacing};
  info["origin_mm"] = vector3(image.originMm);
  nlohmann::ordered_json direction = nlohmann::ordered_json::array();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      direction.push_back(image.direction(r, c));
  }
  info["direction"] = direction;
  info["hu_range"] = {low, high};
  nlohmann::ordered_json groups = nlohmann::ordered_json::array();
  for (const core::CtSliceGroup& g : image.groups) {
    groups.push_back({{"count", g.count}, {"spacing_mm", g.spacingMm}});
  }
  info["slice_groups"] = groups;
  info["series_instance_uid"] = image.seriesInstanceUid;
  info["modality"] = read.modality;
  info["folder"] = image.folder;
  info["files"] = read.files.size();
  info["first_file"] = read.files.empty() ? std::string() : read.files.front();
  info["last_file"] = read.files.empty() ? std::string() : read.files.back();
  info["warnings"] = read.warnings;
  return info;
}

void printCtText(const nlohmann::ordered_json& info, std::ostream& out) {
  const auto& d = info["dimensions"];
  const auto& s = info["spacing_mm"];
  const auto& o = info["origin_mm"];
  out << fmt::format("{}\n", info["folder"].get<std::string>());
  out << fmt::format("  {} series {}: {} x {} pixels, {} slices ({} files)\n",
                     info["modality"].get<std::string>(),
                     info["series_instance_uid"].get<std::string>(), d[0].get<int>(),
                     d[1].get<int>(), d[2].get<int>(), info["files"].get<std::size_t>());
  out << fmt::format("  pixel spacing {} x {} mm; origin (first voxel centre, LPS) {} {} {} mm\n",
                     s[0].get<double>(), s[1].get<double>(), o[0].get<double>(), o[1].get<double>(),
                     o[2].get<double>());
  const auto& m = info["direction"];
  out << fmt::format("  axes (LPS): i {} {} {}, j {} {} {}, k {} {} {}\n", m[0].get<double>(),
                     m[3].get<double>(), m[6].get<double>(), m[1].get<double>(), m[4].get<double>(),
                     m[7].get<double>(), m[2].get<double>(), m[5].get<double>(),
                     m[8].get<double>());
  out << "  slice groups:";
  for (const auto& g : info["slice_groups"]) {
    out << fmt::format(" {} at {} mm;", g["count"].get<int>(), g["spacing_mm"].get<double>());
  }
  out << "\n";
  out << fmt::format("  HU range {} to {}\n", info["hu_range"][0].get<int>(),
                     info["hu_range"][1].get<int>());
  for (const auto& w : info["warnings"])
    out << "  warning: " << w.get<std::string>() << "\n";
}

nlohmann::json describe(const core::Sequence& sequence, const std::string& path) {
  nlohmann::json info;
  info["kind"] = "capture";
  info["file"] = path;
  info["frames"] = sequence.frameCount();
  info["samples_per_frame"] = sequence.frameSize[0];
  info["rows_per_frame"] = sequence.frameSize[1];
  info["element_type"] = std::string(core::elementTypeName(sequence.elementType));

  nlohmann::json transforms = nlohmann::json::array();
  for (const std::string& name : sequence.transformNames()) {
    int valid = 0, present = 0;
    for (const core::SequenceFrame& frame : sequence.frames) {
      const auto it = frame.transforms.find(name);
      if (it == frame.transforms.end())
        continue;
      ++present;
      valid += it->second.valid() ? 1 : 0;
    }
    transforms.push_back({{"name", name + "Transform"},
                          {"frames", present},
                          {"valid_frames", valid},
                          {"invalid_frames", present - valid}});
  }
  info["transforms"] = transforms;

  double first = std::numeric_limits<double>::infinity();
  double last = -std::numeric_limits<double>::infinity();
  int stamped = 0;
  for (const core::SequenceFrame& frame : sequence.frames) {
    if (!frame.timestampS)
      continue;
    ++stamped;
    first = std::min(first, *frame.timestampS);
    last = std::max(last, *frame.timestampS);
  }
  if (stamped > 0) {
    info["time_span_s"] = {first, last};
    info["duration_s"] = last - first;
    if (stamped > 1 && last > first)
      info["frame_rate_hz"] = (stamped - 1) / (last - first);
  } else {
    info["time_span_s"] = nullptr;
  }

  nlohmann::json acquisition = nlohmann::json::object();
  const core::AcquisitionSettings& a = sequence.acquisition;
  if (a.samplingFrequencyHz)
    acquisition["sampling_frequency_hz"] = *a.samplingFrequencyHz;
  if (a.delayS)
    acquisition["delay_s"] = *a.delayS;
  if (a.speedOfSoundMps)
    acquisition["speed_of_sound_mps"] = *a.speedOfSoundMps;
  if (!a.transducer.empty())
    acquisition["transducer"] = a.transducer;
  info["acquisition"] = acquisition;

  nlohmann::json header = nlohmann::json::object();
  for (const auto& [key, value] : sequence.extraHeader)
    header[key] = value;
  info["header"] = header;
  return info;
}

void printText(const nlohmann::json& info, std::ostream& out) {
  out << fmt::format("{}\n", info["file"].get<std::string>());
  const int samples = info["samples_per_frame"].get<int>();
  if (samples > 0) {
    out << fmt::format("  A-line capture: {} frames of {} samples ({})\n",
                       info["frames"].get<std::size_t>(), samples,
                       info["element_type"].get<std::string>());
  } else {
    out << fmt::format("  tracker-only capture: {} frames\n", info["frames"].get<std::size_t>());
  }
  if (!info["time_span_s"].is_null()) {
    out << fmt::format("  time span: {:.3f} s to {:.3f} s ({:.3f} s)",
                       info["time_span_s"][0].get<double>(), info["time_span_s"][1].get<double>(),
                       info["duration_s"].get<double>());
    if (info.contains("frame_rate_hz"))
      out << fmt::format(", {:.1f} frames/s", info["frame_rate_hz"].get<double>());
    out << "\n";
  }
  for (const auto& t : info["transforms"]) {
    out << fmt::format("  {}: {} of {} frames valid\n", t["name"].get<std::string>(),
                       t["valid_frames"].get<int>(), t["frames"].get<int>());
  }
  const auto& a = info["acquisition"];
  if (a.empty()) {
    out << "  acquisition settings: none in the header (detect uses its flags or defaults)\n";
  } else {
    if (a.contains("sampling_frequency_hz"))
      out << fmt::format("  sampling frequency: {} Hz\n", a["sampling_frequency_hz"].get<double>());
    if (a.contains("delay_s"))
      out << fmt::format("  delay: {} s\n", a["delay_s"].get<double>());
    if (a.contains("speed_of_sound_mps"))
      out << fmt::format("  speed of sound: {} m/s\n", a["speed_of_sound_mps"].get<double>());
    if (a.contains("transducer"))
      out << fmt::format("  transducer: {}\n", a["transducer"].get<std::string>());
  }
}

}  // namespace

CommandAction addInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* info = app.add_subcommand(
      "info",
      "Say what a file holds. A capture: frames, samples, element type, transforms and how "
      "many frames of each are valid, time span, acquisition settings. A CT (a DICOM "
      "folder, or one DICOM file): dimensions, spacing, origin and axes in LPS, HU range, "
      "slice groups; the whole series is read and checked (refused if slices are missing, "
      "duplicated, tilted or truncated)");
  info->add_option(
          "file", options->path,
          "PLUS sequence file (.igs.mha, .seq.mha, .mhd, .igs.nrrd), or a DICOM folder / file")
      ->required();
  info->add_option("--series", options->series,
                   "DICOM SeriesInstanceUID to read (default: the CT series with the most files)");
  info->add_flag("--json", options->json, "Print the description as JSON");
  return [options](const Streams& io) {
    if (looksLikeCt(options->path)) {
      segmentation::DicomReadOptions read;
      read.seriesUid = options->series;
      const nlohmann::ordered_json description =
          describeCt(segmentation::readDicomSeriesWithWarnings(options->path, read));
      if (options->json) {
        io.out << description.dump(2) << "\n";
      } else {
        printCtText(description, io.out);
      }
      return 0;
    }
    if (!options->series.empty()) {
      throw std::invalid_argument("--series applies to DICOM folders and files only");
    }
    const core::Sequence sequence = core::readSequence(options->path);
    const nlohmann::json description = describe(sequence, options->path);
    if (options->json) {
      io.out << description.dump(2) << "\n";
    } else {
      printText(description, io.out);
    }
    return 0;
  };
}

}  // namespace echoreg::cli
