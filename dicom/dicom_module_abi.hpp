// The interface between the DICOM functions of echoreg::segmentation (readDicomSeries...) and
// echoreg::simulation (writeDicomSeries), which every executable links, and the DICOM module that
// does the work with GDCM (libechoreg_dicom.so, opened with dlopen on the first DICOM file a
// process reads or writes; docs/architecture.md). GDCM builds its dictionaries in static
// constructors when it is loaded (about 50 ms of CPU), which commands that never touch DICOM
// (`detect`, `register`...) no longer pay.
//
// C entry points, so that dlsym finds them by name; C++ types cross by pointer, which holds
// because the module is built from the same sources by the same compiler (checked by dicomAbi()).
// An exception thrown inside the module (FileError, std::invalid_argument, or whatever the
// caller's progress callback threw) crosses as a std::exception_ptr and is rethrown by the caller:
// the same object, so the same type.
#pragma once

#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/simulation/ct.hpp"

#include <fmt/format.h>

#include <exception>
#include <string>
#include <vector>

#ifndef ECHOREG_VERSION
#error "ECHOREG_VERSION must be defined (dicom/CMakeLists.txt)"
#endif

namespace echoreg::dicom {

/// const char* echoreg_dicom_abi(): the module's dicomAbi().
inline constexpr const char* kAbiSymbol = "echoreg_dicom_abi";

/// void echoreg_dicom_list_series(const std::string* folder,
/// std::vector<std::string>* warnings (may be null), std::vector<DicomSeriesSummary>* out,
/// std::exception_ptr* error): segmentation::listDicomSeries.
inline constexpr const char* kListSeriesSymbol = "echoreg_dicom_list_series";
using ListSeriesFunction = void (*)(const std::string*, std::vector<std::string>*,
                                    std::vector<segmentation::DicomSeriesSummary>*,
                                    std::exception_ptr*);

/// void echoreg_dicom_read_series(const std::string* folder, const DicomReadOptions* options,
/// int voxels, DicomSeriesRead* out, std::exception_ptr* error):
/// segmentation::readDicomSeriesWithWarnings (voxels != 0) or readDicomSeriesGeometry.
inline constexpr const char* kReadSeriesSymbol = "echoreg_dicom_read_series";
using ReadSeriesFunction = void (*)(const std::string*, const segmentation::DicomReadOptions*, int,
                                    segmentation::DicomSeriesRead*, std::exception_ptr*);

/// void echoreg_dicom_write_series(const std::string* folder, const core::CtImage* volume,
/// const DicomSeriesInfo* info, std::exception_ptr* error): simulation::writeDicomSeries.
inline constexpr const char* kWriteSeriesSymbol = "echoreg_dicom_write_series";
using WriteSeriesFunction = void (*)(const std::string*, const core::CtImage*,
                                     const simulation::DicomSeriesInfo*, std::exception_ptr*);

/// The version, the compiler and the layout of the types that cross; the module and the
/// executable must agree on it.
inline std::string dicomAbi() {
  return fmt::format(
      "echoreg {} / {} / DicomSeriesSummary {} DicomReadOptions {} DicomSeriesRead {} CtImage {} "
      "DicomSeriesInfo {}",
      ECHOREG_VERSION, __VERSION__, sizeof(segmentation::DicomSeriesSummary),
      sizeof(segmentation::DicomReadOptions), sizeof(segmentation::DicomSeriesRead),
      sizeof(core::CtImage), sizeof(simulation::DicomSeriesInfo));
}

}  // namespace echoreg::dicom
