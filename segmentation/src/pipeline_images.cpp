#include "pipeline_images.hpp"

#include <vtkDataArray.h>
#include <vtkDataObject.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMatrix3x3.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkUnsignedCharArray.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace echoreg::segmentation::pipeline {

core::CtImage ctImageOf(vtkImageData* image, bool withVoxels) {
  if (image == nullptr)
    throw std::invalid_argument("no CT image");
  core::CtImage ct;
  int dimensions[3];
  image->GetDimensions(dimensions);
  if (dimensions[0] <= 0 || dimensions[1] <= 0 || dimensions[2] <= 0)
    throw std::invalid_argument("the CT image has no voxels");
  ct.dimensions = {dimensions[0], dimensions[1], dimensions[2]};
  const double* origin = image->GetOrigin();
  ct.originMm = Eigen::Vector3d(origin[0], origin[1], origin[2]);
  vtkMatrix3x3* direction = image->GetDirectionMatrix();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      ct.direction(r, c) = direction->GetElement(r, c);
  }
  const double* spacing = image->GetSpacing();
  ct.pixelSpacingMm = Eigen::Vector2d(spacing[0], spacing[1]);
  ct.slicePositionsMm.resize(static_cast<std::size_t>(dimensions[2]));
  for (int k = 0; k < dimensions[2]; ++k)
    ct.slicePositionsMm[static_cast<std::size_t>(k)] = k * spacing[2];
  ct.groups = {core::CtSliceGroup{0, dimensions[2], dimensions[2] > 1 ? spacing[2] : 0.0}};
  if (!withVoxels)
    return ct;
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  if (scalars == nullptr || scalars->GetNumberOfComponents() != 1 ||
      static_cast<std::size_t>(scalars->GetNumberOfTuples()) != ct.voxelCount()) {
    throw std::invalid_argument("the CT image needs one-component scalars (HU) on every voxel");
  }
  ct.hu.resize(ct.voxelCount());
  if (scalars->GetDataType() == VTK_SHORT) {
    std::memcpy(ct.hu.data(), scalars->GetVoidPointer(0), ct.hu.size() * sizeof(std::int16_t));
  } else {
    for (std::size_t v = 0; v < ct.hu.size(); ++v) {
      ct.hu[v] = static_cast<std::int16_t>(
          std::lround(scalars->GetComponent(static_cast<vtkIdType>(v), 0)));
    }
  }
  return ct;
}

vtkSmartPointer<vtkImageData> maskImageOf(const VoxelMask& mask, const char* name) {
  auto image = vtkSmartPointer<vtkImageData>::New();
  const core::CtImage& grid = mask.geometry;
  image->SetDimensions(grid.dimensions[0], grid.dimensions[1], grid.dimensions[2]);
  const Eigen::Vector3d spacing = grid.spacingMm();
  image->SetSpacing(spacing.x(), spacing.y(), spacing.z());
  image->SetOrigin(grid.originMm.x(), grid.originMm.y(), grid.originMm.z());
  double direction[9];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      direction[3 * r + c] = grid.direction(r, c);
  }
  image->SetDirectionMatrix(direction);
  auto voxels = vtkSmartPointer<vtkUnsignedCharArray>::New();
  voxels->SetName(name);
  voxels->SetNumberOfValues(static_cast<vtkIdType>(mask.voxels.size()));
  std::memcpy(voxels->GetPointer(0), mask.voxels.data(), mask.voxels.size());
  image->GetPointData()->SetScalars(voxels);
  return image;
}

VoxelMask voxelMaskOf(vtkImageData* image, const core::CtImage& grid) {
  if (image == nullptr)
    throw std::invalid_argument("no mask image");
  int dimensions[3];
  image->GetDimensions(dimensions);
  if (dimensions[0] != grid.dimensions[0] || dimensions[1] != grid.dimensions[1] ||
      dimensions[2] != grid.dimensions[2]) {
    throw std::invalid_argument("the mask's grid differs from the CT's");
  }
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  if (scalars == nullptr ||
      static_cast<std::size_t>(scalars->GetNumberOfTuples()) != grid.voxelCount()) {
    throw std::invalid_argument("the mask image needs scalars on every voxel");
  }
  VoxelMask mask = emptyMask(grid);
  for (std::size_t v = 0; v < mask.voxels.size(); ++v)
    mask.voxels[v] = scalars->GetComponent(static_cast<vtkIdType>(v), 0) != 0.0 ? 1 : 0;
  return mask;
}

void masksOnInputGrid(vtkInformationVector** inputVector, vtkInformationVector* outputVector,
                      int ports) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  for (int port = 0; port < ports; ++port) {
    vtkInformation* outInfo = outputVector->GetInformationObject(port);
    outInfo->CopyEntry(inInfo, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    outInfo->CopyEntry(inInfo, vtkDataObject::SPACING());
    outInfo->CopyEntry(inInfo, vtkDataObject::ORIGIN());
    outInfo->CopyEntry(inInfo, vtkDataObject::DIRECTION());
    vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_UNSIGNED_CHAR, 1);
  }
}

void requestWholeInput(vtkInformationVector** inputVector) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int wholeExtent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), wholeExtent);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), wholeExtent, 6);
}

}  // namespace echoreg::segmentation::pipeline
