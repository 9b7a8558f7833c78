// A-line envelopes: the dissertation's rectify + Butterworth chain and three alternatives.
//
// Every method first conditions the record: it removes the record's mean (8-bit digitisers store
// 0 V as 128, 12-bit ones a DC offset) or, with `highPassSamples`, a centred moving average of
// that length (a high-pass that also removes the slow baseline drift of real front ends, below
// the transducer's band), and zeroes the first `ringDownSamples` samples (the transducer's
// ring-down), then:
//  - Mozes:   |x| low-passed by a Butterworth filter (Mozes 2008, Fig. 4.9), zero-phase by
//             default; causal reproduces the dissertation's one-pass filter, whose group delay
//             (45 samples for order 2 at 0.01, 0.69 mm at 50 MHz and 1540 m/s) moves every peak
//             deeper.
//  - Hann:    centred moving Hann-weighted average of |x| over `windowSamples` (PLUS's A-mode
//             device uses 153 at 420 MHz), normalised to unit DC gain.
//  - StdDev:  centred moving standard deviation over `windowSamples` (Bass 2003: 0.5 us).
//  - Hilbert: |analytic signal| of x band-passed around the transducer frequency (raised-cosine
//             band in the frequency domain, FFT from Eigen), then a centred box average over
//             `smoothingSamples`.
#pragma once

#include "echoreg/core/butterworth.hpp"

#include <memory>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

namespace echoreg::core {

enum class EnvelopeMethod { Mozes, Hann, StdDev, Hilbert };

/// "mozes", "hann", "stddev", "hilbert".
std::string_view envelopeMethodName(EnvelopeMethod method);
/// Parses a name of envelopeMethodName; throws std::invalid_argument listing the valid names.
EnvelopeMethod parseEnvelopeMethod(std::string_view name);

struct EnvelopeParams {
  EnvelopeMethod method = EnvelopeMethod::Hann;
  /// Samples zeroed at the start of the record (ring-down), >= 0.
  int ringDownSamples = 0;
  /// Conditioning: 0 removes the record's mean only; L >= 2 subtracts the centred moving average
  /// of L samples (clipped at the record's ends), a high-pass whose gain is 1 - sinc(f L / fs):
  /// 0.5 % at a twentieth of fs / L, full at fs / L and above (see highPassLength()).
  int highPassSamples = 0;
  /// Mozes: Butterworth order (1..12) and cutoff normalised to Nyquist (0, 1).
  int butterworthOrder = 2;
  double cutoffNormalized = 0.01;
  /// Mozes: forward-backward (true) or the dissertation's single causal pass (false).
  bool zeroPhase = true;
  /// Hann and StdDev: window length in samples (>= 1).
  int windowSamples = 153;
  /// Hilbert: band centre (the transducer's frequency), relative -6 dB bandwidth, sampling rate.
  double transducerFrequencyHz = 9e6;
  double relativeBandwidth = 0.8;
  double samplingFrequencyHz = 50e6;
  /// Hilbert: centred box smoothing of the magnitude, samples (>= 1; 1 = none).
  int smoothingSamples = 5;
};

/// Checks the parameters; throws std::invalid_argument naming the first bad one.
void validate(const EnvelopeParams& params);

/// out = x - the centred moving average of x over `window` samples, clipped at the record's ends
/// (the conditioning high-pass; `out` may not alias `samples`).
void subtractMovingAverage(const float* samples, int count, int window, float* out);

/// The moving-average length (odd, >= 3) of a high-pass with its corner at `cornerHz`: the
/// average spans 1.5 periods of the corner frequency, so the gain is 0.70 at the corner, 1.2 at
/// twice it, 3.6 % at a tenth of it and 0.3 % at a thirtieth.
int highPassLength(double cornerHz, double samplingFrequencyHz);

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const EnvelopeParams& a, const EnvelopeParams& b) {
  const auto& [methodA, ringDownA, highPassA, orderA, cutoffA, zeroPhaseA, windowA, transducerA,
               bandwidthA, samplingA, smoothingA] = a;
  const auto& [methodB, ringDownB, highPassB, orderB, cutoffB, zeroPhaseB, windowB, transducerB,
               bandwidthB, samplingB, smoothingB] = b;
  return std::tie(methodA, ringDownA, highPassA, orderA, cutoffA, zeroPhaseA, windowA, transducerA,
                  bandwidthA, samplingA, smoothingA) ==
         std::tie(methodB, ringDownB, highPassB, orderB, cutoffB, zeroPhaseB, windowB, transducerB,
                  bandwidthB, samplingB, smoothingB);
}
inline bool operator!=(const EnvelopeParams& a, const EnvelopeParams& b) {
  return !(a == b);
}

/// Computes envelopes of records of one length with one parameter set. Construction designs the
/// filters and windows once; compute() reuses scratch buffers, so one detector per thread.
class EnvelopeDetector {
 public:
  explicit EnvelopeDetector(const EnvelopeParams& params);
  ~EnvelopeDetector();
  EnvelopeDetector(EnvelopeDetector&&) noexcept;
  EnvelopeDetector& operator=(EnvelopeDetector&&) noexcept;

  const EnvelopeParams& params() const;

  /// Envelope of `count` samples into `envelope` (count values). `envelope` may alias `samples`.
  void compute(const float* samples, int count, float* envelope);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace echoreg::core
