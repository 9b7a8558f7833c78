#include "echoreg/filters/MeshIO.h"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"

#include <vtkCellArray.h>
#include <vtkCleanPolyData.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkPLYReader.h>
#include <vtkPoints.h>
#include <vtkPolyDataNormals.h>
#include <vtkSTLReader.h>
#include <vtkSTLWriter.h>
#include <vtkTriangleFilter.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>

namespace echoreg::filters {

namespace {

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

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

core::TriangleMesh readMesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw FileError(path, "no such file");
  const std::string ext = lowerExtension(path);
  vtkSmartPointer<vtkPolyData> poly;
  if (ext == ".stl") {
    vtkNew<vtkSTLReader> reader;
    reader->SetFileName(path.c_str());
    reader->MergingOff();
    reader->Update();
    poly = reader->GetOutput();
  } else if (ext == ".vtp") {
    vtkNew<vtkXMLPolyDataReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    if (reader->GetErrorCode() != 0)
      throw FileError(path, "not a readable VTK XML PolyData file");
    poly = reader->GetOutput();
  } else if (ext == ".ply") {
    vtkNew<vtkPLYReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    poly = reader->GetOutput();
  } else if (ext == ".obj") {
    vtkNew<vtkOBJReader> reader;
    reader->SetFileName(path.c_str());
    reader->Update();
    poly = reader->GetOutput();
  } else {
    throw FileError(path, "unknown mesh kind '" + ext + "' (expected .stl, .vtp, .ply or .obj)");
  }
  if (!poly || poly->GetNumberOfPolys() == 0)
    throw FileError(path, "holds no triangles");
  core::TriangleMesh mesh = toTriangleMesh(poly);
  if (mesh.triangles.empty())
    throw FileError(path, "holds no triangles");
  return mesh;
}

void writeMesh(const std::string& path, vtkPolyData* polyData) {
  const std::string ext = lowerExtension(path);
  if (ext != ".vtp" && ext != ".stl") {
    throw FileError(path, "cannot write mesh kind '" + ext + "' (expected .vtp or .stl)");
  }
  // VTK writers open the file themselves: write to a temporary name beside it, then rename.
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid()) + ext;
  int ok = 0;
  if (ext == ".vtp") {
    vtkNew<vtkXMLPolyDataWriter> writer;
    writer->SetFileName(temporary.c_str());
    writer->SetInputData(polyData);
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    writer->SetCompressorTypeToZLib();
    ok = writer->Write();
  } else {
    vtkNew<vtkSTLWriter> writer;
    writer->SetFileName(temporary.c_str());
    writer->SetInputData(polyData);
    writer->SetFileTypeToBinary();
    ok = writer->Write();
  }
  if (ok != 1) {
    std::remove(temporary.c_str());
    throw FileError(path, "could not be written");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::remove(temporary.c_str());
    throw FileError(path, "could not be written: " + ec.message());
  }
}

void writeMesh(const std::string& path, const core::TriangleMesh& mesh) {
  writeMesh(path, toPolyData(mesh).Get());
}

}  // namespace echoreg::filters
