#include "randomised_sequence.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace echoreg::test {

namespace {

template <typename T>
void append(std::vector<std::uint8_t>& pixels, float code) {
  const auto value = static_cast<T>(std::lround(code));
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian, as the writer's hosts are
  pixels.insert(pixels.end(), bytes, bytes + sizeof(T));
}

}  // namespace

core::Sequence randomisedSequence(const RandomisedCapture& capture) {
  if (capture.frames.empty())
    throw std::invalid_argument("a capture without frames");
  core::Sequence sequence;
  void (*store)(std::vector<std::uint8_t>&, float) = nullptr;
  switch (capture.storage) {
    case SampleStorage::UInt8:
      sequence.elementType = core::ElementType::UInt8;
      store = append<std::uint8_t>;
      break;
    case SampleStorage::Int8:
      sequence.elementType = core::ElementType::Int8;
      store = append<std::int8_t>;
      break;
    case SampleStorage::Int16:
      sequence.elementType = core::ElementType::Int16;
      store = append<std::int16_t>;
      break;
    case SampleStorage::UInt16:
      sequence.elementType = core::ElementType::UInt16;
      store = append<std::uint16_t>;
      break;
  }
  const std::size_t samples = capture.frames.front().samples.size();
  sequence.frameSize = {static_cast<int>(samples), 1};
  sequence.acquisition.samplingFrequencyHz = capture.samplingFrequencyHz;
  sequence.acquisition.delayS = capture.delayS;
  sequence.acquisition.speedOfSoundMps = capture.speedOfSoundMps;
  for (const RandomisedFrame& record : capture.frames) {
    if (record.samples.size() != samples)
      throw std::invalid_argument("the capture's records differ in length");
    for (float code : record.samples)
      store(sequence.pixels, code);
    core::SequenceFrame frame;
    frame.timestampS = record.timestampS;
    frame.fields.emplace_back("ImageStatus", "OK");
    if (record.hasPose) {
      core::TrackedTransform pose;
      pose.matrix = record.probeToTracker;
      pose.status = "OK";
      frame.transforms["ProbeToTracker"] = pose;
    }
    sequence.frames.push_back(std::move(frame));
  }
  return sequence;
}

}  // namespace echoreg::test
