#include "echoreg/filters/vtkEchoregRigidErrorFilter.h"

#include <vtkDataArray.h>
#include <vtkDataObject.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <exception>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregRigidErrorFilter);

namespace {

// The transforms of a 16-component array of `data`'s field data, one per tuple.
std::vector<Eigen::Isometry3d> transformsOf(vtkDataObject* data, const std::string& name,
                                            const char* which) {
  auto* array = vtkDataArray::SafeDownCast(data->GetFieldData()->GetAbstractArray(name.c_str()));
  if (array == nullptr || array->GetNumberOfComponents() != 16 || array->GetNumberOfTuples() < 1) {
    throw std::invalid_argument(std::string("the ") + which + " input has no 16-component \"" +
                                name + "\" in its field data (a row-major 4x4 per tuple)");
  }
  std::vector<Eigen::Isometry3d> transforms;
  for (vtkIdType tuple = 0; tuple < array->GetNumberOfTuples(); ++tuple) {
    Eigen::Matrix<double, 4, 4, Eigen::RowMajor> matrix;
    array->GetTuple(tuple, matrix.data());
    Eigen::Isometry3d transform;
    transform.matrix() = matrix;
    transforms.push_back(transform);
  }
  return transforms;
}

}  // namespace

vtkEchoregRigidErrorFilter::vtkEchoregRigidErrorFilter() {
  this->SetNumberOfInputPorts(2);
}

vtkEchoregRigidErrorFilter::~vtkEchoregRigidErrorFilter() = default;

void vtkEchoregRigidErrorFilter::SetEstimateArrayName(const std::string& name) {
  if (this->EstimateArrayName == name)
    return;
  this->EstimateArrayName = name;
  this->Modified();
}

void vtkEchoregRigidErrorFilter::SetReferenceArrayName(const std::string& name) {
  if (this->ReferenceArrayName == name)
    return;
  this->ReferenceArrayName = name;
  this->Modified();
}

void vtkEchoregRigidErrorFilter::SetCentreCtMm(double x, double y, double z) {
  const Eigen::Vector3d centre(x, y, z);
  if (this->CentreCtMm == centre)
    return;
  this->CentreCtMm = centre;
  this->Modified();
}

void vtkEchoregRigidErrorFilter::AddTarget(const std::string& label, double x, double y, double z) {
  this->Targets.emplace_back(label, Eigen::Vector3d(x, y, z));
  this->Modified();
}

void vtkEchoregRigidErrorFilter::RemoveAllTargets() {
  if (this->Targets.empty())
    return;
  this->Targets.clear();
  this->Modified();
}

void vtkEchoregRigidErrorFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregRigidErrorFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  return 1;
}

int vtkEchoregRigidErrorFilter::RequestData(vtkInformation* /*request*/,
                                            vtkInformationVector** inputVector,
                                            vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkDataObject* estimates = vtkDataObject::GetData(inputVector[0]);
  vtkDataObject* reference = vtkDataObject::GetData(inputVector[1]);
  vtkTable* output = vtkTable::GetData(outputVector);
  if (estimates == nullptr || reference == nullptr || output == nullptr) {
    this->Fail("needs the estimates on input 0 and the reference on input 1");
    return 0;
  }
  std::vector<Eigen::Vector3d> targets;
  for (const auto& [label, point] : this->Targets)
    targets.push_back(point);
  Result result;
  try {
    const Eigen::Isometry3d referenceTransform =
        transformsOf(reference, this->ReferenceArrayName, "reference").front();
    for (const Eigen::Isometry3d& estimate :
         transformsOf(estimates, this->EstimateArrayName, "estimates")) {
      result.rows.push_back(
          echoreg::core::rigidError(referenceTransform, estimate, targets, this->CentreCtMm));
    }
    result.meanAbsolute = echoreg::core::meanAbsoluteError(result.rows);
  } catch (const std::exception& exception) {
    this->Fail(std::string("error decomposition failed: ") + exception.what());
    return 0;
  }

  vtkNew<vtkStringArray> names;
  names->SetName("estimate");
  std::vector<vtkSmartPointer<vtkDoubleArray>> columns;
  const auto addColumn = [&](const std::string& name) {
    auto array = vtkSmartPointer<vtkDoubleArray>::New();
    array->SetName(name.c_str());
    columns.push_back(array);
  };
  for (const char* name : {"tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg"})
    addColumn(name);
  for (const auto& [label, point] : this->Targets)
    addColumn("target_" + label + "_mm");
  const auto addRow = [&](const std::string& name, const echoreg::core::RigidError& error) {
    names->InsertNextValue(name);
    for (int axis = 0; axis < 3; ++axis) {
      columns[static_cast<std::size_t>(axis)]->InsertNextValue(error.translationMm[axis]);
      columns[static_cast<std::size_t>(axis + 3)]->InsertNextValue(error.rotationDeg[axis]);
    }
    for (std::size_t t = 0; t < error.targetErrorsMm.size(); ++t)
      columns[6 + t]->InsertNextValue(error.targetErrorsMm[t]);
  };
  for (std::size_t row = 0; row < result.rows.size(); ++row)
    addRow(std::to_string(row), result.rows[row]);
  addRow("mean_abs", result.meanAbsolute);
  output->Initialize();
  output->AddColumn(names);
  for (const auto& column : columns)
    output->AddColumn(column);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregRigidErrorFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "EstimateArrayName: " << this->EstimateArrayName << "\n";
  os << indent << "ReferenceArrayName: " << this->ReferenceArrayName << "\n";
  os << indent << "CentreCtMm: " << this->CentreCtMm.transpose() << "\n";
  os << indent << "Targets:";
  for (const auto& [label, point] : this->Targets)
    os << " " << label << " (" << point.transpose() << ")";
  os << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
