// The VTK adapter of the DICOM reader (geometry, groups, resampling, zero-copy hand-over) and the
// NRRD volume writer/reader.
#include "echoreg/core/error.hpp"
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/segmentation/nrrd_volume.hpp"
#include "echoreg/segmentation/vtkEchoregDicomSeriesReader.h"
#include "echoreg/simulation/ct.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

using echoreg::core::CtImage;

/// Three groups (2 slices at 4 mm, 5 at 1 mm, 2 at 4 mm) of 5 x 4 pixels of 0.7 mm, written by
/// the simulator's writer; HU = 10 i + 100 j + k - 500.
CtImage threeGroups() {
  CtImage v = echoreg::core::axialCtImage(5, 4, 0.7, {3.0, -4.0},
                                          {{"g", {0, 4, 20, 21, 22, 23, 24, 40, 44}, 1.0}});
  for (int k = 0; k < v.dimensions[2]; ++k) {
    for (int j = 0; j < v.dimensions[1]; ++j) {
      for (int i = 0; i < v.dimensions[0]; ++i)
        v.hu.push_back(static_cast<std::int16_t>(10 * i + 100 * j + k - 500));
    }
  }
  return v;
}

class CtVolumeIo : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = dir_.file("ct");
    echoreg::simulation::DicomSeriesInfo info;
    info.uidSeed = 5;
    echoreg::simulation::writeDicomSeries(folder_, threeGroups(), info);
  }
  echoreg::test::TempDir dir_;
  std::string folder_;
};

TEST_F(CtVolumeIo, ReaderRefusesUnevenSlicesUnlessResampledOrOneGroup) {
  vtkNew<vtkEchoregDicomSeriesReader> reader;
  reader->SetDirectoryName(folder_);
  reader->GlobalWarningDisplayOff();
  reader->Update();
  EXPECT_NE(reader->GetLastError().find("several spacings"), std::string::npos)
      << reader->GetLastError();
  EXPECT_NE(reader->GetLastError().find(folder_), std::string::npos);
  EXPECT_EQ(reader->GetOutput()->GetNumberOfPoints(), 0);
  ASSERT_EQ(reader->GetSeriesGeometry().groups.size(), 3U);

  reader->SetGroup(1);
  reader->Update();
  ASSERT_TRUE(reader->GetLastError().empty()) << reader->GetLastError();
  vtkImageData* image = reader->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  EXPECT_EQ(dims[0], 5);
  EXPECT_EQ(dims[1], 4);
  EXPECT_EQ(dims[2], 5);
  EXPECT_DOUBLE_EQ(image->GetSpacing()[0], 0.7);
  EXPECT_NEAR(image->GetSpacing()[2], 1.0, 1e-12);
  EXPECT_NEAR(image->GetOrigin()[2], 20.0, 1e-12);
  auto* scalars = vtkShortArray::SafeDownCast(image->GetPointData()->GetScalars());
  ASSERT_NE(scalars, nullptr);
  EXPECT_STREQ(scalars->GetName(), "HU");
  // Voxel (i=3, j=2) of group slice 1 = series slice 3.
  EXPECT_EQ(scalars->GetValue(image->ComputePointId(std::array<int, 3>{3, 2, 1}.data())),
            10 * 3 + 100 * 2 + 3 - 500);
  double lps[3];
  image->TransformIndexToPhysicalPoint(3, 2, 1, lps);
  EXPECT_NEAR(lps[0], 3.0 + 3 * 0.7, 1e-12);
  EXPECT_NEAR(lps[1], -4.0 + 2 * 0.7, 1e-12);
  EXPECT_NEAR(lps[2], 21.0, 1e-12);

  reader->SetGroup(-1);
  reader->ResampleToUniformOn();
  reader->Update();
  ASSERT_TRUE(reader->GetLastError().empty()) << reader->GetLastError();
  reader->GetOutput()->GetDimensions(dims);
  EXPECT_EQ(dims[2], 45);  // 0..44 mm at the smallest step, 1 mm
  reader->SetResampleSpacing(2.0);
  reader->Update();
  reader->GetOutput()->GetDimensions(dims);
  EXPECT_EQ(dims[2], 23);
  EXPECT_NEAR(reader->GetOutput()->GetSpacing()[2], 2.0, 1e-12);

  reader->SetDirectoryName(dir_.file("absent"));
  reader->Update();
  EXPECT_NE(reader->GetLastError().find("does not exist"), std::string::npos)
      << reader->GetLastError();
}

