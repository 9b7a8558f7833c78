// Sequence members, format dispatch, and what the MetaImage and NRRD readers/writers share: the
// layout check, the reader's assembly (assembleSequence) and the checks before writing. Header
// text, PLUS keys and pixel data are in the files sequence_io_detail.hpp names.
#include "echoreg/core/sequence.hpp"

#include "echoreg/core/error.hpp"
#include "sequence_io_detail.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <stdexcept>

namespace echoreg::core {

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

std::string layoutText(const ParsedHeader& header, ElementType type) {
  return std::string(header.dimSizeKey) + " " + std::to_string(header.dimSize[0]) + " " +
         std::to_string(header.dimSize[1]) + " " + std::to_string(header.dimSize[2]) + " of " +
         std::string(elementTypeName(type));
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

}  // namespace

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

}  // namespace echoreg::core
