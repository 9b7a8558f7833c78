// The DICOM CT series reader, inside the DICOM module (dicom/CMakeLists.txt): headers scanned first
// (gdcm::Reader up to the pixel data), checked and sorted, then the volume allocated once and every
// slice decoded (gdcm::ImageReader) by a pool of threads straight into its place, each slice with
// its own rescale. segmentation's functions of the same names call it through the module; the
// fuzz harness compiles it directly.
#include "echoreg/segmentation/dicom_series.hpp"

#include "echoreg/core/error.hpp"

#include <fmt/format.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmPixelFormat.h>
#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <Eigen/Geometry>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <system_error>
#include <thread>

namespace echoreg::segmentation {

namespace {

namespace fs = std::filesystem;

/// Two slices closer than this along the normal are at the same position.
constexpr double kSamePositionMm = 1e-3;
/// Slice centres may lie this far off the normal through the first slice (plus kOffNormalRelative
/// of their distance along it) before the series counts as tilted.
constexpr double kOffNormalMm = 0.01;
constexpr double kOffNormalRelative = 1e-4;
/// Orientation cosines (and pixel spacings, relatively) that differ by less are equal.
constexpr double kOrientationTolerance = 1e-4;
constexpr double kSpacingRelativeTolerance = 1e-4;
/// A step continues a group when within this of its spacing (absolute mm, or relative).
constexpr double kGroupStepMm = 0.01;
constexpr double kGroupStepRelative = 0.01;
/// A non-zero GantryDetectorTilt above this (degrees) is refused.
constexpr double kGantryTiltDegrees = 1e-3;
/// The transfer syntax RLE Lossless (DICOM PS3.5 annex G).
constexpr const char* kRleLossless = "1.2.840.10008.1.2.5";
/// At most this many file names in one message.
constexpr std::size_t kNamesInMessage = 8;

void silenceGdcm() {
  static std::once_flag once;
  std::call_once(once, [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
  });
}

std::string trimmed(std::string text) {
  const auto blank = [](char c) {
    return c == ' ' || c == '\0' || c == '\t' || c == '\r' || c == '\n';
  };
  while (!text.empty() && blank(text.back()))
    text.pop_back();
  std::size_t first = 0;
  while (first < text.size() && blank(text[first]))
    ++first;
  return text.substr(first);
}

/// Backslash-separated decimal numbers; nullopt when any part is not a number.
std::optional<std::vector<double>> numbers(const std::string& text) {
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\\', start);
    if (end == std::string::npos)
      end = text.size();
    const std::string part = trimmed(text.substr(start, end - start));
    if (part.empty())
      return std::nullopt;
    char* stop = nullptr;
    const double value = std::strtod(part.c_str(), &stop);
    if (stop != part.c_str() + part.size() || !std::isfinite(value))
      return std::nullopt;
    values.push_back(value);
    start = end + 1;
  }
  return values;
}

/// "a, b, c and 4 more".
std::string nameList(const std::vector<std::string>& names) {
  std::string out;
  const std::size_t shown = std::min(names.size(), kNamesInMessage);
  for (std::size_t n = 0; n < shown; ++n) {
    if (n > 0)
      out += ", ";
    out += names[n];
  }
  if (names.size() > shown)
    out += fmt::format(" and {} more", names.size() - shown);
  return out;
}

/// Native pixel data whose declared length runs past the end of the file (found by the walk).
struct PixelBeyondFile {
  std::uint64_t elementAt = 0;  ///< the element's first byte (its tag); 0: none found
  std::uint64_t valueAt = 0;    ///< its value's first byte
  std::uint64_t declared = 0;   ///< the length its header declares
};

/// What the header of one file says (read up to the pixel data).
struct SliceHeader {
  std::string name;  ///< file name (the path's last component)
  std::string path;
  bool dicom = false;  ///< GDCM read the header
  /// Why the file was not given to GDCM ("" when it was): an element longer than the file.
  std::string damaged;
  bool image = false;  ///< it has Rows and Columns
  std::string seriesUid, modality, description, sopClass, transferSyntax, photometric;
  int rows = 0, columns = 0;
  int bitsAllocated = 0, bitsStored = 0, highBit = -1, pixelRepresentation = 0;
  int samplesPerPixel = 1;
  std::string frames = "1";  ///< NumberOfFrames as written ("1" when absent)
  std::optional<Eigen::Vector3d> position;
  std::optional<std::array<double, 6>> orientation;
  std::optional<Eigen::Vector2d> pixelSpacing;  ///< as written: between rows, between columns
  double slope = 1.0, intercept = 0.0;
  double gantryTiltDegrees = 0.0;
  std::vector<std::string> problems;  ///< unparsable values
  /// Where the pixel data value starts in the file, and the file's size (0 when unknown): a
  /// native (uncompressed) element must fit in the file; GDCM pads a truncated one silently.
  std::uint64_t pixelDataOffset = 0;
  std::uint64_t fileSize = 0;
  /// Native pixel data declaring more bytes than the file holds after its start (elementAt 0:
  /// none).
  PixelBeyondFile pixelBeyondFile;
};

/// The unsigned number in the `count` (at most 4) bytes at `b`, little endian unless `bigEndian`
/// (the pre-check walk's element headers, the RLE frame's items and header).
std::uint32_t unsignedAt(const unsigned char* b, int count, bool bigEndian = false) {
  std::uint32_t value = 0;
  for (int i = 0; i < count; ++i)
    value |= static_cast<std::uint32_t>(b[bigEndian ? count - 1 - i : i]) << (8 * i);
  return value;
}

/// The VR of an element of the image (pixel description, geometry, rescale) that GDCM reads through
/// its typed attributes (gdcm::Attribute, whose SetFromDataElement asserts, aborting the process,
/// on any other VR but UN: a RescaleSlope of VR CS, found by fuzz/fuzz_dicom), or null for any
/// other.
const char* imageElementVr(std::uint32_t group, std::uint32_t element) {
  struct Known {
    std::uint32_t group, element;
    const char* vr;
  };
  static const Known kKnown[] = {
      {0x0018, 0x0050, "DS"}, {0x0018, 0x0088, "DS"}, {0x0018, 0x1164, "DS"},
      {0x0020, 0x0032, "DS"}, {0x0020, 0x0037, "DS"}, {0x0028, 0x0002, "US"},
      {0x0028, 0x0004, "CS"}, {0x0028, 0x0006, "US"}, {0x0028, 0x0008, "IS"},
      {0x0028, 0x0010, "US"}, {0x0028, 0x0011, "US"}, {0x0028, 0x0030, "DS"},
      {0x0028, 0x0100, "US"}, {0x0028, 0x0101, "US"}, {0x0028, 0x0102, "US"},
      {0x0028, 0x0103, "US"}, {0x0028, 0x1052, "DS"}, {0x0028, 0x1053, "DS"}};
  for (const Known& k : kKnown) {
    if (k.group == group && k.element == element)
      return k.vr;
  }
  return nullptr;
}

/// The ways GDCM reads a data set (gdcm::Reader::InternalReadCommon): as its transfer syntax says
/// (an element of an unknown VR ends that read in a big-endian data set; in a little-endian one
/// the read goes on as the third way does); on from an element of an unknown VR, little endian,
/// with a 2-byte length for such VRs (VR16ExplicitDataElement); from the start, little endian,
/// such elements read as implicit (ExplicitImplicitDataElement).
enum class ReadWay {
  AsEncoded,
  Vr16AfterUnknown,
  LittleEndianImplicitUnknown,
  UnSequencesExplicit
};

/// GDCM allocates (and zero-fills) the length a data element declares before it reads the value:
/// 1.2 GB for a 1.5 kB file (found by fuzz/fuzz_dicom), up to 4 GB per file and thread. So the
/// elements of a file are walked first, without reading their values: the file meta group
/// (explicit VR little endian, or implicit where GDCM reads it so: below), then the data set in its
/// transfer syntax (implicit or explicit VR, little or big endian; a deflated one is left to GDCM),
/// into sequences and items, past the pixel data. A file without the preamble is walked in the
/// encoding GDCM guesses for it from its first tag and the two bytes after it
/// (gdcm::FileMetaInformation::ReadCompat), whatever its first group: a 665-byte file starting with
/// group 0x0020 took GDCM 26 s and 1.09 GB (fuzz/fuzz_dicom). A file meta group is read as
/// implicit, as GDCM does, when the two bytes after its first tag are not a VR GDCM knows (GE's
/// private syntax; "Ul" for "UL" made GDCM abort, fuzz/fuzz_dicom). Returns the first element whose
/// declared length runs past the end of the file, or "" when none does (or the file is not DICOM
/// enough to tell: GDCM then says so). Native little endian pixel data longer than the file is not
/// reported here but in `pixelBeyondFile` (its element's start, its value's and the length it
/// declares): the reader refuses it before any pixel is read, as truncated with its sizes when its
/// pixels are missing, else as a wrong length.
///
/// An element whose VR GDCM does not know and is not two printable characters (GDCM reads those
/// as UN), in an explicit data set, makes GDCM read the data set
/// again one of two ways (gdcm::Reader): from that element on with a 2-byte length for such VRs
/// (VR16ExplicitDataElement; the pixel data: 2 reserved bytes and a 4-byte length), and, when
/// that fails, from the start with such elements read as implicit, their 4-byte length right
/// after the tag (ExplicitImplicitDataElement): a 32-byte file whose second element had the VR
/// "\0@" took 1.4 GB (fuzz/fuzz_dicom). Both ways read little endian, whatever the transfer
/// syntax: in a big-endian data set GDCM first reads big endian up to that element, then the rest
/// little endian, then the whole data set little endian; a 244-byte file whose first group made
/// GDCM guess explicit big endian had a length of 3.77 GB read little endian from its second
/// element (11 s; fuzz/fuzz_dicom). The walk follows `way` and says in `sawUnknownVr` whether the
/// other ways need walking too.
///
/// An element of VR UN and undefined length in an explicit data set is read by GDCM as a sequence
/// in implicit VR; when that read fails, GDCM reads the whole data set again with the items of
/// such sequences in explicit VR (gdcm::Reader, "Attempt to read non CP 246":
/// CP246ExplicitDataElement), which asserts (aborts the process) on a sequence delimiter where an
/// element must stand (found by fuzz/fuzz_dicom). The walk stops at such an element
/// (ReadWay::UnSequencesExplicit excepted), says in `unFailsImplicit` whether the sequence does
/// not read in implicit VR to its delimiter within the file, and walks into it in explicit VR the
/// UnSequencesExplicit way.
///
/// A file without the preamble whose first tag gives GDCM no encoding ("Cannot find DICOM type")
/// sets `notDicom`: GDCM does not always give up there, and reads on as explicit VR big endian; a
/// 130-byte file whose first VR was "??" had a length of 0x3f3f3f3f read from it, 1 GB allocated
/// and filled (7.8 s; fuzz/fuzz_dicom). Such a file is not a CT slice: it is never given to GDCM.
std::string walkElements(const fs::path& path, ReadWay way, bool& sawUnknownVr,
                         bool& unFailsImplicit, PixelBeyondFile& pixelBeyondFile, bool& notDicom) {
  const bool unknownVrImplicit = way != ReadWay::Vr16AfterUnknown;
  const bool littleEndianOnly = way == ReadWay::LittleEndianImplicitUnknown;
  std::ifstream in(path, std::ios::binary);
  std::error_code sizeError;
  const std::uint64_t size = fs::file_size(path, sizeError);
  if (!in || sizeError)
    return "";
  std::uint64_t pos = 0;
  const auto bytes = [&](std::uint64_t at, std::size_t count, unsigned char* out) {
    in.clear();
    in.seekg(static_cast<std::streamoff>(at));
    return static_cast<bool>(
        in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(count)));
  };
  unsigned char head[132] = {};
  if (size >= 132 && bytes(0, 132, head) && std::memcmp(head + 128, "DICM", 4) == 0)
    pos = 132;
  bool explicitVr = true, bigEndian = false, meta = pos == 132, fragments = false;
  std::uint64_t fragmentsAt = 0;  // where the encapsulated pixel data's element starts
  // The sequences ('S') and items ('I') of undefined length still open, innermost last, with the
  // byte each began at: GDCM reads an item's elements until its item delimiter, and asserts
  // (aborts the process) when the file ends first (gdcm::DataSet::ReadNested; found by
  // fuzz/fuzz_dicom).
  std::vector<std::pair<char, std::uint64_t>> open;
  // The sequences ('S') and items ('I') of a defined length still open, innermost last: where
  // each began and where it ends. An element must end within them: GDCM mends a data set whose
  // element runs past its item or sequence ("Out of Range SQ detected", "Item length is wrong")
  // by reading it again as a mixture of explicit and implicit VR, without clearing the stream's
  // error state first, and asserts (aborts the process) when that read met the file's end (found
  // by fuzz/fuzz_dicom, stop 34).
  struct Within {
    char kind;
    std::uint64_t start, end;
  };
  std::vector<Within> within;
  const auto pastItsEnd = [&](std::uint32_t group, std::uint32_t element, std::uint64_t start,
                              std::uint64_t end) -> std::string {
    if (within.empty() || end <= within.back().end)
      return "";
    return fmt::format(
        "element ({:04x},{:04x}) at byte {} runs {} bytes past the end of the {} "
        "at byte {}",
        group, element, start, end - within.back().end,
        within.back().kind == 'S' ? "sequence" : "item", within.back().start);
  };
  // The VRs GDCM knows (gdcm::VR::GetVRTypeFromFile).
  static const std::set<std::string> kVr{"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL",
                                         "IS", "LO", "LT", "OB", "OD", "OF", "OL", "OV", "OW",
                                         "PN", "SH", "SL", "SQ", "SS", "ST", "SV", "TM", "UC",
                                         "UI", "UL", "UN", "UR", "US", "UT", "UV"};
  // An implicit file meta group (GE's private syntax): group 0x0002's elements with no VR, a
  // 4-byte length right after the tag.
  bool metaImplicit = false, sawSyntax = false;
  // A compressed (encapsulated) transfer syntax: its pixel data is read by GDCM only.
  bool encapsulated = false;
  // Met an element of an unknown VR, little endian: GDCM's read on from it (Vr16AfterUnknown).
  bool readingVr16 = false;
  {
    // The encoding GDCM takes (gdcm::Reader, gdcm::FileMetaInformation::Read and ReadCompat),
    // from the first tag after the preamble (or at the start of a file without one) read little
    // endian and whether the two bytes after it are a VR GDCM knows. With the preamble, a first
    // element (0002,0000) "UL" is read as an explicit meta group; any other first element is
    // read again by ReadCompat, as a file without the preamble is.
    // A file that ends inside its first element's header (a tag, less than 4 more bytes) is
    // damaged once its first tag says it is DICOM: GDCM asserts (aborts the process) reading such
    // a file meta group (a 7-byte file, found by fuzz/fuzz_dicom) or element header.
    unsigned char first[8] = {};
    const std::size_t available = static_cast<std::size_t>(std::min<std::uint64_t>(8, size - pos));
    const std::string endsInMeta =
        fmt::format("the file ends at byte {}, inside its file meta group", size);
    if (available < 4 || !bytes(pos, available, first))
      return meta ? endsInMeta : "";
    const std::string endsInHeader =
        available < 8
            ? fmt::format("the file ends at byte {}, inside the header of an element", size)
            : std::string();
    const std::uint32_t group = unsignedAt(first, 2, false),
                        element = unsignedAt(first + 2, 2, false);
    const bool vrFollows = kVr.count(std::string(reinterpret_cast<const char*>(first + 4), 2)) > 0;
    meta = false;
    if (group == 0x0002) {
      // A group whose first two bytes after the tag are not a VR GDCM knows is read as implicit
      // (ReadCompatInternal): "Ul" there made GDCM take the rest of the header for a length and
      // abort the process (found by fuzz/fuzz_dicom).
      if (available < 8)
        return endsInMeta;
      meta = true;
      metaImplicit = !vrFollows;
    } else if (group == 0x0800) {
      if (!vrFollows) {  // implicit big endian (ACR-NEMA): GDCM refuses it
        notDicom = true;
        return "";
      }
      bigEndian = !littleEndianOnly;
    } else if (group == 0x0008 || element == 0x0010) {
      explicitVr = vrFollows;  // group 0x0008, or a private creator: little endian
    } else if (vrFollows) {
      bigEndian = !littleEndianOnly && (group > 0xff || element > 0xff);  // other group, explicit
    } else if (group == 0 && element == 0 && unsignedAt(first + 4, 4, false) == 4) {
      explicitVr = false;  // a command group length (0000,0000), implicit
    } else {               // "Cannot find DICOM type": not DICOM
      notDicom = true;
      return "";
    }
    if (!endsInHeader.empty())
      return endsInHeader;
  }
  // The VRs with a 2-byte length; any other VR GDCM knows (OB, SQ, UN...) has 2 reserved bytes
  // and a 4-byte length.
  static const std::set<std::string> kShortVr{"AE", "AS", "AT", "CS", "DA", "DS", "DT",
                                              "FL", "FD", "IS", "LO", "LT", "PN", "SH",
                                              "SL", "SS", "ST", "TM", "UI", "UL", "US"};
  constexpr std::uint32_t kUndefined = 0xffffffffu;
  // Group fffe holds items and delimiters only: any other tag of it is damaged (why, where each
  // is checked), "" otherwise.
  const auto notItemNorDelimiter = [](std::uint32_t element, std::uint64_t at) -> std::string {
    if (element == 0xe000 || element == 0xe00d || element == 0xe0dd)
      return "";
    return fmt::format("the tag (fffe,{:04x}) at byte {} is neither an item nor a delimiter",
                       element, at);
  };
  // Does the sequence whose items start at `from` read in implicit VR little endian (a 4-byte
  // length after each tag; items and nested sequences of undefined length closed by their
  // delimiters) to its sequence delimiter, every length within the file? Returns where it ends
  // (after that delimiter), or 0. A tag of group fffe that is no item nor delimiter in it is
  // damaged (`damage`): GDCM's implicit read fails there and it reads the data set again as
  // GDCM 1.x wrote it (a VR UN with a 2-byte length: UNExplicitDataElement), which took the text
  // behind it for a length of 1.7 GB (found by fuzz/fuzz_dicom, stop 35).
  const auto implicitSequenceEnd = [&](std::uint64_t from, std::string& damage) -> std::uint64_t {
    std::vector<char> nesting{'S'};
    for (std::uint64_t at = from; at + 8 <= size;) {
      unsigned char h[8] = {};
      if (!bytes(at, 8, h))
        return 0;
      const std::uint32_t group = unsignedAt(h, 2, false), element = unsignedAt(h + 2, 2, false);
      const std::uint32_t length = unsignedAt(h + 4, 4, false);
      if (group == 0xfffe && !(damage = notItemNorDelimiter(element, at)).empty())
        return 0;
      at += 8;
      if (group == 0xfffe && (element == 0xe00d || element == 0xe0dd)) {
        if (!nesting.empty() && nesting.back() == 'I')
          nesting.pop_back();
        if (element == 0xe0dd && !nesting.empty())
          nesting.pop_back();
        if (nesting.empty())
          return at;
      } else if (length == kUndefined) {
        nesting.push_back(group == 0xfffe ? 'I' : 'S');
      } else if (length > size - at) {
        return 0;
      } else if (group != 0xfffe || element != 0xe000) {
        at += length;  // a value (an item of a defined length: its elements follow)
      }
    }
    return 0;
  };
  while (pos + 8 <= size) {
    const std::uint64_t start = pos;
    while (!within.empty() && start >= within.back().end)
      within.pop_back();
    unsigned char e[12] = {};
    if (!bytes(pos, 8, e))
      return "";
    const bool big = bigEndian && !meta;
    const std::uint32_t group = unsignedAt(e, 2, big), element = unsignedAt(e + 2, 2, big);
    if (meta && group != 0x0002) {
      meta = false;  // the data set, in the transfer syntax the meta group named
      // An implicit meta group without a transfer syntax: GDCM guesses the data set's from
      // whether a VR it knows follows the first tag (little endian either way).
      if (metaImplicit && !sawSyntax)
        explicitVr = kVr.count(std::string(reinterpret_cast<const char*>(e + 4), 2)) > 0;
      continue;
    }
    std::uint32_t length = 0;
    std::uint64_t valueAt = pos + 8;
    std::string vr;
    // Encapsulated pixel data is items of a defined length (the basic offset table, then the
    // fragments) up to a sequence delimiter (DICOM PS3.5 A.4). GDCM reads anything else there as
    // a broken file it tries to mend: a first item with another tag makes it read the data set
    // again on from two bytes before that tag with 2-byte lengths (VR16ExplicitDataElement), which
    // allocated 3.7 GB for a 157 kB JPEG 2000 slice (found by fuzz/fuzz_dicom, stop 34); other tags
    // after a fragment take it into repairs that assert (abort the process).
    if (fragments && (group != 0xfffe || (element != 0xe000 && element != 0xe0dd))) {
      return fmt::format(
          "byte {} of the file is neither a fragment of the pixel data at byte {} nor their end "
          "(tag ({:04x},{:04x}))",
          start, fragmentsAt, group, element);
    }
    if (fragments && element == 0xe000 && unsignedAt(e + 4, 4, big) == kUndefined) {
      return fmt::format(
          "the fragment at byte {} of the pixel data at byte {} has an undefined "
          "length",
          start, fragmentsAt);
    }
    if (group == 0xfffe) {  // an item or a delimiter: no VR, a 4-byte length
      // Where GDCM reads an element's header, it asserts (aborts the process) on the tag
      // (fffe,0000), and on a sequence delimiter where the rest is read with 2-byte lengths
      // (VR16ExplicitDataElement::ReadPreValue): that is where an explicit little-endian data set
      // has one outside any sequence (its read fails there and goes on that way), or on from an
      // element of an unknown VR, inside an item too (found by fuzz/fuzz_dicom).
      const bool asElement = !fragments && !meta && (open.empty() || open.back().first == 'I');
      const bool vr16 = (way == ReadWay::Vr16AfterUnknown && readingVr16) ||
                        (explicitVr && !bigEndian && open.empty()) ||
                        way == ReadWay::UnSequencesExplicit;
      if (asElement && (element == 0x0000 || (element == 0xe0dd && vr16))) {
        return fmt::format("a {} at byte {} stands where an element must",
                           element == 0x0000 ? "tag (fffe,0000)" : "sequence delimiter", start);
      }
      // Group fffe holds items and delimiters only. GDCM reads any other tag of it as an element
      // with a VR, fails there, and reads the data set again on from it with 2-byte lengths
      // (VR16ExplicitDataElement), at the top level, where the sequence delimiter behind it made
      // it assert (found by fuzz/fuzz_dicom, stop 34).
      if (std::string damage = notItemNorDelimiter(element, start); !damage.empty())
        return damage;
      length = unsignedAt(e + 4, 4, big);
      pos = valueAt;
      const bool definedItem = element == 0xe000 && length != kUndefined && !fragments;
      // (An item longer than the file is damaged below, saying so.)
      if (const std::string past = pastItsEnd(
              group, element, start,
              definedItem ? valueAt + std::min<std::uint64_t>(length, size - valueAt) : valueAt);
          !past.empty()) {
        return past;
      }
      if (element == 0xe0dd && fragments) {
        // GDCM reads the delimiter of encapsulated pixel data as a fragment and allocates the
        // length it declares (gdcm::Fragment::ReadValue): 1.5 GB for a 909-byte file (found by
        // fuzz/fuzz_dicom, stop 34). DICOM gives it a length of 0.
        if (length != 0) {
          return fmt::format(
              "the sequence delimiter at byte {} of the pixel data at byte {} has a length of {} "
              "(0 in DICOM)",
              start, fragmentsAt, length);
        }
        fragments = false;
      } else if (element == 0xe00d || element == 0xe0dd) {
        // An item delimiter ends the open item. A sequence delimiter ends the open sequence, and
        // an item left open in it, which GDCM takes for ended there too (ReadNested: "SQ End
        // found but no Item end found").
        if (!open.empty() && open.back().first == 'I')
          open.pop_back();
        if (element == 0xe0dd && !open.empty() && open.back().first == 'S')
          open.pop_back();
      }
      if (element == 0xe000 && length == kUndefined && !fragments)
        open.emplace_back('I', start);
      if (element != 0xe000 || length == kUndefined)
        continue;
      if (length > size - pos)
        return fmt::format("item at byte {} claims {} bytes, but {} are left in the file", start,
                           length, size - pos);
      if (fragments)
        pos += length;  // a fragment of encapsulated pixel data: bytes, not elements
      else
        within.push_back({'I', start, pos + length});
      continue;  // an item of a sequence: its elements follow
    }
    const bool pixelData = group == 0x7fe0 && element == 0x0010;
    if (meta && metaImplicit) {
      length = unsignedAt(e + 4, 4, false);
    } else if (explicitVr || meta) {
      vr.assign(reinterpret_cast<const char*>(e + 4), 2);
      // A VR GDCM does not know but of two printable characters is read as UN, 2 reserved bytes
      // and a 4-byte length (gdcm::VR::GetVRTypeFromFile: "newly added VR"); only any other
      // (GDCM's INVALID) makes it read the data set again the two ways above.
      const bool otherVr = !meta && kVr.count(vr) == 0;
      const bool printable =
          std::all_of(vr.begin(), vr.end(), [](char c) { return c >= ' ' && c <= '~'; });
      const bool unknownVr = otherVr && !printable;
      // GDCM's first read of an explicit data set stops at the first element whose VR it cannot
      // read (a ParseException naming that element), and asserts (aborts the process) when that
      // element's tag is (feff,00e0), an item tag byte-swapped (gdcm::Reader: "Philips with
      // ByteSwap private sequence"; 8 bytes inserted in a slice were enough).
      if (unknownVr && !sawUnknownVr && way == ReadWay::AsEncoded && group == 0xfeff &&
          element == 0x00e0) {
        return fmt::format(
            "element (feff,00e0) at byte {}, an item tag byte-swapped, has no VR "
            "(bytes {:02x} {:02x})",
            start, e[4], e[5]);
      }
      sawUnknownVr = sawUnknownVr || unknownVr;
      readingVr16 = readingVr16 || (unknownVr && !big);
      // GDCM asserts (aborts the process) on pixel data of an unknown VR whose next two bytes are
      // not zero (VR16ExplicitDataElement; found by fuzz/fuzz_dicom).
      if (otherVr && pixelData && (e[6] != 0 || e[7] != 0)) {
        return fmt::format("the pixel data at byte {} has an unknown VR (bytes {:02x} {:02x})",
                           start, e[4], e[5]);
      }
      if (otherVr && printable)
        vr = "UN";
      if (!meta && open.empty()) {
        const char* expected = imageElementVr(group, element);
        if (expected != nullptr && !vr.empty() && vr != "UN" && vr != expected && !unknownVr) {
          return fmt::format(
              "element ({:04x},{:04x}) at byte {} has the VR {}, where it must be {}", group,
              element, start, vr, expected);
        }
      }
      if (unknownVr && big) {
        if (way == ReadWay::AsEncoded)
          return "";  // GDCM's big-endian read ends here; the other ways read on little endian
        bigEndian = false;  // this element again, little endian
        pos = start;
        continue;
      }
      if (unknownVr && unknownVrImplicit) {
        vr.clear();
        length = unsignedAt(e + 4, 4, big);
      } else if (unknownVr && !pixelData) {
        vr.clear();
        length = unsignedAt(e + 6, 2, big);
      } else if (kShortVr.count(vr) == 0) {
        if (pos + 12 > size || !bytes(pos, 12, e))
          return fmt::format("element ({:04x},{:04x}) at byte {}: the file ends inside its header",
                             group, element, start);
        length = unsignedAt(e + 8, 4, big);
        valueAt = pos + 12;
      } else {
        length = unsignedAt(e + 6, 2, big);
      }
    } else {
      length = unsignedAt(e + 4, 4, big);
    }
    // Debian's GDCM asserts (aborts the process) on a sequence or an undefined length in the
    // file meta group (found by fuzz/fuzz_dicom).
    if (meta && (vr == "SQ" || length == kUndefined)) {
      return fmt::format("element ({:04x},{:04x}) at byte {} of the file meta group is a {}", group,
                         element, start, vr == "SQ" ? "sequence" : "value of undefined length");
    }
    // (An element longer than the file is damaged below, saying so.)
    if (const std::string past = pastItsEnd(
            group, element, start,
            length == kUndefined ? valueAt
                                 : valueAt + std::min<std::uint64_t>(length, size - valueAt));
        !past.empty()) {
      return past;
    }
    pos = valueAt;
    // An undefined length in an explicit data set only on a sequence, UN, or pixel data of OB, OW
    // or UN: Debian's GDCM asserts (aborts the process) on any other
    // (gdcm::ExplicitDataElement::ReadValue; found by fuzz/fuzz_dicom).
    if (length == kUndefined && !vr.empty() && vr != "UN" &&
        (pixelData ? vr != "OB" && vr != "OW" : vr != "SQ")) {
      return fmt::format(
          "element ({:04x},{:04x}) at byte {} has an undefined length, which its VR "
          "{} cannot have",
          group, element, start, vr);
    }
    if (length == kUndefined) {
      if (vr == "UN" && way != ReadWay::UnSequencesExplicit) {
        // A sequence in implicit VR inside an explicit data set: GDCM reads it so, and reads the
        // data set again the UnSequencesExplicit way when that fails.
        // (Pixel data of VR UN and an undefined length: fragments, not items; as before.)
        std::string damage;
        const std::uint64_t end = implicitSequenceEnd(pos, damage);
        if (pixelData) {
          unFailsImplicit = unFailsImplicit || end == 0;
          return "";
        }
        if (!damage.empty())
          return damage;
        if (end == 0) {
          unFailsImplicit = true;
          return "";
        }
        pos = end;  // the data set goes on as encoded behind the sequence
        continue;
      }
      fragments = pixelData;  // encapsulated pixel data, else a sequence: items follow
      if (pixelData)
        fragmentsAt = start;
      if (!pixelData)
        open.emplace_back('S', start);
      continue;
    }
    if (length > size - pos) {
      // Native little endian pixel data cut short is refused later with its sizes, and read from
      // the file, not by GDCM. Any other is read by GDCM, which allocates the length it declares:
      // 4 GB for RLE pixel data of a defined length in a 908-byte file (fuzz/fuzz_dicom). So does
      // GDCM's read with 2-byte lengths on from an unknown VR, skipping pixel data or not
      // (VR16ExplicitDataElement::ReadValue): 1.46 GB for an 840-byte file (fuzz/fuzz_dicom).
      const bool gdcmReadsIt = way == ReadWay::Vr16AfterUnknown && readingVr16;
      if (pixelData && !bigEndian && !encapsulated && !gdcmReadsIt) {
        pixelBeyondFile = {start, pos, length};
        return "";
      }
      return fmt::format(
          "element ({:04x},{:04x}) at byte {} claims {} bytes, but {} are left in "
          "the file",
          group, element, start, length, size - pos);
    }
    // The transfer syntax: GDCM keeps the first of two (0002,0010) elements (its data set
    // inserts, never replaces), and read a data set in implicit VR after an explicit first one
    // as explicit, allocating 800 MB from a 900-byte file (found by fuzz/fuzz_dicom, stop 33).
    if (group == 0x0002 && element == 0x0010 && length <= 64 && !sawSyntax) {
      std::string uid(length, '\0');
      if (!bytes(pos, length, reinterpret_cast<unsigned char*>(uid.data())))
        return "";
      uid = uid.substr(0, uid.find_last_not_of(std::string(" \0", 2)) + 1);
      sawSyntax = true;
      if (uid == "1.2.840.10008.1.2.1.99")
        return "";  // deflated: GDCM inflates it
      explicitVr = uid != "1.2.840.10008.1.2";
      bigEndian = !littleEndianOnly && uid == "1.2.840.10008.1.2.2";
      encapsulated = explicitVr && !bigEndian && uid != "1.2.840.10008.1.2.1";
    }
    if (vr != "SQ")
      pos += length;  // a value; a sequence's items follow as elements
    else
      within.push_back({'S', start, pos + length});
  }
  // A file that ends inside (or right after) its file meta group: GDCM asserts (aborts the
  // process) reading the next tag (found by fuzz/fuzz_dicom).
  if (meta)
    return fmt::format("the file ends at byte {}, inside its file meta group", size);
  // A tag and less than the rest of an element's header: GDCM asserts (aborts the process) reading
  // its VR or length (gdcm::ExplicitDataElement::ReadPreValue; found by fuzz/fuzz_dicom).
  if (size - pos >= 4 && !fragments)
    return fmt::format("the file ends at byte {}, inside the header of an element", size);
  const auto item =
      std::find_if(open.rbegin(), open.rend(), [](const auto& o) { return o.first == 'I'; });
  if (item != open.rend()) {
    return fmt::format(
        "the file ends at byte {}, inside the item of undefined length at byte {}, which no item "
        "delimiter ends",
        size, item->second);
  }
  return "";
}

