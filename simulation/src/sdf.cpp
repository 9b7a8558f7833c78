#include "echoreg/simulation/sdf.hpp"

#include "echoreg/filters/mesh_io.h"

#include <vtkFloatArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::simulation::sdf {

namespace {

/// Runs body(begin, end) over [0, count) in contiguous chunks on a few threads. Each index is
/// computed independently, so the result does not depend on the thread count.
template <typename Body>
void parallelFor(std::size_t count, const Body& body) {
  const std::size_t hardware = std::max<std::size_t>(1, std::thread::hardware_concurrency());
  const std::size_t threads =
      std::min<std::size_t>({hardware, 8, std::max<std::size_t>(1, count / 4096)});
  if (threads <= 1) {
    body(std::size_t{0}, count);
    return;
  }
  std::vector<std::thread> pool;
  const std::size_t chunk = (count + threads - 1) / threads;
  for (std::size_t t = 0; t < threads; ++t) {
    const std::size_t begin = t * chunk;
    const std::size_t end = std::min(count, begin + chunk);
    if (begin >= end)
      break;
    pool.emplace_back([&body, begin, end] { body(begin, end); });
  }
  for (auto& thread : pool)
    thread.join();
}

}  // namespace

Eigen::Vector3d gradient(const Field& field, const Eigen::Vector3d& p, double stepMm) {
  Eigen::Vector3d g;
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    offset[axis] = stepMm;
    g[axis] = (field(p + offset) - field(p - offset)) / (2.0 * stepMm);
  }
  return g;
}

Eigen::Vector3d rayExit(const Field& field, const Eigen::Vector3d& inside,
                        const Eigen::Vector3d& direction, double maxDistanceMm) {
  if (!(field(inside) < 0.0)) {
    throw std::invalid_argument("rayExit: the start point is not inside the surface");
  }
  const Eigen::Vector3d d = direction.normalized();
  constexpr double kStepMm = 0.25;
  double low = 0.0;
  double high = -1.0;
  for (double t = kStepMm; t <= maxDistanceMm; t += kStepMm) {
    if (field(inside + t * d) >= 0.0) {
      high = t;
      break;
    }
    low = t;
  }
  if (high < 0.0) {
    throw std::invalid_argument("rayExit: the ray does not leave the surface within " +
                                std::to_string(maxDistanceMm) + " mm");
  }
  for (int i = 0; i < 60 && high - low > 1e-7; ++i) {
    const double mid = 0.5 * (low + high);
    (field(inside + mid * d) < 0.0 ? low : high) = mid;
  }
  return inside + 0.5 * (low + high) * d;
}

Eigen::AlignedBox3d solidBounds(const Field& field, const Eigen::AlignedBox3d& searchBox,
                                double stepMm, double padMm) {
  const Eigen::Vector3d size = searchBox.sizes();
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a)
    n[a] = static_cast<int>(std::ceil(size[a] / stepMm)) + 1;
  Eigen::AlignedBox3d found;  // empty
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d p = searchBox.min() + stepMm * Eigen::Vector3d(i, j, k);
        // A cell corner within a cell diagonal of the surface may border the solid.
        if (field(p) < stepMm * std::sqrt(3.0))
          found.extend(p);
      }
    }
  }
  if (found.isEmpty())
    throw std::invalid_argument("solidBounds: the field has no inside");
  const Eigen::Vector3d pad = Eigen::Vector3d::Constant(padMm + stepMm);
  return Eigen::AlignedBox3d(found.min() - pad, found.max() + pad);
}

