/**
 * @class   vtkEchoregPivotCalibrationFilter
 * @brief   The fixed point of a tracked marker's poses: a stylus tip pivoting in a divot, or the
 *          hip centre while the femur is rotated.
 *
 * A thin adapter over echoreg::core::pivotCalibration: the valid ("OK") poses of
 * MarkerTransformName in the input's field data (echoreg::filters::SequenceFieldData, e.g. a
 * tracker-only capture from vtkEchoregSequenceReader) give p_marker and p_fixed in least squares
 * of R_i p_marker + t_i = p_fixed, with robust rounds (outliers beyond max(OutlierSigmas x robust
 * sigma, MinOutlierMm) dropped) and a refusal when the rotations do not span
 * MinRotationSpreadDeg about two axes.
 *
 * Input (port 0): any data object whose field data holds the marker's poses.
 * Output (port 0): vtkTable, one row per valid pose: "frame", "residual_mm", "inlier" (0/1).
 * Field data: "PointInMarkerMm" and "PointInTrackerMm" (3 components), "RmsMm", "Inliers",
 * "RotationSpreadDeg" (3 components, largest first); GetLastResult() holds the core's result.
 * Errors (no such transform, no valid pose, too little rotation, ...) go through the executive
 * with the core's message.
 *
 * Defaults: "StylusToTracker"; those of echoreg::core::PivotOptions (3 sigma, 0.5 mm, 5 rounds,
 * 15 degrees).
 */
#pragma once

#include "echoreg/core/fits.hpp"

#include <vtkTableAlgorithm.h>

#include <string>

class vtkEchoregPivotCalibrationFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregPivotCalibrationFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregPivotCalibrationFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * The marker's transform in the field data, e.g. "StylusToTracker" (the default) or
   * "FemurToTracker" for the hip centre.
   */
  void SetMarkerTransformName(const std::string& name);
  const std::string& GetMarkerTransformName() const { return this->MarkerTransformName; }
  ///@}

  ///@{
  /**
   * Robust rounds and the rotation needed, as echoreg::core::PivotOptions: OutlierSigmas (> 0),
   * MinOutlierMm (>= 0), MaxRounds (>= 1), MinRotationSpreadDeg (>= 0). Modified() only on a
   * change.
   */
  void SetOptions(const echoreg::core::PivotOptions& options);
  const echoreg::core::PivotOptions& GetOptions() const { return this->Options; }
  void SetMinRotationSpreadDeg(double degrees);
  double GetMinRotationSpreadDeg() const { return this->Options.minRotationSpreadDeg; }
  ///@}

  /// The core's result of the last successful run, with the frame of each pose used.
  struct Result {
    echoreg::core::PivotResult pivot;
    std::vector<int> frames;
  };
  const Result& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregPivotCalibrationFilter();
  ~vtkEchoregPivotCalibrationFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregPivotCalibrationFilter(const vtkEchoregPivotCalibrationFilter&) = delete;
  void operator=(const vtkEchoregPivotCalibrationFilter&) = delete;

  void Fail(const std::string& message);

  std::string MarkerTransformName = "StylusToTracker";
  echoreg::core::PivotOptions Options;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
