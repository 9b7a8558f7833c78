#include "echoreg/filters/vtkEchoregInterSignalFilter.h"

#include <vtkAbstractArray.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <cmath>
#include <exception>
#include <vector>

vtkStandardNewMacro(vtkEchoregInterSignalFilter);

namespace {

constexpr const char* kAccepted = "accepted";
constexpr const char* kRejected = "rejected";

// Every reason a frame can end with, for counts that always list all of them.
constexpr echoreg::core::RejectReason kReasons[] = {
    echoreg::core::RejectReason::NoPeak,      echoreg::core::RejectReason::TooManyPeaks,
    echoreg::core::RejectReason::TooFewPeaks, echoreg::core::RejectReason::OutsideWindow,
    echoreg::core::RejectReason::NotBone,     echoreg::core::RejectReason::Inconsistent,
    echoreg::core::RejectReason::TooClose,    echoreg::core::RejectReason::InvalidPose,
    echoreg::core::RejectReason::InRingDown,
};

void addCount(vtkFieldData* fieldData, const std::string& name, int count) {
  vtkNew<vtkIntArray> array;
  array->SetName(name.c_str());
  array->InsertNextValue(count);
  fieldData->AddArray(array);
}

}  // namespace

vtkEchoregInterSignalFilter::vtkEchoregInterSignalFilter() = default;

vtkEchoregInterSignalFilter::~vtkEchoregInterSignalFilter() = default;

void vtkEchoregInterSignalFilter::SetInterSignalParams(
    const echoreg::core::InterSignalParams& params) {
  if (this->Params == params)
    return;
  this->Params = params;
  this->Modified();
}

void vtkEchoregInterSignalFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregInterSignalFilter::RequestData(vtkInformation* /*request*/,
                                             vtkInformationVector** inputVector,
                                             vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkTable* input = vtkTable::GetData(inputVector[0]);
  vtkTable* output = vtkTable::GetData(outputVector);
  if (input == nullptr || output == nullptr) {
    this->Fail("the input and the output must be vtkTable");
    return 0;
  }
  auto* reasons = vtkStringArray::SafeDownCast(input->GetColumnByName("reason"));
  auto* xs = vtkDataArray::SafeDownCast(input->GetColumnByName("x_mm"));
  auto* ys = vtkDataArray::SafeDownCast(input->GetColumnByName("y_mm"));
  auto* zs = vtkDataArray::SafeDownCast(input->GetColumnByName("z_mm"));
  if (reasons == nullptr || xs == nullptr || ys == nullptr || zs == nullptr) {
    this->Fail(
        "the input table needs the columns \"reason\", \"x_mm\", \"y_mm\" and \"z_mm\" "
        "(a vtkEchoregBeamPointsFilter output)");
    return 0;
  }
  try {
    // The inter-signal checks of the whole chain's validation, so the messages are the core's.
    echoreg::core::DetectionParams params;
    params.interSignal = this->Params;
    echoreg::core::validate(params);
  } catch (const std::exception& exception) {
    this->Fail(std::string("invalid inter-signal parameters: ") + exception.what());
    return 0;
  }
  auto* depths = vtkDataArray::SafeDownCast(input->GetColumnByName("depth_mm"));
  auto* timestamps = vtkDataArray::SafeDownCast(input->GetColumnByName("timestamp_s"));
  auto* pointFrame =
      vtkStringArray::SafeDownCast(input->GetFieldData()->GetAbstractArray("PointFrame"));
  Result result;
  result.tracked = pointFrame != nullptr && pointFrame->GetNumberOfValues() == 1 &&
                   pointFrame->GetValue(0) != "Beam";

  const vtkIdType rows = input->GetNumberOfRows();
  std::vector<echoreg::core::InterSignalInput> frames(static_cast<std::size_t>(rows));
  for (vtkIdType row = 0; row < rows; ++row) {
    echoreg::core::InterSignalInput& frame = frames[static_cast<std::size_t>(row)];
    const Eigen::Vector3d point(xs->GetComponent(row, 0), ys->GetComponent(row, 0),
                                zs->GetComponent(row, 0));
    frame.detected = reasons->GetValue(row).empty() && point.allFinite();
    if (frame.detected) {
      frame.pointMm = point;
      frame.depthMm = depths != nullptr ? depths->GetComponent(row, 0) : point.z();
      ++result.echoes;
    }
    if (timestamps != nullptr && std::isfinite(timestamps->GetComponent(row, 0)))
      frame.timestampS = timestamps->GetComponent(row, 0);
  }
  std::vector<echoreg::core::RejectReason> verdicts;
  try {
    verdicts = echoreg::core::applyInterSignal(this->Params, frames, result.tracked);
  } catch (const std::exception& exception) {
    this->Fail(std::string("inter-signal filter failed: ") + exception.what());
    return 0;
  }

  result.reasonCounts[kAccepted] = 0;
  for (echoreg::core::RejectReason reason : kReasons)
    result.reasonCounts[std::string(echoreg::core::rejectReasonName(reason))] = 0;
  vtkNew<vtkStringArray> finalReasons;
  finalReasons->SetName("reason");
  finalReasons->SetNumberOfValues(rows);
  vtkNew<vtkStringArray> statuses;
  statuses->SetName("status");
  statuses->SetNumberOfValues(rows);
  for (vtkIdType row = 0; row < rows; ++row) {
    const auto index = static_cast<std::size_t>(row);
    const std::string reason = frames[index].detected
                                   ? std::string(echoreg::core::rejectReasonName(verdicts[index]))
                                   : reasons->GetValue(row);
    finalReasons->SetValue(row, reason);
    statuses->SetValue(row, reason.empty() ? kAccepted : kRejected);
    ++result.reasonCounts[reason.empty() ? std::string(kAccepted) : reason];
  }
  result.accepted = result.reasonCounts[kAccepted];

  output->Initialize();
  for (vtkIdType column = 0; column < input->GetNumberOfColumns(); ++column) {
    vtkAbstractArray* array = input->GetColumn(column);
    const std::string name = array->GetName() != nullptr ? array->GetName() : "";
    if (name == "reason") {
      output->AddColumn(finalReasons);
    } else if (name != "status") {
      output->AddColumn(array);
    }
  }
  output->AddColumn(statuses);
  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  for (const auto& [name, count] : result.reasonCounts)
    addCount(output->GetFieldData(), "Count_" + name, count);
  addCount(output->GetFieldData(), "EchoesBeforeInterSignal", result.echoes);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregInterSignalFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "TemporalMode: " << echoreg::core::temporalModeName(this->Params.temporal)
     << "\n";
  os << indent << "History: " << this->Params.history << "\n";
  os << indent << "ConsistencyMm: " << this->Params.consistencyMm << "\n";
  os << indent << "MaxDepthRateMmPerS: " << this->Params.maxDepthRateMmPerS << "\n";
  os << indent << "MaxGapS: " << this->Params.maxGapS << "\n";
  os << indent << "FrameRateHz: " << this->Params.frameRateHz << "\n";
  os << indent << "MinSpreadMm: " << this->Params.minSpreadMm << "\n";
  os << indent << "LastResult: " << this->LastResult.echoes << " echoes, "
     << this->LastResult.accepted << " accepted, "
     << (this->LastResult.tracked ? "tracked" : "untracked") << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
