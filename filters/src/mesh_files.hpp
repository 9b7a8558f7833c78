// Mesh files through VTK's readers and writers, which live in the mesh I/O module
// (libechoreg_mesh_io.so, filters/module/): VTK's I/O libraries (XML, geometry, PLY and the image
// formats they bring) cost every process start-up about 20 ms of CPU, so nothing in an executable
// links them; readMesh and writeMesh open the module with dlopen on the first mesh file
// (docs/architecture.md, "Modules opened on demand"). Internal to filters/.
//
// The module's C entry points take C++ types by pointer, which holds because it is built from the
// same sources by the same compiler and against the same VTK (checked by meshIoAbi()); an exception
// thrown inside crosses as a std::exception_ptr and is rethrown by the caller.
#pragma once

#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkVersionMacros.h>

#include <exception>
#include <string>

#ifndef ECHOREG_VERSION
#error "ECHOREG_VERSION must be defined (filters/CMakeLists.txt)"
#endif

namespace echoreg::filters::detail {

/// The polygons of the mesh file `path` by its extension (.stl, .vtp, .ply, .obj; any case), as
/// VTK's reader gives them. Throws FileError naming `path` when it is missing, of an unknown kind,
/// or (.vtp) not readable; FileError naming the module when the module cannot be opened.
vtkSmartPointer<vtkPolyData> readPolyDataFile(const std::string& path);

/// Writes `polyData` as .vtp (XML, binary, zlib) or .stl (binary) to a temporary name beside
/// `path`, renamed onto it at the end. Throws FileError naming `path` for another extension or a
/// failed write; FileError naming the module when the module cannot be opened.
void writePolyDataFile(const std::string& path, vtkPolyData* polyData);

/// const char* echoreg_mesh_io_abi(): the module's meshIoAbi().
inline constexpr const char* kMeshIoAbiSymbol = "echoreg_mesh_io_abi";
/// void echoreg_mesh_io_read(const std::string* path, vtkSmartPointer<vtkPolyData>* out,
/// std::exception_ptr* error): readPolyDataFile.
inline constexpr const char* kMeshIoReadSymbol = "echoreg_mesh_io_read";
using MeshIoReadFunction = void (*)(const std::string*, vtkSmartPointer<vtkPolyData>*,
                                    std::exception_ptr*);
/// void echoreg_mesh_io_write(const std::string* path, vtkPolyData* polyData,
/// std::exception_ptr* error): writePolyDataFile.
inline constexpr const char* kMeshIoWriteSymbol = "echoreg_mesh_io_write";
using MeshIoWriteFunction = void (*)(const std::string*, vtkPolyData*, std::exception_ptr*);

/// echoreg's version, the compiler, VTK's version and the size of what crosses.
inline std::string meshIoAbi() {
  return std::string("echoreg ") + ECHOREG_VERSION + " / " + __VERSION__ + " / VTK " + VTK_VERSION +
         " / vtkSmartPointer " + std::to_string(sizeof(vtkSmartPointer<vtkPolyData>));
}

}  // namespace echoreg::filters::detail
