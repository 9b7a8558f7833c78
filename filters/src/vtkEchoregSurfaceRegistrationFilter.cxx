#include "echoreg/filters/vtkEchoregSurfaceRegistrationFilter.h"

#include "echoreg/filters/mesh_io.h"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkPointSet.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <cmath>
#include <exception>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregSurfaceRegistrationFilter);

namespace {

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

vtkDataArray* column(vtkTable* table, const char* name) {
  auto* array = vtkDataArray::SafeDownCast(table->GetColumnByName(name));
  if (array == nullptr)
    throw std::invalid_argument(std::string("the table has no column \"") + name + "\"");
  return array;
}

// The accepted rows of a detection table.
std::vector<echoreg::core::SurfacePoint> pointsOfTable(vtkTable* table, double sigmaMm) {
  auto* statuses = vtkStringArray::SafeDownCast(table->GetColumnByName("status"));
  if (statuses == nullptr)
    throw std::invalid_argument("the points table has no column \"status\"");
  vtkDataArray* xs = column(table, "x_mm");
  vtkDataArray* ys = column(table, "y_mm");
  vtkDataArray* zs = column(table, "z_mm");
  std::vector<echoreg::core::SurfacePoint> points;
  for (vtkIdType row = 0; row < table->GetNumberOfRows(); ++row) {
    if (statuses->GetValue(row) != "accepted")
      continue;
    echoreg::core::SurfacePoint point;
    point.point = Eigen::Vector3d(xs->GetComponent(row, 0), ys->GetComponent(row, 0),
                                  zs->GetComponent(row, 0));
    point.sigmaMm = sigmaMm;
    points.push_back(point);
  }
  return points;
}

std::vector<echoreg::core::SurfacePoint> pointsOfPointSet(vtkPointSet* set, double sigmaMm) {
  vtkPointData* data = set->GetPointData();
  vtkDataArray* sigmas = data->GetArray("SigmaMm");
  vtkDataArray* origins = data->GetArray("BeamOriginMm");
  vtkDataArray* directions = data->GetArray("BeamDirection");
  vtkDataArray* depths = data->GetArray("DepthMm");
  const bool beams = origins != nullptr && directions != nullptr && depths != nullptr &&
                     origins->GetNumberOfComponents() == 3 &&
                     directions->GetNumberOfComponents() == 3;
  std::vector<echoreg::core::SurfacePoint> points;
  for (vtkIdType id = 0; id < set->GetNumberOfPoints(); ++id) {
    double p[3];
    set->GetPoint(id, p);
    echoreg::core::SurfacePoint point;
    point.point = Eigen::Vector3d(p[0], p[1], p[2]);
    point.sigmaMm = sigmas != nullptr ? sigmas->GetComponent(id, 0) : sigmaMm;
    if (beams) {
      point.hasBeam = true;
      point.beamOrigin = Eigen::Vector3d(origins->GetComponent(id, 0), origins->GetComponent(id, 1),
                                         origins->GetComponent(id, 2));
      point.beamDirection =
          Eigen::Vector3d(directions->GetComponent(id, 0), directions->GetComponent(id, 1),
                          directions->GetComponent(id, 2));
      point.depthMm = depths->GetComponent(id, 0);
    }
    points.push_back(point);
  }
  return points;
}

std::vector<echoreg::core::LandmarkPair> landmarksOf(vtkTable* table) {
  std::vector<echoreg::core::LandmarkPair> pairs;
  if (table == nullptr)
    return pairs;
  auto* names = vtkStringArray::SafeDownCast(table->GetColumnByName("name"));
  const char* keys[6] = {"bone_x_mm",  "bone_y_mm",  "bone_z_mm",
                         "model_x_mm", "model_y_mm", "model_z_mm"};
  vtkDataArray* values[6];
  for (int k = 0; k < 6; ++k)
    values[k] = column(table, keys[k]);
  auto* sigmas = vtkDataArray::SafeDownCast(table->GetColumnByName("sigma_mm"));
  for (vtkIdType row = 0; row < table->GetNumberOfRows(); ++row) {
    echoreg::core::LandmarkPair pair;
    pair.name = names != nullptr ? names->GetValue(row) : "landmark " + std::to_string(row);
    for (int axis = 0; axis < 3; ++axis) {
      pair.bone[axis] = values[axis]->GetComponent(row, 0);
      pair.model[axis] = values[axis + 3]->GetComponent(row, 0);
    }
    if (sigmas != nullptr)
      pair.sigmaMm = sigmas->GetComponent(row, 0);
    pairs.push_back(pair);
  }
  return pairs;
}

}  // namespace

vtkEchoregSurfaceRegistrationFilter::vtkEchoregSurfaceRegistrationFilter() {
  this->SetNumberOfInputPorts(3);
}

vtkEchoregSurfaceRegistrationFilter::~vtkEchoregSurfaceRegistrationFilter() = default;

void vtkEchoregSurfaceRegistrationFilter::SetOptions(
    const echoreg::core::SurfaceRegistrationOptions& options) {
  this->Options = options;
  this->Modified();
}

void vtkEchoregSurfaceRegistrationFilter::SetMethod(echoreg::core::SurfaceMethod method) {
  if (this->Options.method == method)
    return;
  this->Options.method = method;
  this->Modified();
}

void vtkEchoregSurfaceRegistrationFilter::SetPointSigmaMm(double sigma) {
  if (this->PointSigmaMm == sigma)
    return;
  this->PointSigmaMm = sigma;
  this->Modified();
}

void vtkEchoregSurfaceRegistrationFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregSurfaceRegistrationFilter::FillInputPortInformation(int port, vtkInformation* info) {
  if (port == 0) {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  } else if (port == 1) {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkPolyData");
  } else {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkTable");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkEchoregSurfaceRegistrationFilter::RequestData(vtkInformation* /*request*/,
                                                     vtkInformationVector** inputVector,
                                                     vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkDataObject* pointsInput = vtkDataObject::GetData(inputVector[0]);
  vtkPolyData* model = vtkPolyData::GetData(inputVector[1]);
  vtkTable* landmarkTable = inputVector[2]->GetNumberOfInformationObjects() > 0
                                ? vtkTable::GetData(inputVector[2])
                                : nullptr;
  vtkPolyData* output = vtkPolyData::GetData(outputVector);
  if (pointsInput == nullptr || model == nullptr || output == nullptr) {
    this->Fail("needs points on input 0 and the model (vtkPolyData) on input 1");
    return 0;
  }
  if (!(this->PointSigmaMm > 0.0)) {
    this->Fail("PointSigmaMm must be > 0 mm, got " + std::to_string(this->PointSigmaMm));
    return 0;
  }
  if (!this->Model || this->ModelData != model || this->ModelTime != model->GetMTime()) {
    this->Model.reset();
    try {
      this->Model = std::make_unique<echoreg::core::SurfaceRegistration>(
          echoreg::filters::toTriangleMesh(model));
    } catch (const std::exception& exception) {
      this->Fail(std::string("bad model: ") + exception.what());
      return 0;
    }
    this->ModelData = model;
    this->ModelTime = model->GetMTime();
    ++this->ModelPreparationCount;
  }

  std::vector<echoreg::core::SurfacePoint> points;
  std::vector<echoreg::core::LandmarkPair> landmarks;
  echoreg::core::SurfaceRegistrationResult result;
  try {
    if (auto* table = vtkTable::SafeDownCast(pointsInput)) {
      points = pointsOfTable(table, this->PointSigmaMm);
    } else if (auto* set = vtkPointSet::SafeDownCast(pointsInput)) {
      points = pointsOfPointSet(set, this->PointSigmaMm);
    } else {
      throw std::invalid_argument(std::string("input 0 must be a vtkTable or a vtkPointSet, not ") +
                                  pointsInput->GetClassName());
    }
    landmarks = landmarksOf(landmarkTable);
    result = this->Model->registerPoints(points, landmarks, this->Options);
  } catch (const std::exception& exception) {
    this->Fail(std::string("surface registration failed: ") + exception.what());
    return 0;
  }

  vtkNew<vtkPoints> mapped;
  mapped->SetDataTypeToDouble();
  vtkNew<vtkDoubleArray> residuals;
  residuals->SetName("ResidualMm");
  vtkNew<vtkIntArray> inliers;
  inliers->SetName("Inlier");
  vtkNew<vtkCellArray> vertices;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = result.transform * points[i].at(result.speedOfSoundScale);
    const vtkIdType id = mapped->InsertNextPoint(p.data());
    vertices->InsertNextCell(1, &id);
    residuals->InsertNextValue(result.residualsMm[i]);
    inliers->InsertNextValue(result.inlier[i] ? 1 : 0);
  }
  output->Initialize();
  output->SetPoints(mapped);
  output->SetVerts(vertices);
  output->GetPointData()->AddArray(residuals);
  output->GetPointData()->AddArray(inliers);
  vtkFieldData* fieldData = output->GetFieldData();
  vtkNew<vtkDoubleArray> transform;
  transform->SetName("BoneToCT");
  transform->SetNumberOfComponents(16);
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> rowMajor = result.transform.matrix();
  transform->InsertNextTuple(rowMajor.data());
  fieldData->AddArray(transform);
  addValue(fieldData, "RmsMm", result.rmsMm);
  addValue(fieldData, "RmsAllMm", result.rmsAllMm);
  addValue(fieldData, "PointsUsed", result.pointsUsed);
  addValue(fieldData, "PointsRejected", result.pointsRejected);
  addValue(fieldData, "Iterations", result.iterations);
  addValue(fieldData, "Starts", result.starts);
  addValue(fieldData, "SpeedOfSoundScale", result.speedOfSoundScale);
  addValue(fieldData, "RotationSigmaDeg", result.rotationSigmaDeg);
  addValue(fieldData, "TranslationSigmaMm", result.translationSigmaMm);
  addValue(fieldData, "Converged", result.converged ? 1.0 : 0.0);
  vtkNew<vtkStringArray> message;
  message->SetName("Message");
  message->InsertNextValue(result.message);
  fieldData->AddArray(message);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregSurfaceRegistrationFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Method: " << echoreg::core::surfaceMethodName(this->Options.method) << "\n";
  os << indent << "Loss: " << echoreg::core::robustLossName(this->Options.loss) << "\n";
  os << indent << "FitSpeedOfSound: " << (this->Options.fitSpeedOfSound ? "On" : "Off") << "\n";
  os << indent << "UseLandmarks: " << (this->Options.useLandmarks ? "On" : "Off") << "\n";
  os << indent << "Restarts: " << this->Options.restarts << "\n";
  os << indent << "MaxIterations: " << this->Options.maxIterations << "\n";
  os << indent << "PointSigmaMm: " << this->PointSigmaMm << "\n";
  os << indent << "LastResult: RMS " << this->LastResult.rmsMm << " mm, "
     << (this->LastResult.converged ? "converged" : "not converged") << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
  os << indent << "ModelPreparationCount: " << this->ModelPreparationCount << "\n";
}
