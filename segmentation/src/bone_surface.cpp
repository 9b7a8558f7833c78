#include "echoreg/segmentation/bone_surface.hpp"

#include "echoreg/segmentation/end_shares.hpp"

#include "echoreg/filters/mesh_io.h"

#include <vtkDecimatePro.h>
#include <vtkFloatArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace echoreg::segmentation {

namespace {

std::size_t sz(int v) {
  return static_cast<std::size_t>(v);
}

double median(std::vector<double> v) {
  if (v.empty())
    return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Splits a mesh into its vertex-connected pieces.
std::vector<core::TriangleMesh> components(const core::TriangleMesh& mesh) {
  std::vector<int> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[sz(x)] != x) {
      parent[sz(x)] = parent[sz(parent[sz(x)])];
      x = parent[sz(x)];
    }
    return x;
  };
  for (const auto& t : mesh.triangles) {
    const int a = find(t[0]);
    parent[sz(find(t[1]))] = a;
    parent[sz(find(t[2]))] = a;
  }
  std::vector<int> pieceOfRoot(mesh.vertices.size(), -1);
  std::vector<core::TriangleMesh> pieces;
  std::vector<int> newIndex(mesh.vertices.size(), -1);
  for (const auto& t : mesh.triangles) {
    const int root = find(t[0]);
    if (pieceOfRoot[sz(root)] < 0) {
      pieceOfRoot[sz(root)] = static_cast<int>(pieces.size());
      pieces.emplace_back();
    }
    core::TriangleMesh& piece = pieces[sz(pieceOfRoot[sz(root)])];
    std::array<int, 3> nt{};
    for (int c = 0; c < 3; ++c) {
      const int v = t[sz(c)];
      if (newIndex[sz(v)] < 0) {
        newIndex[sz(v)] = static_cast<int>(piece.vertices.size());
        piece.vertices.push_back(mesh.vertices[sz(v)]);
      }
      nt[sz(c)] = newIndex[sz(v)];
    }
    piece.triangles.push_back(nt);
  }
  return pieces;
}

