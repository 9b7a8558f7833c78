// Sequence members, format dispatch, and what the MetaImage and NRRD readers/writers share:
// header scanning, pixel data (raw or zlib/gzip), per-frame keys, checks before writing.
#include "echoreg/core/sequence.hpp"

#include "echoreg/core/depth.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/parallel_deflate.hpp"
#include "echoreg/core/prefault.hpp"
#include "sequence_io_detail.hpp"

#define ZLIB_CONST
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <stdexcept>
#include <system_error>

namespace echoreg {

// Sequence::pixels is defined as little-endian; the readers swap big-endian files and the writers
// write the bytes as they are, which is only right on a little-endian host.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "echoreg assumes a little-endian host");

namespace {

template <typename Element>
void convertSamples(const std::uint8_t* data, std::vector<float>& out) {
  for (std::size_t i = 0; i < out.size(); ++i) {
    Element value;
    std::memcpy(&value, data + i * sizeof(Element), sizeof(Element));
    out[i] = static_cast<float>(value);
  }
}

}  // namespace

std::string_view elementTypeName(ElementType type) {
  switch (type) {
    case ElementType::None:
      return "none";
    case ElementType::UInt8:
      return "uint8";
    case ElementType::Int8:
      return "int8";
    case ElementType::Int16:
      return "int16";
    case ElementType::UInt16:
      return "uint16";
    case ElementType::Float32:
      return "float";
  }
  return "unknown";
}

std::size_t elementSize(ElementType type) {
  switch (type) {
    case ElementType::None:
      return 0;
    case ElementType::UInt8:
      return 1;
    case ElementType::Int8:
      return 1;
    case ElementType::Int16:
    case ElementType::UInt16:
      return 2;
    case ElementType::Float32:
      return 4;
  }
  return 0;
}

void Sequence::frameSamples(std::size_t frame, std::vector<float>& out) const {
  if (frame >= frames.size()) {
    throw std::out_of_range("Sequence::frameSamples: frame " + std::to_string(frame) +
                            " of a sequence of " + std::to_string(frames.size()) + " frames");
  }
  if (frameSize[0] < 0 || frameSize[1] < 0) {
    throw std::invalid_argument("Sequence::frameSamples: negative frame size");
  }
  const std::size_t count = samplesPerFrame();
  out.resize(count);
  if (count == 0)
    return;
  const std::size_t bytesPerFrame = count * elementSize(elementType);
  if (bytesPerFrame == 0 || pixels.size() / bytesPerFrame <= frame) {
    throw std::invalid_argument("Sequence::frameSamples: the pixels do not hold frame " +
                                std::to_string(frame));
  }
  const std::uint8_t* data = pixels.data() + frame * bytesPerFrame;
  switch (elementType) {
    case ElementType::UInt8:
      convertSamples<std::uint8_t>(data, out);
      break;
    case ElementType::Int8:
      convertSamples<std::int8_t>(data, out);
      break;
    case ElementType::Int16:
      convertSamples<std::int16_t>(data, out);
      break;
    case ElementType::UInt16:
      convertSamples<std::uint16_t>(data, out);
      break;
    case ElementType::Float32:
      convertSamples<float>(data, out);
      break;
    case ElementType::None:
      break;
  }
}

std::vector<std::string> Sequence::transformNames() const {
  std::set<std::string> names;
  for (const SequenceFrame& frame : frames) {
    for (const auto& entry : frame.transforms)
      names.insert(entry.first);
  }
  return {names.begin(), names.end()};
}

namespace detail {

namespace {

namespace fs = std::filesystem;

constexpr std::size_t kFirstChunkBytes = 64 * 1024;
// Header lines are at most a few hundred bytes; a longer "line" means binary data.
constexpr std::size_t kMaxHeaderLineBytes = 1024 * 1024;
// deflate cannot compress better than about 1032:1, so a smaller stream cannot hold the pixels
// DimSize promises: refuse before allocating them.
constexpr std::uint64_t kMaxDeflateRatio = 1032;
static_assert(kPixelCompressionLevel == Z_BEST_SPEED);
constexpr std::string_view kFramePrefix = "Seq_Frame";
constexpr std::string_view kTransformSuffix = "Transform";
constexpr std::string_view kStatusSuffix = "TransformStatus";

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

bool endsWith(std::string_view text, std::string_view suffix) {
  return text.size() >= suffix.size() && text.substr(text.size() - suffix.size()) == suffix;
}

bool isControlByte(char c) {
  const auto byte = static_cast<unsigned char>(c);
  return (byte < 0x20 && c != '\t') || byte == 0x7f;
}

// a * b, or nullopt when it does not fit in 64 bits.
std::optional<std::uint64_t> multiply(std::uint64_t a, std::uint64_t b) {
  std::uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product))
    return std::nullopt;
  return product;
}

uInt zlibChunk(std::size_t remaining) {
  return static_cast<uInt>(std::min<std::size_t>(remaining, std::numeric_limits<uInt>::max()));
}

std::string layoutText(const ParsedHeader& header, ElementType type) {
  return std::string(header.dimSizeKey) + " " + std::to_string(header.dimSize[0]) + " " +
         std::to_string(header.dimSize[1]) + " " + std::to_string(header.dimSize[2]) + " of " +
         std::string(elementTypeName(type));
}

// Inflates the zlib or gzip stream (detected from its header; several gzip members are read one
// after the other) of the `compressedBytes` bytes at `offset` of `file` into exactly
// `expectedBytes`. The compressed bytes are read in slices of 1 MiB as they are inflated, so the
// compressed data is never held whole beside the pixels (66 MB of a 24,000-frame sweep).
std::vector<std::uint8_t> inflateExactly(InputFile& file, std::uint64_t offset,
                                         std::uint64_t compressedBytes, std::uint64_t expectedBytes,
                                         const std::string& path) {
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) {
    throw FileError(path, "zlib cannot start decompressing");
  }
  struct InflateEnd {
    z_stream& zs;
    ~InflateEnd() { inflateEnd(&zs); }
  } inflateEndGuard{zs};

