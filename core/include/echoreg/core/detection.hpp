// The whole A-line chain of one record (envelope, peaks, depth), its presets, and the
// inter-signal filters that run over consecutive records (Mozes 2008, section 4.3.3).
#pragma once

#include "echoreg/core/depth.hpp"
#include "echoreg/core/envelope.hpp"
#include "echoreg/core/peaks.hpp"

#include <Eigen/Core>

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

namespace echoreg::core {

/// How the temporal filter judges a frame.
enum class TemporalMode {
  /// The dissertation's: a point is accepted once `history` consecutive detected frames (this one
  /// included) lie within `consistencyMm` of it in 3D; a frame with no detection breaks the run.
  Run,
  /// A depth is accepted when at least `history - 1` of the detected frames nearest in time
  /// (before or after it, at most `maxGapS` away) agree with it within consistencyMm +
  /// maxDepthRateMmPerS x their time apart: an echo that jumps alone is dropped, a bone moving
  /// under a sweep or a breathing leg is kept, and a missed frame does not reset anything.
  Neighbours,
};

/// "run", "neighbours".
std::string_view temporalModeName(TemporalMode mode);
/// Parses a name of temporalModeName; throws std::invalid_argument listing the valid names.
TemporalMode parseTemporalMode(std::string_view name);

/// Inter-signal filters. Temporal consistency (see TemporalMode). Spatial spread: a point closer
/// than `minSpreadMm` to an already accepted point is dropped; it runs only on tracked points
/// (a pose transform), since without poses (0, 0, depth) of a transducer that does not move says
/// nothing about where the beam was. Points are 3D: in a tracked frame when poses are present,
/// else (0, 0, depth) in Beam.
struct InterSignalParams {
  int history = 3;             ///< >= 1; 1 switches the temporal filter off
  double consistencyMm = 0.5;  ///< > 0
  double minSpreadMm = 1.0;    ///< >= 0; 0 switches the spatial filter off
  TemporalMode temporal = TemporalMode::Run;
  /// Neighbours: how fast the depth may change, mm/s (>= 0), and the longest time to a neighbour
  /// that still counts, s (> 0). Frames without timestamps are taken 1/`frameRateHz` apart.
  double maxDepthRateMmPerS = 30.0;
  double maxGapS = 0.1;
  double frameRateHz = 50.0;
};

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const InterSignalParams& a, const InterSignalParams& b) {
  const auto& [historyA, consistencyA, spreadA, temporalA, rateA, gapA, fpsA] = a;
  const auto& [historyB, consistencyB, spreadB, temporalB, rateB, gapB, fpsB] = b;
  return std::tie(temporalA, historyA, consistencyA, rateA, gapA, fpsA, spreadA) ==
         std::tie(temporalB, historyB, consistencyB, rateB, gapB, fpsB, spreadB);
}
inline bool operator!=(const InterSignalParams& a, const InterSignalParams& b) {
  return !(a == b);
}

/// What the chain measures from the capture itself before it runs (adaptToCapture), where the
/// user gave nothing: the ring-down, the conditioning high-pass and the envelope window, all from
/// the transducer's frequency (flag, capture header, or the capture's own spectrum).
struct CaptureAdaptation {
  /// Measure where the ring-down burst of the median record ends (else envelope.ringDownSamples).
  bool ringDown = false;
  /// > 0: condition with a high-pass whose corner is this fraction of the transducer frequency.
  double highPassOfTransducer = 0.0;
  /// > 0: condition with a high-pass whose corner is this many Hz (wins over the fraction). With
  /// neither, envelope.highPassSamples is used as given (0: the record's mean removed only).
  double highPassHz = 0.0;
  /// > 0: Hann/StdDev window of this many transducer periods (else envelope.windowSamples).
  double envelopeCycles = 0.0;
  /// Measure the time-gain compensation the front end applied (the rise of the capture's deep
  /// noise with depth); the shadow tests then judge each region against the noise at its depth
  /// (PeakParams::gainDbPerSample).
  bool gain = false;
};

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const CaptureAdaptation& a, const CaptureAdaptation& b) {
  const auto& [ringA, highA, hzA, cyclesA, gainA] = a;
  const auto& [ringB, highB, hzB, cyclesB, gainB] = b;
  return std::tie(ringA, highA, hzA, cyclesA, gainA) == std::tie(ringB, highB, hzB, cyclesB, gainB);
}

