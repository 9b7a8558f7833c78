/**
 * @class   vtkEchoregCompetingBonesFilter
 * @brief   Bones in contact segmented against each other from one seed each (issue 13's method).
 *
 * A thin adapter over echoreg::segmentation::segmentCompetingBones (docs/segmentation.md): the
 * seeded bones (AddSeed, several seeds may name one bone) grow against each other and against
 * the neighbours found automatically, split at the joint lines. One bone is the output's region
 * (SelectedBone, default the first seeded); everything the surface must not snap to (the other
 * named bones, the unnamed neighbours, metal) is the exclusion.
 *
 * Input (port 0): the CT, vtkImageData of HU, uniform, LPS geometry.
 * Output 0: the selected bone's mask (uint8 "BoneMask"). Output 1: the exclusion ("Exclude"),
 * vtkEchoregBoneSurfaceFilter's input 2. Output 2: a label image (uint8 "BoneLabel": 0 none,
 * n for the n-th bone in seed order). Field data of output 0: "Bones" (names in order) and
 * "VolumeMm3" (one value per bone); GetLastResult() the core's result without its masks.
 * A seed outside bone, two bones' seeds in one bone, an implausible bone (with
 * CheckPlausible on) are errors through the executive with the core's sentence.
 *
 * Defaults: no seeds, the first bone selected, those of CompetingOptions.
 */
#pragma once

#include "echoreg/segmentation/bone_labels.hpp"

#include <vtkImageAlgorithm.h>

#include <string>
#include <vector>

class vtkEchoregCompetingBonesFilter : public vtkImageAlgorithm {
 public:
  static vtkEchoregCompetingBonesFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregCompetingBonesFilter, vtkImageAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /// Seeds: a bone's name and a point inside it (LPS, mm).
  void AddSeed(const std::string& bone, double x, double y, double z);
  void RemoveAllSeeds();
  const std::vector<echoreg::segmentation::BoneSeed>& GetSeeds() const { return this->Seeds; }
  ///@}

  ///@{
  /// The bone on output 0; empty (the default) selects the first seeded bone.
  void SetSelectedBone(const std::string& bone);
  const std::string& GetSelectedBone() const { return this->SelectedBone; }
  ///@}

  ///@{
  /// Check each bone's volume and extent against what its name can be. Default on.
  void SetCheckPlausible(bool check);
  bool GetCheckPlausible() const { return this->Options.checkPlausible; }
  ///@}

  /// Names and volumes of the last run's bones.
  struct Result {
    std::vector<std::string> bones;
    std::vector<double> volumesMm3;
    int automaticNeighbours = 0;
    std::size_t metalPieces = 0;
  };
  const Result& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregCompetingBonesFilter();
  ~vtkEchoregCompetingBonesFilter() override;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
                          vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregCompetingBonesFilter(const vtkEchoregCompetingBonesFilter&) = delete;
  void operator=(const vtkEchoregCompetingBonesFilter&) = delete;

  void Fail(const std::string& message);

  std::vector<echoreg::segmentation::BoneSeed> Seeds;
  std::string SelectedBone;
  echoreg::segmentation::CompetingOptions Options;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