// Contours `field` (float, dims nx*ny*nz on the uniform grid of `geometry`, starting at voxel
// `start`) at `level`, maps to LPS, smooths, keeps the closed pieces, decimates. `levelHu` names
// the level in messages.
BoneSurfaceResult contourField(const std::vector<float>& field, const std::array<int, 3>& dims,
                               const Eigen::Vector3i& start, const core::CtImage& geometry,
                               double level, const BoneSurfaceOptions& options, double levelHu) {
  const Eigen::Vector3d spacing = geometry.spacingMm();
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(dims[0], dims[1], dims[2]);
  image->SetSpacing(spacing.x(), spacing.y(), spacing.z());
  image->SetOrigin(start.x() * spacing.x(), start.y() * spacing.y(), start.z() * spacing.z());
  auto scalars = vtkSmartPointer<vtkFloatArray>::New();
  scalars->SetNumberOfTuples(static_cast<vtkIdType>(field.size()));
  std::copy(field.begin(), field.end(), scalars->GetPointer(0));
  image->GetPointData()->SetScalars(scalars);
  auto contour = vtkSmartPointer<vtkFlyingEdges3D>::New();
  contour->SetInputData(image);
  contour->SetValue(0, level);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->Update();
  vtkPolyData* surface = contour->GetOutput();
  if (surface->GetNumberOfPolys() == 0) {
    throw std::invalid_argument(fmt::format("the surface at {:.0f} HU is empty", levelHu));
  }
  // To LPS (the grid is uniform: an affine map), before smoothing so that it works in mm.
  vtkPoints* points = surface->GetPoints();
  for (vtkIdType p = 0; p < points->GetNumberOfPoints(); ++p) {
    double x[3];
    points->GetPoint(p, x);
    const Eigen::Vector3d lps =
        geometry.originMm + geometry.direction * Eigen::Vector3d(x[0], x[1], x[2]);
    points->SetPoint(p, lps.data());
  }
  vtkSmartPointer<vtkPolyData> smoothed = surface;
  if (options.smoothingIterations > 0) {
    auto smoother = vtkSmartPointer<vtkWindowedSincPolyDataFilter>::New();
    smoother->SetInputData(surface);
    smoother->SetNumberOfIterations(options.smoothingIterations);
    smoother->SetPassBand(options.passBand);
    smoother->BoundarySmoothingOff();
    smoother->FeatureEdgeSmoothingOff();
    smoother->NonManifoldSmoothingOn();
    smoother->NormalizeCoordinatesOn();
    smoother->Update();
    smoothed = smoother->GetOutput();
  }
  BoneSurfaceResult result;
  result.isoHu = level;
  core::TriangleMesh all = filters::toTriangleMesh(smoothed);
  core::TriangleMesh kept;
  for (core::TriangleMesh& piece : components(all)) {
    core::MeshCheck check = core::checkMesh(piece);
    if (check.volumeMm3 < 0.0) {
      core::flipWinding(piece);
      check.volumeMm3 = -check.volumeMm3;
    }
    if (!check.closed() || check.volumeMm3 < options.minComponentMm3) {
      ++result.droppedComponents;
      continue;
    }
    ++result.components;
    const int offset = static_cast<int>(kept.vertices.size());
    kept.vertices.insert(kept.vertices.end(), piece.vertices.begin(), piece.vertices.end());
    for (const auto& t : piece.triangles)
      kept.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  if (kept.empty()) {
    throw std::invalid_argument(
        fmt::format("the surface at {:.0f} HU has no closed piece of {:.0f} mm^3 or more", levelHu,
                    options.minComponentMm3));
  }
  if (options.targetTriangles > 0 && kept.triangles.size() > options.targetTriangles) {
    auto decimate = vtkSmartPointer<vtkDecimatePro>::New();
    decimate->SetInputData(filters::toPolyData(kept));
    decimate->SetTargetReduction(1.0 - static_cast<double>(options.targetTriangles) /
                                           static_cast<double>(kept.triangles.size()));
    decimate->PreserveTopologyOn();
    decimate->SplittingOff();
    decimate->BoundaryVertexDeletionOff();
    decimate->Update();
    core::TriangleMesh reduced = filters::toTriangleMesh(decimate->GetOutput());
    core::MeshCheck check = core::checkMesh(reduced);
    if (check.volumeMm3 < 0.0)
      core::flipWinding(reduced);
    if (check.closed() && check.degenerateTriangles == 0) {
      kept = std::move(reduced);
      result.decimated = true;
    }
  }
  result.mesh = std::move(kept);
  return result;
}

void requireUniform(const core::CtImage& g, const char* what) {
  if (!g.uniform())
    throw std::invalid_argument(std::string(what) + " needs a CT of one slice group");
}

// The bounding box of `mask`'s voxels, grown by `pad` voxels (may go beyond the grid).
void maskBounds(const VoxelMask& mask, int pad, Eigen::Vector3i& lo, Eigen::Vector3i& hi) {
  const auto& d = mask.geometry.dimensions;
  lo = Eigen::Vector3i(d[0], d[1], d[2]);
  hi = Eigen::Vector3i(-1, -1, -1);
  for (int k = 0; k < d[2]; ++k) {
    for (int j = 0; j < d[1]; ++j) {
      for (int i = 0; i < d[0]; ++i) {
        if (!mask.at(i, j, k))
          continue;
        lo = lo.cwiseMin(Eigen::Vector3i(i, j, k));
        hi = hi.cwiseMax(Eigen::Vector3i(i, j, k));
      }
    }
  }
  if (hi.x() < 0)
    throw std::invalid_argument("the mask is empty");
  lo.array() -= pad;
  hi.array() += pad;
}

// SphereCut: over the cap, the band's voxels within a voxel of the sphere take at most the value
// that falls linearly from `high` a voxel inside the kept side to `low` a voxel beyond it
// (crossing half way on the sphere), from what the CT says there (`ctValue`, the other bone's
// voxels included: on the kept side they are this bone's up to the sphere).
template <typename F>
void cutBySphere(const core::CtImage& ct, const VoxelMask& band, const Eigen::Vector3i& lo,
                 const Eigen::Vector3i& hi, const SphereCut& cut, std::vector<float>& field,
                 float low, float high, F ctValue) {
  const auto& d = ct.dimensions;
  const std::array<int, 3> dims{hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1};
  const double reach = ct.spacingMm().maxCoeff();
  const double cosCap = std::cos(cut.capDegrees * M_PI / 180.0);
  for (int k = std::max(lo.z(), 0); k <= std::min(hi.z(), d[2] - 1); ++k) {
    for (int j = std::max(lo.y(), 0); j <= std::min(hi.y(), d[1] - 1); ++j) {
      for (int i = std::max(lo.x(), 0); i <= std::min(hi.x(), d[0] - 1); ++i) {
        if (!band.voxels[ct.index(i, j, k)])
          continue;
        const Eigen::Vector3d u = ct.voxelToLps(Eigen::Vector3d(i, j, k)) - cut.centreLps;
        const double r = u.norm();
        const double kept = cut.keepInside ? cut.radiusMm - r : r - cut.radiusMm;
        if (std::fabs(kept) > reach || u.dot(cut.axisLps) < cosCap * r)
          continue;
        const double share = std::clamp(0.5 + 0.5 * kept / reach, 0.0, 1.0);
        const float bound = static_cast<float>(low + share * (high - low));
        float& value =
            field[(sz(k - lo.z()) * sz(dims[1]) + sz(j - lo.y())) * sz(dims[0]) + sz(i - lo.x())];
        value = std::min(ctValue(i, j, k), bound);
      }
    }
  }
}

}  // namespace

