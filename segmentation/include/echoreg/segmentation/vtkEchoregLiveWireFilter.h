/**
 * @class   vtkEchoregLiveWireFilter
 * @brief   Live-Wire contours through a user's anchors on CT slices, and the solid they enclose.
 *
 * The dissertation's way of segmenting a bone (Mozes 2008, section 4.1: 40 sagittal slices per
 * bone, a few anchors on each): for every anchor set, echoreg::segmentation::liveWireContour
 * finds the closed minimum-cost path through the anchors on their slice of the CT (optionally
 * refined to the sub-pixel edge); echoreg::segmentation::contoursToMask fills the contours and
 * interpolates between slices.
 *
 * Anchors: SetAnchors() (in memory), or AnchorsFileName (echoreg's JSON or a 3D Slicer .mrk.json
 * of ClosedCurve markups, read with readAnchors; samples/anchors/ holds one). A file's changes are
 * seen when its name is set again or Modified() is called.
 * Input (port 0): the CT (vtkImageData of HU, uniform, LPS geometry).
 * Output 0: vtkPolyData of the contours, one closed polyline per anchor set, CT LPS mm, with
 * cell data "Label" and "CostPerMm". Output 1: vtkImageData, the enclosed solid as a uint8 mask
 * "LiveWireMask" on the CT's grid (vtkEchoregBoneSurfaceFilter's region). Field data of output
 * 0: "Contours". An anchor outside the volume, an unreadable file or no anchors is an error
 * through the executive.
 *
 * Defaults: no anchors; those of LiveWireContourOptions (sub-pixel refinement on) and
 * ContourMaskOptions.
 */
#pragma once

#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"

#include <vtkPolyDataAlgorithm.h>

#include <string>
#include <vector>

class vtkEchoregLiveWireFilter : public vtkPolyDataAlgorithm {
 public:
  static vtkEchoregLiveWireFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregLiveWireFilter, vtkPolyDataAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /// Anchor sets in memory (used when AnchorsFileName is empty).
  void SetAnchors(const std::vector<echoreg::segmentation::AnchorSet>& anchors);
  const std::vector<echoreg::segmentation::AnchorSet>& GetAnchors() const { return this->Anchors; }
  ///@}

  ///@{
  /// An anchors file; when set it wins over SetAnchors(). Default empty.
  void SetAnchorsFileName(const std::string& path);
  const std::string& GetAnchorsFileName() const { return this->AnchorsFileName; }
  ///@}

  ///@{
  /// Refine each path point to the sub-pixel edge (default on).
  void SetSubpixelRefine(bool refine);
  bool GetSubpixelRefine() const { return this->ContourOptions.subpixelRefine; }
  ///@}

  /// The contours of the last run.
  const std::vector<echoreg::segmentation::SliceContour>& GetLastContours() const {
    return this->LastContours;
  }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregLiveWireFilter();
  ~vtkEchoregLiveWireFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregLiveWireFilter(const vtkEchoregLiveWireFilter&) = delete;
  void operator=(const vtkEchoregLiveWireFilter&) = delete;

  void Fail(const std::string& message);

  std::vector<echoreg::segmentation::AnchorSet> Anchors;
  std::string AnchorsFileName;
  echoreg::segmentation::LiveWireContourOptions ContourOptions;
  echoreg::segmentation::ContourMaskOptions MaskOptions;
  std::vector<echoreg::segmentation::SliceContour> LastContours;
  std::string LastError;
  int ExecutionCount = 0;
};
