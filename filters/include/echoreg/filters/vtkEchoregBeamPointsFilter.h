/**
 * @class   vtkEchoregBeamPointsFilter
 * @brief   Places each detected echo in space: the depth along the beam becomes a 3D point.
 *
 * A depth d on an A-line is the point (0, 0, d) in Beam (Mozes 2008, section 3.2). Each frame
 * whose single-signal detection succeeded (empty "reason") becomes, through
 * echoreg::core::beamPoint:
 *  - PoseTransformName empty: (0, 0, d) in Beam (no tracking).
 *  - PoseTransformName set (e.g. "ProbeToTracker"):
 *      p = ProbeToTracker * BeamToProbe * (0, 0, d, 1)
 *    and, with ReferenceTransformName set (e.g. "FemurToTracker"), in that reference frame:
 *      p = inv(FemurToTracker) * ProbeToTracker * BeamToProbe * (0, 0, d, 1).
 *    A frame whose pose (or reference pose) is missing or not OK is rejected as "invalid-pose";
 *    a transform name the field data does not hold at all is an error listing the names it holds.
 * Rows are independent and placed in parallel with vtkSMPTools.
 *
 * Input (port 0): vtkTable of vtkEchoregPeakFilter ("frame", "depth_mm" and "reason" are
 * required; every other column is kept). Poses come from the table's field data (see
 * echoreg::filters::SequenceFieldData), indexed by the "frame" column.
 * Output (port 0): vtkTable with the input's columns, "reason" set to "invalid-pose" where the
 * pose is missing, plus "x_mm", "y_mm", "z_mm" (NaN when the frame has no point).
 * Input (port 1, optional): the calibration, e.g. a vtkEchoregBeamCalibrationFilter output: its
 * field data's 16-component "BeamToProbe" (row-major) is used instead of the BeamToProbe
 * parameter, so a new calibration upstream re-runs the points (and what follows) by itself.
 * Field data: the input's, plus "PointFrame" (one string: "Beam", the pose's target frame such as
 * "Tracker", or the reference's source frame such as "Femur"), "PointsPlaced" and
 * "PointsInvalidPose" (one int each); GetLastResult() holds the same.
 *
 * Defaults: no pose transform, no reference, BeamToProbe identity.
 */
#pragma once

#include <vtkTableAlgorithm.h>

#include <array>
#include <string>

class vtkMatrix4x4;

class vtkEchoregBeamPointsFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregBeamPointsFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregBeamPointsFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// What the last run did.
  struct Result {
    std::string pointFrame;  ///< "Beam", "Tracker", "Femur", ...
    int placed = 0;          ///< frames that became points
    int invalidPose = 0;     ///< detected frames rejected for a missing or not-OK pose
  };

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
   * Calibration from Beam to Probe (4x4, mm), row-major. Default identity. Modified() only when
   * a number differs.
   */
  void SetBeamToProbe(const double rowMajor[16]);
  /// The calibration's connection (input 1, optional): its "BeamToProbe" wins over the parameter.
  void SetCalibrationConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetBeamToProbe(vtkMatrix4x4* beamToProbe);
  void GetBeamToProbe(double rowMajor[16]) const;
  ///@}

  /**
   * What the last successful run did.
   */
  const Result& GetLastResult() const { return this->LastResult; }

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times RequestData ran.
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregBeamPointsFilter();
  ~vtkEchoregBeamPointsFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregBeamPointsFilter(const vtkEchoregBeamPointsFilter&) = delete;
  void operator=(const vtkEchoregBeamPointsFilter&) = delete;

  template <typename T>
  void SetField(T& field, const T& value) {
    if (field != value) {
      field = value;
      this->Modified();
    }
  }
  void Fail(const std::string& message);

  std::string PoseTransformName;
  std::string ReferenceTransformName;
  std::array<double, 16> BeamToProbe;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
