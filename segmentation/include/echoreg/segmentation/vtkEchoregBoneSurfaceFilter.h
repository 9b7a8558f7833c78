/**
 * @class   vtkEchoregBoneSurfaceFilter
 * @brief   The sub-voxel bone surface: the CT's iso-surface around a region mask.
 *
 * A thin adapter over echoreg::segmentation::boneSurface (docs/segmentation.md): within BandMm
 * of the region the CT decides where the surface lies (the iso level half way between the
 * cortex and the soft tissue, or IsoHu), so the surface is not bound to the voxel grid; then
 * windowed-sinc smoothing and optional decimation, closed pieces below MinComponentMm3 dropped.
 *
 * Input 0: the CT (vtkImageData of HU, uniform, LPS geometry). Input 1: the region, a mask image
 * on the CT's grid (vtkEchoregBoneGrowthFilter's output 0, or a live-wire mask). Input 2
 * (optional): voxels of other bones, counted as soft tissue (vtkEchoregBoneGrowthFilter's
 * output 1).
 * Output: vtkPolyData, closed, wound outward, CT LPS mm, with point normals. Field data:
 * "IsoHu", "CortexHu", "SoftTissueHu", "Components", "DroppedComponents"; GetLastResult().
 *
 * Defaults: those of echoreg::segmentation::BoneSurfaceOptions.
 */
#pragma once

#include "echoreg/segmentation/bone_surface.hpp"

#include <vtkPolyDataAlgorithm.h>

#include <string>

class vtkEchoregBoneSurfaceFilter : public vtkPolyDataAlgorithm {
 public:
  static vtkEchoregBoneSurfaceFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregBoneSurfaceFilter, vtkPolyDataAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  void SetRegionConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetExcludeConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(2, output); }

  ///@{
  /// Iso level, HU; 0 (the default) measures it half way between cortex and soft tissue.
  void SetIsoHu(double hu);
  double GetIsoHu() const { return this->Options.isoHu; }
  ///@}

  ///@{
  /// Smoothing iterations (>= 0; 0: none). Default 10.
  void SetSmoothingIterations(int iterations);
  int GetSmoothingIterations() const { return this->Options.smoothingIterations; }
  ///@}

  ///@{
  /// Every option at once.
  void SetOptions(const echoreg::segmentation::BoneSurfaceOptions& options);
  const echoreg::segmentation::BoneSurfaceOptions& GetOptions() const { return this->Options; }
  ///@}

  /// The last result without its mesh (which is the output).
  const echoreg::segmentation::BoneSurfaceResult& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregBoneSurfaceFilter();
  ~vtkEchoregBoneSurfaceFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregBoneSurfaceFilter(const vtkEchoregBoneSurfaceFilter&) = delete;
  void operator=(const vtkEchoregBoneSurfaceFilter&) = delete;

  void Fail(const std::string& message);

  echoreg::segmentation::BoneSurfaceOptions Options;
  echoreg::segmentation::BoneSurfaceResult LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