  // One byte more than expected, so that a stream that inflates to too much is caught.
  std::vector<std::uint8_t> out = prefaultedZeros(expectedBytes + 1);
  std::vector<std::uint8_t> slice(
      static_cast<std::size_t>(std::min<std::uint64_t>(compressedBytes, std::uint64_t{1} << 20)));
  zs.next_out = out.data();
  std::uint64_t read = 0;  // compressed bytes read from the file so far
  std::size_t produced = 0;
  for (;;) {
    if (zs.avail_in == 0 && read < compressedBytes) {
      const auto count =
          static_cast<std::size_t>(std::min<std::uint64_t>(slice.size(), compressedBytes - read));
      file.readBytes(offset + read, slice.data(), count);
      read += count;
      zs.next_in = slice.data();
      zs.avail_in = static_cast<uInt>(count);
    }
    zs.avail_out = zlibChunk(out.size() - produced);
    const int status = inflate(&zs, Z_NO_FLUSH);
    const std::uint64_t consumed = read - zs.avail_in;
    produced = static_cast<std::size_t>(zs.next_out - out.data());
    if (produced > expectedBytes) {
      throw FileError(path, "compressed data inflates to more than the " +
                                std::to_string(expectedBytes) + " bytes expected");
    }
    if (status == Z_STREAM_END) {
      if (consumed == compressedBytes)
        break;
      if (produced == expectedBytes) {
        throw FileError(path, std::to_string(compressedBytes - consumed) +
                                  " unexpected bytes follow the compressed data");
      }
      inflateReset(&zs);
      continue;
    }
    if (status == Z_BUF_ERROR && consumed == compressedBytes) {
      // All the pixels may be there with the stream's end (its checksum) cut off: say so rather
      // than "inflates to N bytes, expected N".
      if (produced == expectedBytes) {
        throw FileError(path, "compressed data is truncated: its " + std::to_string(produced) +
                                  " bytes inflate, but the stream's end (its checksum) is "
                                  "missing, so they cannot be trusted");
      }
      throw FileError(path, "compressed data is truncated: it inflates to " +
                                std::to_string(produced) + " bytes, expected " +
                                std::to_string(expectedBytes));
    }
    if (status != Z_OK) {
      throw FileError(path, std::string("compressed data does not inflate (zlib error: ") +
                                (zs.msg != nullptr ? zs.msg : zError(status)) + ")");
    }
  }
  if (produced != expectedBytes) {
    throw FileError(path, "compressed data inflates to " + std::to_string(produced) +
                              " bytes, expected " + std::to_string(expectedBytes));
  }
  out.resize(expectedBytes);
  return out;
}

