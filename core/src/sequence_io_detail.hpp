// Private declarations shared by the sequence reader/writer (sequence.cpp), the MetaImage format
// (metaimage_io.cpp) and the NRRD format (nrrd_io.cpp).
//
// Reading goes in two steps. A format parser reads the header text and reduces it to a
// ParsedHeader: the layout (element type, DimSize/sizes, where and how the pixel data is stored)
// plus every other header entry, in file order. assembleSequence() then checks the layout and the
// pixel data's size, interprets the per-frame and echoreg keys, releases the header's text and
// reads the pixel data, identically for both formats.
//
// How Sequence::extraHeader keeps NRRD fields apart from key/values:
//   - NRRD key/values (`key:=value`) and MetaImage keys (`Key = Value`) are stored under their
//     plain key. Both are "a named string", so MetaImage -> NRRD writes them as `key:=value` and
//     NRRD -> MetaImage writes them as `key = value`.
//   - NRRD fields that echoreg does not interpret (`space directions: ...`, `kinds: ...`) are
//     stored under kNrrdFieldPrefix + field name, e.g. "nrrd-field:space directions". The NRRD
//     writer writes them back as fields; the MetaImage writer drops them, because MetaImage has no
//     such fields and a plain key would not carry their meaning (axes, spacing of the NRRD grid).
//   - NRRD comments are not kept.
//
// A sequence whose frames have no samples (DimSize = 0 0 F) reads as ElementType::None whatever
// element type the header names, and is written as MET_OTHER (MetaImage) or uint8 (NRRD, which
// requires a type), uncompressed and without a data file: there are no pixels to store.
#pragma once

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

namespace echoreg::core::detail {

inline constexpr std::string_view kNrrdFieldPrefix = "nrrd-field:";

inline constexpr std::string_view kSamplingFrequencyKey = "EchoregSamplingFrequencyHz";
inline constexpr std::string_view kDelayKey = "EchoregDelayS";
inline constexpr std::string_view kSpeedOfSoundKey = "EchoregSpeedOfSoundMps";
inline constexpr std::string_view kTransducerKey = "EchoregTransducer";
inline constexpr std::string_view kTransducerFrequencyKey = "EchoregTransducerFrequencyHz";

// ---- Text ---------------------------------------------------------------------------------------

/// Without leading and trailing spaces, tabs and carriage returns.
std::string_view trim(std::string_view text);
/// True when `text` is entirely one finite or infinite number (std::from_chars syntax).
bool parseDouble(std::string_view text, double& value);
/// True when `text` is entirely one non-negative decimal integer that fits in 64 bits.
bool parseUnsigned(std::string_view text, std::uint64_t& value);
/// Splits on runs of spaces and tabs.
std::vector<std::string_view> splitWords(std::string_view text);
/// Text that reads back to the same double, appended to `out`: whole numbers below 2^53 as
/// integers, anything else as std::to_chars' shortest round-trip form.
void appendDouble(std::string& out, double value);
/// True when `text` holds a byte below 0x20 other than tab, or DEL.
bool hasControlBytes(std::string_view text);
/// DimSize / sizes: exactly 3 non-negative integers; throws FileError naming `key` otherwise.
std::array<std::uint64_t, 3> parseDimSize(const std::string& path, std::string_view key,
                                          std::string_view value);
/// `text` quoted for an error message, shortened and with control bytes escaped.
std::string quote(std::string_view text);

// ---- Input --------------------------------------------------------------------------------------

/// What a format's line classifier says about one header line.
enum class LineRole {
  Continue,   ///< a header line; the header goes on
  EndAfter,   ///< the last header line (MetaImage ElementDataFile, or a line the parser rejects)
  EndBefore,  ///< not a header line, the header ended before it (NRRD's blank line)
};
using LineClassifier = std::function<LineRole(std::string_view line, std::size_t index)>;

enum class HeaderEnd {
  Classified,     ///< the classifier ended the header
  EndOfFile,      ///< the file ended after a complete line without the classifier ending it
  TruncatedLine,  ///< the file ended in the middle of a line
  LineTooLong,    ///< a line is longer than any header line can be (a binary file)
};

struct HeaderLines {
  /// Header lines without line endings, views into the InputFile's buffer.
  std::vector<std::string_view> lines;
  std::uint64_t dataOffset = 0;  ///< first byte after the header
  HeaderEnd end = HeaderEnd::EndOfFile;
  /// The last line ends at the end of the file, without a line break.
  bool lastLineUnterminated = false;
};

/// A file opened for reading. The header is read in chunks until it ends; pixel data is read
/// from the file straight into its destination, so a large file is held in memory once.
class InputFile {
 public:
  /// Throws FileError for a missing file, a directory, an empty or an unreadable file.
  explicit InputFile(std::string path);

