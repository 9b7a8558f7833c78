/**
 * @class   vtkEchoregEnvelopeFilter
 * @brief   Envelope of every A-line of an image of A-lines.
 *
 * Each row of the input (one frame: x = sample index) is converted to float and passed through
 * echoreg::core::EnvelopeDetector: the record's mean is removed, the first RingDownSamples samples
 * are zeroed, then one of
 *  - Mozes:   |x| low-passed by a Butterworth filter of order ButterworthOrder at
 *             CutoffNormalized (fraction of Nyquist), zero-phase or, with ZeroPhase off, the single
 *             causal pass of Mozes 2008 (Fig. 4.9; "Bone registration with tracked A-mode
 *             ultrasound", Queen's University);
 *  - Hann:    centred Hann-weighted moving average of |x| over WindowSamples;
 *  - StdDev:  centred moving standard deviation over WindowSamples (Bass 2003);
 *  - Hilbert: |analytic signal| of x band-passed around TransducerFrequencyHz with
 *             RelativeBandwidth at SamplingFrequencyHz, smoothed over SmoothingSamples.
 * Frames are processed in parallel with vtkSMPTools, one detector per chunk of frames.
 *
 * Input (port 0): vtkImageData of A-lines as vtkEchoregSequenceReader makes it: one slice, x the
 * sample, y the frame, one-component scalars of any numeric type. Whole records are requested,
 * of the frames asked of the output: all of them, or one block of frames at a time when a
 * downstream filter streams the capture (vtkEchoregPeakFilter's FramesPerBlock); the output then
 * holds only that block, with its absolute frame indices as the extent.
 * Output (port 0): vtkImageData of the same structure with float point scalars "Envelope". The
 * input's field data (timestamps, poses, acquisition settings) is passed through unchanged.
 * Memory: the filter keeps its last "Envelope" array and writes the next run's envelopes into it
 * when nothing else holds it any more (the executive releases the output before each run), so a
 * capture streamed in blocks touches fresh memory for its first block only; a consumer that keeps
 * a reference to an earlier output's array gets a new array instead, never overwritten data.
 * An input without samples (a tracker-only capture) gives an output of the same extent without
 * scalars, with a warning.
 *
 * Defaults: those of echoreg::core::EnvelopeParams (Hann, 153-sample window, no ring-down zeroing;
 * Mozes: order 2, cutoff 0.01, zero-phase; Hilbert: 9 MHz, relative bandwidth 0.8, 50 MHz,
 * smoothing 5). Parameters are checked by echoreg::core::validate when the filter runs; a bad one
 * is an error naming it (GetLastError()).
 */
#pragma once

#include "echoreg/core/envelope.hpp"

#include <vtkImageAlgorithm.h>
#include <vtkSmartPointer.h>

#include <string>

class vtkFloatArray;

class vtkEchoregEnvelopeFilter : public vtkImageAlgorithm {
 public:
  static vtkEchoregEnvelopeFilter* New();
  // vtkTypeMacro ends in an access specifier, so a ';' after it is an empty declaration
  // (-Wpedantic), and without one clang-format joins it to the next line.
  // clang-format off
  vtkTypeMacro(vtkEchoregEnvelopeFilter, vtkImageAlgorithm)
  void PrintSelf(ostream& os, vtkIndent indent) override;
  // clang-format on

  /// Values of Method.
  enum { METHOD_MOZES = 0, METHOD_HANN = 1, METHOD_STDDEV = 2, METHOD_HILBERT = 3 };

  ///@{
  /**
   * Every parameter at once. Modified() only when something differs.
   */
  void SetParams(const echoreg::core::EnvelopeParams& params);
  const echoreg::core::EnvelopeParams& GetParams() const { return this->Params; }
  ///@}

  ///@{
  /**
   * Envelope method, one of METHOD_*; values outside are clamped. Default: METHOD_HANN.
   */
  void SetMethod(int method);
  int GetMethod() const;
  void SetMethodToMozes() { this->SetMethod(METHOD_MOZES); }
  void SetMethodToHann() { this->SetMethod(METHOD_HANN); }
  void SetMethodToStdDev() { this->SetMethod(METHOD_STDDEV); }
  void SetMethodToHilbert() { this->SetMethod(METHOD_HILBERT); }
  /// "mozes", "hann", "stddev" or "hilbert".
  const char* GetMethodAsString() const;
  ///@}