// The stored bytes of the pixels, from `offset` to the end of `file` (raw or compressed), checked
// against the layout before anything is allocated for them: returns how many there are.
std::uint64_t checkPixelData(const InputFile& file, std::uint64_t offset,
                             const ParsedHeader& header, std::uint64_t expectedBytes,
                             const std::string& layout, const std::string& path) {
  const std::uint64_t available = file.sizeBytes() - std::min(offset, file.sizeBytes());
  const std::string where = header.dataFileName.empty() ? std::string("after the header")
                                                        : "in the data file " + file.path();
  if (!header.compressed) {
    if (available < expectedBytes) {
      throw FileError(path, "truncated data: " + layout + " needs " +
                                std::to_string(expectedBytes) + " bytes, found " +
                                std::to_string(available) + " bytes " + where);
    }
    if (available > expectedBytes) {
      throw FileError(path, "data length does not match the frame size: " + layout + " needs " +
                                std::to_string(expectedBytes) + " bytes, found " +
                                std::to_string(available) + " bytes " + where);
    }
    return expectedBytes;
  }
  if (header.compressedBytes) {
    if (*header.compressedBytes > available) {
      throw FileError(path, "truncated data: CompressedDataSize is " +
                                std::to_string(*header.compressedBytes) + " bytes, found " +
                                std::to_string(available) + " bytes " + where);
    }
    if (*header.compressedBytes < available) {
      throw FileError(path, "data length does not match CompressedDataSize: expected " +
                                std::to_string(*header.compressedBytes) + " bytes, found " +
                                std::to_string(available) + " bytes " + where);
    }
  }
  if (expectedBytes > available * kMaxDeflateRatio + 1024) {
    throw FileError(path, "truncated data or wrong frame size: " + std::to_string(available) +
                              " bytes of compressed data cannot inflate to the " +
                              std::to_string(expectedBytes) + " bytes " + layout + " needs");
  }
  return available;
}

void swapByteOrder(std::vector<std::uint8_t>& pixels, std::size_t bytesPerElement) {
  if (bytesPerElement < 2)
    return;
  for (std::size_t i = 0; i + bytesPerElement <= pixels.size(); i += bytesPerElement) {
    std::reverse(pixels.begin() + static_cast<std::ptrdiff_t>(i),
                 pixels.begin() + static_cast<std::ptrdiff_t>(i + bytesPerElement));
  }
}

InputFile openDataFile(const std::string& headerPath, const std::string& dataFileName) {
  fs::path dataPath(dataFileName);
  if (dataPath.is_relative())
    dataPath = fs::path(headerPath).parent_path() / dataPath;
  try {
    return InputFile(dataPath.string());
  } catch (const FileError& error) {
    throw FileError(headerPath, std::string("detached data file ") + error.what());
  }
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

void checkFinite(const std::optional<double>& value, std::string_view what) {
  if (value && !std::isfinite(*value)) {
    throw std::invalid_argument("writeSequence: " + std::string(what) + " is not finite");
  }
}

SequenceFormat formatFromExtension(const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".nrrd")
    return SequenceFormat::Nrrd;
  if (extension == ".mha" || extension == ".mhd")
    return SequenceFormat::MetaImage;
  throw FileError(path, "unknown sequence file extension " + quote(extension) +
                            " (expected .mha, .mhd or .nrrd)");
}

// What DimSize and the element type promise, checked before anything is allocated.
struct CheckedLayout {
  ElementType type = ElementType::None;
  std::uint64_t pixelBytes = 0;
  std::string text;  // e.g. "DimSize 11350 1 150 of int16", for messages
};

CheckedLayout checkLayout(const std::string& path, const ParsedHeader& header) {
  const std::string key(header.dimSizeKey);
  const auto [samples, rows, frameCount] = header.dimSize;
  if (frameCount == 0) {
    throw FileError(path, "the sequence has no frames (" + key + " declares 0 frames)");
  }
  constexpr auto kMaxSide = static_cast<std::uint64_t>(std::numeric_limits<int>::max());
  if (samples > kMaxSide || rows > kMaxSide) {
    throw FileError(path, "frame too large: " + layoutText(header, header.elementType));
  }
  const std::uint64_t samplesPerFrame = samples * rows;
  CheckedLayout layout;
  // A frame without samples is tracker-only, whatever element type the header names.
  layout.type = samplesPerFrame == 0 ? ElementType::None : header.elementType;
  if (layout.type == ElementType::None && samplesPerFrame > 0) {
    throw FileError(path, "the element type has no pixels (MET_OTHER) but " + key + " declares " +
                              std::to_string(samplesPerFrame) + " samples per frame");
  }
  layout.text = layoutText(header, layout.type);
  const std::optional<std::uint64_t> frameBytes =
      multiply(samplesPerFrame, elementSize(layout.type));
  const std::optional<std::uint64_t> pixelBytes =
      frameBytes ? multiply(*frameBytes, frameCount) : std::nullopt;
  if (!pixelBytes || *pixelBytes > std::vector<std::uint8_t>().max_size() / 2) {
    throw FileError(path, "frame size too large: " + layout.text);
  }
  layout.pixelBytes = *pixelBytes;
  if (layout.type == ElementType::None && frameCount > header.dataOffset) {
    throw FileError(path, key + " declares " + std::to_string(frameCount) +
                              " frames, more than a tracker-only header of " +
                              std::to_string(header.dataOffset) + " bytes can describe");
  }
  return layout;
}

