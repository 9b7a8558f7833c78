// The DICOM series reader: synthetic series written by the simulator's writer (exact geometry,
// groups and HU; every refusal names the files), the real CT series in ../shared/data checked
// against pydicom and against GDCM's own decoding, and every broken file of dicom-bad.
#include "echoreg/core/error.hpp"
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/simulation/ct.hpp"
#include "test_support.hpp"

#include <fmt/format.h>
#include <gdcmAttribute.h>
#include <gdcmDataElement.h>
#include <gdcmImage.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmReader.h>
#include <gdcmTag.h>
#include <gdcmVR.h>
#include <gdcmWriter.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
using echoreg::core::CtImage;
using echoreg::core::FileError;
using echoreg::segmentation::DicomReadOptions;
using echoreg::segmentation::DicomSeriesRead;
using echoreg::segmentation::readDicomSeries;
using echoreg::segmentation::readDicomSeriesWithWarnings;

/// HU covering the whole stored range [-1024, 3071], different in every voxel of a small volume.
std::int16_t pattern(int i, int j, int k) {
  return static_cast<std::int16_t>((i * 37 + j * 101 + k * 613) % 4096 - 1024);
}

CtImage volumeWithSlices(const std::vector<double>& z, int columns, int rows, double pixelMm) {
  CtImage v =
      echoreg::core::axialCtImage(columns, rows, pixelMm, {-10.5, 20.25}, {{"test", z, 1.0}});
  v.hu.resize(z.size() * static_cast<std::size_t>(rows * columns));
  for (int k = 0; k < v.dimensions[2]; ++k) {
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < columns; ++i)
        v.hu[v.index(i, j, k)] = pattern(i, j, k);
    }
  }
  return v;
}

void writeSeries(const std::string& folder, const CtImage& volume) {
  echoreg::simulation::DicomSeriesInfo info;
  info.uidSeed = 11;
  info.seriesDescription = "reader test";
  echoreg::simulation::writeDicomSeries(folder, volume, info);
}

std::string fileName(int k) {  // the writer's names, k from 0
  char name[32];
  std::snprintf(name, sizeof name, "IM%06d.dcm", k + 1);
  return name;
}

/// Rewrites one element of a DICOM file (through a temporary file).
void editElement(const std::string& path, const gdcm::DataElement& element) {
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  ASSERT_TRUE(reader.Read()) << path;
  reader.GetFile().GetDataSet().Replace(element);
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  const std::string temporary = path + ".edit";
  writer.SetFileName(temporary.c_str());
  ASSERT_TRUE(writer.Write()) << temporary;
  fs::rename(temporary, path);
}

void editString(const std::string& path, std::uint16_t group, std::uint16_t element, gdcm::VR vr,
                std::string value) {
  if (value.size() % 2 != 0)
    value.push_back(' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<std::uint32_t>(value.size()));
  editElement(path, de);
}

/// The message of the FileError that reading `folder` throws ("" when it does not throw).
std::string refusal(const std::string& folder, const DicomReadOptions& options = {}) {
  try {
    readDicomSeries(folder, options);
  } catch (const FileError& e) {
    EXPECT_EQ(e.path(), folder);
    return e.what();
  }
  return "";
}

#define EXPECT_CONTAINS(text, part)                          \
  EXPECT_NE(std::string(text).find(part), std::string::npos) \
      << "expected \"" << (part) << "\" in: " << (text)

TEST(DicomSeries, ThreeGroupsOfTheSimulatedProtocolGiveExactGeometryGroupsAndHu) {
  echoreg::test::TempDir dir;
  // The simulator's small protocol: 3 hip slices at 5 mm, 160 knee slices at 1 mm, 3 ankle slices
  // at 5 mm, with large gaps between the groups; 256 x 256 pixels of 0.8 mm.
  CtImage volume = echoreg::simulation::ctGeometry(
      echoreg::simulation::smallProtocol(0.0, -430.0, -830.0, Eigen::Vector2d(5.0, -3.0)));
  volume.hu.resize(volume.voxelCount());
  for (int k = 0; k < volume.dimensions[2]; ++k) {
    for (int j = 0; j < volume.dimensions[1]; ++j) {
      for (int i = 0; i < volume.dimensions[0]; ++i)
        volume.hu[volume.index(i, j, k)] = pattern(i, j, k);
    }
  }
  const std::string folder = dir.file("ct");
  writeSeries(folder, volume);
  std::ofstream(dir.file("ct/README.txt")) << "not DICOM\n";

  int calls = 0, lastDone = 0;
  DicomReadOptions options;
  options.progress = [&](int done, int total) {
    ++calls;
    EXPECT_EQ(done, lastDone + 1);
    EXPECT_EQ(total, 166);
    lastDone = done;
  };
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder, options);
  EXPECT_EQ(calls, 166);
  const CtImage& image = read.image;
  ASSERT_EQ(image.dimensions, (std::array<int, 3>{256, 256, 166}));
  ASSERT_EQ(image.groups.size(), 3U);
  EXPECT_EQ(image.groups[0].count, 3);
  EXPECT_EQ(image.groups[1].count, 160);
  EXPECT_EQ(image.groups[2].count, 3);
  EXPECT_EQ(image.groups[1].firstSlice, 3);
  EXPECT_NEAR(image.groups[0].spacingMm, 5.0, 1e-9);
  EXPECT_NEAR(image.groups[1].spacingMm, 1.0, 1e-9);
  EXPECT_NEAR(image.groups[2].spacingMm, 5.0, 1e-9);
  EXPECT_FALSE(image.uniform());
  EXPECT_TRUE(image.direction.isIdentity(0.0));
  EXPECT_NEAR((image.originMm - volume.voxelCentreMm(0, 0, 0)).norm(), 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(image.pixelSpacingMm.x(), 0.8);
  EXPECT_DOUBLE_EQ(image.pixelSpacingMm.y(), 0.8);
  for (int k = 0; k < 166; ++k) {
    EXPECT_NEAR(image.slicePositionsMm[static_cast<std::size_t>(k)],
                volume.sliceLocationsMm[static_cast<std::size_t>(k)] - volume.sliceLocationsMm[0],
                1e-9);
    EXPECT_NEAR((image.voxelToLps(Eigen::Vector3d(7, 9, k)) - volume.voxelCentreMm(7, 9, k)).norm(),
                0.0, 1e-9);
  }
  EXPECT_TRUE(image.hu == volume.hu);  // every voxel exactly
  EXPECT_EQ(read.files.front(), "IM000001.dcm");
  EXPECT_EQ(read.files.back(), "IM000166.dcm");
  EXPECT_EQ(read.modality, "CT");
  EXPECT_EQ(image.seriesInstanceUid, echoreg::simulation::derivedDicomUid(11, "series"));
  ASSERT_EQ(read.warnings.size(), 1U);
  EXPECT_CONTAINS(read.warnings[0], "README.txt");

  const auto series = echoreg::segmentation::listDicomSeries(folder);
  ASSERT_EQ(series.size(), 1U);
  EXPECT_EQ(series[0].files, 166);
  EXPECT_EQ(series[0].modality, "CT");
  EXPECT_EQ(series[0].description, "reader test");
  EXPECT_EQ(series[0].seriesInstanceUid, image.seriesInstanceUid);
}

class DicomSeriesRefusal : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = dir_.file("series");
    volume_ = volumeWithSlices({0, 2, 4, 6, 8, 10}, 4, 3, 0.5);
    writeSeries(folder_, volume_);
  }
  std::string path(int k) const { return folder_ + "/" + fileName(k); }
  /// Slice k's file, whole.
  std::string bytesOf(int k) const {
    std::ifstream in(path(k), std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  /// Where a slice's RescaleIntercept element (0028,1052) starts in its bytes, explicit VR
  /// little endian (npos when it is not there): an element inserted there lies inside the data set.
  static std::size_t rescaleInterceptAt(const std::string& bytes) {
    return bytes.find(
        std::string("\x28\x00\x52\x10"
                    "DS",
                    6));
  }
  /// The test process's peak resident size so far, kB: a declared length GDCM allocated shows.
  static long peakKb() {
    struct rusage usage {};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_maxrss;
  }

  echoreg::test::TempDir dir_;
  std::string folder_;
  CtImage volume_;
};

TEST_F(DicomSeriesRefusal, TheGoodSeriesReadsTheSameWithAnyThreadCount) {
  DicomReadOptions one;
  one.threads = 1;
  DicomReadOptions three;
  three.threads = 3;
  const CtImage a = readDicomSeries(folder_, one);
  const CtImage b = readDicomSeries(folder_, three);
  EXPECT_TRUE(a.hu == volume_.hu);
  EXPECT_TRUE(a.hu == b.hu);
  ASSERT_EQ(a.groups.size(), 1U);
  EXPECT_NEAR(a.sliceSpacingMm(), 2.0, 1e-12);
}

TEST_F(DicomSeriesRefusal, ShuffledFileNamesStillSortByPosition) {
  const std::vector<int> order{3, 0, 5, 1, 4, 2};  // new name "z<n>" for slice order[n]
  for (std::size_t n = 0; n < order.size(); ++n) {
    fs::rename(path(order[n]), folder_ + "/z" + std::to_string(n) + ".dcm");
  }
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder_);
  EXPECT_TRUE(read.image.hu == volume_.hu);
  EXPECT_EQ(read.files,
            (std::vector<std::string>{"z1.dcm", "z3.dcm", "z5.dcm", "z0.dcm", "z4.dcm", "z2.dcm"}));
}

TEST_F(DicomSeriesRefusal, EachSliceUsesItsOwnRescale) {
  // Slice 2: intercept -1000 instead of -1024 (+24 HU); slice 4: slope 2 (stored x 2 - 1024).
  editString(path(2), 0x0028, 0x1052, gdcm::VR::DS, "-1000");
  editString(path(4), 0x0028, 0x1053, gdcm::VR::DS, "2");
  const CtImage image = readDicomSeries(folder_);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(image.at(i, j, 1), pattern(i, j, 1));
      EXPECT_EQ(image.at(i, j, 2), pattern(i, j, 2) + 24);
      EXPECT_EQ(image.at(i, j, 4), std::min(32767, 2 * (pattern(i, j, 4) + 1024) - 1024));
    }
  }
}

