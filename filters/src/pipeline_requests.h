// Pipeline requests shared by the A-line filters.
#pragma once

#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>

namespace echoreg::filters {

/// Asks the first input for its whole extent: every frame, each whole.
inline void requestWholeInput(vtkInformationVector** inputVector) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  int wholeExtent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), wholeExtent);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), wholeExtent, 6);
}

/// Asks the first input for whole records (every sample along x) of the frames (y) asked of the
/// first output: the whole capture, or one block of frames when a downstream filter streams it.
inline void requestWholeRecords(vtkInformationVector** inputVector,
                                vtkInformationVector* outputVector) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  int extent[6];
  inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  if (outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT())) {
    int requested[6];
    outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), requested);
    if (requested[2] <= requested[3] && requested[2] >= extent[2] && requested[3] <= extent[3]) {
      extent[2] = requested[2];
      extent[3] = requested[3];
    }
  }
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), extent, 6);
}

/// Narrows the frames (y) of `extent` to those asked of the first output, when it asks for a
/// non-empty part of them; the samples (x) are kept.
inline void clampToRequestedFrames(vtkInformationVector* outputVector, int extent[6]) {
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  if (!outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT()))
    return;
  int requested[6];
  outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), requested);
  const int first = std::max(extent[2], requested[2]);
  const int last = std::min(extent[3], requested[3]);
  if (first <= last) {
    extent[2] = first;
    extent[3] = last;
  }
}

}  // namespace echoreg::filters