std::string elementBeyondFile(const fs::path& path, PixelBeyondFile& pixelBeyondFile,
                              bool& notDicom) {
  bool sawUnknownVr = false, unFailsImplicit = false;
  std::string damaged = walkElements(path, ReadWay::AsEncoded, sawUnknownVr, unFailsImplicit,
                                     pixelBeyondFile, notDicom);
  // An element of an unknown VR: the other ways GDCM may read the file (in a little-endian data
  // set the first way already walked the third).
  for (const ReadWay way : {ReadWay::Vr16AfterUnknown, ReadWay::LittleEndianImplicitUnknown}) {
    if (!damaged.empty() || !sawUnknownVr)
      break;
    PixelBeyondFile other;
    damaged = walkElements(path, way, sawUnknownVr, unFailsImplicit, other, notDicom);
    if (pixelBeyondFile.elementAt == 0)
      pixelBeyondFile = other;
  }
  // A sequence of VR UN that does not read in implicit VR: GDCM reads its items explicit.
  if (damaged.empty() && unFailsImplicit) {
    PixelBeyondFile other;
    bool unused = false;
    damaged =
        walkElements(path, ReadWay::UnSequencesExplicit, sawUnknownVr, unused, other, notDicom);
  }
  return damaged;
}

SliceHeader scanHeader(const fs::path& path) {
  SliceHeader h;
  h.name = path.filename().string();
  h.path = path.string();
  bool notDicom = false;
  h.damaged = elementBeyondFile(path, h.pixelBeyondFile, notDicom);
  if (!h.damaged.empty() || notDicom)
    return h;
  try {
    gdcm::Reader reader;
    reader.SetFileName(h.path.c_str());
    // With the pixel data in `skip`, GDCM stops right after that element's header: the stream is
    // then at the first pixel byte, and no pixel is read.
    const std::set<gdcm::Tag> skip{gdcm::Tag(0x7fe0, 0x0010)};
    if (!reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010), skip))
      return h;
    const gdcm::File& file = reader.GetFile();
    const gdcm::DataSet& ds = file.GetDataSet();
    if (ds.IsEmpty())
      return h;
    h.dicom = true;
    std::error_code sizeError;
    h.fileSize = fs::file_size(path, sizeError);
    if (sizeError)
      h.fileSize = 0;
    const std::size_t position = reader.GetStreamCurrentPosition();
    if (position != static_cast<std::size_t>(-1) && position < h.fileSize)
      h.pixelDataOffset = position;
    h.transferSyntax = trimmed(file.GetHeader().GetDataSetTransferSyntax().GetString()
                                   ? file.GetHeader().GetDataSetTransferSyntax().GetString()
                                   : "");
    gdcm::StringFilter filter;
    filter.SetFile(file);
    const auto text = [&](std::uint16_t group,
                          std::uint16_t element) -> std::optional<std::string> {
      const gdcm::Tag tag(group, element);
      if (!ds.FindDataElement(tag) || ds.GetDataElement(tag).IsEmpty())
        return std::nullopt;
      return trimmed(filter.ToString(tag));
    };
    const auto number = [&](std::uint16_t group, std::uint16_t element, const char* name,
                            std::size_t count) -> std::optional<std::vector<double>> {
      const auto value = text(group, element);
      if (!value)
        return std::nullopt;
      auto parsed = numbers(*value);
      if (!parsed || parsed->size() < count) {
        h.problems.push_back(
            fmt::format("{} \"{}\" is not {} number{}", name, *value, count, count > 1 ? "s" : ""));
        return std::nullopt;
      }
      return parsed;
    };
    const auto integer = [&](std::uint16_t group, std::uint16_t element, const char* name,
                             int fallback) {
      const auto value = number(group, element, name, 1);
      return value ? static_cast<int>(std::lround((*value)[0])) : fallback;
    };
    h.seriesUid = text(0x0020, 0x000e).value_or("");
    h.modality = text(0x0008, 0x0060).value_or("");
    h.description = text(0x0008, 0x103e).value_or("");
    h.sopClass = text(0x0008, 0x0016).value_or("");
    h.photometric = text(0x0028, 0x0004).value_or("");
    h.rows = integer(0x0028, 0x0010, "Rows", 0);
    h.columns = integer(0x0028, 0x0011, "Columns", 0);
    h.image = h.rows > 0 && h.columns > 0;
    h.bitsAllocated = integer(0x0028, 0x0100, "BitsAllocated", 0);
    h.bitsStored = integer(0x0028, 0x0101, "BitsStored", h.bitsAllocated);
    h.highBit = integer(0x0028, 0x0102, "HighBit", h.bitsStored - 1);
    h.pixelRepresentation = integer(0x0028, 0x0103, "PixelRepresentation", 0);
    h.samplesPerPixel = integer(0x0028, 0x0002, "SamplesPerPixel", 1);
    h.frames = text(0x0028, 0x0008).value_or("1");
    if (const auto p = number(0x0020, 0x0032, "ImagePositionPatient", 3)) {
      h.position = Eigen::Vector3d((*p)[0], (*p)[1], (*p)[2]);
    }
    if (const auto o = number(0x0020, 0x0037, "ImageOrientationPatient", 6)) {
      h.orientation = std::array<double, 6>{(*o)[0], (*o)[1], (*o)[2], (*o)[3], (*o)[4], (*o)[5]};
    }
    if (const auto s = number(0x0028, 0x0030, "PixelSpacing", 2)) {
      if ((*s)[0] > 0.0 && (*s)[1] > 0.0) {
        h.pixelSpacing = Eigen::Vector2d((*s)[0], (*s)[1]);
      } else {
        h.problems.push_back(fmt::format("PixelSpacing {}\\{} is not positive", (*s)[0], (*s)[1]));
      }
    }
    if (const auto v = number(0x0028, 0x1053, "RescaleSlope", 1))
      h.slope = (*v)[0];
    if (const auto v = number(0x0028, 0x1052, "RescaleIntercept", 1))
      h.intercept = (*v)[0];
    if (const auto v = number(0x0018, 0x1120, "GantryDetectorTilt", 1))
      h.gantryTiltDegrees = (*v)[0];
  } catch (const std::exception&) {
    h.dicom = false;  // GDCM throws on some malformed files: not a DICOM file we can read
    h.image = false;
  }
  return h;
}