TEST_F(DicomSeriesRefusal, SignedStoredValuesAreSignExtended) {
  // The same 12 stored bits read as signed: stored values from 2048 up are negative.
  for (int k = 0; k < 6; ++k) {
    gdcm::Attribute<0x0028, 0x0103> representation;
    representation.SetValue(1);
    editElement(path(k), representation.GetAsDataElement());
  }
  const CtImage image = readDicomSeries(folder_);
  int negative = 0;
  for (int k = 0; k < 6; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 4; ++i) {
        const int stored = pattern(i, j, k) + 1024;
        const int expected = (stored >= 2048 ? stored - 4096 : stored) - 1024;
        negative += stored >= 2048 ? 1 : 0;
        EXPECT_EQ(image.at(i, j, k), expected) << i << " " << j << " " << k;
      }
    }
  }
  EXPECT_GT(negative, 10);
}

TEST_F(DicomSeriesRefusal, PaletteImages) {
  editString(path(1), 0x0028, 0x0004, gdcm::VR::CS, "PALETTE COLOR");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "palette");
  EXPECT_CONTAINS(message, fileName(1) + " (PALETTE COLOR)");
}

TEST_F(DicomSeriesRefusal, MissingSlice) {
  fs::remove(path(3));
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "missing");
  EXPECT_CONTAINS(message, fileName(2));
  EXPECT_CONTAINS(message, fileName(4));
}

TEST_F(DicomSeriesRefusal, DuplicatePosition) {
  fs::copy_file(path(2), folder_ + "/copy.dcm");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "duplicate");
  EXPECT_CONTAINS(message, fileName(2));
  EXPECT_CONTAINS(message, "copy.dcm");
}

TEST_F(DicomSeriesRefusal, OneSliceWithAnotherOrientation) {
  editString(path(4), 0x0020, 0x0037, gdcm::VR::DS, "1\\0\\0\\0\\0.9961946981\\0.08715574275");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "mixed orientations");
  EXPECT_CONTAINS(message, fileName(4));
}

TEST_F(DicomSeriesRefusal, GantryTiltFromPositions) {
  // Every slice tilted alike (so orientations agree): positions drift along y with z.
  for (int k = 0; k < 6; ++k) {
    editString(path(k), 0x0020, 0x0037, gdcm::VR::DS, "1\\0\\0\\0\\0.9961946981\\0.08715574275");
    const double z = 2.0 * k;
    editString(path(k), 0x0020, 0x0032, gdcm::VR::DS, "-10.5\\20.25\\" + std::to_string(z));
  }
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "not stacked along their normal");
  EXPECT_CONTAINS(message, fileName(0));
}

TEST_F(DicomSeriesRefusal, GantryTiltTag) {
  for (int k = 0; k < 6; ++k)
    editString(path(k), 0x0018, 0x1120, gdcm::VR::DS, "12");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "gantry tilt");
  EXPECT_CONTAINS(message, fileName(0));
}

TEST_F(DicomSeriesRefusal, DifferentPixelSpacingOrSize) {
  editString(path(1), 0x0028, 0x0030, gdcm::VR::DS, "0.6\\0.6");
  std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "PixelSpacing");
  EXPECT_CONTAINS(message, fileName(1));

  editString(path(1), 0x0028, 0x0030, gdcm::VR::DS, "0.5\\0.5");
  gdcm::Attribute<0x0028, 0x0010> rows;
  rows.SetValue(2);
  editElement(path(5), rows.GetAsDataElement());
  message = refusal(folder_);
  EXPECT_CONTAINS(message, "differ in size");
  EXPECT_CONTAINS(message, fileName(5));
}

TEST_F(DicomSeriesRefusal, TruncatedPixelData) {
  const std::uintmax_t size = fs::file_size(path(3));
  fs::resize_file(path(3), size - 7);
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "truncated");
  EXPECT_CONTAINS(message, fileName(3));
}

// Issue 15, item 12: sizes the headers claim are checked against the files before the volume is
// allocated (4096 x 4096 allocated 5.5 GB before "truncated pixel data"; 65535 x 65535 ended in
// std::bad_alloc with no file named).
TEST_F(DicomSeriesRefusal, RowsAndColumnsLargerThanTheFileAreRefusedBeforeAllocating) {
  for (const int side : {4096, 65535}) {
    for (int k = 0; k < 6; ++k) {
      gdcm::Attribute<0x0028, 0x0010> rows;
      rows.SetValue(static_cast<std::uint16_t>(side));
      editElement(path(k), rows.GetAsDataElement());
      gdcm::Attribute<0x0028, 0x0011> columns;
      columns.SetValue(static_cast<std::uint16_t>(side));
      editElement(path(k), columns.GetAsDataElement());
    }
    const std::string message = refusal(folder_);
    const std::string claim = std::to_string(side) + " x " + std::to_string(side) +
                              " pixels of 16 bits (" + std::to_string(2ULL * side * side) +
                              " bytes), but the file holds 24 bytes";
    EXPECT_CONTAINS(message, fileName(0) + ": truncated pixel data: its header claims " + claim);
    EXPECT_CONTAINS(message, "Rows / Columns in the header are wrong, or the file was cut short");
  }
}

// Found by fuzz/fuzz_dicom: GDCM allocates (and fills) the length an element declares before
// reading it, 1.2 GB for a 1.5 kB file. Here SeriesDescription's VR "LO" (a 2-byte length) is
// made "UT" (2 reserved bytes, then a 4-byte length: the first bytes of "reader test", about
// 1.9 GB). The file is skipped as damaged, named with the element, before GDCM reads it.
TEST_F(DicomSeriesRefusal, AnElementLongerThanTheFileIsNotAllocated) {
  std::string bytes = bytesOf(2);
  const std::size_t at = bytes.find(std::string("\x08\x00\x3e\x10LO", 6));
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at + 4, 2, "UT");
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  const std::string message = refusal(path(2));
  EXPECT_CONTAINS(message, fileName(2) + ": is a damaged DICOM file: element (0008,103e) at byte ");
  EXPECT_CONTAINS(message, "bytes, but ");
  EXPECT_CONTAINS(message, "are left in the file");
  // In the series: that slice is skipped (and said to be), the gap it leaves refused.
  const std::string series = refusal(folder_);
  EXPECT_CONTAINS(series, "missing");
  EXPECT_LT(peakKb(), 1000L * 1024L) << "peak kB: the declared length was allocated";
}

// Found by fuzz/fuzz_dicom (stop 31, seed found-timeout-first-vr-unknown-55567a98): a 130-byte file
// without the preamble whose first tag (4c30,3054) is followed by "??", no VR: GDCM's own guess
// finds no encoding ("Cannot find DICOM type") but reads on as explicit VR big endian, takes
// "????" for a length and allocates and fills 1 GB (7.8 s) before giving up. Such a file is not
// handed to GDCM: skipped as not DICOM at once.
TEST_F(DicomSeriesRefusal, AFileWhoseFirstTagGivesNoEncodingIsNotGivenToGdcm) {
  const std::string folder = dir_.file("junk");
  fs::create_directories(folder);
  std::ofstream(folder + "/a.dcm", std::ios::binary)
      << "0LT0" + std::string(94, '?') + "LN4gdcm9ExcepT" +
             std::string("\0\xf1\0DI\x0f\0\0\0\0\0\x02 \x0f\0\0\0L", 18);
  ASSERT_EQ(fs::file_size(folder + "/a.dcm"), 130U);
  EXPECT_CONTAINS(refusal(folder), "skipped 1 file that GDCM cannot read as DICOM: a.dcm");
  EXPECT_LT(peakKb(), 500L * 1024L) << "peak kB: the length GDCM read was allocated";
}

// Found by fuzz/fuzz_dicom (stop 32, seed found-oom-big-endian-guess-15e0be15): a file without the
// preamble whose first group (4c30) and VR ("LT") make GDCM guess explicit VR big endian. Its
// second element's VR is two zero bytes, which GDCM does not know: it then reads the data set
// again little endian from the start, that element as implicit, and allocated the length its last
// four bytes give read little endian (3.77 GB, 11 s); before that, GDCM's read on from that
// element with a 2-byte length takes 57600 from them. Read big endian they gave 225, inside the
// file, so the walk before GDCM missed it. Refused as damaged, naming the element, before GDCM.
// A second file, of 16 bytes, tells the ways apart: on from the element, its 2-byte length is 0
// and the file ends there, whole; from the start as implicit, its length is 513 little endian
// (16.9 MB big endian).
TEST_F(DicomSeriesRefusal, AnUnknownVrInABigEndianGuessIsWalkedLittleEndianAsGdcmRereadsIt) {
  const std::string folder = dir_.file("guess");
  fs::create_directories(folder);
  std::ofstream(folder + "/a.dcm", std::ios::binary)
      << std::string("0LT0LT\0\0\0\x02\x20\x0f\0\0\0\xe1", 16) + std::string(228, '\xe1');
  ASSERT_EQ(fs::file_size(folder + "/a.dcm"), 244U);
  EXPECT_CONTAINS(refusal(folder),
                  "skipped 1 damaged DICOM file: a.dcm (element (0200,0f20) at "
                  "byte 8 claims 57600 bytes, but 228 are left in the file)");
  EXPECT_LT(peakKb(), 500L * 1024L) << "peak kB: the length GDCM read was allocated";

  std::ofstream(folder + "/a.dcm", std::ios::binary | std::ios::trunc)
      << std::string("0LT0LT\0\0\0\x02\x20\x0f\x01\x02\0\0", 16);
  EXPECT_CONTAINS(refusal(folder),
                  "skipped 1 damaged DICOM file: a.dcm (element (0200,0f20) at "
                  "byte 8 claims 513 bytes, but 0 are left in the file)");
}

// Found by fuzz/fuzz_dicom (stop 33, seed found-abort-un-sequence-explicit-3f59f142): an element
// of VR UN and undefined length in an explicit data set is read by GDCM as a sequence in implicit
// VR (CP-246); when that fails, GDCM reads the whole data set again with such sequences' items in
// explicit VR, and asserts (aborts the process) on a sequence delimiter where an item's element
// must stand. The walk stopped at the UN sequence ("GDCM sorts it out"); it now reads the sequence
// in implicit VR to its delimiter, and where that fails walks into it in explicit VR as GDCM will.
// A sequence that reads either way is read; one whose item lacks its delimiter is refused.
TEST_F(DicomSeriesRefusal, AnUnSequenceThatDoesNotReadImplicitIsWalkedExplicitAsGdcmRereadsIt) {
  const std::string original = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(original);
  ASSERT_NE(at, std::string::npos);
  const std::string un("\x08\x00\x15\x11UN\0\0\xff\xff\xff\xff", 12);
  const std::string itemOpen("\xfe\xff\x00\xe0\xff\xff\xff\xff", 8);
  const std::string itemEnd("\xfe\xff\x0d\xe0\0\0\0\0", 8);
  const std::string sequenceEnd("\xfe\xff\xdd\xe0\0\0\0\0", 8);
  const std::string implicitElement(
      "\x08\x00\x50\x11\x04\0\0\0"
      "1.2\0",
      12);
  const std::string explicitElement(
      "\x08\x00\x50\x11UI\x04\0"
      "1.2\0",
      12);
  const auto withSequence = [&](const std::string& sequence) {
    std::string bytes = original;
    bytes.insert(at, un + sequence);
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  };
  for (const std::string& element : {implicitElement, explicitElement}) {
    withSequence(itemOpen + element + itemEnd + sequenceEnd);
    EXPECT_TRUE(readDicomSeries(folder_).hu == volume_.hu)
        << (element == implicitElement ? "implicit" : "explicit") << " items";
  }
  withSequence(itemOpen + explicitElement + sequenceEnd);
  EXPECT_CONTAINS(refusal(path(2)), fileName(2) +
                                        ": is a damaged DICOM file: a sequence delimiter "
                                        "at byte " +
                                        std::to_string(at + 32) + " stands where an element must");
}

