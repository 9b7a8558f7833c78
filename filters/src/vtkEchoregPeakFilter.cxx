#include "echoreg/filters/vtkEchoregPeakFilter.h"

#include "echoreg/core/detection.hpp"
#include "echoreg/filters/sequence_field_data.h"

#include <vtkAlgorithmOutput.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <vector>

vtkStandardNewMacro(vtkEchoregPeakFilter);

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

template <typename Array>
vtkSmartPointer<Array> column(const char* name, vtkIdType rows) {
  auto array = vtkSmartPointer<Array>::New();
  array->SetName(name);
  array->SetNumberOfValues(rows);
  return array;
}

}  // namespace

vtkEchoregPeakFilter::vtkEchoregPeakFilter() : WindowMinMm(kNaN), WindowMaxMm(kNaN) {
  this->SetNumberOfOutputPorts(2);  // 0: the verdicts, 1: the peak list (PeakList)
}

vtkEchoregPeakFilter::~vtkEchoregPeakFilter() = default;

void vtkEchoregPeakFilter::SetPeakParams(const echoreg::core::PeakParams& params) {
  if (this->PeakParams == params)
    return;
  this->PeakParams = params;
  this->Modified();
}

void vtkEchoregPeakFilter::SetDetectionParams(const echoreg::core::DetectionParams& params) {
  const double windowMin = params.windowMinMm.value_or(kNaN);
  const double windowMax = params.windowMaxMm.value_or(kNaN);
  const auto sameLimit = [](double a, double b) { return std::isnan(a) ? std::isnan(b) : a == b; };
  if (this->PeakParams == params.peaks && this->Depth == params.depth &&
      this->Envelope == params.envelope &&
      this->TransducerFrequencyHz == params.transducerFrequencyHz &&
      sameLimit(this->WindowMinMm, windowMin) && sameLimit(this->WindowMaxMm, windowMax)) {
    return;
  }
  this->PeakParams = params.peaks;
  this->Depth = params.depth;
  this->Envelope = params.envelope;
  this->TransducerFrequencyHz = params.transducerFrequencyHz;
  this->WindowMinMm = windowMin;
  this->WindowMaxMm = windowMax;
  this->Modified();
}

echoreg::core::DetectionParams vtkEchoregPeakFilter::GetDetectionParams() const {
  echoreg::core::DetectionParams detection;
  detection.peaks = this->PeakParams;
  detection.depth = this->Depth;
  detection.envelope = this->Envelope;
  detection.transducerFrequencyHz = this->TransducerFrequencyHz;
  if (!std::isnan(this->WindowMinMm))
    detection.windowMinMm = this->WindowMinMm;
  if (!std::isnan(this->WindowMaxMm))
    detection.windowMaxMm = this->WindowMaxMm;
  return detection;
}

void vtkEchoregPeakFilter::SetDepthConversion(const echoreg::core::DepthConversion& conversion) {
  if (this->Depth == conversion)
    return;
  this->Depth = conversion;
  this->Modified();
}

void vtkEchoregPeakFilter::SetWindowLimit(double& limit, double depthMm) {
  // NaN means "no limit"; NaN != NaN, so compare the states, not the values.
  const bool unchanged = std::isnan(limit) ? std::isnan(depthMm) : limit == depthMm;
  if (unchanged)
    return;
  limit = depthMm;
  this->Modified();
}

void vtkEchoregPeakFilter::SetWindowMinMm(double depthMm) {
  this->SetWindowLimit(this->WindowMinMm, depthMm);
}

void vtkEchoregPeakFilter::SetWindowMaxMm(double depthMm) {
  this->SetWindowLimit(this->WindowMaxMm, depthMm);
}

void vtkEchoregPeakFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregPeakFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

namespace {

// Frames [first, last] of the input, as its whole extent gives them.
struct FrameRange {
  int first = 0;
  int last = -1;
  vtkIdType count() const { return last - first + 1; }
};

FrameRange wholeFrames(vtkInformation* inInfo) {
  int extent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  return {extent[2], extent[3]};
}

// The blocks of at most `framesPerBlock` frames the capture is streamed in; the whole capture as
// one block when framesPerBlock is 0 or the capture is not longer.
std::vector<FrameRange> blocksOf(const FrameRange& whole, int framesPerBlock) {
  if (framesPerBlock <= 0 || whole.count() <= framesPerBlock)
    return {whole};
  std::vector<FrameRange> blocks;
  for (int first = whole.first; first <= whole.last; first += framesPerBlock)
    blocks.push_back({first, std::min(whole.last, first + framesPerBlock - 1)});
  return blocks;
}

}  // namespace

