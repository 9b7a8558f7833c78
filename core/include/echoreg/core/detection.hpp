// The whole A-line chain of one record (envelope, peaks, depth), its presets, and the
// inter-signal filters that run over consecutive records (Mozes 2008, section 4.3.3).
#pragma once

#include "echoreg/core/depth.hpp"
#include "echoreg/core/envelope.hpp"
#include "echoreg/core/peaks.hpp"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

namespace echoreg {

/// Inter-signal filters. Temporal consistency: a point is accepted once `history` consecutive
/// detected frames (this one included) lie within `consistencyMm` of this one; a frame with no
/// detection breaks the run. Spatial spread: a point closer than `minSpreadMm` to an already
/// accepted point is dropped. Points are 3D: in a tracked frame when poses are present, else
/// (0, 0, depth) in Beam.
struct InterSignalParams {
  int history = 3;             ///< >= 1; 1 switches the temporal filter off
  double consistencyMm = 0.5;  ///< > 0
  double minSpreadMm = 1.0;    ///< >= 0; 0 switches the spatial filter off
};

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const InterSignalParams& a, const InterSignalParams& b) {
  const auto& [historyA, consistencyA, spreadA] = a;
  const auto& [historyB, consistencyB, spreadB] = b;
  return std::tie(historyA, consistencyA, spreadA) == std::tie(historyB, consistencyB, spreadB);
}
inline bool operator!=(const InterSignalParams& a, const InterSignalParams& b) { return !(a == b); }

/// Every parameter of the chain. Window limits are depths (mm) and become sample indices through
/// `depth` when the chain is built.
struct DetectionParams {
  EnvelopeParams envelope;
  PeakParams peaks;
  DepthConversion depth;
  InterSignalParams interSignal;
  std::optional<double> windowMinMm;
  std::optional<double> windowMaxMm;
};

/// "default" (specimens: hann envelope and the bone policy), "mozes2008" (the dissertation's
/// chain as it was: causal Butterworth order 2 at 0.01, threshold 1.5 x mean, exactly two
/// peaks), "calibration" (sphere in water: window-max). Throws std::invalid_argument listing the
/// valid names.
DetectionParams detectionPreset(std::string_view name);
/// The preset names, in the order above.
std::vector<std::string> detectionPresetNames();

/// Checks every parameter; throws std::invalid_argument naming the first bad one.
void validate(const DetectionParams& params);

/// Result of the chain on one record.
struct SignalDetection {
  PeakResult peaks;
  double depthMm = 0.0;  ///< depth of the chosen peak; meaningful when peaks.accepted()
  bool accepted() const { return peaks.accepted(); }
};

/// Envelope, peaks and depth of records of one parameter set; one detector per thread.
class SignalDetector {
 public:
  explicit SignalDetector(const DetectionParams& params);

  /// Runs the chain on `count` samples. The envelope stays available in envelope().
  SignalDetection detect(const float* samples, int count);
  const std::vector<float>& envelope() const { return envelope_; }
  const DetectionParams& params() const { return params_; }

 private:
  DetectionParams params_;
  EnvelopeDetector envelopeDetector_;
  std::vector<float> envelope_;
};

/// The peak parameters with the window converted from mm to sample indices.
PeakParams resolvePeakParams(const DetectionParams& params);

/// Temporal consistency and spatial spread over consecutive frames, fed in frame order.
class InterSignalFilter {
 public:
  explicit InterSignalFilter(const InterSignalParams& params);

  /// Judges the point of a frame whose single-signal detection succeeded: None (accepted and
  /// remembered), Inconsistent or TooClose.
  RejectReason judge(const Eigen::Vector3d& pointMm);
  /// A frame without a point (rejected earlier) breaks the temporal run.
  void breakRun() { run_.clear(); }
  const std::vector<Eigen::Vector3d>& acceptedPoints() const { return accepted_; }

 private:
  InterSignalParams params_;
  std::vector<Eigen::Vector3d> run_;
  std::vector<Eigen::Vector3d> accepted_;
};

}  // namespace echoreg
