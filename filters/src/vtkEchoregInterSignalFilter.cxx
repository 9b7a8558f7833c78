#include "echoreg/filters/vtkEchoregInterSignalFilter.h"

#include "echoreg/core/sequence_detection.hpp"

#include "echoreg/filters/SequenceFieldData.h"

#include <vtkAbstractArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <Eigen/Dense>

#include <algorithm>
#include <exception>
#include <limits>
#include <optional>

vtkStandardNewMacro(vtkEchoregInterSignalFilter);

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kAccepted = "accepted";
constexpr const char* kRejected = "rejected";

// Every reason a frame can end with, for counts that always list all of them.
constexpr echoreg::RejectReason kReasons[] = {
    echoreg::RejectReason::NoPeak,      echoreg::RejectReason::TooManyPeaks,
    echoreg::RejectReason::TooFewPeaks, echoreg::RejectReason::OutsideWindow,
    echoreg::RejectReason::NotBone,     echoreg::RejectReason::Inconsistent,
    echoreg::RejectReason::TooClose,    echoreg::RejectReason::InvalidPose,
};

vtkSmartPointer<vtkDoubleArray> coordinateColumn(const char* name, vtkIdType rows) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfValues(rows);
  array->Fill(kNaN);
  return array;
}

}  // namespace

vtkEchoregInterSignalFilter::vtkEchoregInterSignalFilter() {
  vtkMatrix4x4::Identity(this->BeamToProbe.data());
}

vtkEchoregInterSignalFilter::~vtkEchoregInterSignalFilter() = default;

void vtkEchoregInterSignalFilter::SetInterSignalParams(const echoreg::InterSignalParams& params) {
  if (this->Params == params)
    return;
  this->Params = params;
  this->Modified();
}

void vtkEchoregInterSignalFilter::SetBeamToProbe(const double rowMajor[16]) {
  std::array<double, 16> matrix;
  std::copy(rowMajor, rowMajor + 16, matrix.begin());
  this->SetField(this->BeamToProbe, matrix);
}

void vtkEchoregInterSignalFilter::SetBeamToProbe(vtkMatrix4x4* beamToProbe) {
  if (beamToProbe == nullptr) {
    vtkErrorMacro(<< "SetBeamToProbe: null matrix ignored");
    return;
  }
  this->SetBeamToProbe(beamToProbe->GetData());
}