/// Runs fn(index, worker) for index 0..count-1 on `threads` threads. When some calls throw, the
/// rest are skipped and the exception of the lowest index is rethrown (the same whatever the
/// number of threads: indices are handed out in order, so every index below a failing one has
/// been started and runs to its end).
template <class Fn>
void parallelFor(int count, int threads, Fn&& fn) {
  threads = std::max(1, std::min(threads, count));
  std::atomic<int> next{0};
  std::atomic<bool> stop{false};
  std::mutex errorMutex;
  int errorIndex = std::numeric_limits<int>::max();
  std::exception_ptr error;
  const auto work = [&](int worker) {
    for (;;) {
      if (stop.load())
        return;
      const int index = next.fetch_add(1);
      if (index >= count)
        return;
      try {
        fn(index, worker);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(errorMutex);
        if (index < errorIndex) {
          errorIndex = index;
          error = std::current_exception();
        }
        stop.store(true);
      }
    }
  };
  if (threads == 1) {
    work(0);
  } else {
    std::vector<std::thread> pool;
    pool.reserve(static_cast<std::size_t>(threads));
    for (int t = 0; t < threads; ++t)
      pool.emplace_back(work, t);
    for (std::thread& thread : pool)
      thread.join();
  }
  if (error)
    std::rethrow_exception(error);
}

