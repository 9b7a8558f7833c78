// NRRD sequences as PLUS writes them (`.igs.nrrd`): `NRRD000x` magic, `field: value` lines,
// `key:=value` lines, a blank line, then raw or gzip data (or a detached `data file`).
#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "sequence_io_detail.hpp"

#include <algorithm>
#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace echoreg::core::detail {

namespace {

struct NrrdType {
  std::string_view name;
  ElementType type;
};
// Every spelling NRRD allows for the supported types; the first of each is the one written.
constexpr std::array<NrrdType, 19> kNrrdTypes{{
    {"uint8", ElementType::UInt8},
    {"uchar", ElementType::UInt8},
    {"unsigned char", ElementType::UInt8},
    {"uint8_t", ElementType::UInt8},
    {"int8", ElementType::Int8},
    {"signed char", ElementType::Int8},
    {"int8_t", ElementType::Int8},
    {"int16", ElementType::Int16},
    {"short", ElementType::Int16},
    {"short int", ElementType::Int16},
    {"signed short", ElementType::Int16},
    {"signed short int", ElementType::Int16},
    {"int16_t", ElementType::Int16},
    {"uint16", ElementType::UInt16},
    {"ushort", ElementType::UInt16},
    {"unsigned short", ElementType::UInt16},
    {"unsigned short int", ElementType::UInt16},
    {"uint16_t", ElementType::UInt16},
    {"float", ElementType::Float32},
}};

struct StructuralFields {
  std::optional<std::string_view> dimension;
  std::optional<std::string_view> type;
  std::optional<std::string_view> sizes;
  std::optional<std::string_view> endian;
  std::optional<std::string_view> encoding;
  std::optional<std::string_view> dataFile;
  std::optional<std::string_view> byteSkip;
  std::optional<std::string_view> lineSkip;
};

std::optional<std::string_view>* structuralSlot(StructuralFields& fields, std::string_view name) {
  if (name == "dimension")
    return &fields.dimension;
  if (name == "type")
    return &fields.type;
  if (name == "sizes")
    return &fields.sizes;
  if (name == "endian")
    return &fields.endian;
  if (name == "encoding")
    return &fields.encoding;
  if (name == "data file" || name == "datafile")
    return &fields.dataFile;
  if (name == "byte skip" || name == "byteskip")
    return &fields.byteSkip;
  if (name == "line skip" || name == "lineskip")
    return &fields.lineSkip;
  return nullptr;
}

bool isStructuralField(std::string_view name) {
  StructuralFields fields;
  return structuralSlot(fields, name) != nullptr;
}

bool isMagic(std::string_view line) {
  return line.size() == 8 && line.substr(0, 7) == "NRRD000" && line[7] >= '1' && line[7] <= '9';
}

bool isComment(std::string_view line) {
  return !line.empty() && line.front() == '#';
}

struct NrrdLine {
  std::string_view key;
  std::string_view value;
  bool keyValue = false;
};

// A field `name: value` or a key/value `key:=value`, told apart by what follows the first ':'
// that is followed by a blank, '=' or the end of the line.
std::optional<NrrdLine> splitLine(std::string_view line) {
  if (hasControlBytes(line))
    return std::nullopt;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] != ':')
      continue;
    const char next = i + 1 < line.size() ? line[i + 1] : ' ';
    if (next != ' ' && next != '\t' && next != '=')
      continue;
    NrrdLine result;
    result.key = trim(line.substr(0, i));
    result.keyValue = next == '=';
    result.value = trim(line.substr(std::min(line.size(), i + (result.keyValue ? 2 : 1))));
    if (result.key.empty())
      return std::nullopt;
    return result;
  }
  return std::nullopt;
}

// The header ends at the first blank line; a line that is neither a comment, a field nor a
// key/value ends the scan early (the parser rejects it).
LineRole classifyLine(std::string_view line, std::size_t index) {
  if (index == 0)
    return isMagic(line) ? LineRole::Continue : LineRole::EndAfter;
  if (line.empty())
    return LineRole::EndBefore;
  if (isComment(line) || splitLine(line))
    return LineRole::Continue;
  return LineRole::EndAfter;
}

