#include "echoreg/filters/vtkEchoregSequenceReader.h"

#include "pipeline_requests.h"

#include "echoreg/core/error.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/sequence_field_data.h"

#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <system_error>

vtkStandardNewMacro(vtkEchoregSequenceReader);

namespace {

int vtkScalarType(echoreg::core::ElementType type) {
  switch (type) {
    case echoreg::core::ElementType::UInt8:
      return VTK_UNSIGNED_CHAR;
    case echoreg::core::ElementType::Int8:
      return VTK_SIGNED_CHAR;
    case echoreg::core::ElementType::Int16:
      return VTK_SHORT;
    case echoreg::core::ElementType::UInt16:
      return VTK_UNSIGNED_SHORT;
    case echoreg::core::ElementType::Float32:
      return VTK_FLOAT;
    case echoreg::core::ElementType::None:
      break;
  }
  return VTK_VOID;
}

// Extent of the output image: samples along x, frames along y; no samples gives an empty x range.
void sequenceExtent(const echoreg::core::Sequence& sequence, int extent[6]) {
  const int samples = sequence.hasPixels() ? sequence.frameSize[0] : 0;
  const int frames = static_cast<int>(sequence.frameCount());
  extent[0] = 0;
  extent[1] = samples - 1;
  extent[2] = 0;
  extent[3] = frames - 1;
  extent[4] = 0;
  extent[5] = 0;
}

}  // namespace

vtkEchoregSequenceReader::vtkEchoregSequenceReader() {
  this->SetNumberOfInputPorts(0);
}

vtkEchoregSequenceReader::~vtkEchoregSequenceReader() = default;

void vtkEchoregSequenceReader::SetFileName(const std::string& fileName) {
  if (this->FileName == fileName)
    return;
  this->FileName = fileName;
  this->Modified();
}

void vtkEchoregSequenceReader::SetRigidPoseTransforms(const std::vector<std::string>& names) {
  if (this->RigidPoseTransforms == names)
    return;
  this->RigidPoseTransforms = names;
  this->Modified();
}

void vtkEchoregSequenceReader::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

bool vtkEchoregSequenceReader::ReadIfNeeded() {
  if (this->FileName.empty()) {
    this->CacheValid = false;
    this->Fail("no file name set");
    return false;
  }
  std::error_code error;
  const std::filesystem::path path(this->FileName);
  const auto fileTime = std::filesystem::last_write_time(path, error);
  const bool haveTime = !error;
  const std::uintmax_t fileSize =
      std::filesystem::is_regular_file(path, error) ? std::filesystem::file_size(path, error) : 0;
  if (this->CacheValid && haveTime && this->CachedFileName == this->FileName &&
      this->CachedFileTime == fileTime && this->CachedFileSize == fileSize &&
      this->CacheTime.GetMTime() > this->GetMTime()) {
    return true;
  }

  this->CacheValid = false;
  this->Sequence = echoreg::core::Sequence();
  this->RigidPoseReports.clear();
  try {
    ++this->ReadCount;
    echoreg::core::Sequence sequence = echoreg::core::readSequence(this->FileName);
    try {
      // The core's words, so that every command refuses such a capture in the same sentence.
      echoreg::core::requireSingleALineFrames(sequence);
    } catch (const std::invalid_argument& e) {
      throw echoreg::core::FileError(this->FileName, e.what());
    }
    if (sequence.hasPixels() && vtkScalarType(sequence.elementType) == VTK_VOID) {
      throw echoreg::core::FileError(this->FileName, "unsupported element type");
    }
    const std::vector<std::string> held = sequence.transformNames();
    for (const std::string& name : this->RigidPoseTransforms) {
      if (name.empty() || std::find(held.begin(), held.end(), name) == held.end())
        continue;
      this->RigidPoseReports.emplace_back(
          name, echoreg::core::enforceRigidPoses(sequence, this->FileName, name));
    }
    this->Sequence = std::move(sequence);
  } catch (const std::exception& exception) {
    this->Fail(exception.what());
    return false;
  }
  this->CacheValid = true;
  this->CachedFileName = this->FileName;
  this->CachedFileTime = fileTime;
  this->CachedFileSize = fileSize;
  this->CacheTime.Modified();
  this->LastError.clear();
  return true;
}

