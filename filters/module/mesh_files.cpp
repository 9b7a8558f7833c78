// VTK's mesh readers and writers (STL, VTK XML PolyData, PLY, OBJ), inside the mesh I/O module
// (filters/CMakeLists.txt): readMesh and writeMesh (mesh_io.cxx) call them through the module; the
// fuzz harness compiles this file directly.
#include "mesh_files.hpp"
#include "echoreg/core/error.hpp"

#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkPLYReader.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>
#include <vtkSTLWriter.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

namespace echoreg::filters::detail {

namespace {

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

vtkSmartPointer<vtkPolyData> readPolyDataFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw core::FileError(path, "no such file");
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
      throw core::FileError(path, "not a readable VTK XML PolyData file");
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
    throw core::FileError(path,
                          "unknown mesh kind '" + ext + "' (expected .stl, .vtp, .ply or .obj)");
  }
  return poly;
}

void writePolyDataFile(const std::string& path, vtkPolyData* polyData) {
  const std::string ext = lowerExtension(path);
  if (ext != ".vtp" && ext != ".stl") {
    throw core::FileError(path, "cannot write mesh kind '" + ext + "' (expected .vtp or .stl)");
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
    throw core::FileError(path, "could not be written");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::remove(temporary.c_str());
    throw core::FileError(path, "could not be written: " + ec.message());
  }
}

}  // namespace echoreg::filters::detail
