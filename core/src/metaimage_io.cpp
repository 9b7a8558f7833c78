// MetaImage sequences as PLUS writes them: `.mha` (header and data in one file) or `.mhd` with a
// `.raw`/`.zraw` data file; raw or zlib data.
#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "sequence_io_detail.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace echoreg::core::detail {

namespace {

constexpr std::string_view kElementDataFile = "ElementDataFile";
constexpr std::string_view kLocal = "LOCAL";
constexpr std::string_view kNotAHeader =
    "is not a MetaImage or NRRD file: it does not begin with a 'Key = Value' line";

struct MetaImageType {
  std::string_view name;
  ElementType type;
};
constexpr std::array<MetaImageType, 6> kMetaImageTypes{{
    {"MET_UCHAR", ElementType::UInt8},
    {"MET_CHAR", ElementType::Int8},
    {"MET_SHORT", ElementType::Int16},
    {"MET_USHORT", ElementType::UInt16},
    {"MET_FLOAT", ElementType::Float32},
    {"MET_OTHER", ElementType::None},
}};

// The keys that describe the layout; every other key goes to the entries.
struct StructuralKeys {
  std::optional<std::string_view> objectType;
  std::optional<std::string_view> nDims;
  std::optional<std::string_view> binaryData;
  std::optional<std::string_view> byteOrderMsb;
  std::optional<std::string_view> elementByteOrderMsb;
  std::optional<std::string_view> compressedData;
  std::optional<std::string_view> compressedDataSize;
  std::optional<std::string_view> dimSize;
  std::optional<std::string_view> elementType;
  std::optional<std::string_view> channels;
  std::optional<std::string_view> elementDataFile;
};

std::optional<std::string_view>* structuralSlot(StructuralKeys& keys, std::string_view key) {
  if (key == "ObjectType")
    return &keys.objectType;
  if (key == "NDims")
    return &keys.nDims;
  if (key == "BinaryData")
    return &keys.binaryData;
  if (key == "BinaryDataByteOrderMSB")
    return &keys.byteOrderMsb;
  if (key == "ElementByteOrderMSB")
    return &keys.elementByteOrderMsb;
  if (key == "CompressedData")
    return &keys.compressedData;
  if (key == "CompressedDataSize")
    return &keys.compressedDataSize;
  if (key == "DimSize")
    return &keys.dimSize;
  if (key == "ElementType")
    return &keys.elementType;
  if (key == "ElementNumberOfChannels")
    return &keys.channels;
  if (key == kElementDataFile)
    return &keys.elementDataFile;
  return nullptr;
}

bool isStructuralKey(std::string_view key) {
  StructuralKeys keys;
  return structuralSlot(keys, key) != nullptr;
}

// `Key = Value` split at the first '='; nullopt for anything else.
std::optional<std::pair<std::string_view, std::string_view>> splitLine(std::string_view line) {
  const std::size_t equals = line.find('=');
  if (equals == std::string_view::npos || hasControlBytes(line))
    return std::nullopt;
  const std::string_view key = trim(line.substr(0, equals));
  if (key.empty())
    return std::nullopt;
  return std::make_pair(key, trim(line.substr(equals + 1)));
}

// The header ends with ElementDataFile; a line that is not `Key = Value` ends the scan early (the
// parser rejects it), so a binary file is not read as one long header.
LineRole classifyLine(std::string_view line, std::size_t /*index*/) {
  const auto keyValue = splitLine(line);
  if (!keyValue)
    return trim(line).empty() ? LineRole::Continue : LineRole::EndAfter;
  return keyValue->first == kElementDataFile ? LineRole::EndAfter : LineRole::Continue;
}

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

bool parseBool(const std::string& path, std::string_view key, std::string_view value) {
  if (equalsIgnoringCase(value, "True"))
    return true;
  if (equalsIgnoringCase(value, "False"))
    return false;
  throw FileError(path, std::string(key) + " must be True or False, found " + quote(value));
}

ElementType parseElementType(const std::string& path, std::string_view name) {
  for (const MetaImageType& known : kMetaImageTypes) {
    if (known.name == name)
      return known.type;
  }
  throw FileError(
      path, "unknown element type " + quote(name) +
                " (supported: MET_UCHAR, MET_CHAR, MET_SHORT, MET_USHORT, MET_FLOAT, MET_OTHER)");
}

std::string_view metaImageTypeName(ElementType type) {
  for (const MetaImageType& known : kMetaImageTypes) {
    if (known.type == type)
      return known.name;
  }
  return "MET_OTHER";
}

// Reads the header lines into structural keys and entries; throws for malformed lines.
StructuralKeys collectKeys(const std::string& path, const HeaderLines& header,
                           ParsedHeader& parsed) {
  StructuralKeys keys;
  DuplicateKeyCheck duplicates(path, header.lines.size());
  parsed.entries.reserve(header.lines.size());
  bool sawKey = false;
  for (std::size_t i = 0; i < header.lines.size(); ++i) {
    const std::string_view line = header.lines[i];
    const auto keyValue = splitLine(line);
    if (!keyValue) {
      if (trim(line).empty())
        continue;
      if (!sawKey)
        throw FileError(path, std::string(kNotAHeader));
      if (i + 1 == header.lines.size() && header.lastLineUnterminated) {
        throw FileError(path, "truncated header: the file ends in the middle of line " +
                                  std::to_string(i + 1) + ", before any ElementDataFile key");
      }
      throw FileError(path, "malformed header line " + std::to_string(i + 1) +
                                " (expected 'Key = Value'; binary data before any ElementDataFile "
                                "key?): " +
                                quote(line));
    }
    sawKey = true;
    const auto [key, value] = *keyValue;
    duplicates.check(key, "key");
    if (std::optional<std::string_view>* slot = structuralSlot(keys, key)) {
      *slot = value;
    } else {
      parsed.entries.push_back({key, value, false});
    }
  }
  if (!sawKey)
    throw FileError(path, std::string(kNotAHeader));
  return keys;
}

void interpretLayout(const std::string& path, const StructuralKeys& keys, ParsedHeader& parsed) {
  if (keys.objectType && *keys.objectType != "Image") {
    throw FileError(path, "ObjectType is " + quote(*keys.objectType) + ", expected Image");
  }
  if (!keys.nDims)
    throw FileError(path, "has no NDims key (a sequence has NDims = 3)");
  if (*keys.nDims != "3") {
    throw FileError(path, "NDims must be 3 (samples, rows, frames), found " + quote(*keys.nDims));
  }
  if (!keys.dimSize)
    throw FileError(path, "has no DimSize key");
  parsed.dimSizeKey = "DimSize";
  parsed.dimSize = parseDimSize(path, "DimSize", *keys.dimSize);
  const bool hasSamples = parsed.dimSize[0] > 0 && parsed.dimSize[1] > 0;
  if (keys.channels && *keys.channels != "1") {
    throw FileError(path, "ElementNumberOfChannels must be 1, found " + quote(*keys.channels));
  }
  if (keys.elementType) {
    parsed.elementType = parseElementType(path, *keys.elementType);
  } else if (hasSamples) {
    throw FileError(path, "has no ElementType key");
  }
  if (hasSamples && keys.binaryData && !parseBool(path, "BinaryData", *keys.binaryData)) {
    throw FileError(path, "BinaryData = False (pixels as text) is not supported");
  }
  const bool msb =
      keys.byteOrderMsb && parseBool(path, "BinaryDataByteOrderMSB", *keys.byteOrderMsb);
  const bool elementMsb =
      keys.elementByteOrderMsb && parseBool(path, "ElementByteOrderMSB", *keys.elementByteOrderMsb);
  if (keys.byteOrderMsb && keys.elementByteOrderMsb && msb != elementMsb) {
    throw FileError(path, "BinaryDataByteOrderMSB and ElementByteOrderMSB disagree");
  }
  parsed.bigEndian = msb || elementMsb;
  parsed.compressed =
      keys.compressedData && parseBool(path, "CompressedData", *keys.compressedData);
  if (parsed.compressed && keys.compressedDataSize) {
    std::uint64_t bytes = 0;
    if (!parseUnsigned(*keys.compressedDataSize, bytes)) {
      throw FileError(path, "CompressedDataSize must be a non-negative integer, found " +
                                quote(*keys.compressedDataSize));
    }
    parsed.compressedBytes = bytes;
  }
  const std::string_view dataFile = *keys.elementDataFile;
  if (dataFile == "LIST" || dataFile.find('%') != std::string_view::npos || dataFile.empty()) {
    throw FileError(path, "ElementDataFile " + quote(dataFile) +
                              " is not supported (expected LOCAL or one data file)");
  }
  if (dataFile != kLocal)
    parsed.dataFileName = std::string(dataFile);
}

void appendLine(std::string& header, std::string_view key, std::string_view value) {
  header += key;
  header += " = ";
  header += value;
  header += '\n';
}

// Throws std::invalid_argument unless `key = value` reads back as itself and is not structural.
void checkEntry(std::string_view key, std::string_view value) {
  checkHeaderText(key, value, "MetaImage");
  if (key.find('=') != std::string_view::npos) {
    throw std::invalid_argument("writeSequence: MetaImage header key " + quote(key) + " holds '='");
  }
  if (isStructuralKey(key)) {
    throw std::invalid_argument("writeSequence: extraHeader key " + quote(key) +
                                " is a MetaImage structural key");
  }
}

void writeBytes(AtomicFile& file, const std::vector<std::uint8_t>& bytes) {
  file.stream().write(reinterpret_cast<const char*>(bytes.data()),
                      static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

Sequence readMetaImage(InputFile& file) {
  const std::string& path = file.path();
  const HeaderLines header = file.scanHeader(classifyLine);
  if (header.end == HeaderEnd::LineTooLong) {
    if (header.lines.empty())
      throw FileError(path, std::string(kNotAHeader));
    throw FileError(path, "header line " + std::to_string(header.lines.size() + 1) +
                              " is too long (binary data before ElementDataFile?)");
  }
  ParsedHeader parsed;
  parsed.dataOffset = header.dataOffset;
  const StructuralKeys keys = collectKeys(path, header, parsed);
  if (!keys.elementDataFile) {
    if (header.end == HeaderEnd::TruncatedLine) {
      throw FileError(path, "truncated header: the file ends in the middle of line " +
                                std::to_string(header.lines.size()) + ", before ElementDataFile");
    }
    throw FileError(path, "has no ElementDataFile key (it must be the last header key)");
  }
  interpretLayout(path, keys, parsed);
  return assembleSequence(file, parsed);
}

std::string metaImageHeaderPrefix(const Sequence& layout, std::optional<std::size_t> frames,
                                  std::optional<std::uint64_t> compressedBytes) {
  const std::vector<TextEntry> acquisition = acquisitionEntries(layout);
  std::string header;
  header.reserve(512);
  appendLine(header, "ObjectType", "Image");
  appendLine(header, "NDims", "3");
  appendLine(header, "BinaryData", "True");
  appendLine(header, "BinaryDataByteOrderMSB", "False");
  appendLine(header, "CompressedData", compressedBytes ? "True" : "False");
  if (compressedBytes)
    appendLine(header, "CompressedDataSize", std::to_string(*compressedBytes));
  if (frames)
    appendLine(header, "DimSize", metaImageDimSize(layout, *frames));
  appendLine(header, "ElementNumberOfChannels", "1");
  appendLine(
      header, "ElementType",
      metaImageTypeName(layout.samplesPerFrame() > 0 ? layout.elementType : ElementType::None));
  for (const auto& [key, value] : layout.extraHeader) {
    // NRRD fields (axes, space directions) mean nothing in MetaImage: see sequence_io_detail.hpp.
    if (key.compare(0, kNrrdFieldPrefix.size(), kNrrdFieldPrefix) == 0)
      continue;
    checkEntry(key, value);
    appendLine(header, key, value);
  }
  for (const TextEntry& entry : acquisition) {
    checkEntry(entry.key, entry.value);
    appendLine(header, entry.key, entry.value);
  }
  return header;
}

std::string metaImageDimSize(const Sequence& layout, std::size_t frames) {
  return std::to_string(layout.frameSize[0]) + " " + std::to_string(layout.frameSize[1]) + " " +
         std::to_string(frames);
}

void appendMetaImageFrameLines(const SequenceFrame& frame, std::size_t index, std::string& out) {
  std::vector<TextEntry> entries;
  appendFrameMetadata(frame, index, entries);
  for (const TextEntry& entry : entries) {
    checkEntry(entry.key, entry.value);
    appendLine(out, entry.key, entry.value);
  }
}

void writeMetaImage(const Sequence& sequence, const std::string& path, bool compress) {
  namespace fs = std::filesystem;
  const bool hasData = !sequence.pixels.empty();
  const bool compressData = compress && hasData;
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  // A tracker-only .mhd has no pixels, so no data file either.
  const bool detached = extension == ".mhd" && hasData;
  const std::string dataPath =
      detached ? fs::path(path).replace_extension(compressData ? ".zraw" : ".raw").string()
               : std::string();

  std::vector<std::uint8_t> compressed;
  if (compressData)
    compressed = compressBytes(sequence.pixels, Compression::Zlib);
  const std::vector<std::uint8_t>& data = compressData ? compressed : sequence.pixels;

  std::string header = metaImageHeaderPrefix(
      sequence, sequence.frames.size(),
      compressData ? std::optional<std::uint64_t>(data.size()) : std::nullopt);
  for (std::size_t i = 0; i < sequence.frames.size(); ++i)
    appendMetaImageFrameLines(sequence.frames[i], i, header);
  appendLine(header, kElementDataFile,
             detached ? fs::path(dataPath).filename().string() : std::string(kLocal));

  checkTrackerOnlyHeader(sequence, header.size());

  if (detached) {
    AtomicFile dataFile(dataPath);
    writeBytes(dataFile, data);
    AtomicFile headerFile(path);
    headerFile.stream() << header;
    dataFile.commit();
    headerFile.commit();
  } else {
    AtomicFile file(path);
    file.stream() << header;
    writeBytes(file, data);
    file.commit();
  }
}

}  // namespace echoreg::core::detail
