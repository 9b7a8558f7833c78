// How echoreg::segmentation and echoreg::simulation call into the DICOM module
// (dicom_module_abi.hpp): its entry points by name, from the module beside the executable.
#pragma once

#include "dicom_module_abi.hpp"
#include "echoreg/core/loadable_module.hpp"

#include <exception>

#ifndef ECHOREG_DICOM_MODULE_FILE_NAME
#error "ECHOREG_DICOM_MODULE_FILE_NAME must be defined (dicom/CMakeLists.txt)"
#endif

namespace echoreg::dicom {

/// EXE_DIR/../lib/echoreg/libechoreg_dicom.so (core::moduleBesideExecutable).
inline std::filesystem::path dicomModulePath() {
  return core::moduleBesideExecutable(ECHOREG_DICOM_MODULE_FILE_NAME);
}

/// The entry point `symbol` of the DICOM module at `modulePath`, opened on the first call of the
/// process. Throws FileError naming the module's path when it is missing, not the module, or the
/// module of another build.
template <typename Function>
Function dicomFunction(const char* symbol,
                       const std::filesystem::path& modulePath = dicomModulePath()) {
  const core::ModuleIdentity identity{"DICOM module", "echoreg_dicom", "reads and writes DICOM",
                                      kAbiSymbol, dicomAbi()};
  return reinterpret_cast<Function>(core::moduleSymbol(modulePath, identity, symbol));
}

/// Rethrows what the module caught, if anything.
using core::rethrowFromModule;

}  // namespace echoreg::dicom
