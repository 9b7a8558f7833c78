// Pipeline requests shared by the A-line filters.
#pragma once

#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkStreamingDemandDrivenPipeline.h>

namespace echoreg::filters {

/// Asks the first input for its whole extent: every A-line filter needs whole records (and the
/// peak filter every frame, one table row each), never a piece.
inline void requestWholeInput(vtkInformationVector** inputVector) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int wholeExtent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), wholeExtent);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), wholeExtent, 6);
}

}  // namespace echoreg::filters
