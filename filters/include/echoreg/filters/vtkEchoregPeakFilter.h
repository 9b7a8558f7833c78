/**
 * @class   vtkEchoregPeakFilter
 * @brief   Peaks of every A-line envelope, the chosen echo and its depth: one table row per frame.
 *
 * For each row of the envelope image (one frame) echoreg::core::findPeaks finds the peaks, the
 * maxima of contiguous runs above a threshold (a factor of the envelope's mean or a fraction of its
 * maximum; Mozes 2008, Fig. 4.10, used 1.5 x mean), restricted to the processing window, and the
 * policy (single, double, window-max, first, max, bone) chooses one or rejects the frame with a
 * reason. The chosen (sub-sample) index i becomes a depth along the beam with
 * d = (i / fs + delay) * c / 2 (echoreg::core::DepthConversion; Mozes 2008, Eq. 3.2). The window is
 * given in mm (WindowMinMm, WindowMaxMm) and converted to sample indices as
 * echoreg::core::resolvePeakParams does; when set, it replaces the window of the PeakParams, and
 * the PeakParams' mmPerSample is always taken from the DepthConversion.
 *
 * Input (port 0): vtkImageData of envelopes, as vtkEchoregEnvelopeFilter makes it (one slice,
 * x = sample, y = frame, one-component scalars of any numeric type). With FramesPerBlock 0 (the
 * default) the whole input is requested, and the upstream keeps every envelope (a later peak
 * parameter does not recompute them). With FramesPerBlock N > 0 a longer capture is streamed:
 * the input is requested N frames at a time (its update extent along y), first through the
 * pipeline's own request, then by updating the input's producer for each further block from
 * RequestData; each block's rows are done in parallel and written into the one table, so the
 * output is the same, while the envelopes held at any time are one block's (N x samples floats)
 * instead of the capture's. A block that cannot be computed fails the whole execution.
 * Output (port 0): vtkTable, one row per frame, columns
 *   "frame" (int, the y index), "timestamp_s" (double, from the field data "Timestamp", NaN
 *   when absent), "peaks" (int, number of peaks found), "sample_index" (double, NaN when
 *   rejected), "depth_mm" (double, NaN when rejected), "reason" (string, "" when accepted, else
 *   echoreg::core::rejectReasonName), "threshold" (double, in envelope units).
 * The input's field data (timestamps, poses, acquisition settings) is passed through to the
 * table's field data, plus "EchoesFromContext" (one int: the rows the capture's context took,
 * below). An input without samples gives a table without rows, with a warning.
 * With the prominence policy, the rows are then judged in frame order by
 * echoreg::core::EchoContext (ProminenceParams::contextFrames): a not-bone row takes the echo the
 * rows before it agree on, as detectSequence and a live session do.
 * Output (port 1): with PeakList on, every peak of every frame, in frame order then sample
 * order: "frame" (int), "sample_index" (int, the maximum of the run above the threshold),
 * "value" (double, the envelope there); the peaks the verdicts of port 0 were chosen from (what
 * `echoreg figure signals` draws). Off (the default, as `detect` runs): a table without rows.
 *
 * SetDetectionParams() takes the parameters of the whole chain (as adaptToSequence resolved them)
 * and resolves them exactly as echoreg::core::SignalDetector does, so the table's verdicts are
 * detectSequence's single-signal verdicts: the transducer frequency (samples per cycle) and the
 * envelope's ring-down reach the peak policy too. Frames are processed in parallel with
 * vtkSMPTools.
 *
 * Defaults: those of echoreg::core::PeakParams (1.5 x mean, bone policy, sub-sample refinement) and
 * echoreg::core::DepthConversion (50 MHz, no delay, 1540 m/s); no window.
 */
#pragma once

#include "echoreg/core/depth.hpp"
#include "echoreg/core/detection.hpp"
#include "echoreg/core/peaks.hpp"

#include <vtkTableAlgorithm.h>

class vtkImageData;

#include <algorithm>
#include <optional>
#include <string>

class vtkEchoregPeakFilter : public vtkTableAlgorithm {
 public:
  static vtkEchoregPeakFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregPeakFilter, vtkTableAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  ///@{
  /**
   * Threshold, window in samples, policy, bone signature and sub-sample refinement. Modified()
   * only when something differs.
   */
  void SetPeakParams(const echoreg::core::PeakParams& params);
  const echoreg::core::PeakParams& GetPeakParams() const { return this->PeakParams; }
  ///@}