Eigen::Vector3d morphologyRadiiMm(const Eigen::Vector3d& spacingMm, double mm, double voxels) {
  return spacingMm.cwiseProduct(Eigen::Vector3d::Constant(std::max(0.0, voxels)))
      .cwiseMax(Eigen::Vector3d::Constant(mm));
}

VoxelMask dilateOrErode(const VoxelMask& mask, double mm, double voxels, bool grow) {
  const Eigen::Vector3d spacing = mask.geometry.spacingMm();
  const Eigen::Vector3d radii = morphologyRadiiMm(spacing, mm, voxels);
  if ((radii.array() == mm).all() || !(mm > 0.0))
    return grow ? dilate(mask, mm) : erode(mask, mm);
  // An ellipsoid of these radii is the unit ball of the grid whose spacings are divided by them.
  VoxelMask scaled = mask;
  scaled.geometry.pixelSpacingMm =
      Eigen::Vector2d(spacing.x() / radii.x(), spacing.y() / radii.y());
  for (double& z : scaled.geometry.slicePositionsMm)
    z /= radii.z();
  for (auto& g : scaled.geometry.groups)
    g.spacingMm /= radii.z();
  VoxelMask out = grow ? dilate(scaled, 1.0) : erode(scaled, 1.0);
  out.geometry = mask.geometry;
  return out;
}