TEST_F(CtVolumeIo, ToImageDataCopiesOrTakesOverTheVoxels) {
  const CtImage series = echoreg::segmentation::readDicomSeries(folder_);
  EXPECT_THROW(echoreg::segmentation::toImageData(series), std::invalid_argument);
  CtImage group = echoreg::segmentation::extractSliceGroup(series, 2);
  ASSERT_EQ(group.dimensions[2], 2);
  EXPECT_NEAR(group.originMm.z(), 40.0, 1e-12);
  group.direction << 0, -1, 0,  //
      1, 0, 0,                  //
      0, 0, 1;                  // a rotated frame goes through to VTK
  const auto copied = echoreg::segmentation::toImageData(group);
  EXPECT_EQ(group.hu.size(), 40U);
  const std::int16_t* before = group.hu.data();
  const auto taken = echoreg::segmentation::toImageData(std::move(group));
  EXPECT_TRUE(group.hu.empty());
  auto* takenScalars = vtkShortArray::SafeDownCast(taken->GetPointData()->GetScalars());
  EXPECT_EQ(takenScalars->GetPointer(0), before);  // no copy
  auto* copiedScalars = vtkShortArray::SafeDownCast(copied->GetPointData()->GetScalars());
  for (vtkIdType n = 0; n < 40; ++n)
    EXPECT_EQ(takenScalars->GetValue(n), copiedScalars->GetValue(n));
  EXPECT_EQ(taken->GetDirectionMatrix()->GetElement(0, 1), -1.0);
  double lps[3];
  taken->TransformIndexToPhysicalPoint(1, 0, 0, lps);  // one step along i = +y in LPS
  EXPECT_NEAR(lps[0], 3.0, 1e-12);
  EXPECT_NEAR(lps[1], -4.0 + 0.7, 1e-12);
}

TEST_F(CtVolumeIo, NrrdRoundTripWithLpsGeometry) {
  const CtImage series = echoreg::segmentation::readDicomSeries(folder_);
  CtImage knee = echoreg::segmentation::extractSliceGroup(series, 1);
  for (const bool gzip : {true, false}) {
    const std::string path = dir_.file(gzip ? "knee.nrrd" : "knee-raw.nrrd");
    echoreg::segmentation::writeNrrdVolume(path, knee, knee.hu, {gzip});
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    const std::string bytes = text.str();
    EXPECT_EQ(bytes.rfind("NRRD0004\n", 0), 0U);
    EXPECT_NE(bytes.find("space: left-posterior-superior\n"), std::string::npos);
    EXPECT_NE(bytes.find("sizes: 5 4 5\n"), std::string::npos);
    EXPECT_NE(bytes.find("space directions: (0.7,0,0) (0,0.7,0) (0,0,1)\n"), std::string::npos)
        << bytes.substr(0, 400);
    EXPECT_NE(bytes.find("space origin: (3,-4,20)\n"), std::string::npos);
    EXPECT_NE(bytes.find(gzip ? "encoding: gzip\n" : "encoding: raw\n"), std::string::npos);
    const auto back = echoreg::segmentation::readNrrdVolume(path);
    EXPECT_FALSE(back.isMask);
    EXPECT_TRUE(back.image.hu == knee.hu);
    EXPECT_EQ(back.image.dimensions, knee.dimensions);
    EXPECT_TRUE(back.image.originMm.isApprox(knee.originMm));
    EXPECT_TRUE(back.image.direction.isApprox(knee.direction));
    EXPECT_NEAR(back.image.sliceSpacingMm(), 1.0, 1e-12);
  }
  std::vector<std::uint8_t> mask(knee.voxelCount());
  for (std::size_t n = 0; n < mask.size(); ++n)
    mask[n] = knee.hu[n] > -300 ? 1 : 0;
  echoreg::segmentation::writeNrrdVolume(dir_.file("mask.nrrd"), knee, mask);
  const auto maskBack = echoreg::segmentation::readNrrdVolume(dir_.file("mask.nrrd"));
  EXPECT_TRUE(maskBack.isMask);
  EXPECT_TRUE(maskBack.mask == mask);

  // Uneven grids and wrong voxel counts are refused; nothing is left behind.
  EXPECT_THROW(echoreg::segmentation::writeNrrdVolume(dir_.file("series.nrrd"), series, series.hu),
               std::invalid_argument);
  mask.pop_back();
  EXPECT_THROW(echoreg::segmentation::writeNrrdVolume(dir_.file("short.nrrd"), knee, mask),
               std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir_.file("series.nrrd")));
  EXPECT_FALSE(std::filesystem::exists(dir_.file("short.nrrd")));
  // A truncated file is refused naming it.
  const std::string truncated = dir_.file("truncated.nrrd");
  std::filesystem::copy_file(dir_.file("knee-raw.nrrd"), truncated);
  std::filesystem::resize_file(truncated, std::filesystem::file_size(truncated) - 3);
  try {
    echoreg::segmentation::readNrrdVolume(truncated);
    ADD_FAILURE() << "a truncated NRRD was read";
  } catch (const echoreg::core::FileError& e) {
    EXPECT_EQ(e.path(), truncated);
  }
}

