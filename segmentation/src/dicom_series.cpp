// The DICOM series reader as every executable sees it: the work is done with GDCM inside the DICOM
// module (dicom/module/read_series.cpp), opened on the first call (dicom/dicom_module_abi.hpp).
#include "echoreg/segmentation/dicom_series.hpp"

#include "dicom_module_call.hpp"

#include <exception>
#include <string>
#include <vector>

namespace echoreg::segmentation {

namespace {

DicomSeriesRead readThroughModule(const std::string& folder, const DicomReadOptions& options,
                                  bool voxels) {
  const auto read = dicom::dicomFunction<dicom::ReadSeriesFunction>(dicom::kReadSeriesSymbol);
  DicomSeriesRead result;
  std::exception_ptr error;
  read(&folder, &options, voxels ? 1 : 0, &result, &error);
  dicom::rethrowFromModule(error);
  return result;
}

}  // namespace

std::vector<DicomSeriesSummary> listDicomSeries(const std::string& folder,
                                                std::vector<std::string>* warnings) {
  const auto list = dicom::dicomFunction<dicom::ListSeriesFunction>(dicom::kListSeriesSymbol);
  std::vector<DicomSeriesSummary> series;
  std::exception_ptr error;
  list(&folder, warnings, &series, &error);
  dicom::rethrowFromModule(error);
  return series;
}

DicomSeriesRead readDicomSeriesGeometry(const std::string& folder,
                                        const DicomReadOptions& options) {
  return readThroughModule(folder, options, false);
}

DicomSeriesRead readDicomSeriesWithWarnings(const std::string& folder,
                                            const DicomReadOptions& options) {
  return readThroughModule(folder, options, true);
}

core::CtImage readDicomSeries(const std::string& folder, const DicomReadOptions& options) {
  return readDicomSeriesWithWarnings(folder, options).image;
}

}  // namespace echoreg::segmentation
