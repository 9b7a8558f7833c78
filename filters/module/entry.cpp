// The mesh I/O module's entry points (filters/src/mesh_files.hpp): every exception is caught and
// handed back as a std::exception_ptr, which the caller rethrows.
#include "mesh_files.hpp"

#include <exception>
#include <string>

extern "C" {

__attribute__((visibility("default"))) const char* echoreg_mesh_io_abi() {
  static const std::string abi = echoreg::filters::detail::meshIoAbi();
  return abi.c_str();
}

__attribute__((visibility("default"))) void echoreg_mesh_io_read(const std::string* path,
                                                                 vtkSmartPointer<vtkPolyData>* out,
                                                                 std::exception_ptr* error) {
  try {
    *out = echoreg::filters::detail::readPolyDataFile(*path);
  } catch (...) {
    *error = std::current_exception();
  }
}

__attribute__((visibility("default"))) void echoreg_mesh_io_write(const std::string* path,
                                                                  vtkPolyData* polyData,
                                                                  std::exception_ptr* error) {
  try {
    echoreg::filters::detail::writePolyDataFile(*path, polyData);
  } catch (...) {
    *error = std::current_exception();
  }
}

}  // extern "C"