// A header whose frames have no samples (a tracker-only capture) with pixel data after it: a
// damaged DimSize ("0 1 800" for "4096 1 800") would otherwise read as tracker-only, silently
// dropping every A-line. Line breaks and blanks after the header are allowed.
void refusePixelsOfTrackerOnlyHeader(InputFile& file, const ParsedHeader& header) {
  if (!header.dataFileName.empty() || file.sizeBytes() <= header.dataOffset)
    return;
  const std::uint64_t trailing = file.sizeBytes() - header.dataOffset;
  constexpr std::uint64_t kMaxBlankTail = 4096;
  if (trailing <= kMaxBlankTail) {
    std::string tail(static_cast<std::size_t>(trailing), '\0');
    file.readBytes(header.dataOffset, reinterpret_cast<std::uint8_t*>(tail.data()), tail.size());
    if (std::all_of(tail.begin(), tail.end(),
                    [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; })) {
      return;
    }
  }
  const std::uint64_t frames = header.dimSize[2];
  std::string guess;
  const std::size_t bytes = elementSize(header.elementType);
  if (bytes > 0 && frames > 0 && trailing % (frames * bytes) == 0) {
    guess = " (" + std::to_string(frames) + " frames of " +
            std::to_string(trailing / (frames * bytes)) + " " +
            std::string(elementTypeName(header.elementType)) + " samples would be " +
            std::to_string(trailing) + " bytes" + (header.compressed ? " compressed" : "") + ")";
  }
  throw FileError(file.path(),
                  std::string(header.dimSizeKey) + " " + std::to_string(header.dimSize[0]) + " " +
                      std::to_string(header.dimSize[1]) + " " + std::to_string(frames) +
                      " declares frames without samples (a tracker-only capture), but " +
                      std::to_string(trailing) +
                      " bytes of data follow the header: is the header's " +
                      std::string(header.dimSizeKey) + " wrong?" + guess);
}

// Where the pixels are stored (after the header, or in the detached data file) and how many bytes,
// checked against the layout (locatePixels), then read (readPixels).
struct StoredPixels {
  std::optional<InputFile> dataFile;
  std::uint64_t offset = 0;
  std::uint64_t storedBytes = 0;
};

StoredPixels locatePixels(InputFile& file, const ParsedHeader& header,
                          const CheckedLayout& layout) {
  StoredPixels stored;
  if (layout.pixelBytes == 0) {
    refusePixelsOfTrackerOnlyHeader(file, header);
    return stored;
  }
  if (header.dataFileName.empty()) {
    stored.offset = header.dataOffset;
    stored.storedBytes =
        checkPixelData(file, stored.offset, header, layout.pixelBytes, layout.text, file.path());
  } else {
    stored.dataFile = openDataFile(file.path(), header.dataFileName);
    stored.storedBytes =
        checkPixelData(*stored.dataFile, 0, header, layout.pixelBytes, layout.text, file.path());
  }
  return stored;
}

// The pixels in host byte order. `compressed` and `bigEndian` as the header says.
std::vector<std::uint8_t> readPixels(InputFile& file, StoredPixels& stored, bool compressed,
                                     bool bigEndian, const CheckedLayout& layout) {
  if (layout.pixelBytes == 0)
    return {};
  InputFile& source = stored.dataFile ? *stored.dataFile : file;
  std::vector<std::uint8_t> pixels;
  if (compressed) {
    pixels =
        inflateExactly(source, stored.offset, stored.storedBytes, layout.pixelBytes, file.path());
  } else {
    pixels = prefaultedZeros(layout.pixelBytes);
    source.readBytes(stored.offset, pixels.data(), pixels.size());
  }
  if (bigEndian)
    swapByteOrder(pixels, elementSize(layout.type));
  return pixels;
}

}  // namespace