  const std::string& path() const { return path_; }
  std::uint64_t sizeBytes() const { return sizeBytes_; }
  /// The first bytes of the file (at least the first chunk, or the whole file if smaller).
  std::string_view head() const { return buffer_; }
  /// Reads lines from the start of the file until `classify` ends the header.
  HeaderLines scanHeader(const LineClassifier& classify);
  /// Copies `count` bytes starting at `offset` (which must lie within the file) into `out`.
  void readBytes(std::uint64_t offset, std::uint8_t* out, std::size_t count);
  /// Frees the header's bytes held since scanHeader (every view into them dangles); readBytes
  /// then reads from the file.
  void releaseHead();

 private:
  bool readMoreIntoBuffer();

  std::string path_;
  std::ifstream stream_;
  std::uint64_t sizeBytes_ = 0;
  std::string buffer_;  // the file's first bytes (the header and possibly some data)
};

/// One header entry echoreg does not treat as structural, in file order.
struct HeaderEntry {
  std::string_view key;
  std::string_view value;
  bool nrrdField = false;  ///< a NRRD field (`name: value`), not a key/value
};

/// A header reduced to what assembleSequence needs.
struct ParsedHeader {
  ElementType elementType = ElementType::None;
  /// Samples, rows, frames, as declared by DimSize / sizes.
  std::array<std::uint64_t, 3> dimSize{0, 0, 0};
  /// "DimSize" or "sizes", for messages.
  std::string_view dimSizeKey;
  std::vector<HeaderEntry> entries;
  std::uint64_t dataOffset = 0;
  /// Empty: the data follows the header. Otherwise the detached data file, relative to the
  /// header's folder unless absolute.
  std::string dataFileName;
  bool compressed = false;
  /// MetaImage CompressedDataSize when given.
  std::optional<std::uint64_t> compressedBytes;
  bool bigEndian = false;
};

/// Checks the layout and the pixel data's size, interprets the entries, then releases the header's
/// text (file.releaseHead) and entries and reads the pixel data.
///
/// Without pixels nothing but the header vouches for the frame count, so a tracker-only
/// header of N bytes may declare at most N frames (a real capture has at least one per-frame key
/// line per frame); this refuses absurd counts before allocating them.
Sequence assembleSequence(InputFile& file, ParsedHeader& header);

/// Throws FileError when `key` was already seen in the same header.
class DuplicateKeyCheck {
 public:
  DuplicateKeyCheck(const std::string& path, std::size_t expectedKeys);
  void check(std::string_view key, std::string_view kind);

