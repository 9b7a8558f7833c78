#include "echoreg/core/ct_image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace echoreg::core {

double CtImage::sliceSpacingMm() const {
  if (!uniform())
    throw std::logic_error("the CT's slice spacing is not uniform (several groups)");
  if (groups.empty() || groups.front().count < 2)
    return 1.0;
  return groups.front().spacingMm;
}

Eigen::Vector3d CtImage::spacingMm() const {
  return {pixelSpacingMm.x(), pixelSpacingMm.y(), sliceSpacingMm()};
}

namespace {

// Position along k of a fractional slice index.
double slicePosition(const CtImage& image, double k) {
  const auto& z = image.slicePositionsMm;
  const int n = static_cast<int>(z.size());
  if (n == 0)
    return 0.0;
  if (n == 1)
    return k;  // one slice: unit spacing
  if (k <= 0.0)
    return z[0] + k * (z[1] - z[0]);
  if (k >= n - 1)
    return z[static_cast<std::size_t>(n - 1)] +
           (k - (n - 1)) *
               (z[static_cast<std::size_t>(n - 1)] - z[static_cast<std::size_t>(n - 2)]);
  const int k0 = static_cast<int>(std::floor(k));
  const double f = k - k0;
  return (1.0 - f) * z[static_cast<std::size_t>(k0)] + f * z[static_cast<std::size_t>(k0 + 1)];
}

// Fractional slice index of a position along k (inverse of slicePosition).
double sliceIndex(const CtImage& image, double position) {
  const auto& z = image.slicePositionsMm;
  const int n = static_cast<int>(z.size());
  if (n == 0)
    return 0.0;
  if (n == 1)
    return position;
  if (position <= z[0])
    return (position - z[0]) / (z[1] - z[0]);
  if (position >= z.back()) {
    return (n - 1) + (position - z.back()) / (z.back() - z[static_cast<std::size_t>(n - 2)]);
  }
  const auto it = std::upper_bound(z.begin(), z.end(), position);
  const int k1 = static_cast<int>(it - z.begin());
  const int k0 = k1 - 1;
  return k0 + (position - z[static_cast<std::size_t>(k0)]) /
                  (z[static_cast<std::size_t>(k1)] - z[static_cast<std::size_t>(k0)]);
}

}  // namespace

Eigen::Vector3d CtImage::voxelToLps(const Eigen::Vector3d& ijk) const {
  const Eigen::Vector3d local(ijk.x() * pixelSpacingMm.x(), ijk.y() * pixelSpacingMm.y(),
                              slicePosition(*this, ijk.z()));
  return originMm + direction * local;
}

Eigen::Vector3d CtImage::lpsToVoxel(const Eigen::Vector3d& lps) const {
  const Eigen::Vector3d local = direction.transpose() * (lps - originMm);
  return {local.x() / pixelSpacingMm.x(), local.y() / pixelSpacingMm.y(),
          sliceIndex(*this, local.z())};
}

Eigen::Vector3d CtImage::voxelCentreMm(int i, int j, int k) const {
  if (direction == Eigen::Matrix3d::Identity() &&
      sliceLocationsMm.size() == static_cast<std::size_t>(dimensions[2])) {
    return {originMm.x() + i * pixelSpacingMm.x(), originMm.y() + j * pixelSpacingMm.y(),
            sliceLocationsMm[static_cast<std::size_t>(k)]};
  }
  return voxelToLps(Eigen::Vector3d(i, j, k));
}

CtImage axialCtImage(int columns, int rows, double pixelSpacingMm,
                     const Eigen::Vector2d& firstPixelXYMm,
                     const std::vector<AxialSliceGroup>& groups) {
  CtImage image;
  image.dimensions = {columns, rows, 0};
  image.pixelSpacingMm = {pixelSpacingMm, pixelSpacingMm};
  for (const AxialSliceGroup& group : groups) {
    const int first = image.dimensions[2];
    const int count = static_cast<int>(group.zMm.size());
    image.groups.push_back({first, count, count > 1 ? group.zMm[1] - group.zMm[0] : 0.0});
    image.groupNames.push_back(group.name);
    for (double z : group.zMm) {
      image.sliceLocationsMm.push_back(z);
      image.sliceThicknessMm.push_back(group.thicknessMm);
    }
    image.dimensions[2] += count;
  }
  const double z0 = image.sliceLocationsMm.empty() ? 0.0 : image.sliceLocationsMm.front();
  image.originMm = {firstPixelXYMm.x(), firstPixelXYMm.y(), z0};
  for (double z : image.sliceLocationsMm)
    image.slicePositionsMm.push_back(z - z0);
  return image;
}

CtImage resampleUniform(const CtImage& image, double spacingMm) {
  if (image.voxelCount() == 0 || image.slicePositionsMm.empty()) {
    throw std::invalid_argument("resampleUniform: the CT image is empty");
  }
  if (spacingMm <= 0.0) {
    spacingMm = 0.0;  // the smallest step between consecutive slices
    const auto& z = image.slicePositionsMm;
    for (std::size_t k = 1; k < z.size(); ++k) {
      const double step = z[k] - z[k - 1];
      if (spacingMm == 0.0 || step < spacingMm)
        spacingMm = step;
    }
    if (spacingMm <= 0.0)
      spacingMm = 1.0;
  }
  const double length = image.slicePositionsMm.back();
  const int slices = static_cast<int>(std::floor(length / spacingMm + 1e-6)) + 1;
  CtImage out;
  out.dimensions = {image.dimensions[0], image.dimensions[1], slices};
  out.originMm = image.originMm;
  out.direction = image.direction;
  out.pixelSpacingMm = image.pixelSpacingMm;
  out.seriesInstanceUid = image.seriesInstanceUid;
  out.folder = image.folder;
  out.slicePositionsMm.resize(static_cast<std::size_t>(slices));
  for (int k = 0; k < slices; ++k)
    out.slicePositionsMm[static_cast<std::size_t>(k)] = k * spacingMm;
  out.groups = {CtSliceGroup{0, slices, slices > 1 ? spacingMm : 0.0}};
  const std::size_t plane =
      static_cast<std::size_t>(image.dimensions[0]) * static_cast<std::size_t>(image.dimensions[1]);
  out.hu.resize(plane * static_cast<std::size_t>(slices));
  const int last = image.dimensions[2] - 1;
  for (int k = 0; k < slices; ++k) {
    const double source =
        std::clamp(sliceIndex(image, k * spacingMm), 0.0, static_cast<double>(last));
    const int k0 = std::min(static_cast<int>(std::floor(source)), last);
    const int k1 = std::min(k0 + 1, last);
    const double f = source - k0;
    const std::int16_t* a = image.hu.data() + plane * static_cast<std::size_t>(k0);
    const std::int16_t* b = image.hu.data() + plane * static_cast<std::size_t>(k1);
    std::int16_t* o = out.hu.data() + plane * static_cast<std::size_t>(k);
    for (std::size_t p = 0; p < plane; ++p) {
      o[p] = static_cast<std::int16_t>(std::lround((1.0 - f) * a[p] + f * b[p]));
    }
  }
  return out;
}

}  // namespace echoreg::core
