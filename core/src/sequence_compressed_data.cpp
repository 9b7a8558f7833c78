// The pixel data of the sequence formats: located after the header or in the detached data file,
// checked against the layout before anything is allocated, read raw or inflated (zlib, gzip) and
// swapped to host byte order; compressed for writing (sequence_io_detail.hpp).
#include "sequence_io_detail.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/parallel_deflate.hpp"
#include "echoreg/core/prefault.hpp"

#define ZLIB_CONST
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>

namespace echoreg::core::detail {

namespace {

namespace fs = std::filesystem;

// deflate cannot compress better than about 1032:1, so a smaller stream cannot hold the pixels
// DimSize promises: refuse before allocating them.
constexpr std::uint64_t kMaxDeflateRatio = 1032;
static_assert(kPixelCompressionLevel == Z_BEST_SPEED);

uInt zlibChunk(std::size_t remaining) {
  return static_cast<uInt>(std::min<std::size_t>(remaining, std::numeric_limits<uInt>::max()));
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

}  // namespace

// a * b, or nullopt when it does not fit in 64 bits.
std::optional<std::uint64_t> multiply(std::uint64_t a, std::uint64_t b) {
  std::uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product))
    return std::nullopt;
  return product;
}

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

}  // namespace echoreg::core::detail