int threadCount(const DicomReadOptions& options) {
  if (options.threads < 0) {
    throw std::invalid_argument(
        fmt::format("DicomReadOptions.threads = {} is negative", options.threads));
  }
  if (options.threads > 0)
    return options.threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

/// The headers of `folder`'s regular files (sorted by name), or of the single file `folder`.
struct Scan {
  std::vector<SliceHeader> headers;
  bool singleFile = false;
};

Scan scanFolder(const std::string& folder, int threads) {
  silenceGdcm();
  std::error_code ec;
  const fs::file_status status = fs::status(folder, ec);
  if (ec || !fs::exists(status))
    throw core::FileError(folder, "does not exist");
  Scan scan;
  std::vector<fs::path> paths;
  if (fs::is_regular_file(status)) {
    scan.singleFile = true;
    paths.emplace_back(folder);
  } else if (fs::is_directory(status)) {
    fs::directory_iterator it(folder, ec);
    if (ec)
      throw core::FileError(folder, "cannot be listed: " + ec.message());
    for (const fs::directory_entry& entry : it) {
      std::error_code typeError;
      if (entry.is_regular_file(typeError))
        paths.push_back(entry.path());
    }
    std::sort(paths.begin(), paths.end());
  } else {
    throw core::FileError(folder, "is neither a folder nor a regular file");
  }
  scan.headers.resize(paths.size());
  parallelFor(static_cast<int>(paths.size()), threads, [&](int index, int) {
    scan.headers[static_cast<std::size_t>(index)] =
        scanHeader(paths[static_cast<std::size_t>(index)]);
  });
  return scan;
}

std::string seriesLabel(const std::string& uid) {
  return uid.empty() ? std::string("(no SeriesInstanceUID)") : uid;
}

struct SeriesGroup {
  DicomSeriesSummary summary;
  std::vector<std::size_t> members;  ///< indices into Scan::headers, by file name
};

/// Image series by UID, largest first (ties by UID); skipped files into `warnings`.
std::vector<SeriesGroup> groupSeries(const Scan& scan, std::vector<std::string>* warnings) {
  std::map<std::string, SeriesGroup> byUid;
  std::vector<std::string> notDicom, noImage, damaged;
  for (std::size_t n = 0; n < scan.headers.size(); ++n) {
    const SliceHeader& h = scan.headers[n];
    if (!h.damaged.empty()) {
      damaged.push_back(h.name + " (" + h.damaged + ")");
      continue;
    }
    if (!h.dicom) {
      notDicom.push_back(h.name);
      continue;
    }
    if (!h.image) {
      noImage.push_back(h.name);
      continue;
    }
    SeriesGroup& group = byUid[h.seriesUid];
    if (group.members.empty()) {
      group.summary.seriesInstanceUid = h.seriesUid;
      group.summary.modality = h.modality;
      group.summary.description = h.description;
      group.summary.rows = h.rows;
      group.summary.columns = h.columns;
      group.summary.firstFile = h.name;
    }
    group.members.push_back(n);
    group.summary.files = static_cast<int>(group.members.size());
  }
  if (warnings != nullptr) {
    if (!damaged.empty()) {
      warnings->push_back(fmt::format("skipped {} damaged DICOM file{}: {}", damaged.size(),
                                      damaged.size() > 1 ? "s" : "", nameList(damaged)));
    }
    if (!notDicom.empty()) {
      warnings->push_back(fmt::format("skipped {} file{} that GDCM cannot read as DICOM: {}",
                                      notDicom.size(), notDicom.size() > 1 ? "s" : "",
                                      nameList(notDicom)));
    }
    if (!noImage.empty()) {
      warnings->push_back(fmt::format("skipped {} DICOM file{} without an image: {}",
                                      noImage.size(), noImage.size() > 1 ? "s" : "",
                                      nameList(noImage)));
    }
  }
  std::vector<SeriesGroup> series;
  for (auto& [uid, group] : byUid)
    series.push_back(std::move(group));
  std::stable_sort(series.begin(), series.end(), [](const SeriesGroup& a, const SeriesGroup& b) {
    return a.summary.files > b.summary.files;
  });
  return series;
}

std::string describeSeries(const std::vector<SeriesGroup>& series) {
  std::string out;
  for (const SeriesGroup& s : series) {
    if (!out.empty())
      out += "; ";
    out += fmt::format("{} ({}, {} file{}: {}{})", seriesLabel(s.summary.seriesInstanceUid),
                       s.summary.modality.empty() ? "no modality" : s.summary.modality,
                       s.summary.files, s.summary.files > 1 ? "s" : "", s.summary.firstFile,
                       s.summary.files > 1 ? "..." : "");
  }
  return out;
}

/// The headers of the chosen series plus the warnings so far.
struct Selection {
  std::vector<SliceHeader> slices;
  std::vector<std::string> warnings;
  std::string modality;
  std::string uid;
  bool singleFile = false;
};

Selection selectSeries(const std::string& folder, const DicomReadOptions& options, int threads) {
  Scan scan = scanFolder(folder, threads);
  Selection selection;
  selection.singleFile = scan.singleFile;
  if (scan.singleFile) {
    const SliceHeader& h = scan.headers.front();
    if (!h.damaged.empty())
      throw core::FileError(folder, "is a damaged DICOM file: " + h.damaged);
    if (!h.dicom)
      throw core::FileError(folder, "is not a DICOM file (GDCM cannot read it)");
    if (!h.image) {
      throw core::FileError(
          folder, fmt::format("is a DICOM file without an image (no Rows / Columns; SOP class {})",
                              h.sopClass.empty() ? "absent" : h.sopClass));
    }
  }
  std::vector<std::string> skipped;
  std::vector<SeriesGroup> series = groupSeries(scan, &skipped);
  if (series.empty()) {
    std::vector<std::string> subfolders;
    if (!scan.singleFile) {
      std::error_code ec;
      for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
        std::error_code typeError;
        if (entry.is_directory(typeError))
          subfolders.push_back(entry.path().filename().string());
      }
      std::sort(subfolders.begin(), subfolders.end());
    }
    throw core::FileError(
        folder, fmt::format("is a directory with no DICOM image ({} file{}{}{}{}{})",
                            scan.headers.size(), scan.headers.size() == 1 ? "" : "s",
                            skipped.empty() ? "" : "; ", skipped.empty() ? "" : skipped.front(),
                            subfolders.empty() ? "" : "; subfolders are not searched, it has: ",
                            nameList(subfolders)));
  }
  const SeriesGroup* chosen = nullptr;
  if (!options.seriesUid.empty()) {
    for (const SeriesGroup& s : series) {
      if (s.summary.seriesInstanceUid == options.seriesUid)
        chosen = &s;
    }
    if (chosen == nullptr) {
      throw core::FileError(folder, fmt::format("has no series {}; it has: {}", options.seriesUid,
                                                describeSeries(series)));
    }
  } else if (scan.singleFile) {
    chosen = &series.front();
  } else {
    for (const SeriesGroup& s : series) {
      if (s.summary.modality == "CT") {
        chosen = &s;
        break;
      }
    }
    if (chosen == nullptr) {
      throw core::FileError(folder, "holds no CT series; it has: " + describeSeries(series));
    }
  }
  selection.warnings = skipped;
  if (series.size() > 1) {
    std::vector<SeriesGroup> others;
    for (const SeriesGroup& s : series) {
      if (&s != chosen)
        others.push_back(s);
    }
    selection.warnings.push_back(fmt::format("read series {}; left out {} other series: {}",
                                             seriesLabel(chosen->summary.seriesInstanceUid),
                                             others.size(), describeSeries(others)));
  }
  selection.modality = chosen->summary.modality;
  selection.uid = chosen->summary.seriesInstanceUid;
  if (selection.modality != "CT") {
    selection.warnings.push_back(fmt::format(
        "modality {} is not CT: the voxels are the rescaled stored values, not Hounsfield units",
        selection.modality.empty() ? "(absent)" : selection.modality));
  }
  for (std::size_t index : chosen->members)
    selection.slices.push_back(std::move(scan.headers[index]));
  return selection;
}

