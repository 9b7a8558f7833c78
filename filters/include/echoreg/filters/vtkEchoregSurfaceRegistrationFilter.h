/**
 * @class   vtkEchoregSurfaceRegistrationFilter
 * @brief   Registers points on a bone (bone frame) to the bone's model (CT): BoneToCT.
 *
 * A two-input algorithm (three with landmarks), unlike vtkIterativeClosestPointTransform: the
 * points and the model are pipeline connections, so a new detection upstream or a new
 * segmentation re-runs it. A thin adapter over echoreg::core::SurfaceRegistration::registerPoints
 * (the dissertation's ICP, section 4.3, or the robust point-to-plane solver with landmarks and
 * the speed of sound, docs/registration.md); the model's closest-point hierarchy is built once
 * per model and kept while the model input is unchanged.
 *
 * Input 0, the points, bone frame, mm; either
 *   - a vtkTable of vtkEchoregInterSignalFilter run with a reference transform: the rows whose
 *     "status" is "accepted", at ("x_mm", "y_mm", "z_mm"), sigma PointSigmaMm; or
 *   - a vtkPointSet: every point; optional point data "SigmaMm" (1 component), and for points on
 *     a beam "BeamOriginMm", "BeamDirection" (3 components) and "DepthMm" (1), which let the
 *     robust solver fit the speed of sound.
 * Input 1, the model: vtkPolyData (CT, mm), closed and consistently oriented.
 * Input 2, optional, landmark pairs: vtkTable with "name" (string) and "bone_x_mm",
 *   "bone_y_mm", "bone_z_mm", "model_x_mm", "model_y_mm", "model_z_mm", optionally "sigma_mm".
 * Output: vtkPolyData, the points mapped into CT by the result, with point data "ResidualMm"
 * (signed distance to the surface) and "Inlier" (0/1). Field data: "BoneToCT" (16, row-major),
 * "RmsMm", "RmsAllMm", "PointsUsed", "PointsRejected", "Iterations", "Starts",
 * "SpeedOfSoundScale", "RotationSigmaDeg", "TranslationSigmaMm", "Converged", and "Message"
 * (why not converged); GetLastResult() the core's result. Non-convergence is a result, not an
 * error; bad input (too few points, a model that is not closed, a bad option) is an error
 * through the executive.
 *
 * Defaults: echoreg::core::SurfaceRegistrationOptions (robust, Huber), PointSigmaMm 0.5.
 */
#pragma once

#include "echoreg/core/surface_registration.hpp"

#include <vtkPolyDataAlgorithm.h>

#include <memory>
#include <string>

class vtkEchoregSurfaceRegistrationFilter : public vtkPolyDataAlgorithm {
 public:
  static vtkEchoregSurfaceRegistrationFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregSurfaceRegistrationFilter, vtkPolyDataAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  void SetModelConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetModelData(vtkDataObject* model) { this->SetInputData(1, model); }
  void SetLandmarksConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(2, output); }
  void SetLandmarksData(vtkDataObject* landmarks) { this->SetInputData(2, landmarks); }

  ///@{
  /**
   * Every option of the solver (method, loss, starts, gates, speed of sound, initial pose, ...).
   * Modified() on every call: the options struct has no equality; set them once.
   */
  void SetOptions(const echoreg::core::SurfaceRegistrationOptions& options);
  const echoreg::core::SurfaceRegistrationOptions& GetOptions() const { return this->Options; }
  ///@}

  ///@{
  /// Plain (the dissertation's ICP) or Robust (the default).
  void SetMethod(echoreg::core::SurfaceMethod method);
  echoreg::core::SurfaceMethod GetMethod() const { return this->Options.method; }
  ///@}

  ///@{
  /// Localisation error of table points and of points without "SigmaMm", mm (> 0). Default 0.5.
  void SetPointSigmaMm(double sigma);
  double GetPointSigmaMm() const { return this->PointSigmaMm; }
  ///@}

  const echoreg::core::SurfaceRegistrationResult& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }
  /// Number of times a model was prepared (checked and its hierarchy built).
  int GetModelPreparationCount() const { return this->ModelPreparationCount; }

 protected:
  vtkEchoregSurfaceRegistrationFilter();
  ~vtkEchoregSurfaceRegistrationFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregSurfaceRegistrationFilter(const vtkEchoregSurfaceRegistrationFilter&) = delete;
  void operator=(const vtkEchoregSurfaceRegistrationFilter&) = delete;

  void Fail(const std::string& message);

  echoreg::core::SurfaceRegistrationOptions Options;
  double PointSigmaMm = 0.5;
  std::unique_ptr<echoreg::core::SurfaceRegistration> Model;
  const void* ModelData = nullptr;
  vtkMTimeType ModelTime = 0;
  echoreg::core::SurfaceRegistrationResult LastResult;
  std::string LastError;
  int ExecutionCount = 0;
  int ModelPreparationCount = 0;
};
