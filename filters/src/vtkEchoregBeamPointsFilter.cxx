#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/sequence_field_data.h"

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
#include <vtkSMPTools.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <optional>
#include <vector>

vtkStandardNewMacro(vtkEchoregBeamPointsFilter);

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

vtkSmartPointer<vtkDoubleArray> coordinateColumn(const char* name, vtkIdType rows) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfValues(rows);
  array->Fill(kNaN);
  return array;
}

// "ProbeToTracker" -> {"Probe", "Tracker"}; a name without "To" is both.
std::pair<std::string, std::string> framesOf(const std::string& transform) {
  const std::size_t to = transform.rfind("To");
  if (to == std::string::npos || to == 0 || to + 2 >= transform.size())
    return {transform, transform};
  return {transform.substr(0, to), transform.substr(to + 2)};
}

void addInt(vtkFieldData* fieldData, const char* name, int value) {
  vtkNew<vtkIntArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

}  // namespace

vtkEchoregBeamPointsFilter::vtkEchoregBeamPointsFilter() {
  this->SetNumberOfInputPorts(2);
  vtkMatrix4x4::Identity(this->BeamToProbe.data());
}

int vtkEchoregBeamPointsFilter::FillInputPortInformation(int port, vtkInformation* info) {
  if (port == 0) {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkTable");
  } else {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

vtkEchoregBeamPointsFilter::~vtkEchoregBeamPointsFilter() = default;

void vtkEchoregBeamPointsFilter::SetBeamToProbe(const double rowMajor[16]) {
  std::array<double, 16> matrix;
  std::copy(rowMajor, rowMajor + 16, matrix.begin());
  this->SetField(this->BeamToProbe, matrix);
}

void vtkEchoregBeamPointsFilter::SetBeamToProbe(vtkMatrix4x4* beamToProbe) {
  if (beamToProbe == nullptr) {
    vtkErrorMacro(<< "SetBeamToProbe: null matrix ignored");
    return;
  }
  this->SetBeamToProbe(beamToProbe->GetData());
}

void vtkEchoregBeamPointsFilter::GetBeamToProbe(double rowMajor[16]) const {
  std::copy(this->BeamToProbe.begin(), this->BeamToProbe.end(), rowMajor);
}

void vtkEchoregBeamPointsFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregBeamPointsFilter::RequestData(vtkInformation* /*request*/,
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
  const echoreg::filters::SequenceFieldData sequenceData(input->GetFieldData());
  for (const std::string& name : {this->PoseTransformName, this->ReferenceTransformName}) {
    if (name.empty() || sequenceData.hasTransform(name))
      continue;
    std::string known;
    for (const std::string& other : sequenceData.transformNames())
      known += (known.empty() ? "" : ", ") + other;
    this->Fail("the input has no transform \"" + name +
               "\" (it has: " + (known.empty() ? "none" : known) + ")");
    return 0;
  }

  echoreg::core::PointFrameOptions pointFrame;
  pointFrame.poseTransform = this->PoseTransformName;
  pointFrame.referenceTransform = this->ReferenceTransformName;
  pointFrame.beamToProbe =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(this->BeamToProbe.data());
  if (inputVector[1]->GetNumberOfInformationObjects() > 0) {
    vtkDataObject* calibration = vtkDataObject::GetData(inputVector[1]);
    auto* matrix = calibration == nullptr
                       ? nullptr
                       : vtkDataArray::SafeDownCast(
                             calibration->GetFieldData()->GetAbstractArray("BeamToProbe"));
    if (matrix == nullptr || matrix->GetNumberOfComponents() != 16 ||
        matrix->GetNumberOfTuples() < 1) {
      this->Fail(
          "the calibration input has no 16-component \"BeamToProbe\" in its field data (a "
          "vtkEchoregBeamCalibrationFilter output)");
      return 0;
    }
    Eigen::Matrix<double, 4, 4, Eigen::RowMajor> rowMajor;
    matrix->GetTuple(0, rowMajor.data());
    pointFrame.beamToProbe = rowMajor;
  }

  const vtkIdType rows = input->GetNumberOfRows();
  vtkNew<vtkStringArray> finalReasons;
  finalReasons->SetName("reason");
  finalReasons->SetNumberOfValues(rows);
  auto xColumn = coordinateColumn("x_mm", rows);
  auto yColumn = coordinateColumn("y_mm", rows);
  auto zColumn = coordinateColumn("z_mm", rows);
  const std::string invalidPose(
      echoreg::core::rejectReasonName(echoreg::core::RejectReason::InvalidPose));
  // 0: not detected, 1: placed, 2: invalid pose; counted after the parallel loop.
  std::vector<unsigned char> outcome(static_cast<std::size_t>(rows), 0);

  vtkSMPTools::For(0, rows, [&](vtkIdType begin, vtkIdType end) {
    for (vtkIdType row = begin; row < end; ++row) {
      if (!reasons->GetValue(row).empty())
        continue;
      const auto frame = static_cast<vtkIdType>(frames->GetComponent(row, 0));
      std::optional<Eigen::Matrix4d> pose, reference;
      if (!pointFrame.poseTransform.empty())
        pose = sequenceData.validMatrix(pointFrame.poseTransform, frame);
      if (!pointFrame.referenceTransform.empty())
        reference = sequenceData.validMatrix(pointFrame.referenceTransform, frame);
      const std::optional<Eigen::Vector3d> point =
          echoreg::core::beamPoint(depths->GetComponent(row, 0), pointFrame,
                                   pose ? &*pose : nullptr, reference ? &*reference : nullptr);
      if (!point) {
        outcome[static_cast<std::size_t>(row)] = 2;
        continue;
      }
      xColumn->SetValue(row, point->x());
      yColumn->SetValue(row, point->y());
      zColumn->SetValue(row, point->z());
      outcome[static_cast<std::size_t>(row)] = 1;
    }
  });

  // vtkStringArray::SetValue touches the array's lookup state: strings are set on one thread.
  for (vtkIdType row = 0; row < rows; ++row) {
    finalReasons->SetValue(
        row, outcome[static_cast<std::size_t>(row)] == 2 ? invalidPose : reasons->GetValue(row));
  }

  Result result;
  result.pointFrame = this->PoseTransformName.empty() ? std::string("Beam")
                      : this->ReferenceTransformName.empty()
                          ? framesOf(this->PoseTransformName).second
                          : framesOf(this->ReferenceTransformName).first;
  result.placed = static_cast<int>(std::count(outcome.begin(), outcome.end(), 1));
  result.invalidPose = static_cast<int>(std::count(outcome.begin(), outcome.end(), 2));

  output->Initialize();
  for (vtkIdType column = 0; column < input->GetNumberOfColumns(); ++column) {
    vtkAbstractArray* array = input->GetColumn(column);
    const std::string name = array->GetName() != nullptr ? array->GetName() : "";
    if (name == "reason") {
      output->AddColumn(finalReasons);
    } else if (name != "x_mm" && name != "y_mm" && name != "z_mm") {
      output->AddColumn(array);
    }
  }
  output->AddColumn(xColumn);
  output->AddColumn(yColumn);
  output->AddColumn(zColumn);
  output->GetFieldData()->ShallowCopy(input->GetFieldData());
  vtkNew<vtkStringArray> pointFrameArray;
  pointFrameArray->SetName("PointFrame");
  pointFrameArray->InsertNextValue(result.pointFrame);
  output->GetFieldData()->AddArray(pointFrameArray);
  addInt(output->GetFieldData(), "PointsPlaced", result.placed);
  addInt(output->GetFieldData(), "PointsInvalidPose", result.invalidPose);
  this->LastResult = result;
  this->LastError.clear();
  return 1;
}

void vtkEchoregBeamPointsFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "PoseTransformName: "
     << (this->PoseTransformName.empty() ? "(none)" : this->PoseTransformName) << "\n";
  os << indent << "ReferenceTransformName: "
     << (this->ReferenceTransformName.empty() ? "(none)" : this->ReferenceTransformName) << "\n";
  os << indent << "BeamToProbe:";
  for (double value : this->BeamToProbe)
    os << " " << value;
  os << "\n";
  os << indent << "LastResult: frame " << this->LastResult.pointFrame << ", "
     << this->LastResult.placed << " placed, " << this->LastResult.invalidPose << " invalid-pose\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