  ///@{
  /**
   * Samples zeroed at the start of each record (the transducer's ring-down), >= 0. Default 0.
   */
  void SetRingDownSamples(int samples) { this->SetField(this->Params.ringDownSamples, samples); }
  int GetRingDownSamples() const { return this->Params.ringDownSamples; }
  ///@}

  ///@{
  /**
   * Mozes: Butterworth order (1..12, default 2) and cutoff as a fraction of Nyquist ((0, 1),
   * default 0.01: 250 kHz at 50 MHz), zero-phase forward-backward (default on) or one causal pass.
   */
  void SetButterworthOrder(int order) { this->SetField(this->Params.butterworthOrder, order); }
  int GetButterworthOrder() const { return this->Params.butterworthOrder; }
  void SetCutoffNormalized(double cutoff) { this->SetField(this->Params.cutoffNormalized, cutoff); }
  double GetCutoffNormalized() const { return this->Params.cutoffNormalized; }
  void SetZeroPhase(bool zeroPhase) { this->SetField(this->Params.zeroPhase, zeroPhase); }
  bool GetZeroPhase() const { return this->Params.zeroPhase; }
  void ZeroPhaseOn() { this->SetZeroPhase(true); }
  void ZeroPhaseOff() { this->SetZeroPhase(false); }
  ///@}

  ///@{
  /**
   * Hann and StdDev: window length in samples (>= 1). Default 153.
   */
  void SetWindowSamples(int samples) { this->SetField(this->Params.windowSamples, samples); }
  int GetWindowSamples() const { return this->Params.windowSamples; }
  ///@}

  ///@{
  /**
   * Hilbert: band centre in Hz (default 9 MHz), relative -6 dB bandwidth (default 0.8), sampling
   * frequency of the A-lines in Hz (default 50 MHz), box smoothing of the magnitude in samples
   * (>= 1, default 5; 1 = none).
   */
  void SetTransducerFrequencyHz(double hz) {
    this->SetField(this->Params.transducerFrequencyHz, hz);
  }
  double GetTransducerFrequencyHz() const { return this->Params.transducerFrequencyHz; }
  void SetRelativeBandwidth(double bandwidth) {
    this->SetField(this->Params.relativeBandwidth, bandwidth);
  }
  double GetRelativeBandwidth() const { return this->Params.relativeBandwidth; }
  void SetSamplingFrequencyHz(double hz) { this->SetField(this->Params.samplingFrequencyHz, hz); }
  double GetSamplingFrequencyHz() const { return this->Params.samplingFrequencyHz; }
  void SetSmoothingSamples(int samples) { this->SetField(this->Params.smoothingSamples, samples); }
  int GetSmoothingSamples() const { return this->Params.smoothingSamples; }
  ///@}

  /**
   * Message of the last failure, empty after a success.
   */
  const std::string& GetLastError() const { return this->LastError; }

  /**
   * Number of times RequestData ran (once per block when the capture is streamed).
   */
  int GetExecutionCount() const { return this->ExecutionCount; }

  /**
   * Number of frames (rows) whose envelope was computed, over every execution: a capture streamed
   * in blocks and enveloped once adds its frame count.
   */
  vtkIdType GetFramesComputed() const { return this->FramesComputed; }

 protected:
  vtkEchoregEnvelopeFilter();
  ~vtkEchoregEnvelopeFilter() override;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
                         vtkInformationVector* outputVector) override;
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
                          vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
                  vtkInformationVector* outputVector) override;

 private:
  vtkEchoregEnvelopeFilter(const vtkEchoregEnvelopeFilter&) = delete;
  void operator=(const vtkEchoregEnvelopeFilter&) = delete;

  template <typename T>
  void SetField(T& field, T value) {
    if (field != value) {
      field = value;
      this->Modified();
    }
  }
  void Fail(const std::string& message);

  echoreg::core::EnvelopeParams Params;
  /// The last run's envelopes, reused by the next run when this filter is their only holder.
  vtkSmartPointer<vtkFloatArray> Envelopes;
  std::string LastError;
  int ExecutionCount = 0;
  vtkIdType FramesComputed = 0;
};
