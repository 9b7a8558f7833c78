// readPolyDataFile and writePolyDataFile as every executable sees them: through the mesh I/O
// module beside the executable (mesh_files.hpp), opened on the first call.
#include "echoreg/core/loadable_module.hpp"
#include "mesh_files.hpp"

#include <exception>
#include <string>

#ifndef ECHOREG_MESH_IO_MODULE_FILE_NAME
#error "ECHOREG_MESH_IO_MODULE_FILE_NAME must be defined (filters/CMakeLists.txt)"
#endif

namespace echoreg::filters::detail {

namespace {

template <typename Function>
Function meshIoFunction(const char* symbol) {
  const core::ModuleIdentity identity{"mesh I/O module", "echoreg_mesh_io",
                                      "reads and writes mesh files", kMeshIoAbiSymbol, meshIoAbi()};
  return core::moduleFunction<Function>(ECHOREG_MESH_IO_MODULE_FILE_NAME, identity, symbol);
}

}  // namespace

vtkSmartPointer<vtkPolyData> readPolyDataFile(const std::string& path) {
  const auto read = meshIoFunction<MeshIoReadFunction>(kMeshIoReadSymbol);
  vtkSmartPointer<vtkPolyData> polyData;
  std::exception_ptr error;
  read(&path, &polyData, &error);
  if (error)
    std::rethrow_exception(error);
  return polyData;
}

void writePolyDataFile(const std::string& path, vtkPolyData* polyData) {
  const auto write = meshIoFunction<MeshIoWriteFunction>(kMeshIoWriteSymbol);
  std::exception_ptr error;
  write(&path, polyData, &error);
  if (error)
    std::rethrow_exception(error);
}

}  // namespace echoreg::filters::detail
