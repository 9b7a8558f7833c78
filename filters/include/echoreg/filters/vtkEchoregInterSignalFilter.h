/**
 * @class   vtkEchoregInterSignalFilter
 * @brief   Places each detected echo in space and keeps the points that consecutive frames agree
 * on.
 *
 * Mozes 2008 (section 4.3.3) filters single-signal detections over consecutive A-lines: a point
 * is accepted once `History` consecutive detected frames (this one included) lie within
 * `ConsistencyMm` of it (temporal consistency), and a point closer than `MinSpreadMm` to an
 * already accepted point is dropped (spatial spread); echoreg::InterSignalFilter does both.
 *
 * Each frame whose single-signal detection succeeded (empty "reason") becomes a 3D point:
 *  - PoseTransformName empty: (0, 0, depth) in Beam (no tracking).
 *  - PoseTransformName set (e.g. "ProbeToTracker"):
 *      p = ProbeToTracker * BeamToProbe * (0, 0, depth, 1)
 *    and, with ReferenceTransformName set (e.g. "FemurToTracker"), in that reference frame:
 *      p = inv(FemurToTracker) * ProbeToTracker * BeamToProbe * (0, 0, depth, 1).
 *    A frame whose pose (or reference pose) is missing or not OK is rejected as "invalid-pose";
 *    a transform name the field data does not hold at all is an error listing the names it holds.
 * Points are judged in row order (the frame order of the peak table); a rejected frame breaks the
 * temporal run.
 *
 * Input (port 0): vtkTable of vtkEchoregPeakFilter ("frame", "depth_mm" and "reason" are required;
 * every other column is kept). Poses come from the table's field data (see
 * echoreg::filters::SequenceFieldData), indexed by the "frame" column.
 * Output (port 0): vtkTable with the input's columns, "reason" updated with the inter-signal
 * verdicts ("inconsistent", "too-close", "invalid-pose"), plus "status" ("accepted" /
 * "rejected") and "x_mm", "y_mm", "z_mm": the frame's point, NaN when the frame has no point
 * (rejected by the single-signal detection or by an invalid pose). Points rejected by the
 * inter-signal filter keep their coordinates so they can be shown; use "status" to select.
 * Field data: the input's, plus one single-tuple vtkIntArray "Count_<reason>" per reason
 * ("Count_accepted", "Count_no-peak", ..., "Count_invalid-pose"); GetReasonCounts() holds the same.
 *
 * Defaults: those of echoreg::InterSignalParams (history 3, 0.5 mm, 1 mm); no pose transform,
 * no reference, BeamToProbe identity.
 */
#pragma once

#include "echoreg/core/detection.hpp"

#include <vtkTableAlgorithm.h>

#include <array>
#include <map>
#include <string>

class vtkMatrix4x4;

class vtkEchoregInterSignalFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregInterSignalFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregInterSignalFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * Temporal and spatial filter parameters. Modified() only when something differs.
   */
  void SetInterSignalParams(const echoreg::InterSignalParams& params);
  const echoreg::InterSignalParams& GetInterSignalParams() const { return this->Params; }
  ///@}

  ///@{
  /**
   * Consecutive detected frames that must agree (>= 1; 1 switches the temporal filter off).
   * Default 3.
   */
  void SetHistory(int frames) { this->SetField(this->Params.history, frames); }
  int GetHistory() const { return this->Params.history; }
  ///@}

  ///@{
  /**
   * Distance within which consecutive points agree, mm (> 0). Default 0.5.
   */
  void SetConsistencyMm(double mm) { this->SetField(this->Params.consistencyMm, mm); }
  double GetConsistencyMm() const { return this->Params.consistencyMm; }
  ///@}

  ///@{
  /**
   * Minimum distance of an accepted point to the points accepted before, mm (>= 0; 0 switches
   * the spatial filter off). Default 1.
   */
  void SetMinSpreadMm(double mm) { this->SetField(this->Params.minSpreadMm, mm); }
  double GetMinSpreadMm() const { return this->Params.minSpreadMm; }
  ///@}

  ///@{
  /**
   * Name of the probe's tracked transform in the field data, e.g. "ProbeToTracker". Empty (the
   * default): no tracking, points are (0, 0, depth) in Beam.
   */
  void SetPoseTransformName(const std::string& name) {
    this->SetField(this->PoseTransformName, name);
  }
  const std::string& GetPoseTransformName() const { return this->PoseTransformName; }
  ///@}

  ///@{
  /**
   * Name of the reference's tracked transform, e.g. "FemurToTracker": points are expressed in
   * that frame. Empty (the default): points stay in the pose's target frame (Tracker). Needs
   * PoseTransformName.
   */
  void SetReferenceTransformName(const std::string& name) {
    this->SetField(this->ReferenceTransformName, name);
  }
  const std::string& GetReferenceTransformName() const { return this->ReferenceTransformName; }
  ///@}

  ///@{
  /**
   * Calibration from Beam to Probe (4x4, mm), row-major. Default identity.
   */
  void SetBeamToProbe(const double rowMajor[16]);
  void SetBeamToProbe(vtkMatrix4x4* beamToProbe);
  void GetBeamToProbe(double rowMajor[16]) const;
  ///@}

  /**
   * Frames per reason of the last run: "accepted" and every echoreg::rejectReasonName
   * ("no-peak", ..., "invalid-pose"), zeros included.
   */
  const std::map<std::string, int>& GetReasonCounts() const { return this->ReasonCounts; }

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times RequestData ran.
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregInterSignalFilter();
  ~vtkEchoregInterSignalFilter() override;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregInterSignalFilter(const vtkEchoregInterSignalFilter&) = delete;
  void operator=(const vtkEchoregInterSignalFilter&) = delete;

  template <typename T>
  void SetField(T& field, const T& value) {
    if (field != value) {
      field = value;
      this->Modified();
    }
  }
  void Fail(const std::string& message);

  echoreg::InterSignalParams Params;
  std::string PoseTransformName;
  std::string ReferenceTransformName;
  std::array<double, 16> BeamToProbe;
  std::map<std::string, int> ReasonCounts;
  std::string LastError;
  int ExecutionCount = 0;
};
