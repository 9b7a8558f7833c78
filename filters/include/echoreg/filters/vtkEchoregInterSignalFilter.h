/**
 * @class   vtkEchoregInterSignalFilter
 * @brief   Keeps the points that consecutive frames agree on (the inter-signal filters).
 *
 * Mozes 2008 (section 4.3.3) filters single-signal detections over consecutive A-lines: temporal
 * consistency (a point is accepted once enough detected frames agree with it; see
 * echoreg::core::TemporalMode for the dissertation's consecutive run and echoreg's neighbours in
 * time) and spatial spread (a point closer than MinSpreadMm to an already accepted point is
 * dropped; only on tracked points, since (0, 0, depth) of a transducer that does not move says
 * nothing about where the beam was). The filter is a thin adapter over
 * echoreg::core::applyInterSignal, so its verdicts are detectSequence's.
 *
 * Input (port 0): vtkTable of vtkEchoregBeamPointsFilter ("frame", "reason", "x_mm", "y_mm",
 * "z_mm" required, "depth_mm" and "timestamp_s" used when present; every other column is kept).
 * A row takes part when its "reason" is empty and its point is finite. The points are tracked
 * when the field data's "PointFrame" names a frame other than "Beam".
 * Output (port 0): vtkTable with the input's columns, "reason" updated with the verdicts
 * ("inconsistent", "too-close"), plus "status" ("accepted" / "rejected"). Points rejected here
 * keep their coordinates so they can be shown; use "status" to select.
 * Field data: the input's, plus one single-tuple vtkIntArray "Count_<reason>" per reason
 * ("Count_accepted", "Count_no-peak", ..., "Count_invalid-pose") and "EchoesBeforeInterSignal";
 * GetReasonCounts() and GetLastResult() hold the same.
 *
 * Defaults: those of echoreg::core::InterSignalParams (run mode, history 3, 0.5 mm, 1 mm;
 * neighbours: 30 mm/s, 0.1 s, 50 Hz). Parameters are checked when the filter runs; a bad one is an
 * error naming it.
 */
#pragma once

#include "echoreg/core/detection.hpp"

#include <vtkTableAlgorithm.h>

#include <map>
#include <string>

class vtkEchoregInterSignalFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregInterSignalFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregInterSignalFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// What the last run decided.
  struct Result {
    int echoes = 0;    ///< rows that took part (detected, with a point)
    int accepted = 0;  ///< rows accepted
    bool tracked = false;
    std::map<std::string, int> reasonCounts;  ///< as GetReasonCounts()
  };

  ///@{
  /**
   * Every parameter at once. Modified() only when something differs.
   */
  void SetInterSignalParams(const echoreg::core::InterSignalParams& params);
  const echoreg::core::InterSignalParams& GetInterSignalParams() const { return this->Params; }
  ///@}

  ///@{
  /**
   * Temporal mode: echoreg::core::TemporalMode::Run (the default, the dissertation's) or
   * Neighbours.
   */
  void SetTemporalMode(echoreg::core::TemporalMode mode) {
    this->SetField(this->Params.temporal, mode);
  }
  echoreg::core::TemporalMode GetTemporalMode() const { return this->Params.temporal; }
  ///@}

  ///@{
  /**
   * Detected frames that must agree, this one included (>= 1; 1 switches the temporal filter
   * off). Default 3.
   */
  void SetHistory(int frames) { this->SetField(this->Params.history, frames); }
  int GetHistory() const { return this->Params.history; }
  ///@}

  ///@{
  /**
   * Distance within which points agree, mm (> 0). Default 0.5.
   */
  void SetConsistencyMm(double mm) { this->SetField(this->Params.consistencyMm, mm); }
  double GetConsistencyMm() const { return this->Params.consistencyMm; }
  ///@}

  ///@{
  /**
   * Neighbours mode: how fast the depth may change, mm/s (>= 0, default 30), the longest time to
   * a neighbour that still counts, s (> 0, default 0.1), and the frame rate assumed for frames
   * without timestamps, Hz (> 0, default 50).
   */
  void SetMaxDepthRateMmPerS(double rate) { this->SetField(this->Params.maxDepthRateMmPerS, rate); }
  double GetMaxDepthRateMmPerS() const { return this->Params.maxDepthRateMmPerS; }
  void SetMaxGapS(double seconds) { this->SetField(this->Params.maxGapS, seconds); }
  double GetMaxGapS() const { return this->Params.maxGapS; }
  void SetFrameRateHz(double hz) { this->SetField(this->Params.frameRateHz, hz); }
  double GetFrameRateHz() const { return this->Params.frameRateHz; }
  ///@}

  ///@{
  /**
   * Minimum distance of an accepted tracked point to the points accepted before, mm (>= 0; 0
   * switches the spatial filter off). Default 1.
   */
  void SetMinSpreadMm(double mm) { this->SetField(this->Params.minSpreadMm, mm); }
  double GetMinSpreadMm() const { return this->Params.minSpreadMm; }
  ///@}

  /**
   * Frames per reason of the last run: "accepted" and every echoreg::core::rejectReasonName
   * ("no-peak", ..., "invalid-pose"), zeros included.
   */
  const std::map<std::string, int>& GetReasonCounts() const {
    return this->LastResult.reasonCounts;
  }

  /**
   * What the last successful run decided.
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

  echoreg::core::InterSignalParams Params;
  Result LastResult;
  std::string LastError;
  int ExecutionCount = 0;
};