StructuralFields collectLines(const std::string& path, const HeaderLines& header,
                              ParsedHeader& parsed) {
  StructuralFields fields;
  DuplicateKeyCheck fieldNames(path, 32);
  DuplicateKeyCheck keys(path, header.lines.size());
  parsed.entries.reserve(header.lines.size());
  for (std::size_t i = 1; i < header.lines.size(); ++i) {
    const std::string_view line = header.lines[i];
    if (isComment(line))
      continue;
    const std::optional<NrrdLine> split = splitLine(line);
    if (!split) {
      if (i + 1 == header.lines.size() && header.lastLineUnterminated) {
        throw FileError(
            path, "truncated header: the file ends in the middle of line " + std::to_string(i + 1));
      }
      throw FileError(path, "malformed NRRD header line " + std::to_string(i + 1) +
                                " (expected 'field: value' or 'key:=value'): " + quote(line));
    }
    if (split->keyValue) {
      keys.check(split->key, "key");
      parsed.entries.push_back({split->key, split->value, false});
    } else if (std::optional<std::string_view>* slot = structuralSlot(fields, split->key)) {
      if (slot->has_value()) {
        throw FileError(path, "field " + quote(split->key) + " appears twice in the header");
      }
      *slot = split->value;
    } else {
      fieldNames.check(split->key, "field");
      parsed.entries.push_back({split->key, split->value, true});
    }
  }
  return fields;
}

ElementType parseType(const std::string& path, std::string_view name) {
  for (const NrrdType& known : kNrrdTypes) {
    if (known.name == name)
      return known.type;
  }
  throw FileError(path, "unknown element type " + quote(name) +
                            " (supported: uint8, int8, int16, uint16, float)");
}

std::string_view nrrdTypeName(ElementType type) {
  for (const NrrdType& known : kNrrdTypes) {
    if (known.type == type)
      return known.name;
  }
  // A tracker-only sequence has no samples, but NRRD requires a type.
  return "uint8";
}

void interpretLayout(const std::string& path, const StructuralFields& fields,
                     ParsedHeader& parsed) {
  if (!fields.dimension)
    throw FileError(path, "has no dimension field");
  if (*fields.dimension != "3") {
    throw FileError(
        path, "dimension must be 3 (samples, rows, frames), found " + quote(*fields.dimension));
  }
  if (!fields.sizes)
    throw FileError(path, "has no sizes field");
  parsed.dimSizeKey = "sizes";
  parsed.dimSize = parseDimSize(path, "sizes", *fields.sizes);
  const bool hasSamples = parsed.dimSize[0] > 0 && parsed.dimSize[1] > 0;
  if (fields.type) {
    parsed.elementType = parseType(path, *fields.type);
  } else if (hasSamples) {
    throw FileError(path, "has no type field");
  }
  if (!fields.encoding)
    throw FileError(path, "has no encoding field");
  if (*fields.encoding == "gz" || *fields.encoding == "gzip") {
    parsed.compressed = true;
  } else if (*fields.encoding != "raw") {
    throw FileError(
        path, "unsupported encoding " + quote(*fields.encoding) + " (supported: raw, gz, gzip)");
  }
  if (fields.endian) {
    if (*fields.endian != "little" && *fields.endian != "big") {
      throw FileError(path, "endian must be little or big, found " + quote(*fields.endian));
    }
    parsed.bigEndian = *fields.endian == "big";
  } else if (hasSamples && elementSize(parsed.elementType) > 1) {
    throw FileError(path, "has no endian field, needed for " +
                              std::string(elementTypeName(parsed.elementType)) + " data");
  }
  for (const auto& [name, skip] : {std::make_pair("byte skip", fields.byteSkip),
                                   std::make_pair("line skip", fields.lineSkip)}) {
    if (skip && *skip != "0") {
      throw FileError(path, std::string(name) + " " + quote(*skip) + " is not supported");
    }
  }
  if (fields.dataFile) {
    const std::string_view dataFile = *fields.dataFile;
    if (dataFile.empty() || dataFile.substr(0, 4) == "LIST" ||
        dataFile.find('%') != std::string_view::npos) {
      throw FileError(path, "data file " + quote(dataFile) +
                                " is not supported (expected one detached data file)");
    }
    parsed.dataFileName = std::string(dataFile);
  }
}

