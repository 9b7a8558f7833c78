// The CT series writer as every executable sees it: the work is done with GDCM inside the DICOM
// module (dicom/module/write_series.cpp), opened on the first call (dicom/dicom_module_abi.hpp).
#include "dicom_module_call.hpp"
#include "echoreg/simulation/ct.hpp"

#include <exception>
#include <string>

namespace echoreg::simulation {

void writeDicomSeries(const std::string& folder, const core::CtImage& volume,
                      const DicomSeriesInfo& info) {
  const auto write = dicom::dicomFunction<dicom::WriteSeriesFunction>(dicom::kWriteSeriesSymbol);
  std::exception_ptr error;
  write(&folder, &volume, &info, &error);
  dicom::rethrowFromModule(error);
}

}  // namespace echoreg::simulation
