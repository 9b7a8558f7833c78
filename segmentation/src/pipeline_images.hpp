// CT images and masks between the pipeline (vtkImageData) and the segmentation functions
// (core::CtImage, VoxelMask), for the segmentation algorithms' adapters.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/segmentation/bone_mask.hpp"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

class vtkInformationVector;

namespace echoreg::segmentation::pipeline {

/// The uniform core::CtImage of a vtkImageData as vtkEchoregDicomSeriesReader / toImageData make
/// it: one-component scalars (HU, converted to int16 when of another type), spacing, origin (the
/// centre of voxel 0, LPS) and direction matrix. With `withVoxels` false only the geometry.
/// Throws std::invalid_argument for an image without voxels or scalars.
core::CtImage ctImageOf(vtkImageData* image, bool withVoxels = true);

/// A mask image (uint8 0/1 scalars named `name`) on the mask's grid.
vtkSmartPointer<vtkImageData> maskImageOf(const VoxelMask& mask, const char* name);

/// The mask of an image's scalars (non-zero = inside) on the grid of `grid`; throws
/// std::invalid_argument when the dimensions differ.
VoxelMask voxelMaskOf(vtkImageData* image, const core::CtImage& grid);

/// RequestInformation of an algorithm whose first `ports` outputs are uint8 masks on its input's
/// grid: copies the whole extent, spacing, origin and direction of input 0 to each of them.
void masksOnInputGrid(vtkInformationVector** inputVector, vtkInformationVector* outputVector,
                      int ports);

/// RequestUpdateExtent of an algorithm that needs the whole of input 0 (a region grows anywhere).
void requestWholeInput(vtkInformationVector** inputVector);

}  // namespace echoreg::segmentation::pipeline
