// PLUS sequence files (MetaImage .mha/.mhd and NRRD .nrrd) as plain structs.
//
// A PLUS sequence is an image of frames: A-lines are frames of N x 1 samples, tracker-only
// captures have no pixels (DimSize = 0 0 F). Each frame carries a timestamp and named transforms
// `Seq_FrameNNNN_<From>To<To>Transform` (16 numbers, row-major, p_To = M * p_From) with a status
// word (`OK`, `INVALID`, ...). Header keys echoreg does not interpret are kept verbatim, in order,
// and written back, so a file written by echoreg reads back identically.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace echoreg::core {

/// Pixel element types of an A-line capture. None is a tracker-only sequence.
enum class ElementType { None, UInt8, Int8, Int16, UInt16, Float32 };

/// "none", "uint8", "int8", "int16", "uint16", "float".
std::string_view elementTypeName(ElementType type);
/// Bytes per element (0 for None).
std::size_t elementSize(ElementType type);

/// One tracked transform of one frame: the 4x4 matrix (p_To = matrix * p_From) and PLUS's status
/// word, kept verbatim ("OK", "INVALID", "MISSING", ...). Only "OK" is valid.
struct TrackedTransform {
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  std::string status = "OK";
  bool valid() const { return status == "OK"; }
};

/// Per-frame metadata of a sequence.
struct SequenceFrame {
  std::optional<double> timestampS;
  /// Keyed by the transform name without the "Transform" suffix, e.g. "ProbeToTracker".
  std::map<std::string, TrackedTransform> transforms;
  /// Other per-frame fields (e.g. "ImageStatus" -> "OK"), verbatim, in file order.
  std::vector<std::pair<std::string, std::string>> fields;
};

/// Acquisition settings echoreg stores in its own header keys (EchoregSamplingFrequencyHz,
/// EchoregDelayS, EchoregSpeedOfSoundMps, EchoregTransducer, EchoregTransducerFrequencyHz).
struct AcquisitionSettings {
  std::optional<double> samplingFrequencyHz;
  /// The transducer's centre frequency, when the capture says it.
  std::optional<double> transducerFrequencyHz;
  std::optional<double> delayS;
  std::optional<double> speedOfSoundMps;
  std::string transducer;
};

/// A whole PLUS sequence in memory.
struct Sequence {
  ElementType elementType = ElementType::None;
  /// Frame size in elements: {samples, rows}. A-lines {N, 1}; tracker-only {0, 0}.
  std::array<int, 2> frameSize{0, 0};
  std::vector<SequenceFrame> frames;
  /// frames.size() * frameSize[0] * frameSize[1] elements of elementType, host (little-endian)
  /// byte order, frame after frame.
  std::vector<std::uint8_t> pixels;
  AcquisitionSettings acquisition;
  /// Header keys echoreg does not interpret, verbatim and in file order (e.g.
  /// "UltrasoundImageOrientation" -> "MFA").
  std::vector<std::pair<std::string, std::string>> extraHeader;

  std::size_t frameCount() const { return frames.size(); }
  std::size_t samplesPerFrame() const {
    return static_cast<std::size_t>(frameSize[0]) * static_cast<std::size_t>(frameSize[1]);
  }
  bool hasPixels() const { return elementType != ElementType::None && samplesPerFrame() > 0; }
  /// Frame `frame` converted to float samples (out is resized to samplesPerFrame()).
  void frameSamples(std::size_t frame, std::vector<float>& out) const;
  /// Sorted union of the transform names over all frames.
  std::vector<std::string> transformNames() const;
};

enum class SequenceFormat { MetaImage, Nrrd };

struct SequenceWriteOptions {
  /// Deduced from the extension when empty: .nrrd -> Nrrd; .mha/.mhd -> MetaImage.
  std::optional<SequenceFormat> format;
  /// zlib (MetaImage CompressedData = True) or gzip (NRRD encoding: gzip).
  bool compress = true;
};

/// The zlib level of compressed pixels (zlib's Z_BEST_SPEED): RF A-lines compress little, and the
/// fastest level loses a few percent of size and writes several times faster than the default.
/// Live's recording deflates with it too, so a recording holds writeSequence's bytes.
inline constexpr int kPixelCompressionLevel = 1;

/// Reads a PLUS sequence file (.mha, .mhd with .raw/.zraw, .nrrd; raw, zlib or gzip data).
/// Throws FileError naming the file and the problem for anything malformed.
Sequence readSequence(const std::string& path);

/// Writes a PLUS sequence file. Written to a temporary name beside the target and renamed, so a
/// failure leaves no partial file. For .mhd the pixel data goes to a .raw/.zraw beside it.
/// Throws FileError (and std::invalid_argument for an inconsistent Sequence).
void writeSequence(const Sequence& sequence, const std::string& path,
                   const SequenceWriteOptions& options = {});

/// Streaming MetaImage output, for a writer that cannot hold a whole capture in memory (live/'s
/// recorder). writeSequence writes an .mha of N frames as metaImageHeaderStart(layout, N, size),
/// then metaImageFrameLines(frame i, i) for i = 0 .. N-1, then "ElementDataFile = LOCAL\n" and the
/// pixels: raw, or (`compressedBytes` given) one zlib stream of them at level 1 (Z_BEST_SPEED),
/// window bits 15, memory level 8, default strategy. `layout`'s frames and pixels are ignored;
/// `frames` nullopt leaves out the DimSize line (the reader takes it anywhere before
/// ElementDataFile: a growing file can put metaImageDimSizeLine last). Both throw
/// std::invalid_argument for what writeSequence refuses (a number that is not finite, a name that
/// would not read back as itself).
std::string metaImageHeaderStart(const Sequence& layout, std::optional<std::size_t> frames,
                                 std::optional<std::uint64_t> compressedBytes);
std::string metaImageFrameLines(const SequenceFrame& frame, std::size_t index);
/// "DimSize = <samples> <rows> <frames>\n".
std::string metaImageDimSizeLine(const Sequence& layout, std::size_t frames);

}  // namespace echoreg::core