// Found by fuzz/fuzz_dicom (stop 33, seed found-oom-vr16-pixel-data-074d2007): pixel data whose VR
// is neither known to GDCM nor printable ("O\x80") in an explicit little-endian data set. GDCM
// reads the data set again on from it with 2-byte lengths (VR16ExplicitDataElement), which for
// pixel data reads 2 reserved bytes and a 4-byte length and allocates that length, skipping the
// pixel data or not: 1.46 GB for an 840-byte file. The walk deferred pixel data beyond the file
// to the reader's own check (GDCM skips it when it reads as encoded); on that way it no longer
// does: refused as damaged, naming the length GDCM would allocate.
TEST_F(DicomSeriesRefusal, PixelDataBeyondTheFileIsDamagedWhereGdcmReadsItWithTwoByteLengths) {
  std::string bytes = bytesOf(2);
  const std::size_t at = bytes.find(std::string("\xe0\x7f\x10\x00OW\0\0", 8));
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at + 4, 8, std::string("O\x80\0\0\0\x65\0\x57", 8));
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_CONTAINS(refusal(path(2)), fileName(2) +
                                        ": is a damaged DICOM file: element (7fe0,0010) "
                                        "at byte " +
                                        std::to_string(at) + " claims 1459643648 bytes");
  EXPECT_LT(peakKb(), 500L * 1024L) << "peak kB: the length GDCM read was allocated";
}

// Found by fuzz/fuzz_dicom (stop 33, seed found-oom-two-transfer-syntaxes-5effd428): a file meta
// group with two transfer syntaxes, explicit VR little endian first and implicit second, over a
// data set in implicit VR. GDCM keeps the first (its data set inserts and never replaces), reads
// the data set as explicit and allocated 800 MB from a 304-byte file (2.4 s), then found no image;
// the walk before it took the second and saw nothing wrong. It now takes the first, as GDCM does:
// refused as damaged before GDCM, naming the element that reading gives.
TEST_F(DicomSeriesRefusal, TheFirstOfTwoTransferSyntaxesIsTheOneGdcmReadsBy) {
  const auto le16 = [](unsigned v) { return std::string{char(v & 0xff), char(v >> 8)}; };
  const auto le32 = [&](unsigned v) { return le16(v & 0xffff) + le16(v >> 16); };
  const auto explicitElement = [&](unsigned group, unsigned element, const std::string& vr,
                                   const std::string& value) {
    return le16(group) + le16(element) + vr + le16(static_cast<unsigned>(value.size())) + value;
  };
  const auto implicitElement = [&](unsigned group, unsigned element, const std::string& value) {
    return le16(group) + le16(element) + le32(static_cast<unsigned>(value.size())) + value;
  };
  std::string meta = explicitElement(2, 0x10, "UI", std::string("1.2.840.10008.1.2.1\0", 20)) +
                     explicitElement(2, 0x10, "UI", std::string("1.2.840.10008.1.2\0", 18));
  meta = explicitElement(2, 0, "UL", le32(static_cast<unsigned>(meta.size()))) + meta;
  const std::string dataSet =
      implicitElement(8, 0x16, std::string("1.2.840.10008.5.1.4.1.1.2\0", 26)) +
      implicitElement(8, 0x18, std::string("1.2.826.0.1.3680043.8.498.1\0", 28)) +
      implicitElement(0x20, 0xd, std::string("1.2.826.0.1.3680043.8.498.2\0", 28));
  const std::string folder = dir_.file("two-syntaxes");
  fs::create_directories(folder);
  std::ofstream(folder + "/a.dcm", std::ios::binary)
      << std::string(128, '\0') + "DICM" + meta + dataSet;
  ASSERT_EQ(fs::file_size(folder + "/a.dcm"), 304U);
  EXPECT_CONTAINS(refusal(folder),
                  "skipped 1 damaged DICOM file: a.dcm (element (2e31,2e32) at byte 206 claims "
                  "808464433 bytes, but 86 are left in the file)");
  EXPECT_LT(peakKb(), 500L * 1024L) << "peak kB: the length GDCM read was allocated";
}

// Found by fuzz/fuzz_dicom (stop 32, seed found-abort-sequence-delimiter-as-element-5c2cb3b8): a
// sequence delimiter outside any sequence in an explicit little-endian data set ends GDCM's read
// there, which goes on with 2-byte lengths from it and asserts (aborts the process) on that tag;
// so does the tag (fffe,0000) wherever an element is read. Refused as damaged before GDCM.
TEST_F(DicomSeriesRefusal, ADelimiterWhereAnElementMustStandIsDamaged) {
  const std::string original = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(original);
  ASSERT_NE(at, std::string::npos);
  for (const std::string& tag :
       {std::string("\xfe\xff\xdd\xe0", 4), std::string("\xfe\xff\0\0", 4)}) {
    std::string bytes = original;
    bytes.insert(at, tag + std::string(4, '\0'));
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
    EXPECT_CONTAINS(refusal(path(2)),
                    fileName(2) + ": is a damaged DICOM file: a " +
                        (tag[2] == '\0' ? "tag (fffe,0000)" : "sequence delimiter") + " at byte " +
                        std::to_string(at) + " stands where an element must");
  }
  EXPECT_CONTAINS(refusal(folder_), "missing");
}

// Found by fuzz/fuzz_dicom (stop 31, seed found-abort-rescale-vr-5d7e66de): GDCM reads the image's
// own elements (rescale, spacing, geometry, pixel description) through typed attributes that
// assert, aborting the process, on another VR: a RescaleIntercept of VR CS here (the fuzzer's file
// had RescaleSlope). Refused as damaged, naming the element, before GDCM reads it.
TEST_F(DicomSeriesRefusal, AnImageElementOfAnotherVrIsDamaged) {
  std::string bytes = bytesOf(2);
  const std::size_t at =
      bytes.find(std::string("\x28\x00\x52\x10"
                             "DS",
                             6));
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at + 4, 2, "CS");
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_CONTAINS(refusal(path(2)), fileName(2) +
                                        ": is a damaged DICOM file: element (0028,1052) "
                                        "at byte " +
                                        std::to_string(at) + " has the VR CS, where it must be DS");
  EXPECT_CONTAINS(refusal(folder_), "missing");
}

// Found by fuzz/fuzz_dicom (seed found-oom-pixel-length-94f3771e): native pixel data whose
// declared length runs past the end of the file, its pixels all there. GDCM allocates the declared
// length before reading, and pads what the file lacks without a word: 3.2 GB and 12 s for an
// 836-byte slice, read as if whole, when an element out of tag order before the pixel data (a
// private (ff27,1052)) made the header scan miss where the pixels start. Both ways the slice is
// refused before anything is allocated, naming the element and the lengths.
TEST_F(DicomSeriesRefusal, PixelDataDeclaringMoreThanTheFileHoldsIsRefusedBeforeAllocating) {
  std::string bytes = bytesOf(2);
  const std::size_t pixels = bytes.find(std::string("\xe0\x7f\x10\x00OW\x00\x00", 8));
  ASSERT_NE(pixels, std::string::npos);
  const std::size_t held = bytes.size() - (pixels + 12);
  ASSERT_EQ(held, 4U * 3U * 2U);  // 4 x 3 pixels of 16 bits, nothing after them
  bytes.replace(pixels + 8, 4, std::string("\x80\x00\x00\xc4", 4));  // 3,288,334,464
  const std::size_t intercept =
      bytes.find(std::string("\x28\x00\x52\x10"
                             "DS",
                             6));
  ASSERT_NE(intercept, std::string::npos);
  for (const bool outOfOrder : {false, true}) {
    if (outOfOrder)
      bytes.replace(intercept, 2, std::string("\x27\xff", 2));  // (0028,1052) -> (ff27,1052)
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
    const std::string message = refusal(path(2));
    EXPECT_CONTAINS(message, fileName(2) + ": damaged pixel data: its element at byte " +
                                 std::to_string(pixels) + " declares 3288334464 bytes, but the " +
                                 "file ends 24 bytes after the value's start (the 4 x 3 pixels " +
                                 "of 16 bits need 24)");
    EXPECT_CONTAINS(refusal(folder_), fileName(2) + ": damaged pixel data");
  }
  EXPECT_LT(peakKb(), 1000L * 1024L) << "peak kB: the declared length was allocated";
}

// Debian's GDCM asserts (aborts) when a file ends inside its file meta group (found by
// fuzz/fuzz_dicom, seed found-abort-meta-truncated-ebd7dc42): such a file is refused as damaged
// before GDCM reads it, naming the file.
TEST_F(DicomSeriesRefusal, AFileEndingInsideItsMetaGroupIsDamaged) {
  std::string bytes = bytesOf(2);
  ASSERT_EQ(bytes.compare(128, 8, std::string("DICM\x02\x00\x00\x00", 8)), 0);
  const auto groupLength = static_cast<std::size_t>(static_cast<unsigned char>(bytes[140])) |
                           static_cast<std::size_t>(static_cast<unsigned char>(bytes[141])) << 8;
  const std::size_t metaEnd = 144 + groupLength;
  ASSERT_LT(metaEnd + 3, bytes.size());
  for (const std::size_t keep : {metaEnd + 3, metaEnd, std::size_t{154}}) {
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes.substr(0, keep);
    const std::string message = refusal(path(2));
    EXPECT_CONTAINS(message, fileName(2) + ": is a damaged DICOM file: ");
    EXPECT_CONTAINS(message, keep == 154 ? "element (0002,0001) at byte 144: the file ends inside"
                                         : "inside its file meta group");
  }
  EXPECT_CONTAINS(refusal(folder_), "missing");  // in the series: that slice is skipped
}