BoneSurfaceResult boneSurface(const core::CtImage& ct, const VoxelMask& region,
                              const VoxelMask* exclude, const BoneSurfaceOptions& options) {
  requireUniform(ct, "boneSurface");
  if (ct.hu.size() != ct.voxelCount() || region.voxels.size() != ct.voxelCount() ||
      region.geometry.dimensions != ct.dimensions ||
      (exclude != nullptr && exclude->voxels.size() != ct.voxelCount())) {
    throw std::invalid_argument("boneSurface: the CT and the masks lie on different grids");
  }
  if (region.count() == 0)
    throw std::invalid_argument("the bone's mask is empty");
  const VoxelMask band = dilateOrErode(region, options.bandMm, options.bandVoxels, true);
  const VoxelMask interior =
      dilateOrErode(region, options.interiorMm, options.interiorVoxels, false);
  auto excluded = [&](std::size_t i) {
    return exclude != nullptr && exclude->voxels[i] != 0 && region.voxels[i] == 0;
  };

  // Levels of the cortex and of the soft tissue around it.
  BoneSurfaceResult levels;
  {
    const VoxelMask deep = erode(region, 1.0);
    std::vector<double> cortex;
    for (std::size_t i = 0; i < ct.hu.size(); ++i) {
      if (deep.voxels[i] && ct.hu[i] >= options.cortexMinHu)
        cortex.push_back(ct.hu[i]);
    }
    if (cortex.empty()) {
      for (std::size_t i = 0; i < ct.hu.size(); ++i) {
        if (region.voxels[i] && ct.hu[i] >= options.cortexMinHu)
          cortex.push_back(ct.hu[i]);
      }
    }
    const VoxelMask near = dilate(region, 1.5);
    const VoxelMask far = dilate(region, 3.0);
    std::vector<double> soft;
    for (std::size_t i = 0; i < ct.hu.size(); ++i) {
      if (far.voxels[i] && !near.voxels[i] && !excluded(i) && ct.hu[i] < options.cortexMinHu)
        soft.push_back(ct.hu[i]);
    }
    levels.cortexHu = cortex.empty() ? options.cortexMinHu : median(cortex);
    levels.softTissueHu = soft.empty() ? 0.0 : median(soft);
  }
  const double iso =
      options.isoHu != 0.0 ? options.isoHu : 0.5 * (levels.cortexHu + levels.softTissueHu);
  const float high = static_cast<float>(std::max(levels.cortexHu, iso + 100.0));
  const float low = static_cast<float>(std::min(levels.softTissueHu, iso - 100.0));

  Eigen::Vector3i lo, hi;
  maskBounds(band, 1, lo, hi);
  const std::array<int, 3> dims{hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1};
  const auto& d = ct.dimensions;
  if (options.localLevel && options.isoHu == 0.0) {
    // The field (HU - L) / (Hlocal - L), clamped to [0, 1], contoured at 0.5: 1 in the interior,
    // 0 outside the band and on other bones.
    const Eigen::Vector3d spacing = ct.spacingMm();
    const int ri = static_cast<int>(std::floor(options.localLevelMm / spacing.x() + 1e-9));
    const int rj = static_cast<int>(std::floor(options.localLevelMm / spacing.y() + 1e-9));
    const double soft = levels.softTissueHu;
    auto counts = [&](std::size_t v) { return band.voxels[v] && !excluded(v); };
    // The in-slice offsets within the radius, once.
    std::vector<std::array<int, 2>> disc;
    for (int b = -rj; b <= rj; ++b) {
      for (int a = -ri; a <= ri; ++a) {
        const double di = a * spacing.x(), dj = b * spacing.y();
        if (di * di + dj * dj <= options.localLevelMm * options.localLevelMm + 1e-9)
          disc.push_back({a, b});
      }
    }
    // The brightest of this slice's region and band within the radius, at least the bone's one
    // level: thin cortices and slabs of cancellous bone keep the one level.
    const auto bandValue = [&](int i, int j, int k) {
      double top = std::max(soft + options.localMinContrastHu, levels.cortexHu);
      for (const auto& [da, db] : disc) {
        const int a = i + da, b = j + db;
        if (a < 0 || a >= d[0] || b < 0 || b >= d[1])
          continue;
        const std::size_t n = ct.index(a, b, k);
        if (counts(n))
          top = std::max(top, static_cast<double>(ct.hu[n]));
      }
      return static_cast<float>(
          std::clamp((ct.hu[ct.index(i, j, k)] - soft) / (top - soft), 0.0, 1.0));
    };
    std::vector<float> field(sz(dims[0]) * sz(dims[1]) * sz(dims[2]), 0.0f);
    for (int k = std::max(lo.z(), 0); k <= std::min(hi.z(), d[2] - 1); ++k) {
      for (int j = std::max(lo.y(), 0); j <= std::min(hi.y(), d[1] - 1); ++j) {
        for (int i = std::max(lo.x(), 0); i <= std::min(hi.x(), d[0] - 1); ++i) {
          const std::size_t v = ct.index(i, j, k);
          float value = 0.0f;
          if (interior.voxels[v])
            value = 1.0f;
          else if (counts(v))
            value = bandValue(i, j, k);
          field[(sz(k - lo.z()) * sz(dims[1]) + sz(j - lo.y())) * sz(dims[0]) + sz(i - lo.x())] =
              value;
        }
      }
    }
    // Thick slices: the share of bone in the voxels at the ends along z from the sections
    // around them (their HU does not tell it).
    if (options.endSharesMinSliceMm > 0.0 && spacing.z() >= options.endSharesMinSliceMm) {
      const VoxelMask sections =
          jointSlabSections(ct, region, exclude, soft, options.jointSlabShare);
      for (const VoxelShare& end : zEndShares(region, exclude, options.endShares, &sections)) {
        const int i = static_cast<int>(end.voxel % sz(d[0]));
        const int j = static_cast<int>((end.voxel / sz(d[0])) % sz(d[1]));
        const int k = static_cast<int>(end.voxel / (sz(d[0]) * sz(d[1])));
        if ((Eigen::Vector3i(i, j, k).array() < lo.array()).any() ||
            (Eigen::Vector3i(i, j, k).array() > hi.array()).any())
          continue;
        float& value =
            field[(sz(k - lo.z()) * sz(dims[1]) + sz(j - lo.y())) * sz(dims[0]) + sz(i - lo.x())];
        // A flat end's slab is full (its section does not shrink towards it, and the HU of a
        // full slab of cancellous bone under a thin plate falls short of the level); the
        // sections still tell what lies beyond it. The field puts the 0.5 crossing where the
        // share ends the bone (zEndFieldValue).
        value = static_cast<float>(
            zEndFieldValue(end.flatEnd && region.voxels[end.voxel] ? 1.0 : end.share));
      }
    }
    if (options.sphereCut) {
      cutBySphere(ct, band, lo, hi, *options.sphereCut, field, 0.0f, 1.0f,
                  [&](int i, int j, int k) {
                    return interior.voxels[ct.index(i, j, k)] ? 1.0f : bandValue(i, j, k);
                  });
    }
    BoneSurfaceResult result = contourField(field, dims, lo, ct, 0.5, options, iso);
    result.isoHu = iso;
    result.cortexHu = levels.cortexHu;
    result.softTissueHu = levels.softTissueHu;
    return result;
  }
  std::vector<float> field(sz(dims[0]) * sz(dims[1]) * sz(dims[2]), low);
  for (int k = std::max(lo.z(), 0); k <= std::min(hi.z(), d[2] - 1); ++k) {
    for (int j = std::max(lo.y(), 0); j <= std::min(hi.y(), d[1] - 1); ++j) {
      for (int i = std::max(lo.x(), 0); i <= std::min(hi.x(), d[0] - 1); ++i) {
        const std::size_t v = ct.index(i, j, k);
        float value = low;
        if (interior.voxels[v]) {
          value = high;
        } else if (band.voxels[v] && !excluded(v)) {
          value = std::clamp(static_cast<float>(ct.hu[v]), low, high);
        }
        field[(sz(k - lo.z()) * sz(dims[1]) + sz(j - lo.y())) * sz(dims[0]) + sz(i - lo.x())] =
            value;
      }
    }
  }
  if (options.sphereCut) {
    cutBySphere(ct, band, lo, hi, *options.sphereCut, field, low, high, [&](int i, int j, int k) {
      const std::size_t v = ct.index(i, j, k);
      return interior.voxels[v] ? high : std::clamp(static_cast<float>(ct.hu[v]), low, high);
    });
  }
  BoneSurfaceResult result = contourField(field, dims, lo, ct, iso, options, iso);
  result.cortexHu = levels.cortexHu;
  result.softTissueHu = levels.softTissueHu;
  return result;
}