/// Every parameter of the chain. Window limits are depths (mm) and become sample indices through
/// `depth` when the chain is built.
struct DetectionParams {
  EnvelopeParams envelope;
  PeakParams peaks;
  DepthConversion depth;
  InterSignalParams interSignal;
  std::optional<double> windowMinMm;
  std::optional<double> windowMaxMm;
  CaptureAdaptation adapt;
  /// The transducer's centre frequency when the user gave it (else the capture header's, else
  /// measured from the capture's spectrum when something needs it).
  std::optional<double> transducerFrequencyHz;
  /// The time-gain compensation the front end applied when the user gave it, dB per mm of depth
  /// (0: none; else measured when adapt.gain).
  std::optional<double> tgcDbPerMm;
};

/// The most time-gain compensation a user may give (DetectionParams::tgcDbPerMm), dB per mm.
inline constexpr double kMaxTgcDbPerMm = 10.0;

/// What adaptToCapture measured and decided, for the summary.
struct CaptureAnalysis {
  double transducerFrequencyHz = 0.0;
  std::string transducerFrequencySource;  ///< "given", "header", "spectrum" or "" (not needed)
  int ringDownSamples = 0;
  std::string ringDownSource;  ///< "given" or "measured"
  int highPassSamples = 0;
  int envelopeWindowSamples = 0;
  /// Prominence policy: the shadow rule chosen for the capture, and the share of the analysed
  /// records in which bone cast a shadow (>= 20 %: "required", else "ignored").
  std::string shadowRule;
  double shadowShare = 0.0;
  /// The time-gain compensation allowed for, dB per mm; its source ("given", "measured", "none"
  /// when the capture's deep noise does not rise steadily, or "" when none was looked for); and
  /// the rise of the capture's deep noise it was measured from (0 when it is not steady).
  double tgcDbPerMm = 0.0;
  std::string tgcSource;
  double deepNoiseRiseDbPerMm = 0.0;
  std::vector<std::string> warnings;
};

/// The record source adaptToCapture reads: `count` records, record(i, out) fills out with the
/// i-th record's samples (all of one length).
using RecordSource = std::function<void(int, std::vector<float>&)>;

/// Resolves the capture-dependent parameters of `params` (CaptureAdaptation) on up to 64 records
/// spread over the capture: the transducer frequency (given > `headerFrequencyHz` > the peak of
/// the records' mean power spectrum between 1 MHz and 0.45 fs, after a 1 MHz high-pass), the
/// high-pass and envelope lengths from it, and the ring-down as the first sample after the
/// median record's initial burst where its envelope falls below half the burst's peak (-6 dB)
/// (none when the record does not start in a burst). Throws std::invalid_argument for a ring-down
/// that covers the whole record. Fills `analysis` when given.
DetectionParams adaptToCapture(const DetectionParams& params, int recordCount, int samples,
                               const RecordSource& record, std::optional<double> headerFrequencyHz,
                               CaptureAnalysis* analysis = nullptr);

/// The capture's shadow trial: the shadowed records among up to 64 spread over `record`'s, judged
/// by the chain of `adapted` (band and ring-down resolved, the prominence policy) with the shadow
/// required and without the shadow at the noise behind a strong echo, and the rule that share
/// implies for every record: Required from 20 % on, else Auto (each record by its own signature:
/// a shadow or the cortex's ringing). adaptToCapture decides a capture's rule with it; a live
/// session measures it again as its capture grows (live::LiveDetector).
struct ShadowTrial {
  int records = 0;   ///< records judged
  int shadowed = 0;  ///< of them, bone with its shadow
  double share = 0.0;
  ShadowRule rule = ShadowRule::Auto;
};
ShadowTrial measureShadowRule(const DetectionParams& adapted, int recordCount, int samples,
                              const RecordSource& record);

/// The transducer frequency of records: the peak of their mean power spectrum (see above); 0 when
/// the records hold no energy in the band.
double estimateTransducerFrequencyHz(int recordCount, int samples, const RecordSource& record,
                                     double samplingFrequencyHz);

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

/// One frame's single-signal result as the inter-signal filters see it.
struct InterSignalInput {
  bool detected = false;  ///< the single-signal chain accepted it, with a valid pose
  double depthMm = 0.0;
  Eigen::Vector3d pointMm = Eigen::Vector3d::Zero();
  std::optional<double> timestampS;
};

/// Temporal consistency and spatial spread over a whole capture (any TemporalMode; Neighbours
/// looks ahead as well as back). Returns, per frame, None, Inconsistent or TooClose for detected
/// frames (and None for the others, which the caller has already judged). `tracked`: the points
/// are tracked 3D points, so the spatial filter runs.
std::vector<RejectReason> applyInterSignal(const InterSignalParams& params,
                                           const std::vector<InterSignalInput>& frames,
                                           bool tracked);

/// Temporal consistency (Run mode) and spatial spread over consecutive frames, fed in frame
/// order.
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

}  // namespace echoreg::core
