#include "echoreg/live/stream_metadata.hpp"

#include <nlohmann/json.hpp>

#include <stdexcept>

namespace echoreg::live {

namespace {

nlohmann::json optionalNumber(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

std::optional<double> numberOrNone(const nlohmann::json& object, const char* key) {
  if (!object.contains(key) || object.at(key).is_null())
    return std::nullopt;
  return object.at(key).get<double>();
}

}  // namespace

std::string captureHeaderJson(const core::Sequence& sequence) {
  const core::AcquisitionSettings& a = sequence.acquisition;
  nlohmann::json json = {{"sampling_frequency_hz", optionalNumber(a.samplingFrequencyHz)},
                         {"transducer_frequency_hz", optionalNumber(a.transducerFrequencyHz)},
                         {"delay_s", optionalNumber(a.delayS)},
                         {"speed_of_sound_mps", optionalNumber(a.speedOfSoundMps)},
                         {"transducer", a.transducer},
                         {"header", sequence.extraHeader}};
  return json.dump();
}

void applyCaptureHeader(const std::string& text, core::Sequence& layout) {
  try {
    const nlohmann::json json = nlohmann::json::parse(text);
    core::AcquisitionSettings& a = layout.acquisition;
    a.samplingFrequencyHz = numberOrNone(json, "sampling_frequency_hz");
    a.transducerFrequencyHz = numberOrNone(json, "transducer_frequency_hz");
    a.delayS = numberOrNone(json, "delay_s");
    a.speedOfSoundMps = numberOrNone(json, "speed_of_sound_mps");
    a.transducer = json.at("transducer").get<std::string>();
    layout.extraHeader = json.at("header").get<std::vector<std::pair<std::string, std::string>>>();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string(kCaptureHeaderName) +
                                " is not echoreg's capture header: " + e.what());
  }
}

std::string frameJson(const core::SequenceFrame& frame, double timestampS) {
  return nlohmann::json{{"timestamp", timestampS}, {"fields", frame.fields}}.dump();
}

FrameMetadata parseFrameJson(const std::string& text) {
  try {
    const nlohmann::json json = nlohmann::json::parse(text);
    FrameMetadata frame;
    frame.timestampS = json.at("timestamp").get<double>();
    frame.fields = json.at("fields").get<std::vector<std::pair<std::string, std::string>>>();
    return frame;
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string(kFrameName) +
                                " is not echoreg's frame metadata: " + e.what());
  }
}

}  // namespace echoreg::live
