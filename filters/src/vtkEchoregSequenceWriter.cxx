#include "echoreg/filters/vtkEchoregSequenceWriter.h"

#include "echoreg/core/sequence.hpp"
#include "echoreg/filters/sequence_field_data.h"

#include <vtkDataArray.h>
#include <vtkErrorCode.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>

#include <cstring>
#include <exception>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregSequenceWriter);

namespace {

echoreg::core::ElementType elementTypeOf(int vtkType) {
  switch (vtkType) {
    case VTK_UNSIGNED_CHAR:
      return echoreg::core::ElementType::UInt8;
    case VTK_SIGNED_CHAR:
    case VTK_CHAR:
      return echoreg::core::ElementType::Int8;
    case VTK_SHORT:
      return echoreg::core::ElementType::Int16;
    case VTK_UNSIGNED_SHORT:
      return echoreg::core::ElementType::UInt16;
    case VTK_FLOAT:
      return echoreg::core::ElementType::Float32;
    default:
      return echoreg::core::ElementType::None;
  }
}

// The Sequence the image and its field data describe; throws std::invalid_argument when they
// cannot be one.
echoreg::core::Sequence sequenceOf(vtkImageData* image) {
  echoreg::core::Sequence sequence;
  const echoreg::filters::SequenceFieldData fieldData(image->GetFieldData());
  int dimensions[3];
  image->GetDimensions(dimensions);
  const bool hasSamples = dimensions[0] > 0 && dimensions[1] > 0;
  sequence.frames = fieldData.frames();
  sequence.acquisition = fieldData.acquisition();
  if (!hasSamples) {
    // A tracker-only capture: frames come from the field data alone.
    return sequence;
  }
  if (dimensions[2] != 1)
    throw std::invalid_argument("the image has " + std::to_string(dimensions[2]) +
                                " slices; a sequence of A-lines is one (x sample, y frame)");
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  if (scalars == nullptr || scalars->GetNumberOfComponents() != 1)
    throw std::invalid_argument("the image needs one-component point scalars (the A-lines)");
  sequence.elementType = elementTypeOf(scalars->GetDataType());
  if (sequence.elementType == echoreg::core::ElementType::None)
    throw std::invalid_argument(std::string("PLUS sequences hold uint8, int8, int16, uint16 or "
                                            "float samples, not ") +
                                scalars->GetDataTypeAsString());
  const auto frames = static_cast<std::size_t>(dimensions[1]);
  if (sequence.frames.empty()) {
    sequence.frames.resize(frames);
  } else if (sequence.frames.size() != frames) {
    throw std::invalid_argument("the field data describes " +
                                std::to_string(sequence.frames.size()) +
                                " frames and the image holds " + std::to_string(frames));
  }
  sequence.frameSize = {dimensions[0], 1};
  const std::size_t bytes = frames * static_cast<std::size_t>(dimensions[0]) *
                            static_cast<std::size_t>(scalars->GetDataTypeSize());
  sequence.pixels.resize(bytes);
  std::memcpy(sequence.pixels.data(), scalars->GetVoidPointer(0), bytes);
  return sequence;
}

}  // namespace

vtkEchoregSequenceWriter::vtkEchoregSequenceWriter() = default;

vtkEchoregSequenceWriter::~vtkEchoregSequenceWriter() = default;

void vtkEchoregSequenceWriter::SetFileName(const std::string& fileName) {
  if (this->FileName == fileName)
    return;
  this->FileName = fileName;
  this->Modified();
}

void vtkEchoregSequenceWriter::SetCompress(bool compress) {
  if (this->Compress == compress)
    return;
  this->Compress = compress;
  this->Modified();
}

void vtkEchoregSequenceWriter::Fail(const std::string& message) {
  this->LastError = message;
  this->SetErrorCode(vtkErrorCode::UserError);
  vtkErrorMacro(<< message);
}

int vtkEchoregSequenceWriter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

void vtkEchoregSequenceWriter::WriteData() {
  ++this->ExecutionCount;
  this->SetErrorCode(vtkErrorCode::NoError);
  if (this->FileName.empty()) {
    this->Fail("no file name set");
    return;
  }
  auto* image = vtkImageData::SafeDownCast(this->GetInput());
  if (image == nullptr) {
    this->Fail("the input is not a vtkImageData");
    return;
  }
  try {
    echoreg::core::SequenceWriteOptions options;
    options.compress = this->Compress;
    echoreg::core::Sequence sequence;
    try {
      sequence = sequenceOf(image);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(this->FileName + ": " + e.what());
    }
    echoreg::core::writeSequence(sequence, this->FileName, options);
  } catch (const std::exception& exception) {
    this->Fail(exception.what());
    return;
  }
  this->LastError.clear();
}

void vtkEchoregSequenceWriter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << (this->FileName.empty() ? "(none)" : this->FileName) << "\n";
  os << indent << "Compress: " << (this->Compress ? "On" : "Off") << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