int vtkEchoregSequenceReader::RequestInformation(vtkInformation* /*request*/,
                                                 vtkInformationVector** /*inputVector*/,
                                                 vtkInformationVector* outputVector) {
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  if (!this->ReadIfNeeded()) {
    // Leave no stale image behind a failed read.
    if (vtkDataObject* output = outInfo->Get(vtkDataObject::DATA_OBJECT()))
      output->Initialize();
    return 0;
  }

  int extent[6];
  sequenceExtent(this->Sequence, extent);
  const double spacing[3] = {1.0, 1.0, 1.0};
  const double origin[3] = {0.0, 0.0, 0.0};
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
  outInfo->Set(vtkDataObject::ORIGIN(), origin, 3);
  if (this->Sequence.hasPixels()) {
    vtkDataObject::SetPointDataActiveScalarInfo(outInfo, vtkScalarType(this->Sequence.elementType),
                                                1);
  }
  return 1;
}

int vtkEchoregSequenceReader::RequestData(vtkInformation* /*request*/,
                                          vtkInformationVector** /*inputVector*/,
                                          vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  if (output == nullptr) {
    this->Fail("the output is not a vtkImageData");
    return 0;
  }
  if (!this->CacheValid) {
    this->Fail(this->LastError.empty() ? "no sequence read" : this->LastError);
    return 0;
  }

  // The frames asked for (the whole capture unless a downstream filter streams it in blocks);
  // every sample of each.
  int extent[6];
  sequenceExtent(this->Sequence, extent);
  echoreg::filters::clampToRequestedFrames(outputVector, extent);
  output->SetExtent(extent);
  output->SetSpacing(1.0, 1.0, 1.0);
  output->SetOrigin(0.0, 0.0, 0.0);
  if (this->Sequence.hasPixels()) {
    const std::size_t frameBytes =
        this->Sequence.samplesPerFrame() * echoreg::core::elementSize(this->Sequence.elementType);
    const std::size_t bytes = this->Sequence.frameCount() * frameBytes;
    if (bytes != this->Sequence.pixels.size()) {
      this->Fail(this->FileName + ": pixel data holds " +
                 std::to_string(this->Sequence.pixels.size()) + " bytes, expected " +
                 std::to_string(bytes));
      output->Initialize();
      return 0;
    }
    output->AllocateScalars(vtkScalarType(this->Sequence.elementType), 1);
    vtkDataArray* scalars = output->GetPointData()->GetScalars();
    scalars->SetName("ALines");
    const auto frames = static_cast<std::size_t>(extent[3] - extent[2] + 1);
    if (frames * frameBytes > 0) {
      std::memcpy(scalars->GetVoidPointer(0),
                  this->Sequence.pixels.data() + static_cast<std::size_t>(extent[2]) * frameBytes,
                  frames * frameBytes);
    }
  }
  if (this->FieldData == nullptr || this->FieldDataTime < this->CacheTime) {
    this->FieldData = vtkSmartPointer<vtkFieldData>::New();
    echoreg::filters::SequenceFieldData::write(this->Sequence, this->FieldData);
    this->FieldDataTime.Modified();
  }
  output->GetFieldData()->ShallowCopy(this->FieldData);
  return 1;
}

void vtkEchoregSequenceReader::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName.empty() ? "(none)" : this->FileName) << "\n";
  os << indent << "Frames: " << this->Sequence.frameCount() << "\n";
  os << indent << "ElementType: " << echoreg::core::elementTypeName(this->Sequence.elementType)
     << "\n";
  os << indent << "SamplesPerFrame: " << this->Sequence.samplesPerFrame() << "\n";
  os << indent << "RigidPoseTransforms:";
  for (const std::string& name : this->RigidPoseTransforms)
    os << " " << name;
  os << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
  os << indent << "ReadCount: " << this->ReadCount << "\n";
}