/// Little-endian bytes of a 16- or 32-bit number.
std::string le(std::uint32_t value, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i)
    out += static_cast<char>((value >> (8 * i)) & 0xff);
  return out;
}
/// An explicit VR little endian element with a 2-byte length, and one with a 4-byte length.
std::string shortElement(std::uint16_t group, std::uint16_t element, const char* vr,
                         const std::string& value) {
  return le(group, 2) + le(element, 2) + vr + le(static_cast<std::uint32_t>(value.size()), 2) +
         value;
}
std::string longElementHeader(std::uint16_t group, std::uint16_t element, const char* vr,
                              std::uint32_t length) {
  return le(group, 2) + le(element, 2) + vr + std::string(2, '\0') + le(length, 4);
}

// Found by fuzz/fuzz_dicom (seed found-oom-unknown-vr-20b15a58): in an explicit data set, an
// element whose VR GDCM does not know makes GDCM read it as implicit, its 4-byte length right after
// the tag: "\0@UT" here claimed 1.4 GB in a 32-byte file, which GDCM allocated, while the walk
// read a 4-byte length of 0 after 2 reserved bytes. Both ways GDCM may take are walked now.
TEST_F(DicomSeriesRefusal, UnknownVrsAndCutHeadersAreWalkedAsGdcmReadsThem) {
  const std::string file = dir_.file("unknown-vr.dcm");
  const auto write = [&](const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  };
  // The fuzzer's file: read as implicit, (2020,0020) claims 0x54554000 bytes.
  write(shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) + le(0x2020, 2) +
        le(0x0020, 2) + std::string("\0@UT", 4) + std::string(5, '\0') + "\x10" + "abcd");
  EXPECT_CONTAINS(refusal(file),
                  "unknown-vr.dcm: is a damaged DICOM file: element (2020,0020) at byte 14 claims "
                  "1414873088 bytes, but 10 are left in the file");
  // Read with a 2-byte length (GDCM's first way), the unknown VR "\x10\0" has a value of 0
  // bytes and the element after it claims 256 MB; read as implicit, its value is the 16 bytes
  // left, and nothing is beyond the file.
  write(shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) + le(0x0021, 2) +
        le(0x0010, 2) + std::string("\x10\0\0\0", 4) +
        longElementHeader(0x0021, 0x1011, "UT", 1U << 28) + "abcd");
  EXPECT_CONTAINS(refusal(file),
                  "unknown-vr.dcm: is a damaged DICOM file: element (0021,1011) at byte 22 claims "
                  "268435456 bytes, but 4 are left in the file");
  // Pixel data of an unknown VR not followed by two zero bytes: GDCM asserts (aborts the process)
  // reading it (found by fuzz/fuzz_dicom, seed found-abort-pixel-data-unknown-vr-292103ab).
  write(shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) + le(0x7fe0, 2) +
        le(0x0010, 2) + "OX" + std::string("\x01\0", 2) + le(4, 4) + "abcd");
  EXPECT_CONTAINS(
      refusal(file),
      "unknown-vr.dcm: is a damaged DICOM file: the pixel data at byte 14 has an unknown "
      "VR (bytes 4f 58)");
  // An undefined length on an element that is not a sequence or UN (here OW, where the fuzzer's
  // file had turned a sequence's SQ into OW), or on pixel data of a VR other than OB, OW or UN:
  // GDCM asserts (aborts the process) reading it (found by fuzz/fuzz_dicom, seed
  // found-abort-undefined-length-ow-ff4628df); the same sequence as SQ is read.
  const std::string items = le(0xfffe, 2) + le(0xe000, 2) + le(0xffffffffU, 4) + le(0xfffe, 2) +
                            le(0xe00d, 2) + le(0, 4) + le(0xfffe, 2) + le(0xe0dd, 2) + le(0, 4);
  for (const auto& [group, element, vr] :
       std::vector<std::tuple<std::uint16_t, std::uint16_t, const char*>>{{0x0008, 0x9215, "OW"},
                                                                          {0x7fe0, 0x0010, "UT"}}) {
    write(shortElement(0x0008, 0x0060, "CS", "CT") +
          longElementHeader(group, element, vr, 0xffffffffU) + items);
    EXPECT_CONTAINS(refusal(file), fmt::format("unknown-vr.dcm: is a damaged DICOM file: element "
                                               "({:04x},{:04x}) at byte 10 has an undefined "
                                               "length, which its VR {} cannot have",
                                               group, element, vr));
  }
  write(shortElement(0x0008, 0x0060, "CS", "CT") +
        longElementHeader(0x0008, 0x9215, "SQ", 0xffffffffU) + items);
  EXPECT_EQ(refusal(file).find("damaged"), std::string::npos) << refusal(file);
  // A file that ends after a tag, inside the rest of its element's header: GDCM asserts (aborts
  // the process) reading it (found by fuzz/fuzz_dicom, seed found-abort-header-cut-short-3e87910c).
  write(shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) + le(0x0020, 2) +
        le(0x0013, 2) + "I");
  EXPECT_CONTAINS(refusal(file),
                  "unknown-vr.dcm: is a damaged DICOM file: the file ends at byte 19, inside the "
                  "header of an element");
}

// Found by fuzz/fuzz_dicom (seed found-abort-item-never-ended-c1b40295): an item of undefined
// length that no item delimiter ends before the file does (the fuzzer's file: a sequence's item
// holding the rest of the data set, its pixel data included). GDCM reads the item's elements up to
// its delimiter and asserts (aborts the process) at the end of the file; the walk now refuses it.
TEST_F(DicomSeriesRefusal, AnItemOfUndefinedLengthTheFileEndsInsideIsDamaged) {
  const std::string file = dir_.file("open-item.dcm");
  const std::string head = shortElement(0x0008, 0x0060, "CS", "CT") +
                           longElementHeader(0x0008, 0x9215, "SQ", 0xffffffffU) + le(0xfffe, 2) +
                           le(0xe000, 2) + le(0xffffffffU, 4) +
                           shortElement(0x0008, 0x0100, "SH", "ABCD");
  std::ofstream(file, std::ios::binary | std::ios::trunc) << head;
  EXPECT_CONTAINS(refusal(file),
                  "open-item.dcm: is a damaged DICOM file: the file ends at byte 42, inside the "
                  "item of undefined length at byte 22, which no item delimiter ends");
  // A sequence of undefined length inside the open item, ended with its item: the open item is
  // still the one named.
  const std::string ends =
      le(0xfffe, 2) + le(0xe00d, 2) + le(0, 4) + le(0xfffe, 2) + le(0xe0dd, 2) + le(0, 4);
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      << head + longElementHeader(0x0008, 0x1115, "SQ", 0xffffffffU) + le(0xfffe, 2) +
             le(0xe000, 2) + le(0xffffffffU, 4) + ends;
  EXPECT_CONTAINS(refusal(file),
                  "open-item.dcm: is a damaged DICOM file: the file ends at byte 78, inside the "
                  "item of undefined length at byte 22, which no item delimiter ends");
  // The same item ended by its delimiter, and its sequence by its own: read.
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      << head + le(0xfffe, 2) + le(0xe00d, 2) + le(0, 4) + le(0xfffe, 2) + le(0xe0dd, 2) + le(0, 4);
  EXPECT_EQ(refusal(file).find("damaged"), std::string::npos) << refusal(file);
}

// GDCM reads a VR it does not know but made of two printable characters ("Xy") as UN: 2 reserved
// bytes and a 4-byte length (gdcm::VR::GetVRTypeFromFile). The walk took such an element for one
// of GDCM's INVALID VRs and read its length the implicit way ("Xy\0\0", 31064 bytes), so a file
// GDCM reads was skipped as damaged; now it is walked as UN, and a UN length beyond the file is
// refused before GDCM allocates it.
TEST_F(DicomSeriesRefusal, APrintableUnknownVrIsWalkedAsUn) {
  for (int k = 0; k < 6; ++k) {
    std::string bytes;
    {
      std::ifstream in(path(k), std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const std::size_t at = bytes.find(std::string("\x08\x00\x3e\x10LO", 6));
    ASSERT_NE(at, std::string::npos);
    bytes.insert(at, longElementHeader(0x0008, 0x103d, "Xy", 2) + "AB");
    std::ofstream(path(k), std::ios::binary | std::ios::trunc) << bytes;
  }
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder_, {});
  EXPECT_TRUE(read.image.hu == volume_.hu);
  EXPECT_TRUE(read.warnings.empty()) << read.warnings.front();

  const std::string file = dir_.file("printable-vr.dcm");
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      << shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) +
             longElementHeader(0x0021, 0x1010, "Xy", 1U << 28) + "abcd";
  EXPECT_CONTAINS(refusal(file),
                  "printable-vr.dcm: is a damaged DICOM file: element (0021,1010) at byte 14 "
                  "claims 268435456 bytes, but 4 are left in the file");
}

// Found by fuzz/fuzz_dicom: RLE pixel data of a defined length, 0xffff00ff bytes in a 908-byte
// file, passed the walk (pixel data longer than the file was left to the reader's size check,
// which only native pixel data has) and GDCM allocated 4 GB decoding it (33 s, 4.2 GB). Pixel
// data that GDCM reads itself (compressed, or big endian) and claims more than the file is now
// damaged; native little endian pixel data cut short is still refused with its sizes.
TEST_F(DicomSeriesRefusal, CompressedPixelDataLongerThanTheFileIsNotAllocated) {
  const std::string file = dir_.file("rle.dcm");
  for (const char* syntax : {"1.2.840.10008.1.2.5", "1.2.840.10008.1.2.2"}) {
    std::string uid(syntax);
    uid += std::string(uid.size() % 2, '\0');
    const std::string metaRest = shortElement(0x0002, 0x0010, "UI", uid);
    const bool big = std::string(syntax) == "1.2.840.10008.1.2.2";
    // Big endian: the data set's tags and lengths byte-swapped.
    const std::string pixelHeader = big ? std::string("\x7f\xe0\x00\x10OB\0\0\xff\xff\x00\xff", 12)
                                        : longElementHeader(0x7fe0, 0x0010, "OB", 0xffff00ffU);
    std::ofstream(file, std::ios::binary | std::ios::trunc)
        << std::string(128, '\0') + "DICM" +
               shortElement(0x0002, 0x0000, "UL",
                            le(static_cast<std::uint32_t>(metaRest.size()), 4)) +
               metaRest + pixelHeader + "abcd";
    const std::size_t at = 144 + metaRest.size();
    EXPECT_CONTAINS(refusal(file),
                    "rle.dcm: is a damaged DICOM file: element (7fe0,0010) at byte " +
                        std::to_string(at) +
                        " claims 4294902015 bytes, but 4 are left in the file");
  }
  EXPECT_LT(peakKb(), 1000L * 1024L) << "peak kB: the declared length was allocated";
}