Eigen::Vector3d rowDirection(const std::array<double, 6>& o) {
  return {o[0], o[1], o[2]};
}
Eigen::Vector3d columnDirection(const std::array<double, 6>& o) {
  return {o[3], o[4], o[5]};
}

/// Checks the selected headers and computes the geometry; sorts `selection.slices` into slice
/// order. The image gets everything but its voxels.
DicomSeriesRead buildGeometry(const std::string& folder, Selection& selection) {
  std::vector<SliceHeader>& slices = selection.slices;
  const bool single = slices.size() == 1;
  const auto fail = [&folder](const std::string& problem) {
    throw core::FileError(folder, problem);
  };

  // Per-file problems first: each names its files.
  {
    std::vector<std::string> unparsable, multiFrame, colour, noPosition, noOrientation, noSpacing,
        badBits;
    std::string firstProblem;
    for (const SliceHeader& h : slices) {
      if (!h.problems.empty()) {
        unparsable.push_back(h.name);
        if (firstProblem.empty())
          firstProblem = h.problems.front();
      }
      const auto frames = numbers(h.frames);
      if (!frames || frames->size() != 1) {
        unparsable.push_back(h.name);
        if (firstProblem.empty())
          firstProblem = "NumberOfFrames \"" + h.frames + "\" is not a number";
      } else if ((*frames)[0] != 1.0) {
        multiFrame.push_back(h.name + " (" + h.frames + " frames)");
      }
      if (h.samplesPerPixel != 1 || (!h.photometric.empty() && h.photometric != "MONOCHROME2" &&
                                     h.photometric != "MONOCHROME1")) {
        colour.push_back(h.name + (h.photometric.empty() ? "" : " (" + h.photometric + ")"));
      }
      if (!h.position)
        noPosition.push_back(h.name);
      if (!h.orientation)
        noOrientation.push_back(h.name);
      if (!h.pixelSpacing)
        noSpacing.push_back(h.name);
      if ((h.bitsAllocated != 8 && h.bitsAllocated != 16 && h.bitsAllocated != 32) ||
          h.bitsStored < 1 || h.bitsStored > h.bitsAllocated || h.highBit + 1 < h.bitsStored ||
          h.highBit >= h.bitsAllocated) {
        badBits.push_back(
            fmt::format("{} ({}/{}/{})", h.name, h.bitsAllocated, h.bitsStored, h.highBit));
      }
    }
    if (!unparsable.empty())
      fail(fmt::format("unreadable values in {}: {}", nameList(unparsable), firstProblem));
    if (!multiFrame.empty()) {
      fail("multi-frame images are not supported (export the series as one file per slice): " +
           nameList(multiFrame));
    }
    if (!colour.empty()) {
      fail(
          "colour or palette images (not MONOCHROME1/2 with one sample per pixel) are not CT "
          "slices: " +
          nameList(colour));
    }
    if (!badBits.empty()) {
      fail("unsupported pixel layout (BitsAllocated/BitsStored/HighBit): " + nameList(badBits));
    }
    if (!single) {
      if (!noPosition.empty())
        fail("slices without ImagePositionPatient: " + nameList(noPosition));
      if (!noOrientation.empty())
        fail("slices without ImageOrientationPatient: " + nameList(noOrientation));
      if (!noSpacing.empty())
        fail("slices without PixelSpacing: " + nameList(noSpacing));
    }
  }
  DicomSeriesRead result;
  result.warnings = std::move(selection.warnings);
  result.modality = selection.modality;
  SliceHeader& first = slices.front();
  if (!first.position) {
    first.position = Eigen::Vector3d::Zero();
    result.warnings.push_back(first.name +
                              " has no ImagePositionPatient: origin (0, 0, 0) assumed");
  }
  if (!first.orientation) {
    first.orientation = std::array<double, 6>{1, 0, 0, 0, 1, 0};
    result.warnings.push_back(first.name +
                              " has no ImageOrientationPatient: axial (1 0 0, 0 1 0) assumed");
  }
  if (!first.pixelSpacing) {
    first.pixelSpacing = Eigen::Vector2d(1.0, 1.0);
    result.warnings.push_back(first.name + " has no PixelSpacing: 1 mm assumed");
  }

  // Sizes, spacings and orientations equal to the first file's.
  const Eigen::Vector3d row0 = rowDirection(*first.orientation);
  const Eigen::Vector3d column0 = columnDirection(*first.orientation);
  if (std::abs(row0.norm() - 1.0) > 1e-3 || std::abs(column0.norm() - 1.0) > 1e-3 ||
      std::abs(row0.dot(column0)) > 1e-3) {
    fail(fmt::format("{}: ImageOrientationPatient ({}, {}) is not two orthogonal unit vectors",
                     first.name, fmt::join(row0, " "), fmt::join(column0, " ")));
  }
  {
    std::vector<std::string> size, spacing, orientation, tilt;
    for (const SliceHeader& h : slices) {
      if (h.rows != first.rows || h.columns != first.columns) {
        size.push_back(fmt::format("{} ({} x {})", h.name, h.columns, h.rows));
      }
      if (((*h.pixelSpacing - *first.pixelSpacing).array().abs() >
           kSpacingRelativeTolerance * first.pixelSpacing->array())
              .any()) {
        spacing.push_back(
            fmt::format("{} ({}\\{})", h.name, (*h.pixelSpacing)[0], (*h.pixelSpacing)[1]));
      }
      if ((rowDirection(*h.orientation) - row0).cwiseAbs().maxCoeff() > kOrientationTolerance ||
          (columnDirection(*h.orientation) - column0).cwiseAbs().maxCoeff() >
              kOrientationTolerance) {
        orientation.push_back(h.name);
      }
      if (std::abs(h.gantryTiltDegrees) > kGantryTiltDegrees) {
        tilt.push_back(fmt::format("{} ({} degrees)", h.name, h.gantryTiltDegrees));
      }
    }
    if (!size.empty()) {
      fail(fmt::format("slices differ in size: {} is {} x {} but {}", first.name, first.columns,
                       first.rows, nameList(size)));
    }
    if (!spacing.empty()) {
      fail(fmt::format("slices differ in PixelSpacing: {} has {}\\{} but {}", first.name,
                       (*first.pixelSpacing)[0], (*first.pixelSpacing)[1], nameList(spacing)));
    }
    if (!orientation.empty()) {
      fail(fmt::format("mixed orientations: {} has ImageOrientationPatient {}\\{} but {} differ{}",
                       first.name, fmt::join(row0, "\\"), fmt::join(column0, "\\"),
                       nameList(orientation), orientation.size() == 1 ? "s" : ""));
    }
    if (!tilt.empty())
      fail("gantry tilt (GantryDetectorTilt) is not supported: " + nameList(tilt));
  }

  // Sort along the normal (`first` dangles from here on).
  const Eigen::Vector3d row = row0.normalized();
  const Eigen::Vector3d column = (column0 - column0.dot(row) * row).normalized();
  const Eigen::Vector3d normal = row.cross(column);
  std::vector<double> along(slices.size());
  for (std::size_t n = 0; n < slices.size(); ++n)
    along[n] = slices[n].position->dot(normal);
  std::vector<std::size_t> order(slices.size());
  for (std::size_t n = 0; n < order.size(); ++n)
    order[n] = n;
  std::stable_sort(order.begin(), order.end(),
                   [&along](std::size_t a, std::size_t b) { return along[a] < along[b]; });
  {
    std::vector<SliceHeader> sorted;
    std::vector<double> sortedAlong;
    sorted.reserve(slices.size());
    for (std::size_t n : order) {
      sorted.push_back(std::move(slices[n]));
      sortedAlong.push_back(along[n]);
    }
    slices = std::move(sorted);
    along = std::move(sortedAlong);
  }
  const std::size_t count = slices.size();
  for (std::size_t k = 1; k < count; ++k) {
    if (along[k] - along[k - 1] < kSamePositionMm) {
      fail(fmt::format("duplicate slice position: {} and {} are both at {:.3f} mm along the normal",
                       slices[k - 1].name, slices[k].name, along[k]));
    }
  }
  const Eigen::Vector3d origin = *slices.front().position;
  for (std::size_t k = 1; k < count; ++k) {
    const Eigen::Vector3d offset = *slices[k].position - origin;
    const double distance = offset.dot(normal);
    const double off = (offset - distance * normal).norm();
    if (off > kOffNormalMm + kOffNormalRelative * std::abs(distance)) {
      fail(fmt::format(
          "slices are not stacked along their normal (gantry tilt or a sheared series): {} lies "
          "{:.3f} mm off the normal through {} ({:.2f} degrees)",
          slices[k].name, off, slices.front().name,
          std::atan2(off, distance) * 180.0 / 3.14159265358979323846));
    }
  }

  // Steps, missing slices, groups.
  std::vector<double> steps;
  for (std::size_t k = 1; k < count; ++k)
    steps.push_back(along[k] - along[k - 1]);
  const auto sameStep = [](double a, double b) {
    return std::abs(a - b) <= std::max(kGroupStepMm, kGroupStepRelative * std::min(a, b));
  };
  for (std::size_t k = 1; k + 1 < steps.size(); ++k) {
    const double before = steps[k - 1], after = steps[k + 1];
    if (sameStep(before, after) && steps[k] > 1.5 * before && steps[k] > 1.5 * after) {
      fail(fmt::format(
          "a slice seems missing between {} and {}: they are {:.3f} mm apart where the slices on "
          "both sides are {:.3f} mm apart",
          slices[k].name, slices[k + 1].name, steps[k], before));
    }
  }
  core::CtImage& image = result.image;
  image.folder = folder;
  image.seriesInstanceUid = selection.uid;
  image.dimensions = {slices.front().columns, slices.front().rows, static_cast<int>(count)};
  image.originMm = origin;
  image.direction.col(0) = row;
  image.direction.col(1) = column;
  image.direction.col(2) = normal;
  // PixelSpacing is (between rows, between columns): i runs along a row, so its spacing is the
  // second value.
  image.pixelSpacingMm =
      Eigen::Vector2d((*slices.front().pixelSpacing)[1], (*slices.front().pixelSpacing)[0]);
  image.slicePositionsMm.resize(count);
  for (std::size_t k = 0; k < count; ++k)
    image.slicePositionsMm[k] = along[k] - along[0];
  {
    int start = 0;
    double groupFirstStep = -1.0, sum = 0.0;
    int groupSteps = 0;
    const auto close = [&](int last) {
      image.groups.push_back(
          core::CtSliceGroup{start, last - start + 1, groupSteps > 0 ? sum / groupSteps : 0.0});
    };
    for (std::size_t k = 0; k < steps.size(); ++k) {
      const double step = steps[k];
      if (groupSteps == 0) {
        groupFirstStep = step;
        sum = step;
        groupSteps = 1;
      } else if (sameStep(step, groupFirstStep)) {
        sum += step;
        ++groupSteps;
      } else {
        close(static_cast<int>(k));
        start = static_cast<int>(k) + 1;
        sum = 0.0;
        groupSteps = 0;
      }
    }
    close(static_cast<int>(count) - 1);
  }
  result.files.reserve(count);
  for (const SliceHeader& h : slices)
    result.files.push_back(h.name);
  return result;
}