  ///@{
  /**
   * The parameters of the whole chain: peaks, depth, window, and what of the envelope and the
   * transducer the peak policy reads (ring-down, transducer frequency). GetDetectionParams()
   * composes them back. Modified() only when something differs.
   */
  void SetDetectionParams(const echoreg::core::DetectionParams& params);
  echoreg::core::DetectionParams GetDetectionParams() const;
  ///@}

  ///@{
  /**
   * Threshold as a multiple of the envelope's mean (> 0, default 1.5), used by the FactorOfMean
   * threshold mode.
   */
  void SetThresholdFactor(double factor) {
    this->SetField(this->PeakParams.thresholdFactor, factor);
  }
  double GetThresholdFactor() const { return this->PeakParams.thresholdFactor; }
  ///@}

  ///@{
  /**
   * Refine the chosen peak to a fraction of a sample with a parabola (default on).
   */
  void SetSubsample(bool subsample) { this->SetField(this->PeakParams.subsample, subsample); }
  bool GetSubsample() const { return this->PeakParams.subsample; }
  void SubsampleOn() { this->SetSubsample(true); }
  void SubsampleOff() { this->SetSubsample(false); }
  ///@}

  ///@{
  /**
   * Sample index to depth: sampling frequency (Hz, default 50e6), acquisition delay (s, default
   * 0) and speed of sound (m/s, default 1540). Modified() only when something differs.
   */
  void SetDepthConversion(const echoreg::core::DepthConversion& conversion);
  const echoreg::core::DepthConversion& GetDepthConversion() const { return this->Depth; }
  void SetSamplingFrequencyHz(double hz) { this->SetField(this->Depth.samplingFrequencyHz, hz); }
  double GetSamplingFrequencyHz() const { return this->Depth.samplingFrequencyHz; }
  void SetDelayS(double seconds) { this->SetField(this->Depth.delayS, seconds); }
  double GetDelayS() const { return this->Depth.delayS; }
  void SetSpeedOfSoundMps(double mps) { this->SetField(this->Depth.speedOfSoundMps, mps); }
  double GetSpeedOfSoundMps() const { return this->Depth.speedOfSoundMps; }
  ///@}

  ///@{
  /**
   * Processing window along the beam in mm: peaks shallower than WindowMinMm or deeper than
   * WindowMaxMm are ignored. NaN (the default) leaves that side open; min must be below max.
   */
  void SetWindowMinMm(double depthMm);
  double GetWindowMinMm() const { return this->WindowMinMm; }
  void SetWindowMaxMm(double depthMm);
  double GetWindowMaxMm() const { return this->WindowMaxMm; }
  ///@}

  ///@{
  /**
   * Fill output port 1 with every frame's peaks (default off).
   */
  void SetPeakList(bool enabled) { this->SetField(this->PeakList, enabled); }
  bool GetPeakList() const { return this->PeakList; }
  void PeakListOn() { this->SetPeakList(true); }
  void PeakListOff() { this->SetPeakList(false); }
  ///@}

  ///@{
  /**
   * Frames per block when streaming the input (>= 0; default 0: the whole input at once). See
   * above: a block size bounds the memory of the envelopes, at the price of recomputing them
   * when a peak parameter changes.
   */
  void SetFramesPerBlock(int frames) { this->SetField(this->FramesPerBlock, std::max(0, frames)); }
  int GetFramesPerBlock() const { return this->FramesPerBlock; }
  ///@}

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times RequestData ran (one pass over the input, however many blocks it took).
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

 protected:
  vtkEchoregPeakFilter();
  ~vtkEchoregPeakFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
                          vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregPeakFilter(const vtkEchoregPeakFilter&) = delete;
  void operator=(const vtkEchoregPeakFilter&) = delete;

  template <typename T>
  void SetField(T& field, T value) {
    if (field != value) {
      field = value;
      this->Modified();
    }
  }
  void SetWindowLimit(double& limit, double depthMm);
  void Fail(const std::string& message);
  /// Updates the input's producer for frames [firstFrame, lastFrame] (whole records) and returns
  /// its output, or null when the update failed.
  vtkImageData* UpdateInputFrames(int firstFrame, int lastFrame);

  echoreg::core::PeakParams PeakParams;
  echoreg::core::DepthConversion Depth;
  echoreg::core::EnvelopeParams Envelope;
  std::optional<double> TransducerFrequencyHz;
  double WindowMinMm;
  double WindowMaxMm;
  bool PeakList = false;
  int FramesPerBlock = 0;
  std::string LastError;
  int ExecutionCount = 0;
};
