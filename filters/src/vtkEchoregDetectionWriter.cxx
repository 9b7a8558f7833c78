#include "echoreg/filters/vtkEchoregDetectionWriter.h"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/filters/detection_table.h"

#include <vtkErrorCode.h>
#include <vtkInformation.h>
#include <vtkObjectFactory.h>
#include <vtkTable.h>

#include <fmt/format.h>

#include <exception>
#include <optional>
#include <ostream>

vtkStandardNewMacro(vtkEchoregDetectionWriter);

namespace {

std::string optionalNumber(const std::optional<double>& value, int decimals) {
  return value ? fmt::format("{:.{}f}", *value, decimals) : std::string();
}

void writeRows(const echoreg::core::SequenceDetection& detection, bool withPoints,
               std::ostream& csv) {
  csv << "frame,timestamp_s,status,reason,peaks,sample_index,depth_mm";
  if (withPoints)
    csv << ",x_mm,y_mm,z_mm";
  csv << "\n";
  for (const echoreg::core::FrameDetection& f : detection.frames) {
    csv << f.frame << ',' << (f.timestampS ? fmt::format("{}", *f.timestampS) : std::string())
        << ',' << (f.accepted() ? "accepted" : "rejected") << ','
        << echoreg::core::rejectReasonName(f.reason) << ',' << f.peakCount << ','
        << optionalNumber(f.sampleIndex, 3) << ',' << optionalNumber(f.depthMm, 4);
    if (withPoints) {
      if (f.pointMm) {
        csv << fmt::format(",{:.4f},{:.4f},{:.4f}", f.pointMm->x(), f.pointMm->y(), f.pointMm->z());
      } else {
        csv << ",,,";
      }
    }
    csv << "\n";
  }
}

}  // namespace

vtkEchoregDetectionWriter::vtkEchoregDetectionWriter() = default;

vtkEchoregDetectionWriter::~vtkEchoregDetectionWriter() = default;

void vtkEchoregDetectionWriter::SetFileName(const std::string& fileName) {
  if (this->FileName == fileName)
    return;
  this->FileName = fileName;
  this->Modified();
}

void vtkEchoregDetectionWriter::Fail(const std::string& message) {
  this->LastError = message;
  this->SetErrorCode(vtkErrorCode::UserError);
  vtkErrorMacro(<< message);
}

int vtkEchoregDetectionWriter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkTable");
  return 1;
}

void vtkEchoregDetectionWriter::WriteData() {
  ++this->ExecutionCount;
  this->SetErrorCode(vtkErrorCode::NoError);
  if (this->FileName.empty()) {
    this->Fail("no file name set");
    return;
  }
  vtkTable* table = vtkTable::SafeDownCast(this->GetInput());
  try {
    const echoreg::core::SequenceDetection detection = echoreg::filters::sequenceDetectionOf(table);
    echoreg::core::AtomicFile file(this->FileName);
    writeRows(detection, echoreg::filters::hasTrackedPoints(table), file.stream());
    file.commit();
  } catch (const std::exception& exception) {
    this->Fail(exception.what());
    return;
  }
  this->LastError.clear();
}

void vtkEchoregDetectionWriter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName.empty() ? "(none)" : this->FileName) << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