/// Rewrites a slice as RLE Lossless with GDCM's encoder (gdcmconv --rle does the same).
void compressRle(const std::string& path) {
  gdcm::ImageReader reader;
  reader.SetFileName(path.c_str());
  ASSERT_TRUE(reader.Read()) << path;
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(gdcm::TransferSyntax::RLELossless);
  change.SetInput(reader.GetImage());
  ASSERT_TRUE(change.Change()) << path;
  gdcm::ImageWriter writer;
  writer.SetFile(reader.GetFile());
  writer.SetImage(change.GetOutput());
  const std::string temporary = path + ".rle";
  writer.SetFileName(temporary.c_str());
  ASSERT_TRUE(writer.Write()) << temporary;
  fs::rename(temporary, path);
}

/// Where an RLE slice's compressed frame starts in `bytes` (the value of the pixel data's second
/// item, after the empty basic offset table) and its length.
std::pair<std::size_t, std::size_t> rleFrameIn(const std::string& bytes) {
  const std::string header("\xe0\x7f\x10\x00OB\0\0\xff\xff\xff\xff", 12);
  const std::string emptyTable("\xfe\xff\x00\xe0\0\0\0\0", 8);
  const std::size_t at = bytes.find(header);
  if (at == std::string::npos || bytes.compare(at + 12, 8, emptyTable) != 0 ||
      bytes.compare(at + 20, 4, emptyTable, 0, 4) != 0) {
    return {std::string::npos, 0};
  }
  std::uint32_t length = 0;
  std::memcpy(&length, bytes.data() + at + 24, 4);
  return {at + 28, length};
}

/// Replaces an RLE slice's frame (the pixel data's one fragment) by `frame`.
void replaceRleFrame(const std::string& path, std::string frame) {
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto [at, length] = rleFrameIn(bytes);
  ASSERT_NE(at, std::string::npos) << path << " holds no RLE frame where expected";
  if (frame.size() % 2 != 0)
    frame.push_back('\0');
  bytes.replace(at - 4, 4 + length, le(static_cast<std::uint32_t>(frame.size()), 4) + frame);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

/// An RLE frame of these segments: the 64-byte header (their count and offsets), then them.
std::string rleFrame(const std::vector<std::string>& segments,
                     std::uint32_t declared = std::numeric_limits<std::uint32_t>::max()) {
  std::string header = le(declared == std::numeric_limits<std::uint32_t>::max()
                              ? static_cast<std::uint32_t>(segments.size())
                              : declared,
                          4);
  std::uint32_t offset = 64;
  for (const std::string& segment : segments) {
    header += le(offset, 4);
    offset += static_cast<std::uint32_t>(segment.size());
  }
  header.resize(64, '\0');
  std::string frame = header;
  for (const std::string& segment : segments)
    frame += segment;
  return frame;
}

/// A PackBits literal run of these bytes (1 to 128 of them).
std::string literal(const std::string& bytes) {
  return static_cast<char>(bytes.size() - 1) + bytes;
}

/// The fixture's slice k as the two byte planes of its 16-bit stored values (stored = HU + 1024),
/// in RLE's order: the high bytes, then the low bytes (DICOM PS3.5 G.2).
std::pair<std::string, std::string> bytePlanes(int k) {
  std::string low, high;
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 4; ++i) {
      const int stored = pattern(i, j, k) + 1024;
      low += static_cast<char>(stored & 0xff);
      high += static_cast<char>(stored >> 8);
    }
  }
  return {high, low};
}

