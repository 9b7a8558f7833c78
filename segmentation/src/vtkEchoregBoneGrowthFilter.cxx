#include "echoreg/segmentation/vtkEchoregBoneGrowthFilter.h"

#include "pipeline_images.hpp"

#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <exception>

vtkStandardNewMacro(vtkEchoregBoneGrowthFilter);

vtkEchoregBoneGrowthFilter::vtkEchoregBoneGrowthFilter() {
  this->SetNumberOfOutputPorts(2);
}

vtkEchoregBoneGrowthFilter::~vtkEchoregBoneGrowthFilter() = default;

void vtkEchoregBoneGrowthFilter::SetSeedLps(double x, double y, double z) {
  const Eigen::Vector3d seed(x, y, z);
  if (this->SeedLps == seed)
    return;
  this->SeedLps = seed;
  this->Modified();
}

void vtkEchoregBoneGrowthFilter::SetOption(double& field, double value) {
  if (field == value)
    return;
  field = value;
  this->Modified();
}

void vtkEchoregBoneGrowthFilter::SetStrongHu(double hu) {
  this->SetOption(this->Options.threshold.strongHu, hu);
}
void vtkEchoregBoneGrowthFilter::SetWeakHu(double hu) {
  this->SetOption(this->Options.threshold.weakHu, hu);
}
void vtkEchoregBoneGrowthFilter::SetSeparationRadiusMm(double mm) {
  this->SetOption(this->Options.separationRadiusMm, mm);
}
void vtkEchoregBoneGrowthFilter::SetMinVolumeMm3(double mm3) {
  this->SetOption(this->Options.minVolumeMm3, mm3);
}

void vtkEchoregBoneGrowthFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregBoneGrowthFilter::RequestInformation(vtkInformation* /*request*/,
                                                   vtkInformationVector** inputVector,
                                                   vtkInformationVector* outputVector) {
  // Both outputs lie on the CT's grid, as uint8 masks.
  echoreg::segmentation::pipeline::masksOnInputGrid(inputVector, outputVector, 2);
  return 1;
}

int vtkEchoregBoneGrowthFilter::RequestUpdateExtent(vtkInformation* /*request*/,
                                                    vtkInformationVector** inputVector,
                                                    vtkInformationVector* /*outputVector*/) {
  echoreg::segmentation::pipeline::requestWholeInput(inputVector);
  return 1;
}

int vtkEchoregBoneGrowthFilter::RequestData(vtkInformation* /*request*/,
                                            vtkInformationVector** inputVector,
                                            vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkImageData* mask = vtkImageData::GetData(outputVector, 0);
  vtkImageData* others = vtkImageData::GetData(outputVector, 1);
  if (input == nullptr || mask == nullptr || others == nullptr) {
    this->Fail("the input and the outputs must be vtkImageData");
    return 0;
  }
  echoreg::segmentation::GrowResult grown;
  try {
    const echoreg::core::CtImage ct = echoreg::segmentation::pipeline::ctImageOf(input);
    grown = echoreg::segmentation::growBone(ct, this->SeedLps, this->Options);
  } catch (const std::exception& exception) {
    this->Fail(std::string("bone growth failed: ") + exception.what());
    mask->Initialize();
    others->Initialize();
    return 0;
  }
  mask->ShallowCopy(echoreg::segmentation::pipeline::maskImageOf(grown.mask, "BoneMask"));
  others->ShallowCopy(echoreg::segmentation::pipeline::maskImageOf(grown.others, "OtherBones"));

  Result result;
  result.volumeMm3 = grown.volumeMm3;
  result.seedHu = grown.seedHu;
  result.seedVoxel = grown.seedVoxel;
  result.voxels = grown.mask.count();
  vtkNew<vtkDoubleArray> volume;
  volume->SetName("VolumeMm3");
  volume->InsertNextValue(result.volumeMm3);
  mask->GetFieldData()->AddArray(volume);
  vtkNew<vtkIntArray> seedHu;
  seedHu->SetName("SeedHu");
  seedHu->InsertNextValue(result.seedHu);
  mask->GetFieldData()->AddArray(seedHu);
  vtkNew<vtkIntArray> seedVoxel;
  seedVoxel->SetName("SeedVoxel");
  seedVoxel->SetNumberOfComponents(3);
  seedVoxel->InsertNextTypedTuple(result.seedVoxel.data());
  mask->GetFieldData()->AddArray(seedVoxel);
  this->LastResult = result;
  this->LastError.clear();
  return 1;
}

void vtkEchoregBoneGrowthFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "SeedLps: " << this->SeedLps.transpose() << "\n";
  os << indent << "StrongHu: " << this->Options.threshold.strongHu << "\n";
  os << indent << "WeakHu: " << this->Options.threshold.weakHu << "\n";
  os << indent << "SeparationRadiusMm: " << this->Options.separationRadiusMm << "\n";
  os << indent << "MinVolumeMm3: " << this->Options.minVolumeMm3 << "\n";
  os << indent << "LastResult: " << this->LastResult.voxels << " voxels, "
     << this->LastResult.volumeMm3 << " mm^3\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