/// Per-thread scratch: the decoded slice when GDCM must decode, and the lookup table from stored
/// 8- or 16-bit words to HU for the last rescale seen.
struct Scratch {
  std::vector<char> buffer;
  std::vector<std::int16_t> table;
  struct Key {
    int bitsAllocated = -1, bitsStored = -1, highBit = -1, pixelRepresentation = -1;
    double slope = 0, intercept = 0;
    bool operator==(const Key& o) const {
      return bitsAllocated == o.bitsAllocated && bitsStored == o.bitsStored &&
             highBit == o.highBit && pixelRepresentation == o.pixelRepresentation &&
             slope == o.slope && intercept == o.intercept;
    }
  } key;
};

std::int16_t toHu(double value) {
  const double rounded = std::round(value);
  if (!(rounded > std::numeric_limits<std::int16_t>::min()))
    return std::numeric_limits<std::int16_t>::min();
  if (rounded >= std::numeric_limits<std::int16_t>::max())
    return std::numeric_limits<std::int16_t>::max();
  return static_cast<std::int16_t>(rounded);
}

/// The stored value of a raw word: BitsStored bits ending at HighBit, sign-extended if signed.
std::int64_t storedValue(std::uint32_t word, const Scratch::Key& key) {
  const int shift = key.highBit + 1 - key.bitsStored;
  const std::uint64_t mask = (std::uint64_t{1} << key.bitsStored) - 1;
  std::int64_t value = static_cast<std::int64_t>((std::uint64_t{word} >> shift) & mask);
  if (key.pixelRepresentation == 1 && (value >> (key.bitsStored - 1)) != 0) {
    value -= static_cast<std::int64_t>(std::uint64_t{1} << key.bitsStored);
  }
  return value;
}

