// `echoreg info FILE [--json]`: what a capture holds.
#include "commands.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>

namespace echoreg::cli {

namespace {

struct InfoOptions {
  std::string path;
  bool json = false;
};

nlohmann::json describe(const Sequence& sequence, const std::string& path) {
  nlohmann::json info;
  info["kind"] = "capture";
  info["file"] = path;
  info["frames"] = sequence.frameCount();
  info["samples_per_frame"] = sequence.frameSize[0];
  info["rows_per_frame"] = sequence.frameSize[1];
  info["element_type"] = std::string(elementTypeName(sequence.elementType));

  nlohmann::json transforms = nlohmann::json::array();
  for (const std::string& name : sequence.transformNames()) {
    int valid = 0, present = 0;
    for (const SequenceFrame& frame : sequence.frames) {
      const auto it = frame.transforms.find(name);
      if (it == frame.transforms.end()) continue;
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
  for (const SequenceFrame& frame : sequence.frames) {
    if (!frame.timestampS) continue;
    ++stamped;
    first = std::min(first, *frame.timestampS);
    last = std::max(last, *frame.timestampS);
  }
  if (stamped > 0) {
    info["time_span_s"] = {first, last};
    info["duration_s"] = last - first;
    if (stamped > 1 && last > first) info["frame_rate_hz"] = (stamped - 1) / (last - first);
  } else {
    info["time_span_s"] = nullptr;
  }

  nlohmann::json acquisition = nlohmann::json::object();
  const AcquisitionSettings& a = sequence.acquisition;
  if (a.samplingFrequencyHz) acquisition["sampling_frequency_hz"] = *a.samplingFrequencyHz;
  if (a.delayS) acquisition["delay_s"] = *a.delayS;
  if (a.speedOfSoundMps) acquisition["speed_of_sound_mps"] = *a.speedOfSoundMps;
  if (!a.transducer.empty()) acquisition["transducer"] = a.transducer;
  info["acquisition"] = acquisition;

  nlohmann::json header = nlohmann::json::object();
  for (const auto& [key, value] : sequence.extraHeader) header[key] = value;
  info["header"] = header;
  return info;
}

void printText(const nlohmann::json& info, std::ostream& out) {
  out << fmt::format("{}\n", info["file"].get<std::string>());
  const int samples = info["samples_per_frame"].get<int>();
  if (samples > 0) {
    out << fmt::format("  A-line capture: {} frames of {} samples ({})\n", info["frames"].get<std::size_t>(),
                       samples, info["element_type"].get<std::string>());
  } else {
    out << fmt::format("  tracker-only capture: {} frames\n", info["frames"].get<std::size_t>());
  }
  if (!info["time_span_s"].is_null()) {
    out << fmt::format("  time span: {:.3f} s to {:.3f} s ({:.3f} s)", info["time_span_s"][0].get<double>(),
                       info["time_span_s"][1].get<double>(), info["duration_s"].get<double>());
    if (info.contains("frame_rate_hz")) out << fmt::format(", {:.1f} frames/s", info["frame_rate_hz"].get<double>());
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
    if (a.contains("sampling_frequency_hz")) out << fmt::format("  sampling frequency: {} Hz\n", a["sampling_frequency_hz"].get<double>());
    if (a.contains("delay_s")) out << fmt::format("  delay: {} s\n", a["delay_s"].get<double>());
    if (a.contains("speed_of_sound_mps")) out << fmt::format("  speed of sound: {} m/s\n", a["speed_of_sound_mps"].get<double>());
    if (a.contains("transducer")) out << fmt::format("  transducer: {}\n", a["transducer"].get<std::string>());
  }
}

}  // namespace

CommandAction addInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* info = app.add_subcommand(
      "info", "Say what a capture holds: frames, samples, element type, transforms and how many "
              "frames of each are valid, time span, acquisition settings");
  info->add_option("file", options->path, "PLUS sequence file (.igs.mha, .seq.mha, .mhd, .igs.nrrd)")
      ->required();
  info->add_flag("--json", options->json, "Print the description as JSON");
  return [options](const Streams& io) {
    if (std::filesystem::is_directory(options->path)) {
      throw FileError(options->path,
                      "is a directory; info reads capture files (CT folders come with the "
                      "segmentation issue)");
    }
    const Sequence sequence = readSequence(options->path);
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
