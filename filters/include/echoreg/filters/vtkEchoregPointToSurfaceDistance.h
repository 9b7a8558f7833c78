/**
 * @class   vtkEchoregPointToSurfaceDistance
 * @brief   Distance from each point to the nearest point on a surface's triangles.
 *
 * The error metric of the registration and of the figures (Mozes 2008, Eq. 4.4): for every point
 * of input 0, the distance to the closest point on the triangles of input 1 (not its vertices),
 * through echoreg::core::MeshLocator. With SignedDistance on, points inside the (closed) surface
 * get negative distances (MeshLocator::signedDistance). Points are queried in parallel with
 * vtkSMPTools; the locator is built once per surface and kept while the surface input is
 * unchanged, so new points (a new registration) cost only the queries.
 *
 * Input 0: vtkPointSet, the points (e.g. ultrasound points mapped into CT). Input 1: vtkPolyData,
 * the surface (CT, mm), triangulated as echoreg::filters::toTriangleMesh does.
 * Output: vtkPolyData with the points of input 0 (a copy of the same precision), one vertex cell
 * per point, the point data of
 * input 0 plus "DistanceMm" (double) and "ClosestPointMm" (3 components). Field data:
 * "DistanceRmsMm", "DistanceMeanMm", "DistanceMaxMm", "DistanceCount"; GetLastResult() the same.
 * No points: an empty output with a warning. A surface without triangles or with a non-finite
 * vertex is an error through the executive.
 *
 * Defaults: unsigned distances.
 */
#pragma once

#include <vtkPolyDataAlgorithm.h>
#include <vtkTimeStamp.h>

#include <memory>
#include <string>

namespace echoreg::core {
class MeshLocator;
}

class vtkEchoregPointToSurfaceDistance : public vtkPolyDataAlgorithm {
 public:
  static vtkEchoregPointToSurfaceDistance* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregPointToSurfaceDistance, vtkPolyDataAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// Statistics of the last run, mm.
  struct Result {
    int count = 0;
    double rmsMm = 0.0;
    double meanMm = 0.0;  ///< of the distances as signed or not
    double maxMm = 0.0;   ///< largest absolute distance
  };

  /// The surface's connection (input 1).
  void SetSurfaceConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetSurfaceData(vtkDataObject* surface) { this->SetInputData(1, surface); }

  ///@{
  /**
   * Negative distances inside the closed surface. Default off.
   */
  void SetSignedDistance(bool enabled);
  bool GetSignedDistance() const { return this->SignedDistance; }
  void SignedDistanceOn() { this->SetSignedDistance(true); }
  void SignedDistanceOff() { this->SetSignedDistance(false); }
  ///@}

  const Result& GetLastResult() const { return this->LastResult; }
  const std::string& GetLastError() const { return this->LastError; }
  int GetExecutionCount() const { return this->ExecutionCount; }
  /// Number of times the locator was built (once per surface).
  int GetLocatorBuildCount() const { return this->LocatorBuildCount; }

 protected:
  vtkEchoregPointToSurfaceDistance();
  ~vtkEchoregPointToSurfaceDistance() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregPointToSurfaceDistance(const vtkEchoregPointToSurfaceDistance&) = delete;
  void operator=(const vtkEchoregPointToSurfaceDistance&) = delete;

  void Fail(const std::string& message);

  bool SignedDistance = false;
  std::unique_ptr<echoreg::core::MeshLocator> Locator;
  vtkMTimeType LocatorSurfaceTime = 0;
  const void* LocatorSurface = nullptr;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
  int LocatorBuildCount = 0;
};
