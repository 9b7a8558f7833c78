#include "echoreg/segmentation/vtkEchoregCompetingBonesFilter.h"

#include "pipeline_images.hpp"

#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>

#include <algorithm>
#include <exception>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregCompetingBonesFilter);

vtkEchoregCompetingBonesFilter::vtkEchoregCompetingBonesFilter() {
  this->SetNumberOfOutputPorts(3);
}

vtkEchoregCompetingBonesFilter::~vtkEchoregCompetingBonesFilter() = default;

void vtkEchoregCompetingBonesFilter::AddSeed(const std::string& bone, double x, double y,
                                             double z) {
  this->Seeds.push_back({bone, Eigen::Vector3d(x, y, z)});
  this->Modified();
}

void vtkEchoregCompetingBonesFilter::RemoveAllSeeds() {
  if (this->Seeds.empty())
    return;
  this->Seeds.clear();
  this->Modified();
}

void vtkEchoregCompetingBonesFilter::SetSelectedBone(const std::string& bone) {
  if (this->SelectedBone == bone)
    return;
  this->SelectedBone = bone;
  this->Modified();
}

void vtkEchoregCompetingBonesFilter::SetCheckPlausible(bool check) {
  if (this->Options.checkPlausible == check)
    return;
  this->Options.checkPlausible = check;
  this->Modified();
}

void vtkEchoregCompetingBonesFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregCompetingBonesFilter::RequestInformation(vtkInformation* /*request*/,
                                                       vtkInformationVector** inputVector,
                                                       vtkInformationVector* outputVector) {
  echoreg::segmentation::pipeline::masksOnInputGrid(inputVector, outputVector, 3);
  return 1;
}

int vtkEchoregCompetingBonesFilter::RequestUpdateExtent(vtkInformation* /*request*/,
                                                        vtkInformationVector** inputVector,
                                                        vtkInformationVector* /*outputVector*/) {
  echoreg::segmentation::pipeline::requestWholeInput(inputVector);
  return 1;
}

int vtkEchoregCompetingBonesFilter::RequestData(vtkInformation* /*request*/,
                                                vtkInformationVector** inputVector,
                                                vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkImageData* selected = vtkImageData::GetData(outputVector, 0);
  vtkImageData* exclude = vtkImageData::GetData(outputVector, 1);
  vtkImageData* labels = vtkImageData::GetData(outputVector, 2);
  if (input == nullptr || selected == nullptr || exclude == nullptr || labels == nullptr) {
    this->Fail("the input and the outputs must be vtkImageData");
    return 0;
  }
  namespace seg = echoreg::segmentation;
  seg::CompetingResult competing;
  std::size_t chosen = 0;
  try {
    if (this->Seeds.empty())
      throw std::invalid_argument("no seeds (AddSeed)");
    const echoreg::core::CtImage ct = seg::pipeline::ctImageOf(input);
    competing = seg::segmentCompetingBones(ct, this->Seeds, this->Options);
    if (!this->SelectedBone.empty()) {
      const auto it =
          std::find_if(competing.bones.begin(), competing.bones.end(),
                       [&](const seg::SegmentedBone& b) { return b.bone == this->SelectedBone; });
      if (it == competing.bones.end())
        throw std::invalid_argument("SelectedBone \"" + this->SelectedBone + "\" has no seed");
      chosen = static_cast<std::size_t>(it - competing.bones.begin());
    }
  } catch (const std::exception& exception) {
    this->Fail(std::string("bone segmentation failed: ") + exception.what());
    return 0;
  }
  seg::VoxelMask excluded = seg::unite(competing.unnamed, competing.metalMask);
  seg::VoxelMask labelled = seg::emptyMask(competing.threshold.geometry);
  Result result;
  result.automaticNeighbours = competing.automaticNeighbours;
  result.metalPieces = competing.metal.size();
  for (std::size_t b = 0; b < competing.bones.size(); ++b) {
    const seg::SegmentedBone& bone = competing.bones[b];
    result.bones.push_back(bone.bone);
    result.volumesMm3.push_back(bone.volumeMm3);
    if (b != chosen)
      excluded = seg::unite(excluded, bone.mask);
    for (std::size_t v = 0; v < bone.mask.voxels.size(); ++v) {
      if (bone.mask.voxels[v] != 0)
        labelled.voxels[v] = static_cast<std::uint8_t>(b + 1);
    }
  }
  selected->ShallowCopy(seg::pipeline::maskImageOf(competing.bones[chosen].mask, "BoneMask"));
  exclude->ShallowCopy(seg::pipeline::maskImageOf(excluded, "Exclude"));
  labels->ShallowCopy(seg::pipeline::maskImageOf(labelled, "BoneLabel"));
  vtkNew<vtkStringArray> names;
  names->SetName("Bones");
  vtkNew<vtkDoubleArray> volumes;
  volumes->SetName("VolumeMm3");
  for (std::size_t b = 0; b < result.bones.size(); ++b) {
    names->InsertNextValue(result.bones[b]);
    volumes->InsertNextValue(result.volumesMm3[b]);
  }
  selected->GetFieldData()->AddArray(names);
  selected->GetFieldData()->AddArray(volumes);
  this->LastResult = std::move(result);
  this->LastError.clear();
  return 1;
}

void vtkEchoregCompetingBonesFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Seeds:";
  for (const auto& seed : this->Seeds)
    os << " " << seed.bone << " (" << seed.pointLps.transpose() << ")";
  os << "\n";
  os << indent << "SelectedBone: " << (this->SelectedBone.empty() ? "(first)" : this->SelectedBone)
     << "\n";
  os << indent << "CheckPlausible: " << (this->Options.checkPlausible ? "On" : "Off") << "\n";
  os << indent << "StrongHu: " << this->Options.threshold.strongHu << "\n";
  os << indent << "WeakHu: " << this->Options.threshold.weakHu << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