int vtkEchoregPeakFilter::RequestUpdateExtent(vtkInformation* /*request*/,
                                              vtkInformationVector** inputVector,
                                              vtkInformationVector* /*outputVector*/) {
  // Whole records of the first block of frames (every frame unless the capture is streamed);
  // RequestData asks for the other blocks itself.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int extent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  const FrameRange first = blocksOf(wholeFrames(inInfo), this->FramesPerBlock).front();
  if (first.first <= first.last) {
    extent[2] = first.first;
    extent[3] = first.last;
  }
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), extent, 6);
  return 1;
}

int vtkEchoregPeakFilter::RequestData(vtkInformation* /*request*/,
                                      vtkInformationVector** inputVector,
                                      vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkTable* output = vtkTable::GetData(outputVector, 0);
  vtkTable* peakList = vtkTable::GetData(outputVector, 1);
  if (input == nullptr || output == nullptr || peakList == nullptr) {
    this->Fail("the input must be a vtkImageData and the output a vtkTable");
    return 0;
  }

  const echoreg::core::DetectionParams detection = this->GetDetectionParams();
  echoreg::core::PeakParams peakParams;
  try {
    echoreg::core::validate(detection);
    peakParams = echoreg::core::resolvePeakParams(detection);
  } catch (const std::exception& exception) {
    this->Fail(std::string("invalid peak parameters: ") + exception.what());
    return 0;
  }

  int dimensions[3];
  input->GetDimensions(dimensions);
  const bool empty = dimensions[0] <= 0 || dimensions[1] <= 0;
  if (empty)
    vtkWarningMacro(<< "the input has no samples; the table has no rows");

  // The table's frames: the whole capture when it is streamed in blocks, else the input's.
  std::vector<FrameRange> blocks = blocksOf(wholeFrames(inInfo), this->FramesPerBlock);
  if (empty) {
    blocks.clear();
  } else if (blocks.size() == 1) {
    blocks = {{input->GetExtent()[2], input->GetExtent()[3]}};
  }
  const int tableFirstFrame = blocks.empty() ? 0 : blocks.front().first;
  const vtkIdType rows = blocks.empty() ? 0 : blocks.back().last - tableFirstFrame + 1;
  const int samplesPerRow = dimensions[0];
  auto frameColumn = column<vtkIntArray>("frame", rows);
  auto timestampColumn = column<vtkDoubleArray>("timestamp_s", rows);
  auto peaksColumn = column<vtkIntArray>("peaks", rows);
  auto sampleColumn = column<vtkDoubleArray>("sample_index", rows);
  auto depthColumn = column<vtkDoubleArray>("depth_mm", rows);
  auto reasonColumn = column<vtkStringArray>("reason", rows);
  auto thresholdColumn = column<vtkDoubleArray>("threshold", rows);
  vtkIdType peakCount = 0;
  auto listFrame = column<vtkIntArray>("frame", 0);
  auto listIndex = column<vtkIntArray>("sample_index", 0);
  auto listValue = column<vtkDoubleArray>("value", 0);
  // Rows are independent; findPeaks keeps no state. Strings are set on one thread afterwards
  // (vtkStringArray::SetValue touches the array's lookup state).
  std::vector<echoreg::core::RejectReason> verdicts(static_cast<std::size_t>(rows));
  std::vector<std::vector<echoreg::core::Peak>> peaksOfFrames(
      this->PeakList ? static_cast<std::size_t>(rows) : 0);
  // The capture's context (EchoContext) judges the rows in frame order once a block's verdicts
  // are in, from each row's whole result (its peaks), while the block's envelopes are held.
  echoreg::core::EchoContext context(peakParams);
  std::vector<echoreg::core::PeakResult> blockResults;
  int fromContext = 0;

  vtkIdType rowsDone = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const FrameRange& block = blocks[b];
    vtkImageData* image = b == 0 ? input : this->UpdateInputFrames(block.first, block.last);
    if (image == nullptr) {
      this->Fail("the envelopes of frames " + std::to_string(block.first) + "-" +
                 std::to_string(block.last) + " could not be computed");
      return 0;
    }
    int extent[6];
    image->GetExtent(extent);
    int blockDimensions[3];
    image->GetDimensions(blockDimensions);
    if (blockDimensions[2] != 1) {
      this->Fail("the input must be one slice of envelopes (x = sample, y = frame), got " +
                 std::to_string(blockDimensions[2]) + " slices");
      return 0;
    }
    vtkDataArray* scalars = image->GetPointData()->GetScalars();
    if (scalars == nullptr || scalars->GetNumberOfComponents() != 1) {
      this->Fail("the input needs one-component point scalars (the envelopes)");
      return 0;
    }
    if (blockDimensions[0] != samplesPerRow || extent[2] > block.first || extent[3] < block.last) {
      this->Fail("the input holds frames " + std::to_string(extent[2]) + "-" +
                 std::to_string(extent[3]) + " of " + std::to_string(blockDimensions[0]) +
                 " samples, not frames " + std::to_string(block.first) + "-" +
                 std::to_string(block.last) + " of " + std::to_string(samplesPerRow));
      return 0;
    }
    vtkSmartPointer<vtkFloatArray> envelopes = vtkFloatArray::SafeDownCast(scalars);
    if (envelopes == nullptr) {
      envelopes = vtkSmartPointer<vtkFloatArray>::New();
      envelopes->DeepCopy(scalars);
    }
    const echoreg::filters::SequenceFieldData sequenceData(image->GetFieldData());
    std::mutex mutex;
    std::string error;
    if (context.enabled())
      blockResults.assign(static_cast<std::size_t>(block.last - block.first + 1), {});
    const auto peaksOfRows = [&](vtkIdType begin, vtkIdType end) {
      try {
        for (vtkIdType frame = begin; frame < end; ++frame) {
          const vtkIdType row = frame - tableFirstFrame;
          const echoreg::core::PeakResult result = echoreg::core::findPeaks(
              peakParams, envelopes->GetPointer((frame - extent[2]) * samplesPerRow),
              samplesPerRow);
          frameColumn->SetValue(row, static_cast<int>(frame));
          timestampColumn->SetValue(row, sequenceData.timestampS(frame));
          peaksColumn->SetValue(row, static_cast<int>(result.peaks.size()));
          sampleColumn->SetValue(row, result.accepted() ? result.sampleIndex : kNaN);
          depthColumn->SetValue(row,
                                result.accepted() ? this->Depth.depthMm(result.sampleIndex) : kNaN);
          thresholdColumn->SetValue(row, result.threshold);
          verdicts[static_cast<std::size_t>(row)] = result.reason;
          if (this->PeakList)
            peaksOfFrames[static_cast<std::size_t>(row)] = result.peaks;
          if (context.enabled())
            blockResults[static_cast<std::size_t>(frame - block.first)] = result;
        }
      } catch (const std::exception& exception) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (error.empty())
          error = exception.what();
      }
    };
    // Slices of at most a twentieth of the table, the progress reported between them from this
    // thread.
    const vtkIdType slice = std::max<vtkIdType>(256, (rows + 19) / 20);
    for (vtkIdType begin = block.first; begin <= block.last && error.empty(); begin += slice) {
      const vtkIdType end = std::min<vtkIdType>(block.last + 1, begin + slice);
      vtkSMPTools::For(begin, end, peaksOfRows);
      rowsDone += end - begin;
      this->UpdateProgress(static_cast<double>(rowsDone) / static_cast<double>(rows));
    }
    if (!error.empty()) {
      this->Fail("peak detection failed: " + error);
      return 0;
    }
    if (context.enabled()) {
      for (vtkIdType frame = block.first; frame <= block.last; ++frame) {
        echoreg::core::PeakResult& result =
            blockResults[static_cast<std::size_t>(frame - block.first)];
        if (!context.judge(result, envelopes->GetPointer((frame - extent[2]) * samplesPerRow),
                           samplesPerRow))
          continue;
        const vtkIdType row = frame - tableFirstFrame;
        sampleColumn->SetValue(row, result.sampleIndex);
        depthColumn->SetValue(row, this->Depth.depthMm(result.sampleIndex));
        verdicts[static_cast<std::size_t>(row)] = result.reason;
        ++fromContext;
      }
    }
  }
  for (const auto& peaks : peaksOfFrames)
    peakCount += static_cast<vtkIdType>(peaks.size());
  listFrame->SetNumberOfValues(peakCount);
  listIndex->SetNumberOfValues(peakCount);
  listValue->SetNumberOfValues(peakCount);
  vtkIdType at = 0;
  for (std::size_t row = 0; row < peaksOfFrames.size(); ++row) {
    for (const echoreg::core::Peak& peak : peaksOfFrames[row]) {
      listFrame->SetValue(at, tableFirstFrame + static_cast<int>(row));
      listIndex->SetValue(at, peak.index);
      listValue->SetValue(at, peak.value);
      ++at;
    }
  }
  for (vtkIdType row = 0; row < rows; ++row) {
    reasonColumn->SetValue(
        row, std::string(echoreg::core::rejectReasonName(verdicts[static_cast<std::size_t>(row)])));
  }

  output->Initialize();
  output->AddColumn(frameColumn);
  output->AddColumn(timestampColumn);
  output->AddColumn(peaksColumn);
  output->AddColumn(sampleColumn);
  output->AddColumn(depthColumn);
  output->AddColumn(reasonColumn);
  output->AddColumn(thresholdColumn);
  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  vtkNew<vtkIntArray> fromContextArray;
  fromContextArray->SetName("EchoesFromContext");
  fromContextArray->InsertNextValue(fromContext);
  output->GetFieldData()->AddArray(fromContextArray);
  peakList->Initialize();
  peakList->AddColumn(listFrame);
  peakList->AddColumn(listIndex);
  peakList->AddColumn(listValue);
  this->LastError.clear();
  return 1;
}

