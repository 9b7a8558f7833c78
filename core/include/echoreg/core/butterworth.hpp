// Digital Butterworth low-pass design (bilinear transform with pre-warping, as MATLAB's
// butter(n, Wn) and scipy.signal.butter) and IIR filtering, causal or zero-phase.
#pragma once

#include <vector>

namespace echoreg::core {

/// Transfer function b(z)/a(z), a[0] == 1.
struct IirCoefficients {
  std::vector<double> b;
  std::vector<double> a;
};

/// Designs an order-`order` Butterworth low-pass with the cutoff normalised to Nyquist
/// (0 < cutoffNormalized < 1; the dissertation's 0.01 at 50 MHz is 250 kHz). Unit gain at DC.
/// Throws std::invalid_argument for order < 1 or > 12, or a cutoff outside (0, 1).
IirCoefficients designButterworthLowPass(int order, double cutoffNormalized);

/// Group delay of the filter at normalised frequency w (radians per sample), in samples.
double groupDelaySamples(const IirCoefficients& filter, double radiansPerSample);

/// One causal pass (direct form II transposed, zero initial state), like MATLAB's filter().
/// `out` may alias `in`.
void filterCausal(const IirCoefficients& filter, const float* in, int count, float* out);

/// Zero-phase forward-backward filtering as scipy.signal.filtfilt with its defaults: odd
/// extension of 3 * max(len(a), len(b)) samples at both ends and steady-state initial
/// conditions scaled by the first sample of each pass. Records shorter than the extension are
/// filtered without it. `out` may alias `in`.
void filterZeroPhase(const IirCoefficients& filter, const float* in, int count, float* out);

}  // namespace echoreg::core