void appendField(std::string& header, std::string_view name, std::string_view value) {
  header += name;
  header += value.empty() ? ":" : ": ";
  header += value;
  header += '\n';
}

void appendKeyValue(std::string& header, std::string_view key, std::string_view value) {
  header += key;
  header += ":=";
  header += value;
  header += '\n';
}

// Throws std::invalid_argument unless the key reads back as itself from a NRRD line.
void checkKey(std::string_view key, std::string_view value) {
  checkHeaderText(key, value, "NRRD");
  if (key.find(':') != std::string_view::npos || key.front() == '#') {
    throw std::invalid_argument("writeSequence: NRRD header key " + quote(key) +
                                " holds ':' or begins with '#'");
  }
}

}  // namespace

Sequence readNrrd(InputFile& file) {
  const std::string& path = file.path();
  const HeaderLines header = file.scanHeader(classifyLine);
  if (header.lines.empty() || !isMagic(header.lines.front())) {
    throw FileError(path, "is not a NRRD file: the first line is " +
                              quote(header.lines.empty() ? std::string_view() : header.lines[0]) +
                              ", expected NRRD0001 to NRRD0009");
  }
  if (header.end == HeaderEnd::LineTooLong) {
    throw FileError(path, "NRRD header line " + std::to_string(header.lines.size() + 1) +
                              " is too long (binary data without a blank line before it?)");
  }
  ParsedHeader parsed;
  parsed.dataOffset = header.dataOffset;
  const StructuralFields fields = collectLines(path, header, parsed);
  if (header.end == HeaderEnd::TruncatedLine) {
    throw FileError(path, "truncated header: the file ends in the middle of line " +
                              std::to_string(header.lines.size()));
  }
  if (header.end == HeaderEnd::EndOfFile && !fields.dataFile) {
    throw FileError(path, "truncated header: no blank line ends the header before the data");
  }
  interpretLayout(path, fields, parsed);
  return assembleSequence(file, parsed);
}

void writeNrrd(const Sequence& sequence, const std::string& path, bool compress) {
  const bool compressData = compress && !sequence.pixels.empty();
  std::vector<std::uint8_t> compressed;
  if (compressData)
    compressed = compressBytes(sequence.pixels, Compression::Gzip);
  const std::vector<std::uint8_t>& data = compressData ? compressed : sequence.pixels;

  const std::vector<TextEntry> metadata = metadataEntries(sequence);
  std::string header;
  header.reserve(512 + metadata.size() * 64);
  header += "NRRD0004\n";
  header += "# Complete NRRD file format specification at:\n";
  header += "# http://teem.sourceforge.net/nrrd/format.html\n";
  appendField(header, "dimension", "3");
  appendField(
      header, "type",
      nrrdTypeName(sequence.samplesPerFrame() > 0 ? sequence.elementType : ElementType::None));
  appendField(header, "sizes",
              std::to_string(sequence.frameSize[0]) + " " + std::to_string(sequence.frameSize[1]) +
                  " " + std::to_string(sequence.frames.size()));
  appendField(header, "endian", "little");
  appendField(header, "encoding", compressData ? "gzip" : "raw");
  // In extraHeader's order: NRRD lets fields and key/values interleave after "dimension".
  for (const auto& [key, value] : sequence.extraHeader) {
    if (key.compare(0, kNrrdFieldPrefix.size(), kNrrdFieldPrefix) != 0) {
      checkKey(key, value);
      appendKeyValue(header, key, value);
      continue;
    }
    const std::string_view name = std::string_view(key).substr(kNrrdFieldPrefix.size());
    checkKey(name, value);
    if (isStructuralField(name)) {
      throw std::invalid_argument("writeSequence: extraHeader key " + quote(key) +
                                  " is a NRRD structural field");
    }
    appendField(header, name, value);
  }
  for (const TextEntry& entry : metadata) {
    checkKey(entry.key, entry.value);
    appendKeyValue(header, entry.key, entry.value);
  }
  header += '\n';
  checkTrackerOnlyHeader(sequence, header.size());

  AtomicFile file(path);
  file.stream() << header;
  file.stream().write(reinterpret_cast<const char*>(data.data()),
                      static_cast<std::streamsize>(data.size()));
  file.commit();
}

}  // namespace echoreg::core::detail
