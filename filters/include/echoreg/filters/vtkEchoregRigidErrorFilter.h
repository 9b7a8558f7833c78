/**
 * @class   vtkEchoregRigidErrorFilter
 * @brief   The error of estimated registrations against a reference, decomposed per CT axis.
 *
 * Mozes 2008, Eq. 4.5 and Tables 5.3-5.7, through echoreg::core::rigidError and
 * meanAbsoluteError: E = estimate * inverse(reference) in CT, its translation (the displacement
 * of CentreCt) along CT x, y, z (medial-lateral, anterior-posterior, superior-inferior) in mm,
 * its rotation about them in degrees with R = Rz * Ry * Rx, and the distances at named targets.
 *
 * Input 0, the estimates: any data object whose field data holds EstimateArrayName (default
 * "BoneToCT", as vtkEchoregSurfaceRegistrationFilter writes it): 16 components row-major, one
 * tuple per estimate. Input 1, the reference (e.g. the mechanical probe's registration): the same
 * layout under ReferenceArrayName, first tuple.
 * Output: vtkTable, one row per estimate then "mean_abs": "estimate" (the tuple index, or
 * "mean_abs"), "tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg", and "target_<label>_mm"
 * per target. GetLastResult() the core's rows and their mean of absolute values.
 *
 * Defaults: "BoneToCT" on both inputs, the CT origin as centre, no targets.
 */
#pragma once

#include "echoreg/core/rigid_error.hpp"

#include <vtkTableAlgorithm.h>

#include <string>
#include <utility>
#include <vector>

class vtkEchoregRigidErrorFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregRigidErrorFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregRigidErrorFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  void SetReferenceConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  ///@{
  void SetEstimateArrayName(const std::string& name);
  const std::string& GetEstimateArrayName() const { return this->EstimateArrayName; }
  void SetReferenceArrayName(const std::string& name);
  const std::string& GetReferenceArrayName() const { return this->ReferenceArrayName; }
  ///@}

  ///@{
  /// The point whose displacement is the translation error (CT, mm). Default the origin.
  void SetCentreCtMm(double x, double y, double z);
  ///@}

  ///@{
  /// Named target points (CT, mm), e.g. the hip centre. Default none.
  void AddTarget(const std::string& label, double x, double y, double z);
  void RemoveAllTargets();
  ///@}

  struct Result {
    std::vector<echoreg::core::RigidError> rows;
    echoreg::core::RigidError meanAbsolute;
  };
  const Result& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregRigidErrorFilter();
  ~vtkEchoregRigidErrorFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregRigidErrorFilter(const vtkEchoregRigidErrorFilter&) = delete;
  void operator=(const vtkEchoregRigidErrorFilter&) = delete;

  void Fail(const std::string& message);

  std::string EstimateArrayName = "BoneToCT";
  std::string ReferenceArrayName = "BoneToCT";
  Eigen::Vector3d CentreCtMm = Eigen::Vector3d::Zero();
  std::vector<std::pair<std::string, Eigen::Vector3d>> Targets;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
