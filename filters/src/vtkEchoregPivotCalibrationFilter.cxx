#include "echoreg/filters/vtkEchoregPivotCalibrationFilter.h"

#include "echoreg/filters/sequence_field_data.h"

#include <vtkDataObject.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkTable.h>

#include <exception>
#include <tuple>

vtkStandardNewMacro(vtkEchoregPivotCalibrationFilter);

namespace {

void addVector(vtkFieldData* fieldData, const char* name, const Eigen::Vector3d& value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->SetNumberOfComponents(3);
  array->InsertNextTuple(value.data());
  fieldData->AddArray(array);
}

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

bool sameOptions(const echoreg::core::PivotOptions& a, const echoreg::core::PivotOptions& b) {
  return std::tie(a.outlierSigmas, a.minOutlierMm, a.maxRounds, a.minRotationSpreadDeg) ==
         std::tie(b.outlierSigmas, b.minOutlierMm, b.maxRounds, b.minRotationSpreadDeg);
}

}  // namespace

vtkEchoregPivotCalibrationFilter::vtkEchoregPivotCalibrationFilter() = default;

vtkEchoregPivotCalibrationFilter::~vtkEchoregPivotCalibrationFilter() = default;

void vtkEchoregPivotCalibrationFilter::SetMarkerTransformName(const std::string& name) {
  if (this->MarkerTransformName == name)
    return;
  this->MarkerTransformName = name;
  this->Modified();
}

void vtkEchoregPivotCalibrationFilter::SetOptions(const echoreg::core::PivotOptions& options) {
  if (sameOptions(this->Options, options))
    return;
  this->Options = options;
  this->Modified();
}

void vtkEchoregPivotCalibrationFilter::SetMinRotationSpreadDeg(double degrees) {
  echoreg::core::PivotOptions options = this->Options;
  options.minRotationSpreadDeg = degrees;
  this->SetOptions(options);
}

void vtkEchoregPivotCalibrationFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregPivotCalibrationFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  return 1;
}

int vtkEchoregPivotCalibrationFilter::RequestData(vtkInformation* /*request*/,
                                                  vtkInformationVector** inputVector,
                                                  vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkDataObject* input = vtkDataObject::GetData(inputVector[0]);
  vtkTable* output = vtkTable::GetData(outputVector);
  if (input == nullptr || output == nullptr) {
    this->Fail("needs an input with poses in its field data and a vtkTable output");
    return 0;
  }
  const echoreg::filters::SequenceFieldData poses(input->GetFieldData());
  if (!poses.hasTransform(this->MarkerTransformName)) {
    std::string known;
    for (const std::string& name : poses.transformNames())
      known += (known.empty() ? "" : ", ") + name;
    this->Fail("the input has no transform \"" + this->MarkerTransformName +
               "\" (it has: " + (known.empty() ? "none" : known) + ")");
    return 0;
  }
  Result result;
  std::vector<Eigen::Isometry3d> markerToTracker;
  for (vtkIdType frame = 0; frame < poses.frameCount(); ++frame) {
    if (auto matrix = poses.validMatrix(this->MarkerTransformName, frame)) {
      Eigen::Isometry3d pose;
      pose.matrix() = *matrix;
      markerToTracker.push_back(pose);
      result.frames.push_back(static_cast<int>(frame));
    }
  }
  if (markerToTracker.empty()) {
    this->Fail("every " + this->MarkerTransformName + " pose of the input's " +
               std::to_string(poses.frameCount()) + " frames is invalid");
    return 0;
  }
  try {
    result.pivot = echoreg::core::pivotCalibration(markerToTracker, this->Options);
  } catch (const std::exception& exception) {
    this->Fail(std::string("pivot calibration failed: ") + exception.what());
    return 0;
  }

  const auto rows = static_cast<vtkIdType>(result.frames.size());
  vtkNew<vtkIntArray> frameColumn;
  frameColumn->SetName("frame");
  vtkNew<vtkDoubleArray> residualColumn;
  residualColumn->SetName("residual_mm");
  vtkNew<vtkIntArray> inlierColumn;
  inlierColumn->SetName("inlier");
  for (vtkIdType row = 0; row < rows; ++row) {
    const auto index = static_cast<std::size_t>(row);
    frameColumn->InsertNextValue(result.frames[index]);
    residualColumn->InsertNextValue(result.pivot.residualsMm[index]);
    inlierColumn->InsertNextValue(result.pivot.inlier[index] ? 1 : 0);
  }
  output->Initialize();
  output->AddColumn(frameColumn);
  output->AddColumn(residualColumn);
  output->AddColumn(inlierColumn);
  vtkFieldData* fieldData = output->GetFieldData();
  addVector(fieldData, "PointInMarkerMm", result.pivot.pointInMarker);
  addVector(fieldData, "PointInTrackerMm", result.pivot.pointInTracker);
  addValue(fieldData, "RmsMm", result.pivot.rmsMm);
  addValue(fieldData, "Inliers", result.pivot.inliers);
  addVector(fieldData, "RotationSpreadDeg", result.pivot.rotationSpreadDeg);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregPivotCalibrationFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "MarkerTransformName: " << this->MarkerTransformName << "\n";
  os << indent << "OutlierSigmas: " << this->Options.outlierSigmas << "\n";
  os << indent << "MinOutlierMm: " << this->Options.minOutlierMm << "\n";
  os << indent << "MaxRounds: " << this->Options.maxRounds << "\n";
  os << indent << "MinRotationSpreadDeg: " << this->Options.minRotationSpreadDeg << "\n";
  os << indent << "LastResult: RMS " << this->LastResult.pivot.rmsMm << " mm over "
     << this->LastResult.pivot.inliers << " poses\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