// A series compressed as RLE Lossless reads as the uncompressed one: as GDCM's encoder writes
// it, and as written by hand with what the standard allows and encoders write (a padding byte
// after a segment, a -128 control byte that does nothing, replicate runs).
TEST_F(DicomSeriesRefusal, AnRleSeriesReadsAsTheUncompressedOne) {
  for (int k = 0; k < 6; ++k)
    compressRle(path(k));
  std::string bytes;
  {
    std::ifstream in(path(0), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  EXPECT_NE(bytes.find("1.2.840.10008.1.2.5"), std::string::npos) << "not compressed";
  EXPECT_NE(rleFrameIn(bytes).first, std::string::npos);
  DicomReadOptions three;
  three.threads = 3;
  EXPECT_TRUE(readDicomSeries(folder_, three).hu == volume_.hu);

  const auto [high, low] = bytePlanes(3);
  replaceRleFrame(path(3), rleFrame({literal(high.substr(0, 5)) + "\x80" + literal(high.substr(5)) +
                                         std::string(1, '\0'),
                                     literal(low.substr(0, 7)) + literal(low.substr(7))}));
  EXPECT_TRUE(readDicomSeries(folder_).hu == volume_.hu);
  // Replicate runs: slice 3 made of one value (HU 0: stored 1024, bytes 0x00 and 0x04).
  replaceRleFrame(path(3), rleFrame({std::string("\xf5\x04", 2), std::string("\xf5\x00", 2)}));
  const CtImage image = readDicomSeries(folder_);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(image.at(i, j, 3), 0);
  }
}

// Found by fuzz/fuzz_dicom (stop 34, seed found-abort-group-fffe-element): inside a sequence's item
// an element with the tag (fffe,23f3), then the item's and the sequence's delimiters. GDCM reads a
// tag of group fffe other than an item or a delimiter as an element with a VR, fails on its VR,
// reads the data set again on from it with 2-byte lengths at the top level, and asserts on the
// sequence delimiter behind it. Group fffe holds items and delimiters only: any other tag of it
// is damaged before GDCM reads the file.
TEST_F(DicomSeriesRefusal, AGroupFffeTagThatIsNoItemNorDelimiterIsDamaged) {
  std::string bytes = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(bytes);
  ASSERT_NE(at, std::string::npos);
  bytes.insert(at, std::string("\x08\x00\x15\x11SQ\0\0\xff\xff\xff\xff"
                               "\xfe\xff\x00\xe0\xff\xff\xff\xff"
                               "\xfe\xff\xf3\x23\0\0\0\0"
                               "\xfe\xff\x0d\xe0\0\0\0\0"
                               "\xfe\xff\xdd\xe0\0\0\0\0",
                               44));
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_CONTAINS(refusal(path(2)),
                  fileName(2) + ": is a damaged DICOM file: the tag (fffe,23f3) at byte " +
                      std::to_string(at + 20) + " is neither an item nor a delimiter");
}

// Found by fuzz/fuzz_dicom (stop 35, seed found-oom-fffe-tag-in-un-sequence-c4f50699): the same tag
// (fffe,23f3) inside an item of a sequence of VR UN and an undefined length, which GDCM reads in
// implicit VR (CP 246). Its implicit read fails there, and it reads the data set again as GDCM 1.x
// wrote it (a VR UN with a 2-byte length), which took text further on for a length of 1.7 GB: 6.6 s
// and 1.7 GB for a 901-byte file before it gave up. The walk checked nothing inside or behind such
// a sequence; it now walks the sequence's tags and goes on behind it.
TEST_F(DicomSeriesRefusal, AGroupFffeTagInASequenceOfVrUnIsDamaged) {
  const std::string original = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(original);
  ASSERT_NE(at, std::string::npos);
  const auto withUnSequence = [&](const std::string& inItem, const std::string& behind) {
    std::string bytes = original;
    bytes.insert(at, std::string("\x08\x00\x15\x11UN\0\0\xff\xff\xff\xff"
                                 "\xfe\xff\x00\xe0\xff\xff\xff\xff",
                                 20) +
                         inItem +
                         std::string("\xfe\xff\x0d\xe0\0\0\0\0"
                                     "\xfe\xff\xdd\xe0\0\0\0\0",
                                     16) +
                         behind);
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  };
  // An element in implicit VR in the item: read.
  const std::string implicitElement(
      "\x08\x00\x50\x11\x08\0\0\0"
      "1.2.3.4\0",
      16);
  withUnSequence(implicitElement, "");
  EXPECT_TRUE(readDicomSeries(folder_).hu == volume_.hu) << "a good sequence of VR UN";
  const std::string prefix = fileName(2) + ": is a damaged DICOM file: ";
  withUnSequence(std::string("\xfe\xff\xf3\x23\0\0\0\0", 8), "");
  EXPECT_CONTAINS(refusal(path(2)), prefix + "the tag (fffe,23f3) at byte " +
                                        std::to_string(at + 20) +
                                        " is neither an item nor a delimiter");
  // Behind the sequence the data set is walked as before: the byte-swapped item tag without a VR
  // (AByteSwappedItemTagWithoutAVrIsDamaged) made GDCM abort there.
  withUnSequence(implicitElement, std::string("\xff\xfe\xe0\x00\0\0\0\0", 8));
  EXPECT_CONTAINS(refusal(path(2)), prefix + "element (feff,00e0) at byte " +
                                        std::to_string(at + 52) +
                                        ", an item tag byte-swapped, has no VR (bytes 00 00)");
}

// Found reading gdcm::Reader for the previous case (stop 34): GDCM's first read of an explicit data
// set stops at the first element whose VR it cannot read, and when that element's tag is
// (feff,00e0), an item tag byte-swapped (its fallback for a Philips bug it never finished), it
// asserts: the 8 bytes (feff,00e0) "\0\0" 0 inserted in a slice made `echoreg info` abort. Refused
// as damaged before GDCM reads the file; an element of an unknown VR with another tag is walked as
// before (AnUnknownVrInABigEndianGuessIsWalkedLittleEndianAsGdcmRereadsIt and others).
TEST_F(DicomSeriesRefusal, AByteSwappedItemTagWithoutAVrIsDamaged) {
  std::string bytes = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(bytes);
  ASSERT_NE(at, std::string::npos);
  bytes.insert(at, std::string("\xff\xfe\xe0\x00\0\0\0\0", 8));
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_CONTAINS(refusal(path(2)),
                  fileName(2) + ": is a damaged DICOM file: element (feff,00e0) at byte " +
                      std::to_string(at) + ", an item tag byte-swapped, has no VR (bytes 00 00)");
}

// Found by fuzz/fuzz_dicom (stop 34, seed found-abort-element-past-its-item-3ac0f635): an element
// inside an item of a defined length that runs past the item's end (a mutated JPEG 2000 slice).
// GDCM warns ("Out of Range SQ detected", "Item length is wrong"), then reads the data set again
// as a mixture of explicit and implicit VR without clearing the stream's error state, and asserts
// (aborts the process) in gdcm::FileMetaInformation::ReadCompat when the first read had met the
// file's end. An element (or an item) must end within the item (or sequence) of a defined length
// it lies in (DICOM PS3.5 7.5); one that does not is damaged before GDCM reads the file. The same
// sequence with its lengths right is read.
TEST_F(DicomSeriesRefusal, AnElementRunningPastItsItemOrSequenceIsDamaged) {
  const std::string original = bytesOf(2);
  const std::size_t at = rescaleInterceptAt(original);
  ASSERT_NE(at, std::string::npos);
  const auto le32 = [](std::uint32_t v) { return le(v, 4); };
  const std::string element(
      "\x08\x00\x50\x11UI\x08\x00"
      "1.2.3.4\0",
      16);
  const auto withSequence = [&](std::uint32_t sequenceLength, std::uint32_t itemLength) {
    std::string bytes = original;
    bytes.insert(at, std::string("\x08\x00\x40\x11SQ\0\0", 8) + le32(sequenceLength) +
                         std::string("\xfe\xff\x00\xe0", 4) + le32(itemLength) + element);
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << bytes;
  };
  withSequence(24, 16);
  EXPECT_TRUE(readDicomSeries(folder_).hu == volume_.hu) << "the lengths right";
  const std::string prefix = fileName(2) + ": is a damaged DICOM file: ";
  withSequence(20, 12);
  EXPECT_CONTAINS(refusal(path(2)),
                  prefix + "element (0008,1150) at byte " + std::to_string(at + 20) +
                      " runs 4 bytes past the end of the item at byte " + std::to_string(at + 12));
  withSequence(20, 16);
  EXPECT_CONTAINS(refusal(path(2)),
                  prefix + "element (fffe,e000) at byte " + std::to_string(at + 12) +
                      " runs 4 bytes past the end of the sequence at byte " + std::to_string(at));
}

// Found by fuzz/fuzz_dicom (stop 34): two slices of the JPEG 2000 series, the basic offset table's
// item tag in one changed to (fffe,ffff) with a length of 0xdddf. GDCM (gdcm::BasicOffsetTable)
// throws there, and gdcm::Reader reads the data set again on from two bytes before that tag with
// 2-byte lengths (VR16ExplicitDataElement), which met a 4-byte length of 3.78 GB and allocated it
// (18 s, 3.7 GB for a 157 kB slice). Encapsulated pixel data is items up to a sequence delimiter
// (DICOM PS3.5 A.4): anything else there, and a fragment of undefined length, is now damaged
// before GDCM reads the file, and so is a delimiter after the fragments with a length. Shown on
// the RLE series (seed found-oom-offset-table-not-an-item).
TEST_F(DicomSeriesRefusal, EncapsulatedPixelDataOfAnythingButItemsIsDamaged) {
  for (int k = 0; k < 6; ++k)
    compressRle(path(k));
  const std::string original = bytesOf(2);
  const std::size_t frameAt = rleFrameIn(original).first;
  ASSERT_NE(frameAt, std::string::npos);
  const std::size_t pixelAt = frameAt - 28, tableAt = frameAt - 16, fragmentAt = frameAt - 8;
  const auto damaged = [&](std::size_t at, const std::string& bytes) {
    std::string changed = original;
    changed.replace(at, bytes.size(), bytes);
    std::ofstream(path(2), std::ios::binary | std::ios::trunc) << changed;
    return refusal(path(2));
  };
  const std::string prefix = fileName(2) + ": is a damaged DICOM file: ";
  EXPECT_CONTAINS(damaged(tableAt, std::string("\xfe\xff\xff\xff\xdf\xdd\0\0", 8)),
                  prefix + "byte " + std::to_string(tableAt) +
                      " of the file is neither a fragment of the pixel data at byte " +
                      std::to_string(pixelAt) + " nor their end (tag (fffe,ffff))");
  EXPECT_CONTAINS(damaged(fragmentAt, std::string("\x28\x00\x52\x10", 4)),
                  prefix + "byte " + std::to_string(fragmentAt) +
                      " of the file is neither a fragment of the pixel data at byte " +
                      std::to_string(pixelAt) + " nor their end (tag (0028,1052))");
  EXPECT_CONTAINS(damaged(fragmentAt + 4, std::string("\xff\xff\xff\xff", 4)),
                  prefix + "the fragment at byte " + std::to_string(fragmentAt) +
                      " of the pixel data at byte " + std::to_string(pixelAt) +
                      " has an undefined length");
  // Found next (seed found-oom-fragments-delimiter-length-3a2958b6): the delimiter after the
  // fragments with a length of 0x5b000000, which GDCM reads as a fragment's and allocates (1.5 GB
  // for a 909-byte slice).
  const std::size_t delimiterAt = original.rfind(std::string("\xfe\xff\xdd\xe0\0\0\0\0", 8));
  ASSERT_NE(delimiterAt, std::string::npos);
  EXPECT_CONTAINS(damaged(delimiterAt + 4, std::string("\0\0\0\x5b", 4)),
                  prefix + "the sequence delimiter at byte " + std::to_string(delimiterAt) +
                      " of the pixel data at byte " + std::to_string(pixelAt) +
                      " has a length of 1526726656 (0 in DICOM)");
  EXPECT_LT(peakKb(), 500L * 1024L) << "peak kB: a length GDCM read was allocated";
  std::ofstream(path(2), std::ios::binary | std::ios::trunc) << original;
  EXPECT_TRUE(readDicomSeries(folder_).hu == volume_.hu);
}

// Debian's GDCM (3.0.21) trusts an RLE frame's header: a segment count that does not divide the
// slice's bytes fails an assertion in gdcm::RLECodec::Decode (`check == len`; found by
// fuzz/fuzz_dicom) and 0 segments divide by zero (SIGFPE), both ending the process, already while
// gdcm::ImageReader reads the file. The frame is now checked before GDCM reads it. Each case runs
// in a child process, so that an abort fails this test rather than end the test program.
TEST_F(DicomSeriesRefusal, AnRleSegmentCountGdcmAbortsOnIsRefused) {
  for (int k = 0; k < 6; ++k)
    compressRle(path(k));
  const std::string four = literal("abcd");
  const std::string prefix =
      fileName(2) + ": damaged RLE pixel data (4 x 3 pixels of 16 bits): its RLE header declares ";
  // 5 segments of 4 bytes each: 20 bytes where the slice has 24 (GDCM's assertion).
  const std::vector<std::pair<std::string, std::string>> cases{
      {rleFrame({four, four, four, four, four}),
       prefix + "5 segments, where the pixels need 2 (one per byte of a pixel)"},
      {rleFrame({four + four + four, four + four + four}, 0), prefix + "0 segments"},
      {rleFrame({four + four + four, four + four + four}, 16), prefix + "16 segments"},
  };
  for (const auto& [frame, expected] : cases) {
    replaceRleFrame(path(2), frame);
    EXPECT_EXIT(
        {
          const std::string message = refusal(folder_);
          std::fprintf(stderr, "%s\n", message.c_str());
          std::exit(message.find(expected) != std::string::npos ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "")
        << "expected \"" << expected << "\"";
  }
}

// A segment that decodes to fewer bytes than its byte plane within its own bytes was completed
// by GDCM with the next segment's bytes: here the high bytes of slice 2 ended after 6 of 12, and
// the slice was read, wrong, without a word. A segment that decodes past its plane, offsets that
// do not increase, and a frame shorter than its header are refused too, each naming the file.
TEST_F(DicomSeriesRefusal, AnRleSegmentThatEndsEarlyOrRunsOverIsRefused) {
  for (int k = 0; k < 6; ++k)
    compressRle(path(k));
  const auto [high, low] = bytePlanes(2);
  const std::string prefix =
      "series: " + fileName(2) + ": damaged RLE pixel data (4 x 3 pixels of 16 bits): ";
  const auto frameWithOffsets = [](std::uint32_t second) {
    std::string frame = rleFrame({literal(std::string(12, 'a')), literal(std::string(12, 'b'))});
    frame.replace(8, 4, le(second, 4));
    return frame;
  };
  const std::vector<std::pair<std::string, std::string>> cases{
      // GDCM read 6 bytes of segment 1, then the first 6 of segment 2.
      {rleFrame({literal(high.substr(0, 6)), literal(low.substr(0, 6)) + literal(low.substr(6))}),
       "segment 1 of 2 (bytes 64 to 71 of the frame) decodes to 6 bytes, where the pixels need 12"},
      {rleFrame({literal(high), literal(low.substr(0, 6))}),
       "segment 2 of 2 (bytes 77 to 84 of the frame) decodes to 6 bytes, where the pixels need 12"},
      {rleFrame({literal(high) + literal("xy"), literal(low)}).substr(0, 90),
       "segment 2 of 2 (bytes 80 to 90 of the frame) ends inside the 12-byte literal run at "
       "byte 80"},
      {rleFrame({literal(high.substr(0, 8)) + std::string("\xfb\x07", 2), literal(low)}),
       "segment 1 of 2 decodes to more than the 12 bytes the pixels need (its run at byte 73 of "
       "the frame ends at 14)"},
      {frameWithOffsets(60),
       "its RLE header's segment offsets (64, 60) are not 64, then "
       "increasing, inside the 90-byte frame"},
      {frameWithOffsets(200),
       "its RLE header's segment offsets (64, 200) are not 64, then "
       "increasing, inside the 90-byte frame"},
      {le(2, 4) + le(64, 4) + le(70, 4),
       "its frame holds 12 bytes, fewer than the 64 of an RLE "
       "header"},
  };
  for (const auto& [frame, expected] : cases) {
    replaceRleFrame(path(2), frame);
    const std::string message = refusal(folder_);
    EXPECT_CONTAINS(message, prefix + expected);
  }
}

// Found by fuzz/fuzz_dicom: a file meta group whose first element's VR GDCM does not know ("Ul"
// for "UL") is read by GDCM as an implicit meta group (GE's private syntax), its 4-byte length
// right after the tag: "Ul" and the 2-byte length were taken for 289877 bytes, and Debian's GDCM
// aborted the process reading them (the walk had taken the group as explicit). The walk reads
// the group as GDCM does: that file is damaged, a well-formed implicit meta group is read as
// before, one that claims more than the file or ends the file is damaged.
TEST_F(DicomSeriesRefusal, AFileMetaGroupIsWalkedImplicitWhereGdcmReadsItSo) {
  const std::string file = dir_.file("implicit-meta.dcm");
  const auto write = [&](const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  };
  const std::string preamble = std::string(128, '\0') + "DICM";
  const std::string syntax("1.2.840.10008.1.2.1\0", 20);
  const std::string dataSet = shortElement(0x0008, 0x0060, "CS", "CT");
  // The fuzzer's file: (0002,0000) "Ul", read as implicit.
  write(preamble + shortElement(0x0002, 0x0000, "Ul", le(28, 4)) +
        shortElement(0x0002, 0x0010, "UI", syntax) + dataSet);
  EXPECT_CONTAINS(refusal(file),
                  "implicit-meta.dcm: is a damaged DICOM file: element (0002,0000) at byte 132 "
                  "claims 289877 bytes, but 42 are left in the file");
  // An implicit meta group whose element claims more than the file holds.
  write(preamble + le(0x0002, 2) + le(0x0000, 2) + le(4, 4) + le(8, 4) + le(0x0002, 2) +
        le(0x0010, 2) + le(1000, 4) + "1.2");
  EXPECT_CONTAINS(refusal(file),
                  "implicit-meta.dcm: is a damaged DICOM file: element (0002,0010) at byte 144 "
                  "claims 1000 bytes, but 3 are left in the file");
  // An implicit meta group that ends the file: GDCM aborts reading the next tag.
  write(preamble + le(0x0002, 2) + le(0x0010, 2) + le(20, 4) + syntax);
  EXPECT_CONTAINS(refusal(file),
                  "implicit-meta.dcm: is a damaged DICOM file: the file ends at byte 160, inside "
                  "its file meta group");

  // A good series whose files' meta groups are rewritten implicit (GE's private syntax) is
  // walked without a word and read as before.
  for (int k = 0; k < 6; ++k) {
    std::string bytes;
    {
      std::ifstream in(path(k), std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_EQ(bytes.compare(128, 4, "DICM"), 0);
    std::string implicitMeta;
    std::size_t at = 132;
    while (at + 8 <= bytes.size() && bytes[at] == 0x02 && bytes[at + 1] == 0) {
      const std::string vr = bytes.substr(at + 4, 2);
      const bool longVr = vr == "OB" || vr == "UN" || vr == "UT" || vr == "UC" || vr == "UR";
      std::size_t length = 0, value = at + (longVr ? 12 : 8);
      for (int i = longVr ? 3 : 1; i >= 0; --i)
        length = length << 8 | static_cast<unsigned char>(bytes[at + (longVr ? 8 : 6) + i]);
      implicitMeta += bytes.substr(at, 4) + le(static_cast<std::uint32_t>(length), 4) +
                      bytes.substr(value, length);
      at = value + length;
    }
    ASSERT_GT(implicitMeta.size(), 40U);
    std::ofstream(path(k), std::ios::binary | std::ios::trunc)
        << bytes.substr(0, 132) + implicitMeta + bytes.substr(at);
  }
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder_, {});
  EXPECT_TRUE(read.image.hu == volume_.hu);
  EXPECT_TRUE(read.warnings.empty()) << read.warnings.front();
}

// Found by fuzz/fuzz_dicom: a 665-byte file with no preamble whose first element is of group
// 0x0020 took GDCM 26 s and 1.09 GB to refuse, as the element walk run before GDCM took only
// files starting with group 0x0000 or 0x0008. Now any file GDCM reads without the preamble is
// walked in the encoding GDCM guesses for it, and an element longer than the file is refused,
// naming the file and the element, before GDCM allocates it (256 MB claimed in 40 bytes here).
TEST_F(DicomSeriesRefusal, AFileWithoutPreambleIsWalkedWhateverItsFirstGroup) {
  const std::string file = dir_.file("no-preamble.dcm");
  const auto write = [&](const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  };
  // Explicit VR little endian from (0020,000d) on.
  write(shortElement(0x0020, 0x000d, "UI", std::string("1.2.3\0", 6)) +
        shortElement(0x0020, 0x0013, "IS", "1 ") +
        longElementHeader(0x0020, 0x4000, "UT", 1U << 28) + "abcd");
  EXPECT_CONTAINS(refusal(file),
                  "no-preamble.dcm: is a damaged DICOM file: element (0020,4000) at byte 24 claims "
                  "268435456 bytes, but 4 are left in the file");
  // Implicit VR little endian, starting with a private creator (GDCM's other guess).
  write(le(0x0029, 2) + le(0x0010, 2) + le(4, 4) + "ACME" + le(0x0029, 2) + le(0x1010, 2) +
        le(1U << 28, 4) + "abcd");
  EXPECT_CONTAINS(refusal(file),
                  "no-preamble.dcm: is a damaged DICOM file: element (0029,1010) at byte 12 claims "
                  "268435456 bytes, but 4 are left in the file");
  // A file meta group without the preamble, naming implicit VR little endian for the data set.
  const std::string syntax("1.2.840.10008.1.2\0", 18);
  const std::string metaRest = shortElement(0x0002, 0x0010, "UI", syntax);
  write(shortElement(0x0002, 0x0000, "UL", le(static_cast<std::uint32_t>(metaRest.size()), 4)) +
        metaRest + le(0x0008, 2) + le(0x103e, 2) + le(1U << 28, 4) + "abcd");
  EXPECT_CONTAINS(refusal(file),
                  "no-preamble.dcm: is a damaged DICOM file: element (0008,103e) at byte 38 claims "
                  "268435456 bytes, but 4 are left in the file");
  // Text that GDCM takes for no DICOM at all is still said to be not DICOM, not damaged.
  write("frame,timestamp,depth_mm\n0,0.0,12.5\n");
  EXPECT_CONTAINS(refusal(file), "no-preamble.dcm: is not a DICOM file");
  write("abcdef");
  EXPECT_CONTAINS(refusal(file), "no-preamble.dcm: is not a DICOM file");
  // Files shorter than one element's header whose first tag is DICOM's: Debian's GDCM asserts
  // (aborts the process) reading them (the first found by fuzz/fuzz_dicom, 7 bytes).
  write(le(0x0002, 2) + le(0x0000, 2) + std::string("\x02\x20\x02", 3));
  EXPECT_CONTAINS(refusal(file),
                  "no-preamble.dcm: is a damaged DICOM file: the file ends at byte 7, inside its "
                  "file meta group");
  write(le(0x0008, 2) + le(0x0060, 2) + "CS");
  EXPECT_CONTAINS(refusal(file),
                  "no-preamble.dcm: is a damaged DICOM file: the file ends at byte 6, inside the "
                  "header of an element");

  // And a good series whose files have lost their preamble is walked without a word and read as
  // before (the walk starts at the file meta group).
  for (int k = 0; k < 6; ++k) {
    std::string bytes;
    {
      std::ifstream in(path(k), std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_EQ(bytes.compare(128, 4, "DICM"), 0);
    std::ofstream(path(k), std::ios::binary | std::ios::trunc) << bytes.substr(132);
  }
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder_, {});
  EXPECT_TRUE(read.image.hu == volume_.hu);
  EXPECT_TRUE(read.warnings.empty()) << read.warnings.front();
}

TEST_F(DicomSeriesRefusal, MultiFrame) {
  editString(path(2), 0x0028, 0x0008, gdcm::VR::IS, "2");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "multi-frame");
  EXPECT_CONTAINS(message, fileName(2));
}

TEST_F(DicomSeriesRefusal, NoCtSeriesListsWhatThereIs) {
  for (int k = 0; k < 6; ++k)
    editString(path(k), 0x0008, 0x0060, gdcm::VR::CS, "MR");
  const std::string message = refusal(folder_);
  EXPECT_CONTAINS(message, "no CT series");
  EXPECT_CONTAINS(message, "(MR, 6 files: IM000001.dcm...)");
  // Asked for by UID it reads, with a warning that the values are not HU.
  DicomReadOptions options;
  options.seriesUid = echoreg::simulation::derivedDicomUid(11, "series");
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder_, options);
  EXPECT_TRUE(read.image.hu == volume_.hu);
  ASSERT_FALSE(read.warnings.empty());
  EXPECT_CONTAINS(read.warnings.back(), "not Hounsfield units");
  options.seriesUid = "1.2.3";
  EXPECT_CONTAINS(refusal(folder_, options), "has no series 1.2.3");
}

TEST_F(DicomSeriesRefusal, NotDicomEmptyOrAbsent) {
  EXPECT_CONTAINS(refusal(dir_.file("absent")), "does not exist");
  fs::create_directory(dir_.file("empty"));
  EXPECT_CONTAINS(refusal(dir_.file("empty")), "is a directory with no DICOM image");
  std::ofstream(dir_.file("empty/notes.dcm")) << "hello";
  EXPECT_CONTAINS(refusal(dir_.file("empty")), "notes.dcm");
  EXPECT_CONTAINS(refusal(dir_.file("empty/notes.dcm")), "is not a DICOM file");
  // A folder holding only the series' folder says so.
  EXPECT_CONTAINS(refusal(dir_.path()), "subfolders are not searched");
}

TEST_F(DicomSeriesRefusal, OneFileIsAOneSliceImage) {
  const CtImage image = readDicomSeries(path(2));
  ASSERT_EQ(image.dimensions, (std::array<int, 3>{4, 3, 1}));
  EXPECT_NEAR(image.originMm.z(), 4.0, 1e-12);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(image.at(i, j, 0), pattern(i, j, 2));
  }
}

// ---- real data ------------------------------------------------------------------------------

/// pydicom's view of a folder or file (tests/segmentation/read_ct_reference.py); null if python3
/// or pydicom is missing.
nlohmann::json pydicomReference(const std::string& folder, const std::vector<std::string>& voxels) {
  std::string command =
      "/usr/bin/python3 " ECHOREG_SEGMENTATION_TEST_DIR "/read_ct_reference.py '" + folder + "'";
  for (const std::string& v : voxels)
    command += " " + v;
  command += " 2>/dev/null";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe)
    return nullptr;
  std::string out;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe.get())) > 0)
    out.append(buffer, n);
  if (out.empty())
    return nullptr;
  return nlohmann::json::parse(out);
}