 private:
  const std::string& path_;
  std::unordered_set<std::string_view> keys_;
};

Sequence readMetaImage(InputFile& file);

/// The MetaImage header writeSequence writes, up to the per-frame keys (see
/// echoreg::core::metaImageHeaderStart); `frames` nullopt leaves out DimSize.
std::string metaImageHeaderPrefix(const Sequence& layout, std::optional<std::size_t> frames,
                                  std::optional<std::uint64_t> compressedBytes);
/// DimSize's value for `frames` frames of `layout`.
std::string metaImageDimSize(const Sequence& layout, std::size_t frames);
/// Frame `index`'s `key = value` lines, appended to `out`.
void appendMetaImageFrameLines(const SequenceFrame& frame, std::size_t index, std::string& out);
Sequence readNrrd(InputFile& file);

// ---- Per-frame keys -----------------------------------------------------------------------------

enum class FrameKeyKind { Timestamp, Transform, TransformStatus, Field };

/// `Seq_Frame<digits>_<rest>` split into the frame index and what `rest` names.
struct FrameKey {
  std::uint64_t frame = 0;  ///< UINT64_MAX when the number does not fit
  FrameKeyKind kind = FrameKeyKind::Field;
  std::string_view name;  ///< transform name (without "Transform"/"TransformStatus") or field
};

/// nullopt unless `key` is `Seq_Frame<digits>_<non-empty rest>`.
std::optional<FrameKey> parseFrameKey(std::string_view key);
bool isEchoregKey(std::string_view key);

// ---- Output -------------------------------------------------------------------------------------

struct TextEntry {
  std::string key;
  std::string value;
};

/// Checks that `sequence` can be written so that it reads back identically: throws FileError
/// (naming `path`) for an empty sequence and std::invalid_argument for an inconsistent one.
void checkWritable(const Sequence& sequence, const std::string& path);

/// Throws std::invalid_argument when a tracker-only sequence declares more frames than its
/// header of `headerBytes` has bytes, which assembleSequence would refuse to read.
void checkTrackerOnlyHeader(const Sequence& sequence, std::size_t headerBytes);

/// The acquisition keys and the per-frame keys, in writing order: frame after frame; within a
/// frame transforms by name (matrix, then status), the timestamp, then fields in their order.
std::vector<TextEntry> metadataEntries(const Sequence& sequence);

/// The acquisition keys alone (the start of metadataEntries).
std::vector<TextEntry> acquisitionEntries(const Sequence& sequence);

/// Frame `index`'s keys as metadataEntries writes them, appended to `entries` (no finiteness
/// check: checkWritable does that for a whole sequence).
void appendFrameMetadata(const SequenceFrame& frame, std::size_t index,
                         std::vector<TextEntry>& entries);

/// Throws std::invalid_argument when `key`/`value` would not read back as themselves from a
/// header line (line breaks, surrounding blanks, an empty key).
void checkHeaderText(std::string_view key, std::string_view value, std::string_view format);

/// Throws std::invalid_argument when extraHeader holds the same key twice, a per-frame key or an
/// echoreg key, which would read back as something else.
void checkExtraHeader(const Sequence& sequence);

/// zlib (MetaImage) or gzip (NRRD) compression, deterministic (gzip header without a time).
enum class Compression { Zlib, Gzip };
std::vector<std::uint8_t> compressBytes(const std::vector<std::uint8_t>& bytes,
                                        Compression compression);

void writeMetaImage(const Sequence& sequence, const std::string& path, bool compress);
void writeNrrd(const Sequence& sequence, const std::string& path, bool compress);

// ---- Shared by the pieces of the reader and writer ---------------------------------------------
// sequence.cpp: the model (element types, Sequence's members), the format dispatch, the layout
// check and the reader's assembly; sequence_plus_keys.cpp: PLUS's per-frame keys and echoreg's
// acquisition keys, read and written; sequence_header_text.cpp: header text and the input file;
// sequence_compressed_data.cpp: the pixel data, raw or zlib/gzip.

// a * b, or nullopt when it does not fit in 64 bits.
std::optional<std::uint64_t> multiply(std::uint64_t a, std::uint64_t b);

/// Throws std::invalid_argument ("writeSequence: WHAT is not finite") unless `value` is absent or
/// finite.
void checkFinite(const std::optional<double>& value, std::string_view what);

/// The header's entries into `sequence`: the per-frame keys, echoreg's acquisition keys, the rest
/// (and NRRD's fields) as extraHeader.
void applyEntries(const std::string& path, const ParsedHeader& header, Sequence& sequence);

// What DimSize and the element type promise, checked before anything is allocated.
struct CheckedLayout {
  ElementType type = ElementType::None;
  std::uint64_t pixelBytes = 0;
  std::string text;  // e.g. "DimSize 11350 1 150 of int16", for messages
};

// Where the pixels are stored (after the header, or in the detached data file) and how many bytes,
// checked against the layout (locatePixels), then read (readPixels).
struct StoredPixels {
  std::optional<InputFile> dataFile;
  std::uint64_t offset = 0;
  std::uint64_t storedBytes = 0;
};

StoredPixels locatePixels(InputFile& file, const ParsedHeader& header, const CheckedLayout& layout);

// The pixels in host byte order. `compressed` and `bigEndian` as the header says.
std::vector<std::uint8_t> readPixels(InputFile& file, StoredPixels& stored, bool compressed,
                                     bool bigEndian, const CheckedLayout& layout);

}  // namespace echoreg::core::detail
