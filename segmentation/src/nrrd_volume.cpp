// NRRD volume writer and reader (single file, raw or gzip, little endian, LPS geometry).
#include "echoreg/segmentation/nrrd_volume.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace echoreg::segmentation {

namespace {

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

std::string header(const core::CtImage& g, const char* type, bool gzip) {
  const Eigen::Vector3d spacing = g.spacingMm();
  std::string text = "NRRD0004\n# Written by echoreg\n";
  text += fmt::format("type: {}\ndimension: 3\nspace: left-posterior-superior\n", type);
  text += fmt::format("sizes: {} {} {}\n", g.dimensions[0], g.dimensions[1], g.dimensions[2]);
  text += "space directions:";
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d v = g.direction.col(a) * spacing[a];
    text += fmt::format(" ({},{},{})", v.x(), v.y(), v.z());
  }
  text += "\nkinds: domain domain domain\n";
  text += fmt::format("endian: little\nencoding: {}\n", gzip ? "gzip" : "raw");
  text +=
      fmt::format("space origin: ({},{},{})\n\n", g.originMm.x(), g.originMm.y(), g.originMm.z());
  return text;
}

void writeBytes(const std::string& path, const core::CtImage& geometry, const char* type,
                const char* data, std::size_t count, std::size_t elementSize,
                const NrrdWriteOptions& options) {
  if (!geometry.uniform()) {
    throw std::invalid_argument(
        "writeNrrdVolume: " + path +
        ": the CT grid has several slice spacings; resample it or extract one group");
  }
  if (count != geometry.voxelCount() || count == 0) {
    throw std::invalid_argument(
        fmt::format("writeNrrdVolume: {}: {} voxels for a {} x {} x {} grid", path, count,
                    geometry.dimensions[0], geometry.dimensions[1], geometry.dimensions[2]));
  }
  if (elementSize > 1 && !hostIsLittleEndian()) {
    throw std::runtime_error("writeNrrdVolume: big-endian hosts are not supported");
  }
  core::AtomicFile file(path);
  std::ofstream& out = file.stream();
  out << header(geometry, type, options.gzip);
  const std::size_t bytes = count * elementSize;
  if (!options.gzip) {
    out.write(data, static_cast<std::streamsize>(bytes));
  } else {
    z_stream z{};
    if (deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
      throw core::FileError(path, "zlib cannot start compressing");
    }
    std::vector<unsigned char> buffer(1 << 20);
    std::size_t done = 0;
    int status = Z_OK;
    do {
      const std::size_t chunk = std::min<std::size_t>(bytes - done, 1u << 30);
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + done));
      z.avail_in = static_cast<uInt>(chunk);
      done += chunk;
      const int flush = done == bytes ? Z_FINISH : Z_NO_FLUSH;
      do {
        z.next_out = buffer.data();
        z.avail_out = static_cast<uInt>(buffer.size());
        status = deflate(&z, flush);
        out.write(reinterpret_cast<const char*>(buffer.data()),
                  static_cast<std::streamsize>(buffer.size() - z.avail_out));
      } while (z.avail_out == 0);
    } while (done < bytes);
    deflateEnd(&z);
    if (status != Z_STREAM_END)
      throw core::FileError(path, "zlib failed to compress the voxels");
  }
  file.commit();
}

std::string trimmed(const std::string& text) {
  std::size_t a = 0, b = text.size();
  while (a < b && (text[a] == ' ' || text[a] == '\t'))
    ++a;
  while (b > a && (text[b - 1] == ' ' || text[b - 1] == '\t' || text[b - 1] == '\r'))
    --b;
  return text.substr(a, b - a);
}

// "(a,b,c)" -> vector; false on a malformed triple.
bool parseTriple(const std::string& text, Eigen::Vector3d& v) {
  std::string t = trimmed(text);
  if (t.size() < 2 || t.front() != '(' || t.back() != ')')
    return false;
  t = t.substr(1, t.size() - 2);
  for (char& c : t) {
    if (c == ',')
      c = ' ';
  }
  std::istringstream in(t);
  in >> v.x() >> v.y() >> v.z();
  std::string rest;
  return !in.fail() && !(in >> rest);
}

}  // namespace

void writeNrrdVolume(const std::string& path, const core::CtImage& geometry,
                     const std::vector<std::int16_t>& voxels, const NrrdWriteOptions& options) {
  writeBytes(path, geometry, "short", reinterpret_cast<const char*>(voxels.data()), voxels.size(),
             2, options);
}