TEST(DicomSeriesRealData, AbdomenMatchesPydicom) {
  ECHOREG_REQUIRE_SHARED_FILE(first, "ct-abdomen/1-001.dcm");
  const std::string folder = fs::path(first).parent_path().string();
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder);
  const CtImage& image = read.image;
  ASSERT_EQ(image.dimensions, (std::array<int, 3>{512, 512, 134}));
  ASSERT_EQ(image.groups.size(), 1U);
  EXPECT_NEAR(image.sliceSpacingMm(), 3.0, 1e-6);
  const auto [low, high] = std::minmax_element(image.hu.begin(), image.hu.end());
  EXPECT_GE(*low, -1024);
  EXPECT_LE(*low, -1000);  // air; intercept -1000 in this series
  EXPECT_GT(*high, 1000);  // cortical bone

  const nlohmann::json ref =
      pydicomReference(folder, {"100,200,0", "256,300,60", "300,350,133", "10,20,77"});
  if (ref.is_null())
    GTEST_SKIP() << "python3 with pydicom is not available";
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(image.originMm[a], ref["origin"][static_cast<std::size_t>(a)].get<double>(), 1e-9);
    EXPECT_NEAR(image.direction(a, 0), ref["row"][static_cast<std::size_t>(a)].get<double>(),
                1e-12);
    EXPECT_NEAR(image.direction(a, 1), ref["column"][static_cast<std::size_t>(a)].get<double>(),
                1e-12);
    EXPECT_NEAR(image.direction(a, 2), ref["normal"][static_cast<std::size_t>(a)].get<double>(),
                1e-12);
  }
  EXPECT_DOUBLE_EQ(image.pixelSpacingMm.x(), ref["spacing"][0].get<double>());
  EXPECT_DOUBLE_EQ(image.pixelSpacingMm.y(), ref["spacing"][1].get<double>());
  ASSERT_EQ(ref["positions"].size(), 134U);
  for (std::size_t k = 0; k < 134; ++k) {
    EXPECT_NEAR(image.slicePositionsMm[k], ref["positions"][k].get<double>(), 1e-9);
    EXPECT_EQ(read.files[k], ref["files"][k].get<std::string>());
  }
  for (const auto& v : ref["voxels"]) {
    EXPECT_EQ(image.at(v["i"], v["j"], v["k"]), static_cast<int>(v["hu"].get<double>()))
        << v.dump();
  }
}