void convert(const char* data, std::size_t pixels, const Scratch::Key& key, Scratch& scratch,
             std::int16_t* out) {
  if (key.bitsAllocated == 32) {
    for (std::size_t p = 0; p < pixels; ++p) {
      std::uint32_t word = 0;
      std::memcpy(&word, data + 4 * p, 4);
      out[p] = toHu(static_cast<double>(storedValue(word, key)) * key.slope + key.intercept);
    }
    return;
  }
  // Integer rescale of unsigned values that cannot leave the int16 range (the usual CT: 12 or 16
  // stored bits, slope 1, intercept -1024 or -1000): a plain loop the compiler vectorises.
  const int intercept = static_cast<int>(key.intercept);
  const std::int64_t largest = (std::int64_t{1} << key.bitsStored) - 1 + intercept;
  if (key.bitsAllocated == 16 && key.slope == 1.0 &&
      key.intercept == static_cast<double>(intercept) && key.pixelRepresentation == 0 &&
      key.highBit + 1 == key.bitsStored && intercept >= -32768 && largest <= 32767) {
    const auto mask = static_cast<std::uint16_t>((1u << key.bitsStored) - 1u);
    for (std::size_t p = 0; p < pixels; ++p) {
      std::uint16_t word = 0;
      std::memcpy(&word, data + 2 * p, 2);
      out[p] = static_cast<std::int16_t>(static_cast<int>(word & mask) + intercept);
    }
    return;
  }
  if (!(scratch.key == key)) {
    const std::size_t size = std::size_t{1} << key.bitsAllocated;
    scratch.table.resize(size);
    for (std::size_t word = 0; word < size; ++word) {
      scratch.table[word] =
          toHu(static_cast<double>(storedValue(static_cast<std::uint32_t>(word), key)) * key.slope +
               key.intercept);
    }
    scratch.key = key;
  }
  const std::int16_t* table = scratch.table.data();
  if (key.bitsAllocated == 8) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(data);
    for (std::size_t p = 0; p < pixels; ++p)
      out[p] = table[bytes[p]];
  } else {
    for (std::size_t p = 0; p < pixels; ++p) {
      std::uint16_t word = 0;
      std::memcpy(&word, data + 2 * p, 2);
      out[p] = table[word];
    }
  }
}

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// Native little-endian pixel data (implicit or explicit VR) whose value offset the header scan
/// found: read straight from the file into the thread's buffer, without GDCM parsing the file
/// again and allocating the pixel data. The 12 bytes before the value are read too and must be
/// the pixel data element's header (tag, VR OB/OW in explicit VR, a length covering the pixels);
/// otherwise (an offset the scan got wrong, e.g. after a nested icon image) GDCM reads the file.
/// True when done; false when this path does not apply.
bool readNativeSlice(const std::string& folder, const SliceHeader& h, std::int16_t* out,
                     Scratch& scratch) {
  constexpr std::size_t kHeader = 12;
  if (h.pixelDataOffset < kHeader || !hostIsLittleEndian() ||
      (h.transferSyntax != "1.2.840.10008.1.2" && h.transferSyntax != "1.2.840.10008.1.2.1")) {
    return false;
  }
  const bool explicitVr = h.transferSyntax == "1.2.840.10008.1.2.1";
  const Scratch::Key key{h.bitsAllocated,       h.bitsStored, h.highBit,
                         h.pixelRepresentation, h.slope,      h.intercept};
  const std::size_t pixels = static_cast<std::size_t>(h.rows) * static_cast<std::size_t>(h.columns);
  const std::size_t bytes = pixels * static_cast<std::size_t>(key.bitsAllocated / 8);
  const int fd = ::open(h.path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw core::FileError(folder, h.name + ": cannot be opened: " + std::strerror(errno));
  scratch.buffer.resize(kHeader + bytes);
  std::size_t done = 0;
  while (done < kHeader + bytes) {
    const ssize_t n = ::pread(fd, scratch.buffer.data() + done, kHeader + bytes - done,
                              static_cast<off_t>(h.pixelDataOffset - kHeader + done));
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
      break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  const char* head = scratch.buffer.data();
  const char tag[4] = {'\xe0', '\x7f', '\x10', '\x00'};
  std::uint32_t length = 0;
  std::memcpy(&length, head + 8, 4);
  const bool headerFound =
      done >= kHeader &&
      (explicitVr ? std::memcmp(head, tag, 4) == 0 &&
                        (std::memcmp(head + 4, "OW", 2) == 0 || std::memcmp(head + 4, "OB", 2) == 0)
                  : std::memcmp(head + 4, tag, 4) == 0) &&
      length != 0xffffffffu;
  if (!headerFound)
    return false;
  if (done != kHeader + bytes || length < bytes) {
    throw core::FileError(
        folder,
        fmt::format("{}: truncated pixel data: {} bytes where {} x {} pixels of {} bits need {}",
                    h.name, std::min<std::size_t>(done - kHeader, length), h.columns, h.rows,
                    key.bitsAllocated, bytes));
  }
  convert(head + kHeader, pixels, key, scratch, out);
  return true;
}

/// The bytes of an RLE Lossless slice's compressed frame, read from the file as GDCM will read
/// them (gdcm::SequenceOfFragments, then gdcm::RLECodec::Decode): the pixel data's items after
/// its header, the first the basic offset table, the others fragments, up to the sequence
/// delimiter (or the file's end), their values joined. Throws a FileError when the items are not
/// where the header scan found the pixel data.
std::vector<unsigned char> rleFrame(const std::string& folder, const SliceHeader& h) {
  constexpr std::uint64_t kHeader = 12;
  std::ifstream in(h.path, std::ios::binary);
  const auto fail = [&](const std::string& problem) {
    throw core::FileError(folder, fmt::format("{}: damaged RLE pixel data: {}", h.name, problem));
  };
  if (!in || h.pixelDataOffset < kHeader || h.fileSize == 0)
    fail("the pixel data could not be found in the file");
  unsigned char header[kHeader] = {};
  in.seekg(static_cast<std::streamoff>(h.pixelDataOffset - kHeader));
  in.read(reinterpret_cast<char*>(header), kHeader);
  // Encapsulated pixel data (explicit VR little endian): its tag, OB or OW, an undefined length.
  if (!in || unsignedAt(header, 2) != 0x7fe0 || unsignedAt(header + 2, 2) != 0x0010 ||
      (std::memcmp(header + 4, "OB", 2) != 0 && std::memcmp(header + 4, "OW", 2) != 0) ||
      unsignedAt(header + 8, 4) != 0xffffffffu) {
    fail(fmt::format("the pixel data at byte {} is not a sequence of fragments",
                     h.pixelDataOffset - kHeader));
  }
  std::vector<unsigned char> frame;
  std::uint64_t pos = h.pixelDataOffset;
  for (int item = 0; pos + 8 <= h.fileSize; ++item) {
    unsigned char tag[8] = {};
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(reinterpret_cast<char*>(tag), 8);
    const std::uint32_t group = unsignedAt(tag, 2), element = unsignedAt(tag + 2, 2);
    const std::uint32_t length = unsignedAt(tag + 4, 4);
    if (in && group == 0xfffe && element == 0xe0dd)
      break;
    if (!in || group != 0xfffe || element != 0xe000 || length > h.fileSize - pos - 8) {
      fail(fmt::format("byte {} of the file is not a fragment of the pixel data, nor their end",
                       pos));
    }
    pos += 8;
    if (item > 0) {  // item 0 is the basic offset table
      const std::size_t at = frame.size();
      frame.resize(at + length);
      in.read(reinterpret_cast<char*>(frame.data() + at), static_cast<std::streamsize>(length));
      if (!in)
        fail(fmt::format("the fragment at byte {} cannot be read", pos - 8));
    }
    pos += length;
  }
  return frame;
}

/// Why GDCM cannot decode `frame`, an RLE Lossless frame (DICOM PS3.5 annex G), into `segments`
/// byte planes of `planeBytes` bytes each, or "" when it can. The frame is a 64-byte header (the
/// number of segments, 1 to 15, then 15 offsets from the frame's start, the first 64) and the
/// segments, each a PackBits stream of one byte plane: a control byte n of 0 to 127 copies the
/// next n + 1 bytes, -1 to -127 repeats the next byte 1 - n times, -128 does nothing.
/// GDCM 3.0's decoder (gdcm::RLECodec::DecodeByStreams) trusts the header and reads each segment
/// from its offset until it has its share of the slice's bytes: 0 segments divide by zero
/// (SIGFPE), more than 15 read offsets from beyond the header, a count that does not divide the
/// slice's bytes fails an assertion (the process aborts; found by fuzz/fuzz_dicom), and a segment
/// that ends early is completed with the next segment's bytes (a silently wrong slice). So the
/// header is checked, then each segment is decoded by counting, without writing a byte, within
/// its own bytes (up to the next offset, or the frame's end): it must give exactly planeBytes
/// before it ends. Bytes left after that are padding, which GDCM skips too.
std::string rleFrameProblem(const std::vector<unsigned char>& frame, std::uint32_t segments,
                            std::uint64_t planeBytes) {
  constexpr std::size_t kRleHeader = 64;
  if (frame.size() < kRleHeader) {
    return fmt::format("its frame holds {} bytes, fewer than the {} of an RLE header", frame.size(),
                       kRleHeader);
  }
  const auto word = [&frame](std::size_t index) { return unsignedAt(&frame[4 * index], 4); };
  const std::uint32_t declared = word(0);
  if (declared != segments) {
    return fmt::format(
        "its RLE header declares {} segments, where the pixels need {} (one per byte of a pixel)",
        declared, segments);
  }
  // Where each segment starts, and the frame's end after the last.
  std::vector<std::uint64_t> bounds;
  for (std::uint32_t s = 0; s < segments; ++s)
    bounds.push_back(word(1 + s));
  bounds.push_back(frame.size());
  bool increasing = bounds.front() == kRleHeader;
  for (std::size_t s = 1; s < bounds.size(); ++s)
    increasing = increasing && bounds[s] > bounds[s - 1];
  if (!increasing) {
    return fmt::format(
        "its RLE header's segment offsets ({}) are not {}, then increasing, inside "
        "the {}-byte frame",
        fmt::join(bounds.begin(), bounds.end() - 1, ", "), kRleHeader, frame.size());
  }
  for (std::uint32_t s = 0; s < segments; ++s) {
    const std::uint64_t begin = bounds[s], end = bounds[s + 1];
    std::uint64_t decoded = 0, at = begin;
    while (decoded < planeBytes) {
      if (at >= end) {
        return fmt::format(
            "segment {} of {} (bytes {} to {} of the frame) decodes to {} bytes, "
            "where the pixels need {}",
            s + 1, segments, begin, end, decoded, planeBytes);
      }
      const std::uint64_t runAt = at;
      const auto control = static_cast<signed char>(frame[static_cast<std::size_t>(at++)]);
      std::uint64_t run = 0;
      if (control >= 0) {
        run = static_cast<std::uint64_t>(control) + 1;  // a literal run: its bytes follow
        if (end - at < run) {
          return fmt::format(
              "segment {} of {} (bytes {} to {} of the frame) ends inside the "
              "{}-byte literal run at byte {}",
              s + 1, segments, begin, end, run, runAt);
        }
        at += run;
      } else if (control != -128) {
        run = static_cast<std::uint64_t>(1 - control);  // a replicate run: one byte follows
        if (at >= end) {
          return fmt::format(
              "segment {} of {} (bytes {} to {} of the frame) ends inside the "
              "replicate run at byte {}",
              s + 1, segments, begin, end, runAt);
        }
        at += 1;
      }
      decoded += run;
      if (decoded > planeBytes) {
        return fmt::format(
            "segment {} of {} decodes to more than the {} bytes the pixels need "
            "(its run at byte {} of the frame ends at {})",
            s + 1, segments, planeBytes, runAt, decoded);
      }
    }
  }
  return "";
}

void decodeSlice(const std::string& folder, const SliceHeader& h, std::int16_t* out,
                 Scratch& scratch) {
  if (readNativeSlice(folder, h, out, scratch))
    return;
  // GDCM decodes an RLE slice already while it reads the file (gdcm::PixmapReader computes the
  // lossy flag by decoding), so its frame is checked before: see rleFrameProblem.
  if (h.transferSyntax == kRleLossless) {
    const std::uint64_t planeBytes =
        static_cast<std::uint64_t>(h.rows) * static_cast<std::uint64_t>(h.columns);
    const auto segments = static_cast<std::uint32_t>(h.bitsAllocated / 8 * h.samplesPerPixel);
    const std::string problem = rleFrameProblem(rleFrame(folder, h), segments, planeBytes);
    if (!problem.empty()) {
      throw core::FileError(folder,
                            fmt::format("{}: damaged RLE pixel data ({} x {} pixels of {} bits): "
                                        "{}",
                                        h.name, h.columns, h.rows, h.bitsAllocated, problem));
    }
  }
  gdcm::ImageReader reader;
  reader.SetFileName(h.path.c_str());
  bool read = false;
  try {
    read = reader.Read();
  } catch (const std::exception&) {
    read = false;
  }
  if (!read)
    throw core::FileError(folder, h.name + ": GDCM cannot read its image");
  const gdcm::Image& image = reader.GetImage();
  const gdcm::PixelFormat& format = image.GetPixelFormat();
  const unsigned int* dims = image.GetDimensions();
  if (dims == nullptr || dims[0] != static_cast<unsigned int>(h.columns) ||
      dims[1] != static_cast<unsigned int>(h.rows) ||
      (image.GetNumberOfDimensions() > 2 && dims[2] != 1)) {
    throw core::FileError(
        folder, h.name + ": GDCM reports image dimensions other than the header's Rows / Columns");
  }
  if (format.GetSamplesPerPixel() != 1)
    throw core::FileError(folder, h.name + ": not a one-sample (grey) image");
  const Scratch::Key key{format.GetBitsAllocated(),
                         format.GetBitsStored(),
                         format.GetHighBit(),
                         format.GetPixelRepresentation(),
                         h.slope,
                         h.intercept};
  if ((key.bitsAllocated != 8 && key.bitsAllocated != 16 && key.bitsAllocated != 32) ||
      key.bitsStored < 1 || key.bitsStored > key.bitsAllocated ||
      key.highBit + 1 < key.bitsStored || key.highBit >= key.bitsAllocated) {
    throw core::FileError(
        folder,
        fmt::format("{}: unsupported pixel format ({} bits allocated, {} stored, high bit {})",
                    h.name, key.bitsAllocated, key.bitsStored, key.highBit));
  }
  const std::size_t pixels = static_cast<std::size_t>(h.rows) * static_cast<std::size_t>(h.columns);
  const std::size_t bytes = pixels * static_cast<std::size_t>(key.bitsAllocated / 8);
  const gdcm::DataElement& pixelData = image.GetDataElement();
  const gdcm::ByteValue* raw = pixelData.GetByteValue();
  if (pixelData.IsEmpty() && pixelData.GetSequenceOfFragments() == nullptr) {
    throw core::FileError(folder, h.name + ": no pixel data");
  }
  const gdcm::TransferSyntax& syntax = image.GetTransferSyntax();
  if (raw != nullptr && !syntax.IsEncapsulated()) {
    if (h.pixelDataOffset > 0 && h.fileSize > 0 && h.pixelDataOffset + bytes > h.fileSize) {
      throw core::FileError(
          folder,
          fmt::format("{}: truncated pixel data: the file ends {} bytes short of the {} x {} "
                      "pixels of {} bits",
                      h.name, h.pixelDataOffset + bytes - h.fileSize, h.columns, h.rows,
                      key.bitsAllocated));
    }
    if (raw->GetLength() < bytes) {
      throw core::FileError(
          folder,
          fmt::format("{}: truncated pixel data: {} bytes where {} x {} pixels of {} bits "
                      "need {}",
                      h.name, raw->GetLength(), h.columns, h.rows, key.bitsAllocated, bytes));
    }
    if (hostIsLittleEndian() && syntax.GetSwapCode() == gdcm::SwapCode::LittleEndian) {
      convert(raw->GetPointer(), pixels, key, scratch, out);  // no copy for the common case
      return;
    }
  }
  const unsigned long length = image.GetBufferLength();
  if (length < bytes) {
    throw core::FileError(folder, fmt::format("{}: GDCM decodes {} bytes where {} are needed",
                                              h.name, length, bytes));
  }
  scratch.buffer.resize(length);
  bool decoded = false;
  try {
    decoded = image.GetBuffer(scratch.buffer.data());
  } catch (const std::exception&) {
    decoded = false;
  }
  if (!decoded) {
    throw core::FileError(
        folder, fmt::format("{}: GDCM cannot decode its pixel data ({})", h.name,
                            syntax.GetString() ? syntax.GetString() : "unknown transfer syntax"));
  }
  convert(scratch.buffer.data(), pixels, key, scratch, out);
}

/// Sizes the headers claim, checked against the files before the volume is allocated (issue 15,
/// item 12): a slice claiming 4096 x 4096 pixels in a file of 30 kB allocated 5.5 GB for 12 s
/// before "truncated pixel data", and 65535 x 65535 ended in std::bad_alloc with no file named.
/// An uncompressed slice must hold its Rows x Columns pixels after the pixel data's start; the
/// volume (16-bit HU) must fit in this machine's memory whatever the transfer syntax.
void checkSizesBeforeAllocating(const std::string& folder, const std::vector<SliceHeader>& slices,
                                const core::CtImage& image) {
  for (const SliceHeader& h : slices) {
    const std::uint64_t bytesPerPixel =
        static_cast<std::uint64_t>(std::max(1, h.samplesPerPixel)) *
        static_cast<std::uint64_t>((std::max(0, h.bitsAllocated) + 7) / 8);
    const std::uint64_t needed = static_cast<std::uint64_t>(std::max(0, h.rows)) *
                                 static_cast<std::uint64_t>(std::max(0, h.columns)) * bytesPerPixel;
    // GDCM allocates the declared length before it reads the value, and fills what the file lacks
    // silently: a 836-byte slice declaring 3,288,334,464 bytes of pixel data took 3.2 GB and 12 s
    // and was read without a word when its 128 bytes of pixels were there and a private element
    // after the pixel data's tag made the header scan miss the pixels' start (fuzz/fuzz_dicom).
    // The pixels the header claims, against the bytes the file holds after their start.
    const auto refuseTruncated = [&](std::uint64_t held) {
      if (needed <= held)
        return;
      throw core::FileError(
          folder,
          fmt::format("{}: truncated pixel data: its header claims {} x {} pixels of {} bits "
                      "({} bytes), but the file holds {} bytes after the pixel data's start: "
                      "Rows / Columns in the header are wrong, or the file was cut short",
                      h.name, h.columns, h.rows, h.bitsAllocated, needed, held));
    };
    if (const PixelBeyondFile& beyond = h.pixelBeyondFile; beyond.elementAt != 0) {
      const std::uint64_t held = h.fileSize > beyond.valueAt ? h.fileSize - beyond.valueAt : 0;
      refuseTruncated(held);
      throw core::FileError(
          folder, fmt::format("{}: damaged pixel data: its element at byte {} declares {} bytes, "
                              "but the file ends {} bytes after the value's start (the {} x {} "
                              "pixels of {} bits need {}): the length in the file is wrong, or "
                              "the file was cut short",
                              h.name, beyond.elementAt, beyond.declared, held, h.columns, h.rows,
                              h.bitsAllocated, needed));
    }
    const bool native = h.transferSyntax == "1.2.840.10008.1.2" ||
                        h.transferSyntax == "1.2.840.10008.1.2.1" ||
                        h.transferSyntax == "1.2.840.10008.1.2.2";
    if (!native || h.pixelDataOffset == 0 || h.fileSize == 0 || h.bitsAllocated <= 0)
      continue;
    refuseTruncated(h.fileSize - std::min(h.fileSize, h.pixelDataOffset));
  }
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long pageBytes = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || pageBytes <= 0)
    return;
  const double memoryBytes = static_cast<double>(pages) * static_cast<double>(pageBytes);
  const double volumeBytes = static_cast<double>(image.dimensions[0]) *
                             static_cast<double>(image.dimensions[1]) *
                             static_cast<double>(image.dimensions[2]) * sizeof(std::int16_t);
  if (volumeBytes > memoryBytes) {
    throw core::FileError(
        folder,
        fmt::format("the series' {} x {} x {} voxels (the headers' Columns x Rows of {}, times {} "
                    "slices) need {:.1f} GB as 16-bit HU, more than this machine's {:.1f} GB "
                    "of memory",
                    image.dimensions[0], image.dimensions[1], image.dimensions[2],
                    slices.empty() ? std::string() : slices.front().name, image.dimensions[2],
                    volumeBytes / 1e9, memoryBytes / 1e9));
  }
}

DicomSeriesRead readGeometry(const std::string& folder, const DicomReadOptions& options,
                             int threads, std::vector<SliceHeader>& slices) {
  Selection selection = selectSeries(folder, options, threads);
  DicomSeriesRead result = buildGeometry(folder, selection);
  slices = std::move(selection.slices);
  return result;
}

}  // namespace