BoneSurfaceResult maskSurface(const VoxelMask& mask, double sigmaMm,
                              const BoneSurfaceOptions& options) {
  requireUniform(mask.geometry, "maskSurface");
  if (mask.count() == 0)
    throw std::invalid_argument("the mask is empty");
  const Eigen::Vector3d spacing = mask.geometry.spacingMm();
  Eigen::Vector3i lo, hi;
  const int pad = 2 + static_cast<int>(std::ceil(3.0 * sigmaMm / spacing.minCoeff()));
  maskBounds(mask, pad, lo, hi);
  const std::array<int, 3> dims{hi.x() - lo.x() + 1, hi.y() - lo.y() + 1, hi.z() - lo.z() + 1};
  std::vector<float> field(sz(dims[0]) * sz(dims[1]) * sz(dims[2]), 0.0f);
  const auto& d = mask.geometry.dimensions;
  auto at = [&](int i, int j, int k) -> float& {
    return field[(sz(k) * sz(dims[1]) + sz(j)) * sz(dims[0]) + sz(i)];
  };
  for (int k = 0; k < dims[2]; ++k) {
    for (int j = 0; j < dims[1]; ++j) {
      for (int i = 0; i < dims[0]; ++i) {
        const int a = i + lo.x(), b = j + lo.y(), c = k + lo.z();
        if (a >= 0 && b >= 0 && c >= 0 && a < d[0] && b < d[1] && c < d[2] && mask.at(a, b, c))
          at(i, j, k) = 1.0f;
      }
    }
  }
  // Separable Gaussian blur, edges at 0 (outside the mask).
  if (sigmaMm > 0.0) {
    for (int axis = 0; axis < 3; ++axis) {
      const double s = sigmaMm / spacing[axis];
      const int r = static_cast<int>(std::ceil(3.0 * s));
      std::vector<double> kernel(sz(2 * r + 1));
      double sum = 0.0;
      for (int t = -r; t <= r; ++t)
        sum += kernel[sz(t + r)] = std::exp(-0.5 * t * t / (s * s));
      for (double& w : kernel)
        w /= sum;
      std::vector<float> out(field.size(), 0.0f);
      const int n = dims[sz(axis)];
      for (int k = 0; k < dims[2]; ++k) {
        for (int j = 0; j < dims[1]; ++j) {
          for (int i = 0; i < dims[0]; ++i) {
            const int pos[3] = {i, j, k};
            double acc = 0.0;
            for (int t = -r; t <= r; ++t) {
              const int q = pos[axis] + t;
              if (q < 0 || q >= n)
                continue;
              int p2[3] = {i, j, k};
              p2[axis] = q;
              acc += kernel[sz(t + r)] * at(p2[0], p2[1], p2[2]);
            }
            out[(sz(k) * sz(dims[1]) + sz(j)) * sz(dims[0]) + sz(i)] = static_cast<float>(acc);
          }
        }
      }
      field.swap(out);
    }
  }
  return contourField(field, dims, lo, mask.geometry, 0.5, options, 0.5);
}

}  // namespace echoreg::segmentation
