// Header text of the sequence formats: parsing and quoting of values, the input file (the header
// scanned in chunks, bytes read at offsets), duplicate keys, and the checks that keys and values
// written read back as themselves (sequence_io_detail.hpp).
#include "sequence_io_detail.hpp"

#include "echoreg/core/error.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <system_error>

namespace echoreg::core::detail {

namespace {

namespace fs = std::filesystem;

constexpr std::size_t kFirstChunkBytes = 64 * 1024;
// Header lines are at most a few hundred bytes; a longer "line" means binary data.
constexpr std::size_t kMaxHeaderLineBytes = 1024 * 1024;

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

bool isControlByte(char c) {
  const auto byte = static_cast<unsigned char>(c);
  return (byte < 0x20 && c != '\t') || byte == 0x7f;
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

}  // namespace echoreg::core::detail