// ---- Text ---------------------------------------------------------------------------------------

std::string_view trim(std::string_view text) {
  while (!text.empty() && isBlank(text.front()))
    text.remove_prefix(1);
  while (!text.empty() && isBlank(text.back()))
    text.remove_suffix(1);
  return text;
}

bool parseDouble(std::string_view text, double& value) {
  if (text.empty())
    return false;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  return ec == std::errc() && ptr == end;
}

bool parseUnsigned(std::string_view text, std::uint64_t& value) {
  if (text.empty())
    return false;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  return ec == std::errc() && ptr == end;
}

std::vector<std::string_view> splitWords(std::string_view text) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && isBlank(text[i]))
      ++i;
    const std::size_t start = i;
    while (i < text.size() && !isBlank(text[i]))
      ++i;
    if (i > start)
      words.push_back(text.substr(start, i - start));
  }
  return words;
}

void appendDouble(std::string& out, double value) {
  char buffer[32];
  // Whole numbers as integers ("50000000", not the shorter "5e+07"), as people and PLUS write
  // them; below 2^53 they are exact. Zero goes the other way so that -0 keeps its sign.
  constexpr double kExactIntegerLimit = 9007199254740992.0;
  const bool wholeNumber =
      value != 0.0 && std::fabs(value) < kExactIntegerLimit && std::trunc(value) == value;
  const auto result =
      wholeNumber ? std::to_chars(buffer, buffer + sizeof(buffer), static_cast<std::int64_t>(value))
                  : std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

std::string quote(std::string_view text) {
  constexpr std::size_t kMaxShown = 80;
  std::string out = "'";
  for (std::size_t i = 0; i < text.size() && i < kMaxShown; ++i) {
    const char c = text[i];
    if (isControlByte(c)) {
      static constexpr char kHex[] = "0123456789abcdef";
      const auto byte = static_cast<unsigned char>(c);
      out += "\\x";
      out += kHex[byte >> 4];
      out += kHex[byte & 0xf];
    } else {
      out += c;
    }
  }
  if (text.size() > kMaxShown)
    out += "...";
  out += "'";
  return out;
}

bool hasControlBytes(std::string_view text) {
  return std::any_of(text.begin(), text.end(), isControlByte);
}

std::array<std::uint64_t, 3> parseDimSize(const std::string& path, std::string_view key,
                                          std::string_view value) {
  const std::vector<std::string_view> words = splitWords(value);
  std::array<std::uint64_t, 3> dimSize{0, 0, 0};
  bool valid = words.size() == 3;
  for (std::size_t i = 0; valid && i < 3; ++i)
    valid = parseUnsigned(words[i], dimSize[i]);
  if (!valid) {
    throw FileError(path, std::string(key) +
                              " must be 3 non-negative integers (samples, rows, frames), found " +
                              quote(value));
  }
  return dimSize;
}

// ---- Input --------------------------------------------------------------------------------------

InputFile::InputFile(std::string path) : path_(std::move(path)) {
  std::error_code ec;
  const fs::file_status status = fs::status(path_, ec);
  if (status.type() == fs::file_type::not_found)
    throw FileError(path_, "does not exist");
  if (ec)
    throw FileError(path_, "cannot be accessed: " + ec.message());
  if (fs::is_directory(status))
    throw FileError(path_, "is a directory, not a sequence file");
  if (!fs::is_regular_file(status))
    throw FileError(path_, "is not a regular file");
  sizeBytes_ = fs::file_size(path_, ec);
  if (ec)
    throw FileError(path_, "cannot be accessed: " + ec.message());
  if (sizeBytes_ == 0)
    throw FileError(path_, "is empty");
  stream_.open(path_, std::ios::binary);
  if (!stream_)
    throw FileError(path_, std::string("cannot be opened: ") + std::strerror(errno));
  readMoreIntoBuffer();
}

bool InputFile::readMoreIntoBuffer() {
  const std::size_t old = buffer_.size();
  if (old >= sizeBytes_)
    return false;
  // Doubling keeps a long header (one line per frame key) linear to read.
  const std::size_t chunk = static_cast<std::size_t>(
      std::min<std::uint64_t>(std::max(kFirstChunkBytes, old), sizeBytes_ - old));
  buffer_.resize(old + chunk);
  stream_.read(buffer_.data() + old, static_cast<std::streamsize>(chunk));
  const auto got = static_cast<std::size_t>(stream_.gcount());
  buffer_.resize(old + got);
  stream_.clear();
  if (got < chunk)
    sizeBytes_ = buffer_.size();  // the file shrank while being read
  return got > 0;
}

HeaderLines InputFile::scanHeader(const LineClassifier& classify) {
  HeaderLines result;
  // Offsets, not views: the buffer may move while it grows.
  std::vector<std::pair<std::size_t, std::size_t>> spans;
  std::size_t lineStart = 0;
  std::size_t searchFrom = 0;
  std::size_t index = 0;
  for (;;) {
    const std::size_t newline = buffer_.find('\n', searchFrom);
    if (newline == std::string::npos) {
      if (buffer_.size() - lineStart > kMaxHeaderLineBytes) {
        result.end = HeaderEnd::LineTooLong;
        break;
      }
      searchFrom = buffer_.size();
      if (readMoreIntoBuffer())
        continue;
      result.dataOffset = buffer_.size();
      if (lineStart == buffer_.size()) {
        result.end = HeaderEnd::EndOfFile;
        break;
      }
      // The file ends in the middle of a line: complete only if that line ends the header.
      std::size_t length = buffer_.size() - lineStart;
      if (buffer_.back() == '\r')
        --length;
      const LineRole role = classify(std::string_view(buffer_).substr(lineStart, length), index);
      if (role != LineRole::EndBefore)
        spans.emplace_back(lineStart, length);
      result.end = role == LineRole::EndAfter ? HeaderEnd::Classified : HeaderEnd::TruncatedLine;
      result.lastLineUnterminated = true;
      break;
    }
    std::size_t length = newline - lineStart;
    if (length > 0 && buffer_[newline - 1] == '\r')
      --length;
    const LineRole role = classify(std::string_view(buffer_).substr(lineStart, length), index);
    if (role != LineRole::EndBefore)
      spans.emplace_back(lineStart, length);
    lineStart = newline + 1;
    searchFrom = lineStart;
    ++index;
    if (role != LineRole::Continue) {
      result.end = HeaderEnd::Classified;
      result.dataOffset = lineStart;
      break;
    }
  }
  result.lines.reserve(spans.size());
  const std::string_view buffer(buffer_);
  for (const auto& [start, length] : spans)
    result.lines.push_back(buffer.substr(start, length));
  return result;
}

void InputFile::readBytes(std::uint64_t offset, std::uint8_t* out, std::size_t count) {
  std::size_t copied = 0;
  if (offset < buffer_.size()) {
    copied = std::min(count, buffer_.size() - static_cast<std::size_t>(offset));
    std::memcpy(out, buffer_.data() + offset, copied);
  }
  if (copied == count)
    return;
  stream_.clear();
  stream_.seekg(static_cast<std::streamoff>(offset + copied));
  stream_.read(reinterpret_cast<char*>(out + copied), static_cast<std::streamsize>(count - copied));
  if (static_cast<std::size_t>(stream_.gcount()) != count - copied) {
    throw FileError(path_, "reading failed after " +
                               std::to_string(copied + static_cast<std::size_t>(stream_.gcount())) +
                               " of " + std::to_string(count) + " data bytes");
  }
}

void InputFile::releaseHead() {
  std::string().swap(buffer_);
}

DuplicateKeyCheck::DuplicateKeyCheck(const std::string& path, std::size_t expectedKeys)
    : path_(path) {
  keys_.reserve(expectedKeys);
}

void DuplicateKeyCheck::check(std::string_view key, std::string_view kind) {
  if (!keys_.insert(key).second) {
    throw FileError(path_, std::string(kind) + " " + quote(key) + " appears twice in the header");
  }
}

Sequence assembleSequence(InputFile& file, ParsedHeader& header) {
  const CheckedLayout layout = checkLayout(file.path(), header);
  Sequence sequence;
  sequence.elementType = layout.type;
  sequence.frameSize = {static_cast<int>(header.dimSize[0]), static_cast<int>(header.dimSize[1])};
  // The pixel data's size is checked before the frames are allocated (a damaged frame count is
  // refused, not allocated); the frames' keys are applied before the pixels are read, and the
  // header's text and entries released, so that they are not held beside the pixels (25 MB of
  // text and 7 MB of entries for a 24,000-frame sweep).
  StoredPixels stored = locatePixels(file, header, layout);
  sequence.frames.resize(static_cast<std::size_t>(header.dimSize[2]));
  try {
    applyEntries(file.path(), header, sequence);
  } catch (...) {
    // A fault of the pixel data itself is named first, as when the pixels were read first (a
    // frame count too small for the data is "inflates to more than N bytes", not "a key refers
    // to a frame beyond N").
    readPixels(file, stored, header.compressed, header.bigEndian, layout);
    throw;
  }
  const bool compressed = header.compressed, bigEndian = header.bigEndian;
  std::vector<HeaderEntry>().swap(header.entries);
  file.releaseHead();
  sequence.pixels = readPixels(file, stored, compressed, bigEndian, layout);
  return sequence;
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

// ---- Output -------------------------------------------------------------------------------------

void checkWritable(const Sequence& sequence, const std::string& path) {
  if (sequence.frames.empty())
    throw FileError(path, "the sequence has no frames");
  if (sequence.frameSize[0] < 0 || sequence.frameSize[1] < 0) {
    throw std::invalid_argument("writeSequence: negative frame size");
  }
  const std::size_t samples = sequence.samplesPerFrame();
  if (samples > 0 && sequence.elementType == ElementType::None) {
    throw std::invalid_argument("writeSequence: frames of " + std::to_string(samples) +
                                " samples need an element type");
  }
  const std::optional<std::uint64_t> frameBytes =
      multiply(samples, elementSize(sequence.elementType));
  const std::optional<std::uint64_t> expectedBytes =
      frameBytes ? multiply(*frameBytes, sequence.frames.size()) : std::nullopt;
  if (!expectedBytes || sequence.pixels.size() != *expectedBytes) {
    throw std::invalid_argument(
        "writeSequence: pixels hold " + std::to_string(sequence.pixels.size()) +
        " bytes, but frames x samples x element size is " +
        (expectedBytes ? std::to_string(*expectedBytes) : std::string("too large")));
  }
  checkFinite(sequence.acquisition.samplingFrequencyHz, "the sampling frequency");
  checkFinite(sequence.acquisition.delayS, "the delay");
  checkFinite(sequence.acquisition.speedOfSoundMps, "the speed of sound");
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    const SequenceFrame& frame = sequence.frames[i];
    checkFinite(frame.timestampS, "the timestamp of frame " + std::to_string(i));
    for (const auto& [name, transform] : frame.transforms) {
      if (!transform.matrix.allFinite()) {
        throw std::invalid_argument("writeSequence: transform " + quote(name) + " of frame " +
                                    std::to_string(i) + " is not finite");
      }
    }
  }
  checkExtraHeader(sequence);
}

void checkTrackerOnlyHeader(const Sequence& sequence, std::size_t headerBytes) {
  if (!sequence.hasPixels() && sequence.frames.size() > headerBytes) {
    throw std::invalid_argument("writeSequence: a tracker-only sequence of " +
                                std::to_string(sequence.frames.size()) +
                                " frames needs per-frame metadata; its header of " +
                                std::to_string(headerBytes) + " bytes could not be read back");
  }
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

void checkHeaderText(std::string_view key, std::string_view value, std::string_view format) {
  const auto fail = [&](const std::string& why) {
    throw std::invalid_argument("writeSequence: header key " + quote(key) +
                                " cannot be written in " + std::string(format) + ": " + why);
  };
  if (key.empty())
    fail("the key is empty");
  if (hasControlBytes(key) || hasControlBytes(value))
    fail("it holds a line break or control byte");
  if (trim(key) != key)
    fail("the key begins or ends with blanks");
  if (trim(value) != value)
    fail("the value " + quote(value) + " begins or ends with blanks");
}

void checkExtraHeader(const Sequence& sequence) {
  std::set<std::string_view> keys;
  for (const auto& [key, value] : sequence.extraHeader) {
    if (!keys.insert(key).second) {
      throw std::invalid_argument("writeSequence: extraHeader holds " + quote(key) + " twice");
    }
    if (parseFrameKey(key)) {
      throw std::invalid_argument("writeSequence: extraHeader key " + quote(key) +
                                  " is a per-frame key; put it in Sequence::frames");
    }
    if (isEchoregKey(key)) {
      throw std::invalid_argument("writeSequence: extraHeader key " + quote(key) +
                                  " is an echoreg key; set Sequence::acquisition");
    }
  }
}

std::vector<std::uint8_t> compressBytes(const std::vector<std::uint8_t>& bytes,
                                        Compression compression) {
  if (compression == Compression::Zlib) {
    // One zlib stream compressed on every core (parallel_deflate.hpp): the same bytes as one
    // thread's deflate for pixels up to one block (4 MiB), and the same bytes on any machine.
    std::vector<std::uint8_t> out;
    out.reserve(bytes.size() / 2 + 64);
    core::ParallelDeflateOptions options;
    options.level = kPixelCompressionLevel;
    core::deflateParallel(
        bytes.size(),
        [&bytes](std::uint64_t offset, std::uint8_t* to, std::size_t count) {
          std::memcpy(to, bytes.data() + offset, count);
        },
        [&out](const std::uint8_t* data, std::size_t count) {
          out.insert(out.end(), data, data + count);
        },
        options);
    return out;
  }
  z_stream zs{};
  // windowBits 15 + 16 asks for a gzip wrapper; its header has no name and mtime 0, so the same
  // bytes always compress to the same file.
  const int windowBits = compression == Compression::Gzip ? 15 + 16 : 15;
  if (deflateInit2(&zs, kPixelCompressionLevel, Z_DEFLATED, windowBits, 8, Z_DEFAULT_STRATEGY) !=
      Z_OK) {
    throw std::runtime_error("writeSequence: zlib cannot start compressing");
  }
  struct DeflateEnd {
    z_stream& zs;
    ~DeflateEnd() { deflateEnd(&zs); }
  } deflateEndGuard{zs};

  std::vector<std::uint8_t> out(deflateBound(&zs, static_cast<uLong>(bytes.size())));
  zs.next_in = bytes.data();
  zs.next_out = out.data();
  std::size_t consumed = 0;
  std::size_t produced = 0;
  for (int status = Z_OK; status != Z_STREAM_END;) {
    zs.avail_in = zlibChunk(bytes.size() - consumed);
    zs.avail_out = zlibChunk(out.size() - produced);
    const bool lastInput = consumed + zs.avail_in == bytes.size();
    status = deflate(&zs, lastInput ? Z_FINISH : Z_NO_FLUSH);
    if (status != Z_OK && status != Z_STREAM_END) {
      throw std::runtime_error("writeSequence: zlib compression failed");
    }
    consumed = static_cast<std::size_t>(zs.next_in - bytes.data());
    produced = static_cast<std::size_t>(zs.next_out - out.data());
  }
  out.resize(produced);
  return out;
}

}  // namespace detail

Sequence readSequence(const std::string& path) {
  detail::InputFile file(path);
  return file.head().substr(0, 4) == "NRRD" ? detail::readNrrd(file) : detail::readMetaImage(file);
}

void writeSequence(const Sequence& sequence, const std::string& path,
                   const SequenceWriteOptions& options) {
  const SequenceFormat format =
      options.format ? *options.format : detail::formatFromExtension(path);
  detail::checkWritable(sequence, path);
  if (format == SequenceFormat::Nrrd) {
    detail::writeNrrd(sequence, path, options.compress);
  } else {
    detail::writeMetaImage(sequence, path, options.compress);
  }
}

std::string metaImageHeaderStart(const Sequence& layout, std::optional<std::size_t> frames,
                                 std::optional<std::uint64_t> compressedBytes) {
  if (layout.frameSize[0] < 0 || layout.frameSize[1] < 0)
    throw std::invalid_argument("writeSequence: negative frame size");
  detail::checkFinite(layout.acquisition.samplingFrequencyHz, "the sampling frequency");
  detail::checkFinite(layout.acquisition.delayS, "the delay");
  detail::checkFinite(layout.acquisition.speedOfSoundMps, "the speed of sound");
  detail::checkExtraHeader(layout);
  return detail::metaImageHeaderPrefix(layout, frames, compressedBytes);
}

std::string metaImageFrameLines(const SequenceFrame& frame, std::size_t index) {
  detail::checkFinite(frame.timestampS, "the timestamp of frame " + std::to_string(index));
  for (const auto& [name, transform] : frame.transforms) {
    if (!transform.matrix.allFinite()) {
      throw std::invalid_argument("writeSequence: transform " + detail::quote(name) + " of frame " +
                                  std::to_string(index) + " is not finite");
    }
  }
  std::string out;
  detail::appendMetaImageFrameLines(frame, index, out);
  return out;
}

std::string metaImageDimSizeLine(const Sequence& layout, std::size_t frames) {
  return "DimSize = " + detail::metaImageDimSize(layout, frames) + "\n";
}

}  // namespace echoreg
