#include "echoreg/filters/vtkEchoregBeamCalibrationFilter.h"

#include "echoreg/filters/sequence_field_data.h"

#include "echoreg/core/depth.hpp"

#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

vtkStandardNewMacro(vtkEchoregBeamCalibrationFilter);

namespace {

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

double fieldValue(vtkFieldData* fieldData, const char* name, int component = 0) {
  auto* array = vtkDataArray::SafeDownCast(fieldData->GetAbstractArray(name));
  if (array == nullptr || array->GetNumberOfTuples() < 1 ||
      array->GetNumberOfComponents() <= component) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return array->GetComponent(0, component);
}

}  // namespace

vtkEchoregBeamCalibrationFilter::vtkEchoregBeamCalibrationFilter()
    : AssumedSpeedOfSoundMps(std::numeric_limits<double>::quiet_NaN()) {
  this->SetNumberOfInputPorts(2);
  vtkMatrix4x4::Identity(this->InitialBeamToProbe.data());
}

vtkEchoregBeamCalibrationFilter::~vtkEchoregBeamCalibrationFilter() = default;

void vtkEchoregBeamCalibrationFilter::SetMode(echoreg::core::BeamCalibrationMode mode) {
  if (this->Mode == mode)
    return;
  this->Mode = mode;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::SetFitSpeedOfSound(bool fit) {
  if (this->FitSpeedOfSound == fit)
    return;
  this->FitSpeedOfSound = fit;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::SetAssumedSpeedOfSoundMps(double mps) {
  const bool same = std::isnan(this->AssumedSpeedOfSoundMps) ? std::isnan(mps)
                                                             : this->AssumedSpeedOfSoundMps == mps;
  if (same)
    return;
  this->AssumedSpeedOfSoundMps = mps;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::SetInitialBeamToProbe(const double rowMajor[16]) {
  std::array<double, 16> matrix;
  std::copy(rowMajor, rowMajor + 16, matrix.begin());
  if (this->InitialBeamToProbe == matrix)
    return;
  this->InitialBeamToProbe = matrix;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::SetMaxConditionNumber(double limit) {
  if (this->MaxConditionNumber == limit)
    return;
  this->MaxConditionNumber = limit;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::SetPoseTransformName(const std::string& name) {
  if (this->PoseTransformName == name)
    return;
  this->PoseTransformName = name;
  this->Modified();
}

void vtkEchoregBeamCalibrationFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregBeamCalibrationFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkTable");
  return 1;
}

int vtkEchoregBeamCalibrationFilter::RequestData(vtkInformation* /*request*/,
                                                 vtkInformationVector** inputVector,
                                                 vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkTable* shotsTable = vtkTable::GetData(inputVector[0]);
  vtkTable* sphereTable = vtkTable::GetData(inputVector[1]);
  vtkTable* output = vtkTable::GetData(outputVector);
  if (shotsTable == nullptr || sphereTable == nullptr || output == nullptr) {
    this->Fail("needs the shots' detection table on input 0 and the sphere fit on input 1");
    return 0;
  }
  echoreg::core::BeamCalibrationOptions options;
  options.mode = this->Mode;
  options.fitSpeedOfSound = this->FitSpeedOfSound;
  options.maxConditionNumber = this->MaxConditionNumber;
  options.initialBeamToProbe.matrix() =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(
          this->InitialBeamToProbe.data());
  for (int axis = 0; axis < 3; ++axis) {
    options.sphereCentreTracker[axis] =
        fieldValue(sphereTable->GetFieldData(), "SphereCentreMm", axis);
  }
  options.sphereRadiusMm = fieldValue(sphereTable->GetFieldData(), "SphereRadiusMm");
  if (!options.sphereCentreTracker.allFinite() || !std::isfinite(options.sphereRadiusMm)) {
    this->Fail(
        "input 1 holds no sphere (\"SphereCentreMm\" and \"SphereRadiusMm\" in its field data: "
        "a vtkEchoregSphereFitFilter output)");
    return 0;
  }
  const double headerSpeed = fieldValue(shotsTable->GetFieldData(), "SpeedOfSoundMps");
  options.assumedSpeedOfSoundMps =
      !std::isnan(this->AssumedSpeedOfSoundMps) ? this->AssumedSpeedOfSoundMps
      : std::isfinite(headerSpeed)              ? headerSpeed
                                                : echoreg::core::kWaterSpeedOfSoundMps;

  auto* frames = vtkDataArray::SafeDownCast(shotsTable->GetColumnByName("frame"));
  auto* depths = vtkDataArray::SafeDownCast(shotsTable->GetColumnByName("depth_mm"));
  auto* statuses = vtkStringArray::SafeDownCast(shotsTable->GetColumnByName("status"));
  if (frames == nullptr || depths == nullptr || statuses == nullptr) {
    this->Fail(
        "input 0 needs the columns \"frame\", \"depth_mm\" and \"status\" (a "
        "vtkEchoregInterSignalFilter output)");
    return 0;
  }
  const echoreg::filters::SequenceFieldData poses(shotsTable->GetFieldData());
  if (!poses.hasTransform(this->PoseTransformName)) {
    this->Fail("the shots have no transform \"" + this->PoseTransformName + "\"");
    return 0;
  }
  std::vector<echoreg::core::BeamShot> shots;
  std::vector<int> shotFrames;
  for (vtkIdType row = 0; row < shotsTable->GetNumberOfRows(); ++row) {
    if (statuses->GetValue(row) != "accepted")
      continue;
    const auto frame = static_cast<vtkIdType>(frames->GetComponent(row, 0));
    const auto pose = poses.validMatrix(this->PoseTransformName, frame);
    if (!pose)
      continue;
    echoreg::core::BeamShot shot;
    shot.probeToTracker.matrix() = *pose;
    shot.depthMm = depths->GetComponent(row, 0);
    shots.push_back(shot);
    shotFrames.push_back(static_cast<int>(frame));
  }
  echoreg::core::BeamCalibrationResult result;
  try {
    result = echoreg::core::calibrateBeam(shots, options);
  } catch (const std::exception& exception) {
    this->Fail(std::to_string(shots.size()) + " sphere echoes; " + exception.what());
    return 0;
  }

  vtkNew<vtkIntArray> frameColumn;
  frameColumn->SetName("frame");
  vtkNew<vtkDoubleArray> depthColumn, residualColumn;
  depthColumn->SetName("depth_mm");
  residualColumn->SetName("residual_mm");
  vtkNew<vtkIntArray> usedColumn;
  usedColumn->SetName("used");
  for (std::size_t i = 0; i < shots.size(); ++i) {
    frameColumn->InsertNextValue(shotFrames[i]);
    depthColumn->InsertNextValue(shots[i].depthMm);
    residualColumn->InsertNextValue(result.residualsMm[i]);
    usedColumn->InsertNextValue(result.used[i] ? 1 : 0);
  }
  output->Initialize();
  output->AddColumn(frameColumn);
  output->AddColumn(depthColumn);
  output->AddColumn(residualColumn);
  output->AddColumn(usedColumn);
  vtkFieldData* fieldData = output->GetFieldData();
  vtkNew<vtkDoubleArray> beamToProbe;
  beamToProbe->SetName("BeamToProbe");
  beamToProbe->SetNumberOfComponents(16);
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> rowMajor = result.beamToProbe.matrix();
  beamToProbe->InsertNextTuple(rowMajor.data());
  fieldData->AddArray(beamToProbe);
  addValue(fieldData, "SpeedOfSoundMps", result.speedOfSoundMps);
  addValue(fieldData, "RmsMm", result.rmsMm);
  addValue(fieldData, "ConditionNumber", result.conditionNumber);
  addValue(fieldData, "Iterations", result.iterations);
  addValue(fieldData, "Converged", result.converged ? 1.0 : 0.0);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregBeamCalibrationFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Mode: "
     << (this->Mode == echoreg::core::BeamCalibrationMode::Beam ? "beam" : "translation") << "\n";
  os << indent << "FitSpeedOfSound: " << (this->FitSpeedOfSound ? "On" : "Off") << "\n";
  os << indent << "AssumedSpeedOfSoundMps: " << this->AssumedSpeedOfSoundMps << "\n";
  os << indent << "InitialBeamToProbe:";
  for (double value : this->InitialBeamToProbe)
    os << " " << value;
  os << "\n";
  os << indent << "MaxConditionNumber: " << this->MaxConditionNumber << "\n";
  os << indent << "PoseTransformName: " << this->PoseTransformName << "\n";
  os << indent << "LastResult: RMS " << this->LastResult.rmsMm << " mm, condition "
     << this->LastResult.conditionNumber << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
