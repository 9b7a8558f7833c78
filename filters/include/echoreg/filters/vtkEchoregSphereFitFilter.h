/**
 * @class   vtkEchoregSphereFitFilter
 * @brief   The calibration sphere's centre from a tracked stylus touching it.
 *
 * Mozes 2008, section 4.2.2: the stylus tip touches the sphere all over; each valid pose of
 * StylusTransformName puts the tip at p = StylusToTracker * tipInStylus, and
 * echoreg::core::fitSphere fits the sphere those tips lie on (robust rounds, a refusal of caps
 * too small to determine it). The tip is a ball of TipRadiusMm, so its centre lies on a sphere of
 * radius BallRadiusMm + TipRadiusMm; with BallRadiusMm given that radius is fixed, else fitted.
 * The output's "SphereRadiusMm" is the ball's own radius (the fitted radius minus the tip's),
 * which the ultrasound sees.
 *
 * Input (port 0): any data object whose field data holds the stylus poses (a tracker-only capture
 * from vtkEchoregSequenceReader).
 * Output (port 0): vtkTable, one row per valid pose: "frame", "x_mm", "y_mm", "z_mm" (the tip in
 * Tracker), "residual_mm", "inlier" (0/1). Field data: "SphereCentreMm" (3 components, Tracker),
 * "SphereRadiusMm", "RmsMm", "Inliers", "ConditionNumber"; GetLastResult() the core's result.
 *
 * Defaults: "StylusToTracker", tip at the stylus origin, tip radius 0, free radius, the core's
 * SphereFitOptions.
 */
#pragma once

#include "echoreg/core/fits.hpp"

#include <vtkTableAlgorithm.h>

#include <array>
#include <string>

class vtkEchoregSphereFitFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregSphereFitFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregSphereFitFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /// The stylus's transform in the field data. Default "StylusToTracker".
  void SetStylusTransformName(const std::string& name);
  const std::string& GetStylusTransformName() const { return this->StylusTransformName; }
  ///@}

  ///@{
  /// The tip in Stylus, mm (the translation of StylusTipToStylus). Default (0, 0, 0).
  void SetTipInStylusMm(double x, double y, double z);
  const std::array<double, 3>& GetTipInStylusMm() const { return this->TipInStylusMm; }
  ///@}

  ///@{
  /// Radius of the stylus's ball tip, mm (>= 0). Default 0.
  void SetTipRadiusMm(double radius);
  double GetTipRadiusMm() const { return this->TipRadiusMm; }
  ///@}

  ///@{
  /// The sphere's known radius, mm (> 0); NaN (the default) fits it.
  void SetBallRadiusMm(double radius);
  double GetBallRadiusMm() const { return this->BallRadiusMm; }
  ///@}

  const echoreg::core::SphereFit& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregSphereFitFilter();
  ~vtkEchoregSphereFitFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregSphereFitFilter(const vtkEchoregSphereFitFilter&) = delete;
  void operator=(const vtkEchoregSphereFitFilter&) = delete;

  void Fail(const std::string& message);

  std::string StylusTransformName = "StylusToTracker";
  std::array<double, 3> TipInStylusMm{0.0, 0.0, 0.0};
  double TipRadiusMm = 0.0;
  double BallRadiusMm;
  echoreg::core::SphereFit LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
