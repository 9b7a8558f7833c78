// PLUS's per-frame keys (Seq_Frame0000_ProbeToTrackerTransform, ..._Timestamp, fields) and
// echoreg's acquisition keys: read from a parsed header into a Sequence, and written as header
// entries (sequence_io_detail.hpp).
#include "sequence_io_detail.hpp"

#include "echoreg/core/depth.hpp"
#include "echoreg/core/error.hpp"

#include <cmath>
#include <stdexcept>

namespace echoreg::core::detail {

namespace {

constexpr std::string_view kFramePrefix = "Seq_Frame";
constexpr std::string_view kTransformSuffix = "Transform";
constexpr std::string_view kStatusSuffix = "TransformStatus";

bool endsWith(std::string_view text, std::string_view suffix) {
  return text.size() >= suffix.size() && text.substr(text.size() - suffix.size()) == suffix;
}

Eigen::Matrix4d parseTransform(const std::string& path, const HeaderEntry& entry) {
  Eigen::Matrix4d matrix;
  const std::vector<std::string_view> words = splitWords(entry.value);
  if (words.size() != 16) {
    throw FileError(path, quote(entry.key) + " has " + std::to_string(words.size()) +
                              " numbers, a transform needs 16");
  }
  for (std::size_t i = 0; i < words.size(); ++i) {
    double value = 0.0;
    if (!parseDouble(words[i], value)) {
      throw FileError(path, quote(entry.key) + " has a non-numeric entry " + quote(words[i]));
    }
    if (!std::isfinite(value)) {
      throw FileError(path, quote(entry.key) + " has a non-finite entry " + quote(words[i]) +
                                " (NaN or infinity)");
    }
    matrix(static_cast<Eigen::Index>(i / 4), static_cast<Eigen::Index>(i % 4)) = value;
  }
  return matrix;
}

double parseFiniteNumber(const std::string& path, const HeaderEntry& entry) {
  double value = 0.0;
  if (!parseDouble(entry.value, value) || !std::isfinite(value)) {
    throw FileError(path, quote(entry.key) + " is not a finite number: " + quote(entry.value));
  }
  return value;
}

void applyFrameEntry(const std::string& path, const ParsedHeader& header, const FrameKey& key,
                     const HeaderEntry& entry, Sequence& sequence) {
  if (key.frame >= sequence.frames.size()) {
    throw FileError(path, quote(entry.key) + " refers to a frame beyond the " +
                              std::to_string(sequence.frames.size()) + " frames " +
                              std::string(header.dimSizeKey) + " declares");
  }
  SequenceFrame& frame = sequence.frames[key.frame];
  switch (key.kind) {
    case FrameKeyKind::Timestamp:
      frame.timestampS = parseFiniteNumber(path, entry);
      break;
    case FrameKeyKind::Transform:
      frame.transforms[std::string(key.name)].matrix = parseTransform(path, entry);
      break;
    case FrameKeyKind::TransformStatus:
      frame.transforms[std::string(key.name)].status = std::string(entry.value);
      break;
    case FrameKeyKind::Field:
      frame.fields.emplace_back(key.name, entry.value);
      break;
  }
}

// True when `entry` is one of echoreg's acquisition keys (and stores it).
bool applyAcquisitionEntry(const std::string& path, const HeaderEntry& entry,
                           AcquisitionSettings& acquisition) {
  if (entry.key == kTransducerKey) {
    acquisition.transducer = std::string(entry.value);
    return true;
  }
  std::optional<double>* target =
      entry.key == kSamplingFrequencyKey     ? &acquisition.samplingFrequencyHz
      : entry.key == kDelayKey               ? &acquisition.delayS
      : entry.key == kSpeedOfSoundKey        ? &acquisition.speedOfSoundMps
      : entry.key == kTransducerFrequencyKey ? &acquisition.transducerFrequencyHz
                                             : nullptr;
  if (target == nullptr)
    return false;
  *target = parseFiniteNumber(path, entry);
  // Bounds of what a header may say, so that a damaged value is named as the header's (not as
  // "mm per sample must be > 0" deep in the detector): the same ranges as the flags'.
  struct Bounds {
    double low, high;
    const char* what;
  };
  static_assert(kMinSpeedOfSoundMps == 1000.0 && kMaxSpeedOfSoundMps == 2000.0,
                "the speed of sound's bounds are named in the message below");
  const Bounds bounds =
      entry.key == kSamplingFrequencyKey ? Bounds{1e3, 1e10, "sampling frequency (1e3 to 1e10 Hz)"}
      : entry.key == kDelayKey
          ? Bounds{-1e-3, 1e-3, "acquisition delay (-1e-3 to 1e-3 s: 1 ms is 770 mm of tissue)"}
      : entry.key == kSpeedOfSoundKey
          ? Bounds{kMinSpeedOfSoundMps, kMaxSpeedOfSoundMps, "speed of sound (1000 to 2000 m/s)"}
          : Bounds{1e5, 1e9, "transducer frequency (1e5 to 1e9 Hz)"};
  if (!(**target >= bounds.low && **target <= bounds.high)) {
    throw FileError(path, quote(entry.key) + " = " + std::string(entry.value) +
                              " in the capture's header is not a plausible " + bounds.what);
  }
  return true;
}

std::string frameKey(std::size_t frame, std::string_view name) {
  std::string number = std::to_string(frame);
  if (number.size() < 4)
    number.insert(0, 4 - number.size(), '0');
  std::string key(kFramePrefix);
  key += number;
  key += '_';
  key += name;
  return key;
}

// Throws std::invalid_argument unless `key` reads back as (frame, kind, name).
void checkFrameKey(const std::string& key, std::size_t frame, FrameKeyKind kind,
                   std::string_view name) {
  const std::optional<FrameKey> parsed = parseFrameKey(key);
  if (!parsed || parsed->frame != frame || parsed->kind != kind || parsed->name != name) {
    throw std::invalid_argument("writeSequence: frame " + std::to_string(frame) + ": the name " +
                                quote(name) + " would read back as something else from key " +
                                quote(key));
  }
}

void appendMatrix(std::string& out, const Eigen::Matrix4d& matrix) {
  for (Eigen::Index row = 0; row < 4; ++row) {
    for (Eigen::Index column = 0; column < 4; ++column) {
      if (row + column > 0)
        out += ' ';
      appendDouble(out, matrix(row, column));
    }
  }
}

void appendFrameEntries(const SequenceFrame& frame, std::size_t index,
                        std::vector<TextEntry>& entries) {
  for (const auto& [name, transform] : frame.transforms) {
    TextEntry matrix{frameKey(index, name + std::string(kTransformSuffix)), {}};
    checkFrameKey(matrix.key, index, FrameKeyKind::Transform, name);
    appendMatrix(matrix.value, transform.matrix);
    entries.push_back(std::move(matrix));
    TextEntry status{frameKey(index, name + std::string(kStatusSuffix)), transform.status};
    checkFrameKey(status.key, index, FrameKeyKind::TransformStatus, name);
    entries.push_back(std::move(status));
  }
  if (frame.timestampS) {
    TextEntry timestamp{frameKey(index, "Timestamp"), {}};
    appendDouble(timestamp.value, *frame.timestampS);
    entries.push_back(std::move(timestamp));
  }
  for (std::size_t i = 0; i < frame.fields.size(); ++i) {
    const auto& [name, value] = frame.fields[i];
    for (std::size_t j = 0; j < i; ++j) {
      if (frame.fields[j].first == name) {
        throw std::invalid_argument("writeSequence: frame " + std::to_string(index) +
                                    " has the field " + quote(name) + " twice");
      }
    }
    TextEntry field{frameKey(index, name), value};
    checkFrameKey(field.key, index, FrameKeyKind::Field, name);
    entries.push_back(std::move(field));
  }
}

}  // namespace

void applyEntries(const std::string& path, const ParsedHeader& header, Sequence& sequence) {
  for (const HeaderEntry& entry : header.entries) {
    if (entry.nrrdField) {
      std::string key(kNrrdFieldPrefix);
      key += entry.key;
      sequence.extraHeader.emplace_back(std::move(key), entry.value);
    } else if (const std::optional<FrameKey> frameKey = parseFrameKey(entry.key)) {
      applyFrameEntry(path, header, *frameKey, entry, sequence);
    } else if (!applyAcquisitionEntry(path, entry, sequence.acquisition)) {
      sequence.extraHeader.emplace_back(entry.key, entry.value);
    }
  }
}

void checkFinite(const std::optional<double>& value, std::string_view what) {
  if (value && !std::isfinite(*value)) {
    throw std::invalid_argument("writeSequence: " + std::string(what) + " is not finite");
  }
}

// ---- Per-frame keys -----------------------------------------------------------------------------

std::optional<FrameKey> parseFrameKey(std::string_view key) {
  if (key.substr(0, kFramePrefix.size()) != kFramePrefix)
    return std::nullopt;
  key.remove_prefix(kFramePrefix.size());
  std::size_t digits = 0;
  while (digits < key.size() && key[digits] >= '0' && key[digits] <= '9')
    ++digits;
  if (digits == 0 || digits + 1 >= key.size() || key[digits] != '_')
    return std::nullopt;
  FrameKey result;
  if (!parseUnsigned(key.substr(0, digits), result.frame)) {
    result.frame = std::numeric_limits<std::uint64_t>::max();
  }
  const std::string_view rest = key.substr(digits + 1);
  if (rest == "Timestamp") {
    result.kind = FrameKeyKind::Timestamp;
    result.name = rest;
  } else if (rest.size() > kStatusSuffix.size() && endsWith(rest, kStatusSuffix)) {
    result.kind = FrameKeyKind::TransformStatus;
    result.name = rest.substr(0, rest.size() - kStatusSuffix.size());
  } else if (rest.size() > kTransformSuffix.size() && endsWith(rest, kTransformSuffix)) {
    result.kind = FrameKeyKind::Transform;
    result.name = rest.substr(0, rest.size() - kTransformSuffix.size());
  } else {
    result.kind = FrameKeyKind::Field;
    result.name = rest;
  }
  return result;
}

bool isEchoregKey(std::string_view key) {
  return key == kSamplingFrequencyKey || key == kDelayKey || key == kSpeedOfSoundKey ||
         key == kTransducerKey || key == kTransducerFrequencyKey;
}

std::vector<TextEntry> acquisitionEntries(const Sequence& sequence) {
  std::vector<TextEntry> entries;
  const AcquisitionSettings& acquisition = sequence.acquisition;
  const auto appendNumber = [&entries](std::string_view key, const std::optional<double>& value) {
    if (!value)
      return;
    TextEntry entry{std::string(key), {}};
    appendDouble(entry.value, *value);
    entries.push_back(std::move(entry));
  };
  appendNumber(kSamplingFrequencyKey, acquisition.samplingFrequencyHz);
  appendNumber(kTransducerFrequencyKey, acquisition.transducerFrequencyHz);
  appendNumber(kDelayKey, acquisition.delayS);
  appendNumber(kSpeedOfSoundKey, acquisition.speedOfSoundMps);
  if (!acquisition.transducer.empty()) {
    entries.push_back({std::string(kTransducerKey), acquisition.transducer});
  }
  return entries;
}

void appendFrameMetadata(const SequenceFrame& frame, std::size_t index,
                         std::vector<TextEntry>& entries) {
  appendFrameEntries(frame, index, entries);
}

std::vector<TextEntry> metadataEntries(const Sequence& sequence) {
  std::vector<TextEntry> entries = acquisitionEntries(sequence);
  entries.reserve(entries.size() + sequence.frames.size() * 4);
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    appendFrameEntries(sequence.frames[i], i, entries);
  }
  return entries;
}

}  // namespace echoreg::core::detail
