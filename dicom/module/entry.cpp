// The DICOM module's entry points (dicom/dicom_module_abi.hpp): every exception is caught and
// handed back as a std::exception_ptr, which the caller rethrows.
#include "dicom_module_abi.hpp"

#include "echoreg/core/loadable_module.hpp"

#include <exception>
#include <string>
#include <vector>

extern "C" {

__attribute__((visibility("default"))) const char* echoreg_dicom_abi() {
  static const std::string abi = echoreg::dicom::dicomAbi();
  return abi.c_str();
}

__attribute__((visibility("default"))) void echoreg_dicom_list_series(
    const std::string* folder, std::vector<std::string>* warnings,
    std::vector<echoreg::segmentation::DicomSeriesSummary>* out, std::exception_ptr* error) {
  echoreg::core::captureException(
      error, [&] { *out = echoreg::segmentation::listDicomSeries(*folder, warnings); });
}

__attribute__((visibility("default"))) void echoreg_dicom_read_series(
    const std::string* folder, const echoreg::segmentation::DicomReadOptions* options, int voxels,
    echoreg::segmentation::DicomSeriesRead* out, std::exception_ptr* error) {
  echoreg::core::captureException(error, [&] {
    *out = voxels != 0 ? echoreg::segmentation::readDicomSeriesWithWarnings(*folder, *options)
                       : echoreg::segmentation::readDicomSeriesGeometry(*folder, *options);
  });
}

__attribute__((visibility("default"))) void echoreg_dicom_write_series(
    const std::string* folder, const echoreg::core::CtImage* volume,
    const echoreg::simulation::DicomSeriesInfo* info, std::exception_ptr* error) {
  echoreg::core::captureException(
      error, [&] { echoreg::simulation::writeDicomSeries(*folder, *volume, *info); });
}

}  // extern "C"