void writeNrrdVolume(const std::string& path, const core::CtImage& geometry,
                     const std::vector<std::uint8_t>& voxels, const NrrdWriteOptions& options) {
  writeBytes(path, geometry, "uchar", reinterpret_cast<const char*>(voxels.data()), voxels.size(),
             1, options);
}

NrrdVolume readNrrdVolume(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw core::FileError(path, "cannot be opened");
  std::string line;
  if (!std::getline(in, line) || line.rfind("NRRD000", 0) != 0)
    throw core::FileError(path, "is not a NRRD file");
  std::string type, space, encoding = "raw", endian = "little";
  int dimension = 0;
  std::array<int, 3> sizes{0, 0, 0};
  std::array<Eigen::Vector3d, 3> directions;
  bool haveDirections = false, haveOrigin = false;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line.empty())
      break;
    if (line[0] == '#')
      continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos)
      throw core::FileError(path, "malformed header line \"" + line + "\"");
    const std::string key = trimmed(line.substr(0, colon));
    std::string value = line.substr(colon + 1);
    if (!value.empty() && value[0] == '=')
      throw core::FileError(path, "key/value pairs (\":=\") are not supported");
    value = trimmed(value);
    if (key == "type") {
      type = value;
    } else if (key == "dimension") {
      dimension = std::atoi(value.c_str());
    } else if (key == "sizes") {
      std::istringstream s(value);
      s >> sizes[0] >> sizes[1] >> sizes[2];
      if (s.fail())
        throw core::FileError(path, "bad sizes \"" + value + "\"");
    } else if (key == "space") {
      space = value;
    } else if (key == "space directions") {
      std::istringstream s(value);
      for (Eigen::Vector3d& d : directions) {
        std::string word;
        s >> word;
        if (!parseTriple(word, d))
          throw core::FileError(path, "bad space directions \"" + value + "\"");
      }
      haveDirections = true;
    } else if (key == "space origin") {
      if (!parseTriple(value, origin))
        throw core::FileError(path, "bad space origin \"" + value + "\"");
      haveOrigin = true;
    } else if (key == "encoding") {
      encoding = value;
    } else if (key == "endian") {
      endian = value;
    } else if (key == "data file" || key == "datafile") {
      throw core::FileError(path, "detached data files are not supported");
    }
  }
  if (dimension != 3)
    throw core::FileError(path, fmt::format("dimension {} (expected 3)", dimension));
  std::size_t elementSize = 0;
  bool isMask = false;
  if (type == "short" || type == "int16" || type == "int16_t" || type == "signed short") {
    elementSize = 2;
  } else if (type == "uchar" || type == "uint8" || type == "uint8_t" || type == "unsigned char") {
    elementSize = 1;
    isMask = true;
  } else {
    throw core::FileError(path, "type \"" + type + "\" is not supported (short or uchar)");
  }
  if (elementSize > 1 && endian != "little")
    throw core::FileError(path, "big-endian data is not supported");
  if (!haveDirections || !haveOrigin)
    throw core::FileError(path, "has no space directions / space origin");
  double sign = 1.0;
  if (space == "right-anterior-superior" || space == "RAS") {
    sign = -1.0;
  } else if (space != "left-posterior-superior" && space != "LPS") {
    throw core::FileError(path, "space \"" + space + "\" is not supported (LPS or RAS)");
  }
  if (sizes[0] < 1 || sizes[1] < 1 || sizes[2] < 1)
    throw core::FileError(path, "sizes must be positive");
  // The bytes the sizes ask for, checked against what the file holds before anything is
  // allocated: raw data must be all there; gzip (deflate) cannot expand more than 1032:1.
  const double claimedBytes = static_cast<double>(sizes[0]) * static_cast<double>(sizes[1]) *
                              static_cast<double>(sizes[2]) * static_cast<double>(elementSize);
  const std::streamoff dataStart = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff fileEnd = in.tellg();
  in.seekg(dataStart);
  if (dataStart < 0 || fileEnd < dataStart)
    throw core::FileError(path, "cannot find the voxel data after the header");
  const auto dataBytes = static_cast<double>(fileEnd - dataStart);
  const bool gzipped = encoding == "gzip" || encoding == "gz";
  if (encoding != "raw" && !gzipped)
    throw core::FileError(path, "encoding \"" + encoding + "\" is not supported (raw or gzip)");
  constexpr double kDeflateMaxRatio = 1032.0;
  if (encoding == "raw" && claimedBytes > dataBytes) {
    throw core::FileError(path,
                          fmt::format("truncated data: sizes {} x {} x {} need {:.0f} bytes, the "
                                      "file holds {:.0f} after its header",
                                      sizes[0], sizes[1], sizes[2], claimedBytes, dataBytes));
  }
  if (gzipped && claimedBytes > dataBytes * kDeflateMaxRatio + 64.0) {
    throw core::FileError(path,
                          fmt::format("sizes {} x {} x {} need {:.0f} bytes, more than the {:.0f} "
                                      "bytes of gzip data can hold",
                                      sizes[0], sizes[1], sizes[2], claimedBytes, dataBytes));
  }
  NrrdVolume volume;
  volume.isMask = isMask;
  core::CtImage& image = volume.image;
  image.dimensions = sizes;
  const Eigen::Vector3d flip(sign, sign, 1.0);
  image.originMm = origin.cwiseProduct(flip);
  Eigen::Vector3d spacing;
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d d = directions[static_cast<std::size_t>(a)].cwiseProduct(flip);
    spacing[a] = d.norm();
    if (!(spacing[a] > 0.0))
      throw core::FileError(path, "a space direction is zero");
    if (!std::isfinite(spacing[a]))  // (1e308,1e308,0): each value finite, the length not
      throw core::FileError(path, "a space direction is too long (its length is not finite)");
    image.direction.col(a) = d / spacing[a];
  }
  if (std::abs(image.direction.col(0).dot(image.direction.col(1))) > 1e-4 ||
      std::abs(image.direction.col(0).dot(image.direction.col(2))) > 1e-4 ||
      std::abs(image.direction.col(1).dot(image.direction.col(2))) > 1e-4) {
    throw core::FileError(path, "space directions are not orthogonal");
  }
  image.pixelSpacingMm = Eigen::Vector2d(spacing.x(), spacing.y());
  for (int k = 0; k < sizes[2]; ++k)
    image.slicePositionsMm.push_back(k * spacing.z());
  image.groups = {core::CtSliceGroup{0, sizes[2], sizes[2] > 1 ? spacing.z() : 0.0}};
  const std::size_t bytes = image.voxelCount() * elementSize;
  std::vector<char> data(bytes);
  if (encoding == "raw") {
    in.read(data.data(), static_cast<std::streamsize>(bytes));
    if (static_cast<std::size_t>(in.gcount()) != bytes)
      throw core::FileError(path, "truncated data");
  } else if (gzipped) {
    const std::string compressed((std::istreambuf_iterator<char>(in)),
                                 std::istreambuf_iterator<char>());
    z_stream z{};
    if (inflateInit2(&z, 15 + 32) != Z_OK)
      throw core::FileError(path, "zlib cannot start decompressing");
    // zlib counts in uInt: feed and fill in pieces of at most 1 GB.
    constexpr std::size_t kPiece = std::size_t{1} << 30;
    std::size_t consumed = 0, produced = 0;
    int status = Z_OK;
    while (status == Z_OK) {
      const std::size_t inPiece = std::min(compressed.size() - consumed, kPiece);
      const std::size_t outPiece = std::min(bytes - produced, kPiece);
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + consumed));
      z.avail_in = static_cast<uInt>(inPiece);
      z.next_out = reinterpret_cast<Bytef*>(data.data() + produced);
      z.avail_out = static_cast<uInt>(outPiece);
      status = inflate(&z, Z_NO_FLUSH);
      consumed += inPiece - z.avail_in;
      produced += outPiece - z.avail_out;
      if (status == Z_OK && inPiece == z.avail_in && outPiece == z.avail_out)
        break;  // no progress: the input ended or the output is full before the stream's end
    }
    inflateEnd(&z);
    if (status != Z_STREAM_END || produced != bytes) {
      throw core::FileError(
          path, fmt::format("gzip data is truncated or corrupt ({} of {} bytes)", produced, bytes));
    }
  } else {
    throw core::FileError(path, "encoding \"" + encoding + "\" is not supported (raw or gzip)");
  }
  if (isMask) {
    volume.mask.assign(data.begin(), data.end());
  } else {
    image.hu.resize(image.voxelCount());
    std::memcpy(image.hu.data(), data.data(), bytes);
  }
  return volume;
}

}  // namespace echoreg::segmentation
