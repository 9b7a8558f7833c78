/**
 * @class   vtkEchoregBoneGrowthFilter
 * @brief   The bone that contains a seed point, grown in a CT (the automatic start of a specimen).
 *
 * A thin adapter over echoreg::segmentation::growBone (docs/segmentation.md): hysteresis
 * threshold (StrongHu, WeakHu), bridges between bones in contact cut by an erosion of
 * SeparationRadiusMm, marrow filled, the component of the seed kept.
 *
 * Input (port 0): the CT, vtkImageData of HU with origin, spacing and direction (LPS), uniform,
 * as vtkEchoregDicomSeriesReader makes it (one slice group; see its Group option).
 * Output 0: the bone's mask, vtkImageData of uint8 0/1 "BoneMask" on the CT's grid. Output 1:
 * "OtherBones", the bone voxels nearer another bone (vtkEchoregBoneSurfaceFilter's exclusion).
 * Field data of output 0: "VolumeMm3", "SeedHu", "SeedVoxel" (3 ints); GetLastResult() the same.
 * A seed outside the volume or not in bone, or a bone below MinVolumeMm3, is an error through
 * the executive with growBone's sentence.
 *
 * Defaults: those of echoreg::segmentation::GrowOptions (600 / 200 HU, 2.4 mm, 500 mm^3); seed
 * at the LPS origin.
 */
#pragma once

#include "echoreg/segmentation/bone_mask.hpp"

#include <vtkImageAlgorithm.h>

#include <string>

class vtkEchoregBoneGrowthFilter : public vtkImageAlgorithm {
 public:
  static vtkEchoregBoneGrowthFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregBoneGrowthFilter, vtkImageAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /// The seed, CT patient coordinates (LPS), mm.
  void SetSeedLps(double x, double y, double z);
  const Eigen::Vector3d& GetSeedLps() const { return this->SeedLps; }
  ///@}

  ///@{
  /// Cortical (StrongHu) and cancellous / partial-volume (WeakHu <= StrongHu) thresholds, HU.
  void SetStrongHu(double hu);
  double GetStrongHu() const { return this->Options.threshold.strongHu; }
  void SetWeakHu(double hu);
  double GetWeakHu() const { return this->Options.threshold.weakHu; }
  ///@}

  ///@{
  /// Radius of the erosion that separates bones in contact, mm (>= 0; 0: none). Default 2.4.
  void SetSeparationRadiusMm(double mm);
  double GetSeparationRadiusMm() const { return this->Options.separationRadiusMm; }
  ///@}

  ///@{
  /// Smallest acceptable bone, mm^3. Default 500.
  void SetMinVolumeMm3(double mm3);
  double GetMinVolumeMm3() const { return this->Options.minVolumeMm3; }
  ///@}

  struct Result {
    double volumeMm3 = 0.0;
    int seedHu = 0;
    Eigen::Vector3i seedVoxel = Eigen::Vector3i::Zero();
    std::size_t voxels = 0;
  };
  const Result& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregBoneGrowthFilter();
  ~vtkEchoregBoneGrowthFilter() override;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
                          vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregBoneGrowthFilter(const vtkEchoregBoneGrowthFilter&) = delete;
  void operator=(const vtkEchoregBoneGrowthFilter&) = delete;

  void SetOption(double& field, double value);
  void Fail(const std::string& message);

  Eigen::Vector3d SeedLps = Eigen::Vector3d::Zero();
  echoreg::segmentation::GrowOptions Options;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
