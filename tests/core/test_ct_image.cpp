#include "echoreg/core/ct_image.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

namespace {

using echoreg::core::CtImage;

// A 2 x 1 image of three slices at 0, 5 and 6 mm (two groups: the step changes) on a rotated frame.
CtImage threeSlices() {
  CtImage image;
  image.dimensions = {2, 1, 3};
  image.originMm = {10, 20, 30};
  image.direction << 0, 1, 0,  //
      1, 0, 0,                 //
      0, 0, -1;
  image.pixelSpacingMm = {0.5, 0.75};
  image.slicePositionsMm = {0, 5, 6};
  image.groups = {{0, 2, 5.0}, {2, 1, 0.0}};
  image.hu = {0, 100, 50, 150, 60, 160};
  return image;
}

TEST(CtImage, VoxelToLpsFollowsDirectionSpacingAndSlicePositions) {
  const CtImage image = threeSlices();
  EXPECT_FALSE(image.uniform());
  EXPECT_THROW(image.sliceSpacingMm(), std::logic_error);
  const Eigen::Vector3d p = image.voxelToLps({1, 0, 1.5});
  EXPECT_TRUE(p.isApprox(Eigen::Vector3d(10, 20.5, 30 - 5.5), 1e-12)) << p.transpose();
  const Eigen::Vector3d back = image.lpsToVoxel(p);
  EXPECT_NEAR((back - Eigen::Vector3d(1, 0, 1.5)).norm(), 0.0, 1e-12);
  // Outside the slices: extrapolated with the end groups' spacing.
  EXPECT_NEAR(image.voxelToLps({0, 0, 3}).z(), 30 - 7, 1e-12);
  EXPECT_NEAR(image.lpsToVoxel({10, 20, 30 + 10}).z(), -2.0, 1e-12);
}

TEST(CtImage, ResampleUniformInterpolatesAlongTheSlices) {
  const CtImage out = echoreg::core::resampleUniform(threeSlices());
  EXPECT_TRUE(out.uniform());
  ASSERT_EQ(out.dimensions[2], 7);  // 0..6 mm at 1 mm
  EXPECT_DOUBLE_EQ(out.sliceSpacingMm(), 1.0);
  EXPECT_EQ(out.at(1, 0, 0), 100);
  EXPECT_EQ(out.at(0, 0, 1), 10);  // 1/5 of the way from 0 to 50
  EXPECT_EQ(out.at(1, 0, 5), 150);
  EXPECT_EQ(out.at(0, 0, 6), 60);
  EXPECT_TRUE(out.voxelToLps({0, 0, 6}).isApprox(threeSlices().voxelToLps({0, 0, 2}), 1e-12));
  EXPECT_THROW(echoreg::core::resampleUniform(CtImage{}), std::invalid_argument);
}

TEST(CtImage, AxialImageKeepsTheSlicesZExactly) {
  // z that origin + offset does not give back in the last bit: 0.1 + (0.3 - 0.1) != 0.3.
  const std::vector<double> hip = {0.1, 0.3}, knee = {0.7, 0.8, 0.9};
  const CtImage image =
      echoreg::core::axialCtImage(4, 3, 0.5, {-1.0, 2.0}, {{"hip", hip, 5.0}, {"knee", knee, 1.0}});
  EXPECT_EQ(image.dimensions, (std::array<int, 3>{4, 3, 5}));
  EXPECT_TRUE(image.direction.isIdentity(0.0));
  EXPECT_TRUE(image.hu.empty());
  EXPECT_EQ(image.originMm, Eigen::Vector3d(-1.0, 2.0, 0.1));
  EXPECT_EQ(image.sliceLocationsMm, (std::vector<double>{0.1, 0.3, 0.7, 0.8, 0.9}));
  EXPECT_EQ(image.sliceThicknessMm, (std::vector<double>{5.0, 5.0, 1.0, 1.0, 1.0}));
  EXPECT_EQ(image.groupNames, (std::vector<std::string>{"hip", "knee"}));
  ASSERT_EQ(image.groups.size(), 2u);
  EXPECT_EQ(image.groups[0].firstSlice, 0);
  EXPECT_EQ(image.groups[0].count, 2);
  EXPECT_EQ(image.groups[0].spacingMm, 0.3 - 0.1);
  EXPECT_EQ(image.groups[1].firstSlice, 2);
  EXPECT_EQ(image.groups[1].count, 3);
  EXPECT_EQ(image.groups[1].spacingMm, 0.8 - 0.7);
  for (std::size_t k = 0; k < 5; ++k)
    EXPECT_EQ(image.slicePositionsMm[k], image.sliceLocationsMm[k] - 0.1);
  // The voxel centre is the kept z itself; voxelToLps agrees to rounding.
  const Eigen::Vector3d c = image.voxelCentreMm(3, 2, 1);
  EXPECT_EQ(c, Eigen::Vector3d(-1.0 + 3 * 0.5, 2.0 + 2 * 0.5, 0.3));
  EXPECT_NEAR((image.voxelToLps(Eigen::Vector3d(3, 2, 1)) - c).norm(), 0.0, 1e-12);
  // Without kept locations (an image read from DICOM), the centre is voxelToLps.
  CtImage read = image;
  read.sliceLocationsMm.clear();
  EXPECT_EQ(read.voxelCentreMm(3, 2, 1), read.voxelToLps(Eigen::Vector3d(3, 2, 1)));
}

}  // namespace
