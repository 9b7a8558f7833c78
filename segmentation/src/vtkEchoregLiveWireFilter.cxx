#include "echoreg/segmentation/vtkEchoregLiveWireFilter.h"

#include "pipeline_images.hpp"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>

#include <exception>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregLiveWireFilter);

vtkEchoregLiveWireFilter::vtkEchoregLiveWireFilter() {
  this->SetNumberOfOutputPorts(2);
}

vtkEchoregLiveWireFilter::~vtkEchoregLiveWireFilter() = default;

void vtkEchoregLiveWireFilter::SetAnchors(
    const std::vector<echoreg::segmentation::AnchorSet>& anchors) {
  this->Anchors = anchors;
  this->Modified();
}

void vtkEchoregLiveWireFilter::SetAnchorsFileName(const std::string& path) {
  this->AnchorsFileName = path;
  this->Modified();  // the same name again re-reads the file
}

void vtkEchoregLiveWireFilter::SetSubpixelRefine(bool refine) {
  if (this->ContourOptions.subpixelRefine == refine)
    return;
  this->ContourOptions.subpixelRefine = refine;
  this->Modified();
}

void vtkEchoregLiveWireFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregLiveWireFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkEchoregLiveWireFilter::FillOutputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkPolyData" : "vtkImageData");
  return 1;
}

int vtkEchoregLiveWireFilter::RequestInformation(vtkInformation* /*request*/,
                                                 vtkInformationVector** inputVector,
                                                 vtkInformationVector* outputVector) {
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  vtkInformation* maskInfo = outputVector->GetInformationObject(1);
  maskInfo->CopyEntry(inInfo, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
  maskInfo->CopyEntry(inInfo, vtkDataObject::SPACING());
  maskInfo->CopyEntry(inInfo, vtkDataObject::ORIGIN());
  maskInfo->CopyEntry(inInfo, vtkDataObject::DIRECTION());
  vtkDataObject::SetPointDataActiveScalarInfo(maskInfo, VTK_UNSIGNED_CHAR, 1);
  return 1;
}

int vtkEchoregLiveWireFilter::RequestData(vtkInformation* /*request*/,
                                          vtkInformationVector** inputVector,
                                          vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkPolyData* contoursOutput = vtkPolyData::GetData(outputVector, 0);
  vtkImageData* maskOutput = vtkImageData::GetData(outputVector, 1);
  if (input == nullptr || contoursOutput == nullptr || maskOutput == nullptr) {
    this->Fail("needs the CT (vtkImageData) on input 0");
    return 0;
  }
  std::vector<echoreg::segmentation::SliceContour> contours;
  std::vector<echoreg::segmentation::AnchorSet> anchors;
  echoreg::segmentation::VoxelMask mask;
  try {
    anchors = this->AnchorsFileName.empty()
                  ? this->Anchors
                  : echoreg::segmentation::readAnchors(this->AnchorsFileName);
    if (anchors.empty())
      throw std::invalid_argument("no anchors (SetAnchors or AnchorsFileName)");
    const echoreg::core::CtImage ct = echoreg::segmentation::pipeline::ctImageOf(input);
    for (const echoreg::segmentation::AnchorSet& set : anchors) {
      try {
        contours.push_back(echoreg::segmentation::liveWireContour(ct, set, this->ContourOptions));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("contour \"" + set.label + "\": " + e.what());
      }
    }
    mask = echoreg::segmentation::contoursToMask(contours, ct, this->MaskOptions);
  } catch (const std::exception& exception) {
    this->Fail(std::string("live-wire failed: ") + exception.what());
    return 0;
  }

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkCellArray> lines;
  vtkNew<vtkStringArray> labels;
  labels->SetName("Label");
  vtkNew<vtkDoubleArray> costs;
  costs->SetName("CostPerMm");
  for (std::size_t c = 0; c < contours.size(); ++c) {
    const auto& contour = contours[c];
    std::vector<vtkIdType> ids;
    double lengthMm = 0.0;
    for (std::size_t p = 0; p < contour.pointsLps.size(); ++p) {
      ids.push_back(points->InsertNextPoint(contour.pointsLps[p].data()));
      lengthMm +=
          (contour.pointsLps[(p + 1) % contour.pointsLps.size()] - contour.pointsLps[p]).norm();
    }
    ids.push_back(ids.front());  // closed
    lines->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
    labels->InsertNextValue(anchors[c].label);
    costs->InsertNextValue(lengthMm > 0.0 ? contour.cost / lengthMm : 0.0);
  }
  contoursOutput->Initialize();
  contoursOutput->SetPoints(points);
  contoursOutput->SetLines(lines);
  contoursOutput->GetCellData()->AddArray(labels);
  contoursOutput->GetCellData()->AddArray(costs);
  vtkNew<vtkIntArray> count;
  count->SetName("Contours");
  count->InsertNextValue(static_cast<int>(contours.size()));
  contoursOutput->GetFieldData()->AddArray(count);
  maskOutput->ShallowCopy(echoreg::segmentation::pipeline::maskImageOf(mask, "LiveWireMask"));
  this->LastContours = std::move(contours);
  this->LastError.clear();
  return 1;
}

void vtkEchoregLiveWireFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Anchors: " << this->Anchors.size() << " sets\n";
  os << indent
     << "AnchorsFileName: " << (this->AnchorsFileName.empty() ? "(none)" : this->AnchorsFileName)
     << "\n";
  os << indent << "SubpixelRefine: " << (this->ContourOptions.subpixelRefine ? "On" : "Off")
     << "\n";
  os << indent << "SampleSpacingMm: " << this->ContourOptions.sampleSpacingMm << "\n";
  os << indent << "MarginMm: " << this->ContourOptions.marginMm << "\n";
  os << indent << "RasterMm: " << this->MaskOptions.rasterMm << "\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
