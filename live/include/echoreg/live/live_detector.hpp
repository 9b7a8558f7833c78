// The detection chain on A-lines as they arrive: the core's chain of one record (the envelope,
// peaks and depth `echoreg detect` and `register` run), the beam-to-bone mapping of `beamPoint`,
// and the inter-signal filters fed in frame order (InterSignalFilter, causal).
//
// The capture-dependent settings (transducer band, ring-down, shadow rule: adaptToCapture) are
// measured on the first `adaptFrames` A-lines, which wait for it; after that every frame is
// decided as it arrives. The band and the ring-down are the probe's and the digitiser's, the same
// in every record, so the first A-lines measure them as well as the whole capture does. The
// shadow rule is not: it says whether the bone under the probe casts a shadow in a fifth of the
// capture, and the first second of a sweep may not be over bone at all (on a 24,000-frame
// simulated femur sweep, bone cast a shadow in 3 of its first 64 A-lines and in 20 of 64 spread
// over the whole sweep). So, when the rule is measured (the prominence policy with the shadow
// `auto`), it is measured again on up to 64 A-lines spread over all received so far (a sample
// thinned by halves as the session grows, at most 128 A-lines held) each time their count
// doubles (128, 256, 512, ... with 64), and once more over the whole session at its end
// (flush). Every frame is judged by both rules (one envelope, the peaks twice), each rule with
// its own inter-signal filter, so that when the measurement changes the rule, the frames received
// so far are judged by the new one as if it had been the rule from the first A-line on
// (ShadowRuleSwitch): as `register` judges every frame of the recording by the rule of the whole
// capture. The frames decided before the switch were already reported (and their points sent);
// the switch gives their new verdicts. Offline, adaptToSequence measures on up to 64 A-lines
// spread over the whole capture, so the points of a live session and of `register` on its
// recording differ only when the two spread samples fall on either side of the 20 % (docs/live.md).
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/surface_registration.hpp"
#include "echoreg/live/pose_buffer.hpp"

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::live {

struct LiveDetectorOptions {
  /// The chain's parameters with the depth conversion resolved (validated by the constructor).
  core::DetectionParams params;
  /// The transducer frequency the stream's header gives, if any.
  std::optional<double> headerFrequencyHz;
  /// beamToProbe, and the pose and reference transforms' names ("ProbeToTracker",
  /// "FemurToTracker"); the points are in the reference's frame.
  core::PointFrameOptions points;
  double ultrasoundSigmaMm = 0.5;
  /// A-lines measured before the first is decided (>= 1).
  int adaptFrames = 64;
};

/// One frame's verdict.
struct LiveFrame {
  int frame = 0;
  double timestampS = 0.0;
  std::chrono::steady_clock::time_point arrival;
  /// "accepted", a reject reason of the chain ("no-peak", "too-close", ...), "stale-pose" or
  /// "invalid-pose".
  std::string reason;
  std::string detail;  ///< the pose's refusal in words, for stale-pose and invalid-pose
  std::optional<core::SurfacePoint> point;  ///< accepted: the point with its beam, bone frame
  bool accepted() const { return point.has_value(); }
};

/// A measurement of the capture's shadow rule during a session.
struct ShadowMeasurement {
  long long frames = 0;  ///< A-lines received when measured: the trial's records spread over them
  core::ShadowTrial trial;
};

/// The shadow rule changed: the frames received so far as the new rule judges them, from the
/// first A-line on (each rule has its own inter-signal filter, fed every frame in order).
struct ShadowRuleSwitch {
  ShadowMeasurement measurement;
  core::ShadowRule from = core::ShadowRule::Auto;
  core::ShadowRule to = core::ShadowRule::Auto;
  std::vector<LiveFrame> accepted;      ///< the new rule's accepted frames so far, in order
  std::map<std::string, int> verdicts;  ///< the new rule's verdicts of every frame so far
};

class LiveDetector {
 public:
  /// Throws std::invalid_argument for bad parameters (validate's words) or adaptFrames < 1.
  explicit LiveDetector(LiveDetectorOptions options);
  ~LiveDetector();
  LiveDetector(const LiveDetector&) = delete;
  LiveDetector& operator=(const LiveDetector&) = delete;

  /// An A-line with the poses looked up at its arrival. Returns the frames decided now: none
  /// while the first adaptFrames wait, then those at once, then one per call (decided by the
  /// rule in force before a re-measurement that this A-line may start: see takeSwitch).
  std::vector<LiveFrame> add(int frame, double timestampS, std::vector<float> samples,
                             PoseLookup pose, PoseLookup reference,
                             std::chrono::steady_clock::time_point arrival);
  /// Decides the frames still waiting (a session shorter than adaptFrames), then measures the
  /// shadow rule once more over every A-line received (the end of the stream).
  std::vector<LiveFrame> flush();
  /// The switch of the shadow rule since the last call, if a measurement changed it.
  std::optional<ShadowRuleSwitch> takeSwitch();

  bool adapted() const { return envelope_ != nullptr; }
  /// The parameters in force (the shadow rule the last measurement chose).
  const core::DetectionParams& params() const { return adaptedParams_; }
  /// What the first adaptation measured, with the shadow rule and share of the last measurement.
  const core::CaptureAnalysis& analysis() const { return analysis_; }
  /// Whether the shadow rule is measured as the session goes (both rules judge every frame).
  bool measuresShadowRule() const { return judges_.size() == 2; }
  /// Every measurement of the shadow rule, the first adaptation's first.
  const std::vector<ShadowMeasurement>& shadowMeasurements() const { return measurements_; }

 private:
  struct Waiting {
    int frame;
    double timestampS;
    std::vector<float> samples;
    PoseLookup pose, reference;
    std::chrono::steady_clock::time_point arrival;
  };
  // One shadow rule's judgement of every frame: its peaks, its inter-signal filter, what it
  // accepted and its verdicts.
  struct Judge {
    core::ShadowRule rule = core::ShadowRule::Auto;
    core::PeakParams peaks;  // resolved (window in samples)
    std::unique_ptr<core::InterSignalFilter> interSignal;
    std::unique_ptr<core::EchoContext> context;  // the frames before each one (echo-context)
    std::vector<LiveFrame> accepted;
    std::map<std::string, int> verdicts;
  };
  void keepForMeasurement(const std::vector<float>& samples);
  void adapt();
  void remeasure();
  LiveFrame decide(const Waiting& waiting);
  LiveFrame judge(Judge& judge, const Waiting& waiting, const core::PeakResult& peaks);

  LiveDetectorOptions options_;
  core::DetectionParams adaptedParams_;
  core::CaptureAnalysis analysis_;
  std::unique_ptr<core::EnvelopeDetector> envelope_;
  std::vector<float> envelopeSamples_;
  std::vector<Judge> judges_;  // one, or two when the shadow rule is measured: [0] Auto
  std::size_t active_ = 0;
  std::vector<Waiting> waiting_;
  // A-lines spread over the session for the measurements: every stride-th, thinned by halves.
  std::vector<std::vector<float>> kept_;
  long long keepStride_ = 1;
  long long received_ = 0;
  long long nextMeasurement_ = 0;
  std::vector<ShadowMeasurement> measurements_;
  std::optional<ShadowRuleSwitch> switch_;
};

}  // namespace echoreg::live