// Bad NRRD headers are refused naming the file, before anything is allocated: sizes beyond the
// data (raw: 2^31 x 2^31 x 2 voxels claimed by a file of a few bytes; gzip: more than deflate can
// expand), a direction whose length overflows, an unknown encoding with huge sizes.
TEST_F(CtVolumeIo, NrrdHeadersBeyondTheirDataAreRefusedBeforeAllocating) {
  const auto write = [&](const std::string& name, const std::string& header,
                         const std::string& data) {
    const std::string path = dir_.file(name);
    std::ofstream(path, std::ios::binary)
        << "NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\n"
        << header << "\n"
        << data;
    return path;
  };
  const std::string geometry =
      "space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (0,0,0)\nendian: little\n";
  const auto refusal = [](const std::string& path) {
    try {
      echoreg::segmentation::readNrrdVolume(path);
    } catch (const echoreg::core::FileError& e) {
      EXPECT_EQ(e.path(), path);
      return std::string(e.what());
    }
    ADD_FAILURE() << path << " was read";
    return std::string();
  };
  const std::string raw =
      write("raw.nrrd", geometry + "sizes: 2147483647 2147483647 2\nencoding: raw\n", "abcd");
  EXPECT_NE(refusal(raw).find("truncated data: sizes 2147483647 x 2147483647 x 2 need"),
            std::string::npos)
      << refusal(raw);
  const std::string gzip = write("gzip.nrrd", geometry + "sizes: 1000 1000 1000\nencoding: gzip\n",
                                 std::string(100, 'x'));
  EXPECT_NE(refusal(gzip).find("more than the 100 bytes of gzip data can hold"), std::string::npos)
      << refusal(gzip);
  const std::string other =
      write("other.nrrd", geometry + "sizes: 2147483647 2147483647 2\nencoding: bzip2\n", "abcd");
  EXPECT_NE(refusal(other).find("encoding \"bzip2\" is not supported"), std::string::npos);
  const std::string direction = write(
      "direction.nrrd",
      "space directions: (1e308,1e308,0) (0,0,1) (0,1,0)\nspace origin: (0,0,0)\nsizes: 1 1 1\n",
      "ab");
  EXPECT_NE(refusal(direction).find("a space direction is too long"), std::string::npos)
      << refusal(direction);
  // The same geometry with its two bytes is read.
  const auto one = echoreg::segmentation::readNrrdVolume(
      write("one.nrrd", geometry + "sizes: 1 1 1\nencoding: raw\n", std::string("\x2a\x00", 2)));
  ASSERT_EQ(one.image.hu.size(), 1U);
  EXPECT_EQ(one.image.hu[0], 42);
}

}  // namespace
