/**
 * @class   vtkEchoregBeamCalibrationFilter
 * @brief   BeamToProbe from A-line shots at a sphere of known centre (Mozes 2008, section 4.2).
 *
 * A thin adapter over echoreg::core::calibrateBeam, with two inputs so that either side re-runs
 * it: the sphere (a vtkEchoregSphereFitFilter output: "SphereCentreMm" and "SphereRadiusMm" in
 * its field data) and the shots (a vtkEchoregInterSignalFilter output run without pose, so its
 * depths are along the beam: the accepted rows' "depth_mm", and PoseTransformName's valid poses
 * from the field data). Each shot's point ProbeToTracker * BeamToProbe * (0, 0, d, 1) should lie
 * on the sphere; Levenberg-Marquardt with robust rounds, in Translation (the dissertation's 3
 * parameters) or Beam mode (origin and direction), optionally with the speed of sound.
 *
 * Input 0: the shots' detection table. Input 1: the sphere fit's table.
 * Output: vtkTable, one row per shot used as input: "frame", "depth_mm", "residual_mm", "used"
 * (0/1). Field data: "BeamToProbe" (16 components, row-major), "SpeedOfSoundMps", "RmsMm",
 * "ConditionNumber", "Iterations", "Converged"; GetLastResult() the core's result.
 *
 * The assumed speed of sound is AssumedSpeedOfSoundMps, or when NaN (the default) the shots'
 * field data "SpeedOfSoundMps" (the capture header's), else echoreg::core::kWaterSpeedOfSoundMps
 * (1480 m/s, the calibration preset's, as echoreg calibrate assumes). Defaults otherwise: those of
 * echoreg::core::BeamCalibrationOptions, "ProbeToTracker", initial BeamToProbe identity.
 */
#pragma once

#include "echoreg/core/beam_calibration.hpp"

#include <vtkTableAlgorithm.h>

#include <array>
#include <string>

class vtkEchoregBeamCalibrationFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregBeamCalibrationFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregBeamCalibrationFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// The sphere fit's connection (input 1).
  void SetSphereConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  ///@{
  /// Translation (3 parameters, the default) or Beam (5) mode.
  void SetMode(echoreg::core::BeamCalibrationMode mode);
  echoreg::core::BeamCalibrationMode GetMode() const { return this->Mode; }
  ///@}

  ///@{
  /// Fit the speed of sound too. Default off.
  void SetFitSpeedOfSound(bool fit);
  bool GetFitSpeedOfSound() const { return this->FitSpeedOfSound; }
  ///@}

  ///@{
  /// The speed of sound the depths assumed, m/s; NaN (the default): the shots' field data.
  void SetAssumedSpeedOfSoundMps(double mps);
  double GetAssumedSpeedOfSoundMps() const { return this->AssumedSpeedOfSoundMps; }
  ///@}

  ///@{
  /// The start of the solver (e.g. the holder's drawing), row-major 4x4. Default identity.
  void SetInitialBeamToProbe(const double rowMajor[16]);
  ///@}

  ///@{
  /// Largest condition number accepted (> 1). Default 100.
  void SetMaxConditionNumber(double limit);
  double GetMaxConditionNumber() const { return this->MaxConditionNumber; }
  ///@}

  ///@{
  /// The probe's transform in the shots' field data. Default "ProbeToTracker".
  void SetPoseTransformName(const std::string& name);
  const std::string& GetPoseTransformName() const { return this->PoseTransformName; }
  ///@}

  const echoreg::core::BeamCalibrationResult& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregBeamCalibrationFilter();
  ~vtkEchoregBeamCalibrationFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregBeamCalibrationFilter(const vtkEchoregBeamCalibrationFilter&) = delete;
  void operator=(const vtkEchoregBeamCalibrationFilter&) = delete;

  void Fail(const std::string& message);

  echoreg::core::BeamCalibrationMode Mode = echoreg::core::BeamCalibrationMode::Translation;
  bool FitSpeedOfSound = false;
  double AssumedSpeedOfSoundMps;
  std::array<double, 16> InitialBeamToProbe;
  double MaxConditionNumber = 100.0;
  std::string PoseTransformName = "ProbeToTracker";
  echoreg::core::BeamCalibrationResult LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