vtkImageData* vtkEchoregPeakFilter::UpdateInputFrames(const int firstFrame, const int lastFrame) {
  vtkAlgorithmOutput* connection = this->GetInputConnection(0, 0);
  vtkAlgorithm* source = connection != nullptr ? connection->GetProducer() : nullptr;
  if (source == nullptr)
    return nullptr;
  const int port = connection->GetIndex();
  int extent[6];
  this->GetInputInformation(0, 0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  extent[2] = firstFrame;
  extent[3] = lastFrame;
  vtkNew<vtkInformationVector> requests;
  requests->SetNumberOfInformationObjects(source->GetNumberOfOutputPorts());
  requests->GetInformationObject(port)->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
                                            extent, 6);
  if (source->Update(port, requests) != 1)
    return nullptr;
  return vtkImageData::SafeDownCast(source->GetOutputDataObject(port));
}

void vtkEchoregPeakFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  const echoreg::core::PeakParams& peaks = this->PeakParams;
  os << indent << "ThresholdMode: "
     << (peaks.thresholdMode == echoreg::core::ThresholdMode::FactorOfMean ? "factor-of-mean"
                                                                           : "fraction-of-max")
     << "\n";
  os << indent << "ThresholdFactor: " << peaks.thresholdFactor << "\n";
  os << indent << "ThresholdOfMax: " << peaks.thresholdOfMax << "\n";
  os << indent << "WindowBegin (samples): "
     << (peaks.windowBegin ? std::to_string(*peaks.windowBegin) : "(none)") << "\n";
  os << indent
     << "WindowEnd (samples): " << (peaks.windowEnd ? std::to_string(*peaks.windowEnd) : "(none)")
     << "\n";
  os << indent << "Policy: " << echoreg::core::peakPolicyName(peaks.policy) << "\n";
  os << indent << "BoneRegionMm: " << peaks.bone.regionMm << "\n";
  os << indent << "BoneGapMm: " << peaks.bone.gapMm << "\n";
  os << indent << "BoneMinShadowRatio: " << peaks.bone.minShadowRatio << "\n";
  os << indent << "BoneMinContrast: " << peaks.bone.minContrast << "\n";
  os << indent << "BoneMaxWidthMm: " << peaks.bone.maxWidthMm << "\n";
  os << indent << "BoneNoiseFloorFactor: " << peaks.bone.noiseFloorFactor << "\n";
  os << indent << "BoneMinTissueOverNoise: " << peaks.bone.minTissueOverNoise << "\n";
  os << indent << "Subsample: " << (peaks.subsample ? "On" : "Off") << "\n";
  os << indent << "SamplingFrequencyHz: " << this->Depth.samplingFrequencyHz << "\n";
  os << indent << "DelayS: " << this->Depth.delayS << "\n";
  os << indent << "SpeedOfSoundMps: " << this->Depth.speedOfSoundMps << "\n";
  os << indent << "WindowMinMm: " << this->WindowMinMm << "\n";
  os << indent << "WindowMaxMm: " << this->WindowMaxMm << "\n";
  os << indent << "EnvelopeRingDownSamples: " << this->Envelope.ringDownSamples << "\n";
  os << indent << "TransducerFrequencyHz: "
     << (this->TransducerFrequencyHz ? std::to_string(*this->TransducerFrequencyHz)
                                     : std::string("(envelope's)"))
     << "\n";
  os << indent << "PeakList: " << (this->PeakList ? "On" : "Off") << "\n";
  os << indent << "FramesPerBlock: " << this->FramesPerBlock
     << (this->FramesPerBlock > 0 ? "" : " (the whole capture at once)") << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