TEST(DicomSeriesRealData, Jpeg2000SeriesEqualsGdcmsOwnDecoding) {
  ECHOREG_REQUIRE_SHARED_FILE(license, "ct-jpeg2000/LICENSE");
  const std::string folder = fs::path(license).parent_path().string();
  const DicomSeriesRead read = readDicomSeriesWithWarnings(folder);
  const CtImage& image = read.image;
  ASSERT_EQ(image.dimensions, (std::array<int, 3>{512, 512, 20}));
  EXPECT_TRUE(image.seriesInstanceUid.empty());  // this export leaves it blank
  ASSERT_EQ(image.groups.size(), 1U);
  EXPECT_NEAR(image.sliceSpacingMm(), 2.0, 1e-9);
  const auto [low, high] = std::minmax_element(image.hu.begin(), image.hu.end());
  EXPECT_EQ(*low, -1024);
  EXPECT_GT(*high, 1000);  // humeri
  // Independently: GDCM's decoded buffer, 12-bit unsigned, with GDCM's slope and intercept, at
  // the position GDCM reports for each file.
  for (const int k : {0, 9, 19}) {
    gdcm::ImageReader reader;
    const std::string path = folder + "/" + read.files[static_cast<std::size_t>(k)];
    reader.SetFileName(path.c_str());
    ASSERT_TRUE(reader.Read());
    const gdcm::Image& slice = reader.GetImage();
    EXPECT_NEAR(slice.GetOrigin()[2],
                image.originMm.z() + image.slicePositionsMm[static_cast<std::size_t>(k)], 1e-9);
    std::vector<char> buffer(slice.GetBufferLength());
    ASSERT_EQ(buffer.size(), 512U * 512U * 2U);
    ASSERT_TRUE(slice.GetBuffer(buffer.data()));
    int differ = 0;
    for (int j = 0; j < 512; ++j) {
      for (int i = 0; i < 512; ++i) {
        std::uint16_t stored = 0;
        std::memcpy(&stored, buffer.data() + 2 * (j * 512 + i), 2);
        const double hu = stored * slice.GetSlope() + slice.GetIntercept();
        differ += image.at(i, j, k) != static_cast<int>(hu) ? 1 : 0;
      }
    }
    EXPECT_EQ(differ, 0) << "slice " << k;
  }
}

// A compressed series cannot be checked against its files' sizes: its volume must fit in memory.
TEST(DicomSeriesRealData, Jpeg2000SeriesClaimingMoreVoxelsThanMemoryIsRefusedBeforeAllocating) {
  ECHOREG_REQUIRE_SHARED_FILE(license, "ct-jpeg2000/LICENSE");
  echoreg::test::TempDir dir;
  const std::string folder = dir.file("series");
  fs::create_directory(folder);
  int slices = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(license).parent_path())) {
    if (entry.path().filename() == "LICENSE")
      continue;
    const std::string copy = folder + "/" + entry.path().filename().string();
    fs::copy_file(entry.path(), copy);
    // This export has no SOP class, so GDCM cannot rebuild its meta header: keep it as it is.
    gdcm::Reader reader;
    reader.SetFileName(copy.c_str());
    ASSERT_TRUE(reader.Read()) << copy;
    gdcm::Attribute<0x0028, 0x0010> rows;
    rows.SetValue(65535);
    gdcm::Attribute<0x0028, 0x0011> columns;
    columns.SetValue(65535);
    reader.GetFile().GetDataSet().Replace(rows.GetAsDataElement());
    reader.GetFile().GetDataSet().Replace(columns.GetAsDataElement());
    gdcm::Writer writer;
    writer.SetFile(reader.GetFile());
    writer.CheckFileMetaInformationOff();
    writer.SetFileName((copy + ".edit").c_str());
    ASSERT_TRUE(writer.Write()) << copy;
    fs::rename(copy + ".edit", copy);
    ++slices;
  }
  ASSERT_EQ(slices, 20);
  const std::string message = refusal(folder);
  EXPECT_CONTAINS(message, "the series' 65535 x 65535 x 20 voxels");
  EXPECT_CONTAINS(message, "need 171.8 GB as 16-bit HU, more than this machine's");
}

// Real CT slices compressed as RLE Lossless by GDCM's encoder read exactly as the originals: the
// check of the RLE frame before GDCM decodes it refuses nothing a real encoder writes.
TEST(DicomSeriesRealData, AbdomenSlicesAsRleReadAsTheOriginals) {
  ECHOREG_REQUIRE_SHARED_FILE(first, "ct-abdomen/1-001.dcm");
  echoreg::test::TempDir dir;
  const std::string folder = dir.file("series");
  fs::create_directory(folder);
  for (int k = 1; k <= 8; ++k) {
    const std::string name = fmt::format("1-{:03d}.dcm", k);
    fs::copy_file(fs::path(first).parent_path() / name, folder + "/" + name);
  }
  const DicomSeriesRead original = readDicomSeriesWithWarnings(folder);
  for (int k = 1; k <= 8; ++k)
    compressRle(folder + "/" + fmt::format("1-{:03d}.dcm", k));
  const DicomSeriesRead rle = readDicomSeriesWithWarnings(folder);
  ASSERT_EQ(rle.image.dimensions, (std::array<int, 3>{512, 512, 8}));
  EXPECT_TRUE(rle.image.hu == original.image.hu);
  EXPECT_EQ(rle.files, original.files);
  EXPECT_EQ(rle.warnings, original.warnings);
}

TEST(DicomSeriesRealData, EveryBadFileIsReadCorrectlyOrRefusedClearly) {
  ECHOREG_REQUIRE_SHARED_FILE(ctSmall, "dicom-bad/CT_small.dcm");
  const std::string folder = fs::path(ctSmall).parent_path().string();
  int read = 0, refused = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    const std::string path = entry.path().string();
    try {
      const CtImage image = readDicomSeries(path);
      ++read;
      EXPECT_GT(image.voxelCount(), 0U) << path;
      EXPECT_EQ(image.hu.size(), image.voxelCount()) << path;
    } catch (const FileError& e) {
      ++refused;
      EXPECT_EQ(e.path(), path);
      EXPECT_FALSE(e.problem().empty());
    }
  }
  EXPECT_GE(read, 2);     // CT_small, JPEG-lossy
  EXPECT_GE(refused, 8);  // the broken ones and the licence text
  EXPECT_CONTAINS(refusal(folder + "/MR_truncated.dcm"), "truncated pixel data");
  EXPECT_CONTAINS(refusal(folder + "/badVR.dcm"), "NumberOfFrames \"1A\"");

  // The signed 16-bit CT: equal to pydicom.
  const DicomSeriesRead small = readDicomSeriesWithWarnings(ctSmall);
  ASSERT_EQ(small.image.dimensions, (std::array<int, 3>{128, 128, 1}));
  EXPECT_TRUE(small.warnings.empty());
  const nlohmann::json ref = pydicomReference(ctSmall, {"0,0,0", "64,64,0", "127,5,0", "30,100,0"});
  if (!ref.is_null()) {
    for (const auto& v : ref["voxels"]) {
      EXPECT_EQ(small.image.at(v["i"], v["j"], v["k"]), static_cast<int>(v["hu"].get<double>()))
          << v.dump();
    }
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(small.image.originMm[a], ref["origin"][static_cast<std::size_t>(a)].get<double>(),
                  1e-9);
    }
  }
  // The lossy 12-bit JPEG decodes (NM, no patient geometry: said in the warnings).
  const DicomSeriesRead lossy = readDicomSeriesWithWarnings(folder + "/JPEG-lossy.dcm");
  EXPECT_EQ(lossy.image.dimensions, (std::array<int, 3>{256, 1024, 1}));
  EXPECT_EQ(lossy.modality, "NM");
  EXPECT_EQ(lossy.warnings.size(), 3U);
  const auto [low, high] = std::minmax_element(lossy.image.hu.begin(), lossy.image.hu.end());
  EXPECT_GE(*low, 0);
  EXPECT_GT(*high, *low);
  EXPECT_LT(*high, 4096);

  // The folder as a whole: its only CT series is CT_small; the rest is named in the warnings.
  const DicomSeriesRead whole = readDicomSeriesWithWarnings(folder);
  EXPECT_TRUE(whole.image.hu == small.image.hu);
  std::string warnings;
  for (const std::string& w : whole.warnings)
    warnings += w + "\n";
  EXPECT_CONTAINS(warnings, "no_meta.dcm");
  EXPECT_CONTAINS(warnings, "MR_truncated");
}

}  // namespace
