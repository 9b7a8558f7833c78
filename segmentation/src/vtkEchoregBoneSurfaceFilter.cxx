#include "echoreg/segmentation/vtkEchoregBoneSurfaceFilter.h"

#include "pipeline_images.hpp"

#include "echoreg/filters/mesh_io.h"

#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPolyData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <exception>
#include <optional>

vtkStandardNewMacro(vtkEchoregBoneSurfaceFilter);

namespace {

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

}  // namespace

vtkEchoregBoneSurfaceFilter::vtkEchoregBoneSurfaceFilter() {
  this->SetNumberOfInputPorts(3);
}

vtkEchoregBoneSurfaceFilter::~vtkEchoregBoneSurfaceFilter() = default;

void vtkEchoregBoneSurfaceFilter::SetIsoHu(double hu) {
  if (this->Options.isoHu == hu)
    return;
  this->Options.isoHu = hu;
  this->Modified();
}

void vtkEchoregBoneSurfaceFilter::SetSmoothingIterations(int iterations) {
  if (this->Options.smoothingIterations == iterations)
    return;
  this->Options.smoothingIterations = iterations;
  this->Modified();
}

void vtkEchoregBoneSurfaceFilter::SetOptions(
    const echoreg::segmentation::BoneSurfaceOptions& options) {
  this->Options = options;
  this->Modified();
}

void vtkEchoregBoneSurfaceFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregBoneSurfaceFilter::FillInputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port == 2)
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  return 1;
}

int vtkEchoregBoneSurfaceFilter::RequestData(vtkInformation* /*request*/,
                                             vtkInformationVector** inputVector,
                                             vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkImageData* ctImage = vtkImageData::GetData(inputVector[0]);
  vtkImageData* regionImage = vtkImageData::GetData(inputVector[1]);
  vtkImageData* excludeImage = inputVector[2]->GetNumberOfInformationObjects() > 0
                                   ? vtkImageData::GetData(inputVector[2])
                                   : nullptr;
  vtkPolyData* output = vtkPolyData::GetData(outputVector);
  if (ctImage == nullptr || regionImage == nullptr || output == nullptr) {
    this->Fail("needs the CT on input 0 and the region mask on input 1");
    return 0;
  }
  echoreg::segmentation::BoneSurfaceResult result;
  try {
    namespace pipeline = echoreg::segmentation::pipeline;
    const echoreg::core::CtImage ct = pipeline::ctImageOf(ctImage);
    const echoreg::segmentation::VoxelMask region = pipeline::voxelMaskOf(regionImage, ct);
    std::optional<echoreg::segmentation::VoxelMask> exclude;
    if (excludeImage != nullptr)
      exclude = pipeline::voxelMaskOf(excludeImage, ct);
    result = echoreg::segmentation::boneSurface(ct, region, exclude ? &*exclude : nullptr,
                                                this->Options);
  } catch (const std::exception& exception) {
    this->Fail(std::string("bone surface failed: ") + exception.what());
    return 0;
  }
  output->ShallowCopy(echoreg::filters::toPolyData(result.mesh));
  vtkFieldData* fieldData = output->GetFieldData();
  addValue(fieldData, "IsoHu", result.isoHu);
  addValue(fieldData, "CortexHu", result.cortexHu);
  addValue(fieldData, "SoftTissueHu", result.softTissueHu);
  addValue(fieldData, "Components", result.components);
  addValue(fieldData, "DroppedComponents", result.droppedComponents);
  result.mesh = echoreg::core::TriangleMesh();  // the output holds it
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregBoneSurfaceFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "IsoHu: " << this->Options.isoHu << "\n";
  os << indent << "CortexMinHu: " << this->Options.cortexMinHu << "\n";
  os << indent << "BandMm: " << this->Options.bandMm << "\n";
  os << indent << "InteriorMm: " << this->Options.interiorMm << "\n";
  os << indent << "SmoothingIterations: " << this->Options.smoothingIterations << "\n";
  os << indent << "PassBand: " << this->Options.passBand << "\n";
  os << indent << "TargetTriangles: " << this->Options.targetTriangles << "\n";
  os << indent << "MinComponentMm3: " << this->Options.minComponentMm3 << "\n";
  os << indent << "LastResult: iso " << this->LastResult.isoHu << " HU, "
     << this->LastResult.components << " pieces\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
