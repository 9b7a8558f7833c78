#include "echoreg/filters/vtkEchoregPointToSurfaceDistance.h"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/filters/mesh_io.h"

#include <vtkCellArray.h>
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
#include <vtkSMPTools.h>

#include <algorithm>
#include <cmath>
#include <exception>

vtkStandardNewMacro(vtkEchoregPointToSurfaceDistance);

namespace {

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

}  // namespace

vtkEchoregPointToSurfaceDistance::vtkEchoregPointToSurfaceDistance() {
  this->SetNumberOfInputPorts(2);
}

vtkEchoregPointToSurfaceDistance::~vtkEchoregPointToSurfaceDistance() = default;

void vtkEchoregPointToSurfaceDistance::SetSignedDistance(bool enabled) {
  if (this->SignedDistance == enabled)
    return;
  this->SignedDistance = enabled;
  this->Modified();
}

void vtkEchoregPointToSurfaceDistance::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregPointToSurfaceDistance::FillInputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), port == 0 ? "vtkPointSet" : "vtkPolyData");
  return 1;
}

int vtkEchoregPointToSurfaceDistance::RequestData(vtkInformation* /*request*/,
                                                  vtkInformationVector** inputVector,
                                                  vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkPointSet* points = vtkPointSet::GetData(inputVector[0]);
  vtkPolyData* surface = vtkPolyData::GetData(inputVector[1]);
  vtkPolyData* output = vtkPolyData::GetData(outputVector);
  if (points == nullptr || surface == nullptr || output == nullptr) {
    this->Fail("needs points on input 0 and a surface (vtkPolyData) on input 1");
    return 0;
  }
  // The locator is the expensive part: rebuilt only for a new or modified surface.
  if (!this->Locator || this->LocatorSurface != surface ||
      this->LocatorSurfaceTime != surface->GetMTime()) {
    this->Locator.reset();
    try {
      echoreg::core::TriangleMesh mesh = echoreg::filters::toTriangleMesh(surface);
      if (mesh.triangles.empty())
        throw std::invalid_argument("the surface has no triangles");
      this->Locator = std::make_unique<echoreg::core::MeshLocator>(std::move(mesh));
    } catch (const std::exception& exception) {
      this->Fail(std::string("bad surface: ") + exception.what());
      return 0;
    }
    this->LocatorSurface = surface;
    this->LocatorSurfaceTime = surface->GetMTime();
    ++this->LocatorBuildCount;
  }

  const vtkIdType count = points->GetNumberOfPoints();
  output->Initialize();
  if (count == 0) {
    vtkWarningMacro(<< "no points to measure");
    this->LastResult = Result();
    this->LastError.clear();
    return 1;
  }
  // The input's precision: a vtkPoints is float by default, and DeepCopy of double points into it
  // rounds them (which moved the registration figure's spheres by a fraction of a pixel).
  vtkNew<vtkPoints> outputPoints;
  outputPoints->SetDataType(points->GetPoints()->GetDataType());
  outputPoints->DeepCopy(points->GetPoints());
  vtkNew<vtkDoubleArray> distances;
  distances->SetName("DistanceMm");
  distances->SetNumberOfValues(count);
  vtkNew<vtkDoubleArray> closest;
  closest->SetName("ClosestPointMm");
  closest->SetNumberOfComponents(3);
  closest->SetNumberOfTuples(count);
  const echoreg::core::MeshLocator& locator = *this->Locator;
  const bool signedDistance = this->SignedDistance;
  vtkSMPTools::For(0, count, [&](vtkIdType begin, vtkIdType end) {
    for (vtkIdType id = begin; id < end; ++id) {
      double p[3];
      points->GetPoint(id, p);
      const Eigen::Vector3d point(p[0], p[1], p[2]);
      const echoreg::core::ClosestPoint nearest = locator.closest(point);
      double distance = nearest.distance;
      if (signedDistance && locator.inside(point))
        distance = -distance;
      distances->SetValue(id, distance);
      closest->SetTypedTuple(id, nearest.point.data());
    }
  });

  Result result;
  result.count = static_cast<int>(count);
  double sumSquares = 0.0, sum = 0.0;
  for (vtkIdType id = 0; id < count; ++id) {
    const double d = distances->GetValue(id);
    sumSquares += d * d;
    sum += d;
    result.maxMm = std::max(result.maxMm, std::fabs(d));
  }
  result.rmsMm = std::sqrt(sumSquares / static_cast<double>(count));
  result.meanMm = sum / static_cast<double>(count);

  output->SetPoints(outputPoints);
  vtkNew<vtkCellArray> vertices;
  for (vtkIdType id = 0; id < count; ++id)
    vertices->InsertNextCell(1, &id);
  output->SetVerts(vertices);
  output->GetPointData()->ShallowCopy(points->GetPointData());
  output->GetPointData()->AddArray(distances);
  output->GetPointData()->AddArray(closest);
  output->GetPointData()->SetActiveScalars("DistanceMm");
  output->GetFieldData()->ShallowCopy(points->GetFieldData());
  addValue(output->GetFieldData(), "DistanceRmsMm", result.rmsMm);
  addValue(output->GetFieldData(), "DistanceMeanMm", result.meanMm);
  addValue(output->GetFieldData(), "DistanceMaxMm", result.maxMm);
  vtkNew<vtkIntArray> countArray;
  countArray->SetName("DistanceCount");
  countArray->InsertNextValue(result.count);
  output->GetFieldData()->AddArray(countArray);
  this->LastResult = result;
  this->LastError.clear();
  return 1;
}

void vtkEchoregPointToSurfaceDistance::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "SignedDistance: " << (this->SignedDistance ? "On" : "Off") << "\n";
  os << indent << "LastResult: " << this->LastResult.count << " points, RMS "
     << this->LastResult.rmsMm << " mm, mean " << this->LastResult.meanMm << " mm, max "
     << this->LastResult.maxMm << " mm\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
  os << indent << "LocatorBuildCount: " << this->LocatorBuildCount << "\n";
}
