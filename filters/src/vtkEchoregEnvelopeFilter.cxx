#include "echoreg/filters/vtkEchoregEnvelopeFilter.h"

#include "echoreg/core/prefault.hpp"
#include "pipeline_requests.h"

#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <exception>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

vtkStandardNewMacro(vtkEchoregEnvelopeFilter);

namespace {

echoreg::core::EnvelopeMethod methodOf(int method) {
  switch (method) {
    case vtkEchoregEnvelopeFilter::METHOD_MOZES:
      return echoreg::core::EnvelopeMethod::Mozes;
    case vtkEchoregEnvelopeFilter::METHOD_STDDEV:
      return echoreg::core::EnvelopeMethod::StdDev;
    case vtkEchoregEnvelopeFilter::METHOD_HILBERT:
      return echoreg::core::EnvelopeMethod::Hilbert;
    default:
      return echoreg::core::EnvelopeMethod::Hann;
  }
}

int methodId(echoreg::core::EnvelopeMethod method) {
  switch (method) {
    case echoreg::core::EnvelopeMethod::Mozes:
      return vtkEchoregEnvelopeFilter::METHOD_MOZES;
    case echoreg::core::EnvelopeMethod::Hann:
      return vtkEchoregEnvelopeFilter::METHOD_HANN;
    case echoreg::core::EnvelopeMethod::StdDev:
      return vtkEchoregEnvelopeFilter::METHOD_STDDEV;
    case echoreg::core::EnvelopeMethod::Hilbert:
      return vtkEchoregEnvelopeFilter::METHOD_HILBERT;
  }
  return vtkEchoregEnvelopeFilter::METHOD_HANN;
}

// Envelopes of rows [begin, end) of a row-major image of samples of type T; one detector per
// chunk, since a detector keeps scratch buffers. Rows of another type than float are converted
// one at a time into the chunk's buffer (the whole image is never copied as floats). The first
// failure of any chunk is kept for the caller.
template <typename T>
class EnvelopeRows {
 public:
  EnvelopeRows(const echoreg::core::EnvelopeParams& params, const T* samples, float* envelopes,
               int samplesPerRow)
      : params_(params), samples_(samples), envelopes_(envelopes), samplesPerRow_(samplesPerRow) {}

  void operator()(vtkIdType beginRow, vtkIdType endRow) {
    try {
      echoreg::core::EnvelopeDetector detector(params_);
      std::vector<float> row;
      for (vtkIdType index = beginRow; index < endRow; ++index) {
        const vtkIdType offset = index * samplesPerRow_;
        const float* record = nullptr;
        if constexpr (std::is_same_v<T, float>) {
          record = samples_ + offset;
        } else {
          row.resize(static_cast<std::size_t>(samplesPerRow_));
          std::transform(samples_ + offset, samples_ + offset + samplesPerRow_, row.begin(),
                         [](T value) { return static_cast<float>(value); });
          record = row.data();
        }
        detector.compute(record, samplesPerRow_, envelopes_ + offset);
      }
    } catch (const std::exception& exception) {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (error_.empty())
        error_ = exception.what();
    }
  }

  const std::string& error() const { return error_; }

 private:
  const echoreg::core::EnvelopeParams& params_;
  const T* samples_;
  float* envelopes_;
  int samplesPerRow_;
  std::mutex mutex_;
  std::string error_;
};

// Runs EnvelopeRows over `rows` rows of `scalars` from `firstRow` on, in twenty slices of rows so
// that `filter` reports its progress between them (from this thread: VTK's events are not
// thread-safe); the error message of a failure, else "".
template <typename T>
std::string envelopesOf(const echoreg::core::EnvelopeParams& params, vtkDataArray* scalars,
                        vtkIdType firstRow, float* envelopes, int samplesPerRow, vtkIdType rows,
                        vtkAlgorithm* filter) {
  EnvelopeRows<T> work(params,
                       static_cast<const T*>(scalars->GetVoidPointer(firstRow * samplesPerRow)),
                       envelopes, samplesPerRow);
  const vtkIdType slice = std::max<vtkIdType>(256, (rows + 19) / 20);
  for (vtkIdType begin = 0; begin < rows && work.error().empty(); begin += slice) {
    const vtkIdType end = std::min(rows, begin + slice);
    vtkSMPTools::For(begin, end, work);
    filter->UpdateProgress(static_cast<double>(end) / static_cast<double>(rows));
  }
  return work.error();
}

}  // namespace

vtkEchoregEnvelopeFilter::vtkEchoregEnvelopeFilter() = default;

vtkEchoregEnvelopeFilter::~vtkEchoregEnvelopeFilter() = default;

void vtkEchoregEnvelopeFilter::SetParams(const echoreg::core::EnvelopeParams& params) {
  if (this->Params == params)
    return;
  this->Params = params;
  this->Modified();
}

void vtkEchoregEnvelopeFilter::SetMethod(int method) {
  this->SetField(this->Params.method, methodOf(std::clamp(method, static_cast<int>(METHOD_MOZES),
                                                          static_cast<int>(METHOD_HILBERT))));
}

int vtkEchoregEnvelopeFilter::GetMethod() const {
  return methodId(this->Params.method);
}

const char* vtkEchoregEnvelopeFilter::GetMethodAsString() const {
  switch (this->Params.method) {
    case echoreg::core::EnvelopeMethod::Mozes:
      return "mozes";
    case echoreg::core::EnvelopeMethod::Hann:
      return "hann";
    case echoreg::core::EnvelopeMethod::StdDev:
      return "stddev";
    case echoreg::core::EnvelopeMethod::Hilbert:
      return "hilbert";
  }
  return "hann";
}

void vtkEchoregEnvelopeFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregEnvelopeFilter::RequestInformation(vtkInformation* /*request*/,
                                                 vtkInformationVector** /*inputVector*/,
                                                 vtkInformationVector* outputVector) {
  vtkDataObject::SetPointDataActiveScalarInfo(outputVector->GetInformationObject(0), VTK_FLOAT, 1);
  return 1;
}

int vtkEchoregEnvelopeFilter::RequestUpdateExtent(vtkInformation* /*request*/,
                                                  vtkInformationVector** inputVector,
                                                  vtkInformationVector* outputVector) {
  // Whole records, and the frames asked of the output (all of them unless a downstream filter
  // streams the capture in blocks of frames).
  echoreg::filters::requestWholeRecords(inputVector, outputVector);
  return 1;
}

int vtkEchoregEnvelopeFilter::RequestData(vtkInformation* /*request*/,
                                          vtkInformationVector** inputVector,
                                          vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkImageData* output = vtkImageData::GetData(outputVector);
  if (input == nullptr || output == nullptr) {
    this->Fail("the input and the output must be vtkImageData");
    return 0;
  }

  int dimensions[3];
  input->GetDimensions(dimensions);
  // The output holds the frames asked of it; the input may hold more (a source that ignores the
  // update extent).
  int extent[6];
  input->GetExtent(extent);
  const int inputFirstFrame = extent[2];
  echoreg::filters::clampToRequestedFrames(outputVector, extent);
  output->SetExtent(extent);
  output->SetOrigin(input->GetOrigin());
  output->SetSpacing(input->GetSpacing());
  output->SetDirectionMatrix(input->GetDirectionMatrix());
  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  if (dimensions[0] <= 0 || dimensions[1] <= 0) {
    vtkWarningMacro(<< "the input has no samples; passing its field data through");
    this->LastError.clear();
    return 1;
  }
  if (dimensions[2] != 1) {
    this->Fail("the input must be one slice of A-lines (x = sample, y = frame), got " +
               std::to_string(dimensions[2]) + " slices");
    return 0;
  }
  vtkDataArray* scalars = input->GetPointData()->GetScalars();
  if (scalars == nullptr || scalars->GetNumberOfComponents() != 1) {
    this->Fail("the input needs one-component point scalars (the A-lines)");
    return 0;
  }
  try {
    echoreg::core::validate(this->Params);
  } catch (const std::exception& exception) {
    this->Fail(std::string("invalid envelope parameters: ") + exception.what());
    return 0;
  }

  const vtkIdType rows = extent[3] - extent[2] + 1;
  const vtkIdType firstRow = extent[2] - inputFirstFrame;
  // The previous run's array when nothing but this filter holds it once the output lets it go
  // (every value is written below): streaming a capture first-touches the pages of one block,
  // not of every block. A consumer that kept the previous block's array keeps it unchanged.
  output->GetPointData()->Initialize();
  if (this->Envelopes == nullptr || this->Envelopes->GetReferenceCount() != 1) {
    this->Envelopes = vtkSmartPointer<vtkFloatArray>::New();
    this->Envelopes->SetName("Envelope");
  }
  vtkFloatArray* envelopes = this->Envelopes;
  const float* reused = envelopes->GetNumberOfValues() > 0 ? envelopes->GetPointer(0) : nullptr;
  envelopes->SetNumberOfValues(rows * dimensions[0]);
  if (envelopes->GetPointer(0) != reused) {
    echoreg::core::prefaultForWriting(
        envelopes->GetPointer(0), static_cast<std::size_t>(rows * dimensions[0]) * sizeof(float));
  }
  envelopes->Modified();

  std::string error;
  switch (scalars->GetDataType()) {
    vtkTemplateMacro(error =
                         envelopesOf<VTK_TT>(this->Params, scalars, firstRow,
                                             envelopes->GetPointer(0), dimensions[0], rows, this));
    default:
      error = std::string("unsupported scalar type ") + scalars->GetDataTypeAsString();
  }
  if (!error.empty()) {
    this->Fail("envelope failed: " + error);
    output->Initialize();
    return 0;
  }
  output->GetPointData()->SetScalars(envelopes);
  this->FramesComputed += rows;
  this->LastError.clear();
  return 1;
}

void vtkEchoregEnvelopeFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Method: " << this->GetMethodAsString() << "\n";
  os << indent << "RingDownSamples: " << this->Params.ringDownSamples << "\n";
  os << indent << "ButterworthOrder: " << this->Params.butterworthOrder << "\n";
  os << indent << "CutoffNormalized: " << this->Params.cutoffNormalized << "\n";
  os << indent << "ZeroPhase: " << (this->Params.zeroPhase ? "On" : "Off") << "\n";
  os << indent << "WindowSamples: " << this->Params.windowSamples << "\n";
  os << indent << "TransducerFrequencyHz: " << this->Params.transducerFrequencyHz << "\n";
  os << indent << "RelativeBandwidth: " << this->Params.relativeBandwidth << "\n";
  os << indent << "SamplingFrequencyHz: " << this->Params.samplingFrequencyHz << "\n";
  os << indent << "SmoothingSamples: " << this->Params.smoothingSamples << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
  os << indent << "FramesComputed: " << this->FramesComputed << "\n";
}
