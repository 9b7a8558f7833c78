#include "echoreg/filters/mesh_io.h"

#include "echoreg/core/error.hpp"
#include "mesh_files.hpp"

#include <vtkCellArray.h>
#include <vtkCleanPolyData.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyDataNormals.h>
#include <vtkTriangleFilter.h>

#include <string>

namespace echoreg::filters {

core::TriangleMesh toTriangleMesh(vtkPolyData* polyData) {
  vtkNew<vtkTriangleFilter> triangles;
  triangles->SetInputData(polyData);
  triangles->PassVertsOff();
  triangles->PassLinesOff();
  vtkNew<vtkCleanPolyData>
      clean;  // merge exactly coincident points (STL stores each triangle's own)
  clean->SetInputConnection(triangles->GetOutputPort());
  clean->PointMergingOn();
  clean->SetTolerance(0.0);
  clean->ConvertLinesToPointsOff();
  clean->ConvertPolysToLinesOff();
  clean->ConvertStripsToPolysOff();
  clean->Update();
  vtkPolyData* out = clean->GetOutput();

  core::TriangleMesh mesh;
  mesh.vertices.reserve(static_cast<std::size_t>(out->GetNumberOfPoints()));
  for (vtkIdType i = 0; i < out->GetNumberOfPoints(); ++i) {
    double p[3];
    out->GetPoint(i, p);
    mesh.vertices.emplace_back(p[0], p[1], p[2]);
  }
  vtkCellArray* polys = out->GetPolys();
  mesh.triangles.reserve(static_cast<std::size_t>(polys->GetNumberOfCells()));
  vtkNew<vtkIdList> ids;
  for (polys->InitTraversal(); polys->GetNextCell(ids);) {
    if (ids->GetNumberOfIds() != 3)
      continue;
    mesh.triangles.push_back({static_cast<int>(ids->GetId(0)), static_cast<int>(ids->GetId(1)),
                              static_cast<int>(ids->GetId(2))});
  }
  return mesh;
}

vtkSmartPointer<vtkPolyData> toPolyData(const core::TriangleMesh& mesh) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d& v = mesh.vertices[i];
    points->SetPoint(static_cast<vtkIdType>(i), v.x(), v.y(), v.z());
  }
  vtkNew<vtkCellArray> polys;
  polys->AllocateExact(static_cast<vtkIdType>(mesh.triangles.size()),
                       static_cast<vtkIdType>(3 * mesh.triangles.size()));
  for (const auto& tri : mesh.triangles) {
    const vtkIdType ids[3] = {tri[0], tri[1], tri[2]};
    polys->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetPolys(polys);
  vtkNew<vtkPolyDataNormals> normals;
  normals->SetInputData(poly);
  normals->SplittingOff();
  normals->ConsistencyOff();
  normals->AutoOrientNormalsOff();
  normals->ComputePointNormalsOn();
  normals->ComputeCellNormalsOff();
  normals->Update();
  vtkSmartPointer<vtkPolyData> result = normals->GetOutput();
  return result;
}

namespace {

/// VTK 9.1's readers pass on cells naming points the file does not have (an OBJ with a face before
/// any vertex, its lines indented: found by fuzz/fuzz_mesh), and vtkTriangleFilter then reads out
/// of bounds (a crash). Throws FileError naming the first such cell.
void checkCellsNameTheFilesPoints(const std::string& path, vtkPolyData* poly) {
  const vtkIdType points = poly->GetPoints() != nullptr ? poly->GetNumberOfPoints() : 0;
  for (vtkCellArray* cells :
       {poly->GetVerts(), poly->GetLines(), poly->GetPolys(), poly->GetStrips()}) {
    if (cells == nullptr)
      continue;
    vtkIdType count = 0;
    const vtkIdType* ids = nullptr;
    vtkIdType cell = 0;
    for (cells->InitTraversal(); cells->GetNextCell(count, ids); ++cell) {
      for (vtkIdType corner = 0; corner < count; ++corner) {
        if (ids[corner] < 0 || ids[corner] >= points) {
          throw core::FileError(path, "a face (cell " + std::to_string(cell + 1) +
                                          ") names point " + std::to_string(ids[corner] + 1) +
                                          ", but the file has " + std::to_string(points) +
                                          " points: a damaged model");
        }
      }
    }
  }
}

}  // namespace

core::TriangleMesh readMesh(const std::string& path) {
  const vtkSmartPointer<vtkPolyData> poly = detail::readPolyDataFile(path);
  if (!poly || poly->GetNumberOfPolys() == 0)
    throw core::FileError(path, "holds no triangles");
  checkCellsNameTheFilesPoints(path, poly);
  core::TriangleMesh mesh = toTriangleMesh(poly);
  if (mesh.triangles.empty())
    throw core::FileError(path, "holds no triangles");
  return mesh;
}

void writeMesh(const std::string& path, vtkPolyData* polyData) {
  detail::writePolyDataFile(path, polyData);
}

void writeMesh(const std::string& path, const core::TriangleMesh& mesh) {
  writeMesh(path, toPolyData(mesh).Get());
}

}  // namespace echoreg::filters