core::TriangleMesh meshField(const Field& field, const Eigen::AlignedBox3d& box, double spacingMm,
                             const std::string& what, std::size_t maxTriangles, int newtonSteps) {
  if (!(spacingMm > 0.0) || !std::isfinite(spacingMm)) {
    throw std::invalid_argument("meshField: spacing must be > 0 mm, got " +
                                std::to_string(spacingMm));
  }
  const Eigen::Vector3d size = box.sizes();
  int dims[3];
  for (int a = 0; a < 3; ++a)
    dims[a] = static_cast<int>(std::ceil(size[a] / spacingMm)) + 1;
  const std::size_t nx = static_cast<std::size_t>(dims[0]);
  const std::size_t ny = static_cast<std::size_t>(dims[1]);
  const std::size_t nz = static_cast<std::size_t>(dims[2]);
  const std::size_t count = nx * ny * nz;

  vtkNew<vtkFloatArray> values;
  values->SetName("sdf");
  values->SetNumberOfTuples(static_cast<vtkIdType>(count));
  float* data = values->GetPointer(0);
  const Eigen::Vector3d origin = box.min();
  bool boundaryInside = false;
  std::vector<char> boundaryFlags(nz, 0);
  parallelFor(nz, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      for (std::size_t j = 0; j < ny; ++j) {
        for (std::size_t i = 0; i < nx; ++i) {
          const Eigen::Vector3d p =
              origin + spacingMm * Eigen::Vector3d(static_cast<double>(i), static_cast<double>(j),
                                                   static_cast<double>(k));
          float v = static_cast<float>(field(p));
          // Keep grid values off the iso-level so that no contour vertex sits on a grid node.
          if (v == 0.0f)
            v = 1e-6f;
          data[(k * ny + j) * nx + i] = v;
          const bool onFace =
              i == 0 || j == 0 || k == 0 || i + 1 == nx || j + 1 == ny || k + 1 == nz;
          if (onFace && v < 0.0f)
            boundaryFlags[k] = 1;
        }
      }
    }
  });
  boundaryInside =
      std::any_of(boundaryFlags.begin(), boundaryFlags.end(), [](char flag) { return flag != 0; });
  if (boundaryInside) {
    throw std::invalid_argument("meshField: " + what +
                                " reaches the edge of its sampling box (the mesh would be open)");
  }

  vtkNew<vtkImageData> image;
  image->SetDimensions(dims);
  image->SetOrigin(origin.x(), origin.y(), origin.z());
  image->SetSpacing(spacingMm, spacingMm, spacingMm);
  image->GetPointData()->SetScalars(values);

  vtkNew<vtkFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->SetValue(0, 0.0);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->InterpolateAttributesOff();
  contour->Update();
  vtkPolyData* surface = contour->GetOutput();
  vtkNew<vtkQuadricDecimation> decimate;
  if (maxTriangles > 0 && surface->GetNumberOfPolys() > static_cast<vtkIdType>(maxTriangles)) {
    // Too fine a grid: fewer triangles, then back onto the surface below.
    decimate->SetInputData(surface);
    decimate->SetTargetReduction(1.0 - static_cast<double>(maxTriangles) /
                                           static_cast<double>(surface->GetNumberOfPolys()));
    decimate->VolumePreservationOn();
    decimate->Update();
    surface = decimate->GetOutput();
  }
  core::TriangleMesh mesh = filters::toTriangleMesh(surface);
  if (mesh.empty())
    throw std::runtime_error(what + ": the implicit surface produced no triangles");

  // Newton steps onto the zero level: x <- x - f(x) g / |g|^2, each step limited to a grid cell.
  const double step = 0.05 * spacingMm;
  // Decimated vertices may sit a few grid cells off the surface.
  const double maxStep = 4.0 * spacingMm;
  parallelFor(mesh.vertices.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      Eigen::Vector3d& x = mesh.vertices[v];
      for (int s = 0; s < newtonSteps + (surface == contour->GetOutput() ? 0 : 4); ++s) {
        const double f = field(x);
        if (std::abs(f) < 1e-9)
          break;
        const Eigen::Vector3d g = gradient(field, x, step);
        const double g2 = g.squaredNorm();
        if (!(g2 > 1e-12))
          break;
        Eigen::Vector3d delta = f * g / g2;
        const double length = delta.norm();
        if (length > maxStep)
          delta *= maxStep / length;
        x -= delta;
      }
    }
  });

  core::MeshCheck check = core::checkMesh(mesh);
  if (check.volumeMm3 < 0.0) {
    core::flipWinding(mesh);
    check = core::checkMesh(mesh);
  }
  if (!check.closed() || !(check.volumeMm3 > 0.0)) {
    throw std::runtime_error(what + ": meshing the implicit surface gave " + check.describe() +
                             ", volume " + std::to_string(check.volumeMm3) + " mm3");
  }
  return mesh;
}

}  // namespace echoreg::simulation::sdf