void vtkEchoregInterSignalFilter::GetBeamToProbe(double rowMajor[16]) const {
  std::copy(this->BeamToProbe.begin(), this->BeamToProbe.end(), rowMajor);
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

  auto* frames = vtkDataArray::SafeDownCast(input->GetColumnByName("frame"));
  auto* depths = vtkDataArray::SafeDownCast(input->GetColumnByName("depth_mm"));
  auto* reasons = vtkStringArray::SafeDownCast(input->GetColumnByName("reason"));
  if (frames == nullptr || depths == nullptr || reasons == nullptr) {
    this->Fail(
        "the input table needs the columns \"frame\", \"depth_mm\" and \"reason\" "
        "(a vtkEchoregPeakFilter output)");
    return 0;
  }
  if (!this->ReferenceTransformName.empty() && this->PoseTransformName.empty()) {
    this->Fail("ReferenceTransformName \"" + this->ReferenceTransformName +
               "\" needs a PoseTransformName");
    return 0;
  }
  std::optional<echoreg::InterSignalFilter> interSignal;
  try {
    interSignal.emplace(this->Params);
  } catch (const std::exception& exception) {
    this->Fail(std::string("invalid inter-signal parameters: ") + exception.what());
    return 0;
  }

  const echoreg::filters::SequenceFieldData sequenceData(input->GetFieldData());
  for (const std::string& name : {this->PoseTransformName, this->ReferenceTransformName}) {
    if (name.empty() || sequenceData.hasTransform(name))
      continue;
    std::string known;
    for (const std::string& other : sequenceData.transformNames()) {
      known += (known.empty() ? "" : ", ") + other;
    }
    this->Fail("the input has no transform \"" + name +
               "\" (it has: " + (known.empty() ? "none" : known) + ")");
    return 0;
  }
  echoreg::PointFrameOptions pointFrame;
  pointFrame.poseTransform = this->PoseTransformName;
  pointFrame.referenceTransform = this->ReferenceTransformName;
  pointFrame.beamToProbe =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(this->BeamToProbe.data());

  const vtkIdType rows = input->GetNumberOfRows();
  vtkNew<vtkStringArray> finalReasons;
  finalReasons->SetName("reason");
  finalReasons->SetNumberOfValues(rows);
  vtkNew<vtkStringArray> statuses;
  statuses->SetName("status");
  statuses->SetNumberOfValues(rows);
  auto xColumn = coordinateColumn("x_mm", rows);
  auto yColumn = coordinateColumn("y_mm", rows);
  auto zColumn = coordinateColumn("z_mm", rows);

  std::map<std::string, int> counts;
  counts[kAccepted] = 0;
  for (echoreg::RejectReason reason : kReasons)
    counts[std::string(echoreg::rejectReasonName(reason))] = 0;

  for (vtkIdType row = 0; row < rows; ++row) {
    std::string reason = reasons->GetValue(row);
    std::optional<Eigen::Vector3d> point;
    if (reason.empty()) {
      const auto frame = static_cast<vtkIdType>(frames->GetComponent(row, 0));
      std::optional<Eigen::Matrix4d> pose, reference;
      if (!pointFrame.poseTransform.empty()) {
        pose = sequenceData.validMatrix(pointFrame.poseTransform, frame);
      }
      if (!pointFrame.referenceTransform.empty()) {
        reference = sequenceData.validMatrix(pointFrame.referenceTransform, frame);
      }
      point = echoreg::beamPoint(depths->GetComponent(row, 0), pointFrame,
                                 pose ? &*pose : nullptr, reference ? &*reference : nullptr);
      if (!point) reason = echoreg::rejectReasonName(echoreg::RejectReason::InvalidPose);
    }

    if (point) {
      xColumn->SetValue(row, point->x());
      yColumn->SetValue(row, point->y());
      zColumn->SetValue(row, point->z());
      reason = echoreg::rejectReasonName(interSignal->judge(*point));
    } else {
      interSignal->breakRun();
    }
    finalReasons->SetValue(row, reason);
    statuses->SetValue(row, reason.empty() ? kAccepted : kRejected);
    ++counts[reason.empty() ? std::string(kAccepted) : reason];
  }

  output->Initialize();
  for (vtkIdType column = 0; column < input->GetNumberOfColumns(); ++column) {
    vtkAbstractArray* array = input->GetColumn(column);
    const char* name = array->GetName();
    if (name != nullptr && std::string(name) == "reason") {
      output->AddColumn(finalReasons);
    } else if (name == nullptr || (std::string(name) != "status" && std::string(name) != "x_mm" &&
                                   std::string(name) != "y_mm" && std::string(name) != "z_mm")) {
      output->AddColumn(array);
    }
  }
  output->AddColumn(statuses);
  output->AddColumn(xColumn);
  output->AddColumn(yColumn);
  output->AddColumn(zColumn);

  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  for (const auto& [name, count] : counts) {
    vtkNew<vtkIntArray> countArray;
    countArray->SetName(("Count_" + name).c_str());
    countArray->InsertNextValue(count);
    output->GetFieldData()->AddArray(countArray);
  }
  this->ReasonCounts = std::move(counts);
  this->LastError.clear();
  return 1;
}

void vtkEchoregInterSignalFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "History: " << this->Params.history << "\n";
  os << indent << "ConsistencyMm: " << this->Params.consistencyMm << "\n";
  os << indent << "MinSpreadMm: " << this->Params.minSpreadMm << "\n";
  os << indent << "PoseTransformName: "
     << (this->PoseTransformName.empty() ? "(none)" : this->PoseTransformName) << "\n";
  os << indent << "ReferenceTransformName: "
     << (this->ReferenceTransformName.empty() ? "(none)" : this->ReferenceTransformName) << "\n";
  os << indent << "BeamToProbe:";
  for (double value : this->BeamToProbe)
    os << " " << value;
  os << "\n";
  os << indent << "ReasonCounts:";
  for (const auto& [name, count] : this->ReasonCounts)
    os << " " << name << "=" << count;
  os << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