std::vector<DicomSeriesSummary> listDicomSeries(const std::string& folder,
                                                std::vector<std::string>* warnings) {
  const Scan scan = scanFolder(folder, threadCount({}));
  std::vector<DicomSeriesSummary> out;
  for (const SeriesGroup& group : groupSeries(scan, warnings))
    out.push_back(group.summary);
  return out;
}

DicomSeriesRead readDicomSeriesGeometry(const std::string& folder,
                                        const DicomReadOptions& options) {
  std::vector<SliceHeader> slices;
  return readGeometry(folder, options, threadCount(options), slices);
}

DicomSeriesRead readDicomSeriesWithWarnings(const std::string& folder,
                                            const DicomReadOptions& options) {
  const int threads = threadCount(options);
  std::vector<SliceHeader> slices;
  DicomSeriesRead result = readGeometry(folder, options, threads, slices);
  core::CtImage& image = result.image;
  checkSizesBeforeAllocating(folder, slices, image);
  const std::size_t plane =
      static_cast<std::size_t>(image.dimensions[0]) * static_cast<std::size_t>(image.dimensions[1]);
  image.hu.resize(image.voxelCount());
  const int total = static_cast<int>(slices.size());
  std::vector<Scratch> scratch(static_cast<std::size_t>(std::max(1, std::min(threads, total))));
  std::mutex progressMutex;
  int done = 0;
  parallelFor(total, threads, [&](int k, int worker) {
    decodeSlice(folder, slices[static_cast<std::size_t>(k)],
                image.hu.data() + plane * static_cast<std::size_t>(k),
                scratch[static_cast<std::size_t>(worker)]);
    if (options.progress) {
      const std::lock_guard<std::mutex> lock(progressMutex);
      options.progress(++done, total);
    }
  });
  return result;
}

}  // namespace echoreg::segmentation
