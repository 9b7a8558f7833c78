// The detection chain on A-lines as they arrive: the core's SignalDetector (the chain
// `echoreg detect` and `register` run, envelope, peaks, depth), the beam-to-bone mapping of
// `beamPoint`, and the inter-signal filters fed in frame order (InterSignalFilter, causal).
// The capture-dependent settings (transducer band, ring-down, shadow rule: adaptToCapture) are
// measured on the first `adaptFrames` A-lines, which wait for it; after that every frame is
// decided as it arrives. Offline, adaptToSequence measures them over the whole capture, so the
// points of a live session and of `register` on its recording may differ by the few frames near
// a threshold (docs/live.md).
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/surface_registration.hpp"
#include "echoreg/live/pose_buffer.hpp"

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::live {

struct LiveDetectorOptions {
  /// The chain's parameters with the depth conversion resolved (validated by the constructor).
  DetectionParams params;
  /// The transducer frequency the stream's header gives, if any.
  std::optional<double> headerFrequencyHz;
  /// beamToProbe, and the pose and reference transforms' names ("ProbeToTracker",
  /// "FemurToTracker"); the points are in the reference's frame.
  PointFrameOptions points;
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

class LiveDetector {
 public:
  /// Throws std::invalid_argument for bad parameters (validate's words) or adaptFrames < 1.
  explicit LiveDetector(LiveDetectorOptions options);
  ~LiveDetector();
  LiveDetector(const LiveDetector&) = delete;
  LiveDetector& operator=(const LiveDetector&) = delete;

  /// An A-line with the poses looked up at its arrival. Returns the frames decided now: none
  /// while the first adaptFrames wait, then those at once, then one per call.
  std::vector<LiveFrame> add(int frame, double timestampS, std::vector<float> samples,
                             PoseLookup pose, PoseLookup reference,
                             std::chrono::steady_clock::time_point arrival);
  /// Decides the frames still waiting (a session shorter than adaptFrames).
  std::vector<LiveFrame> flush();

  bool adapted() const { return detector_ != nullptr; }
  const DetectionParams& params() const { return adaptedParams_; }
  const CaptureAnalysis& analysis() const { return analysis_; }

 private:
  struct Waiting {
    int frame;
    double timestampS;
    std::vector<float> samples;
    PoseLookup pose, reference;
    std::chrono::steady_clock::time_point arrival;
  };
  void adapt();
  LiveFrame decide(const Waiting& waiting);

  LiveDetectorOptions options_;
  DetectionParams adaptedParams_;
  CaptureAnalysis analysis_;
  std::unique_ptr<SignalDetector> detector_;
  std::unique_ptr<InterSignalFilter> interSignal_;
  std::vector<Waiting> waiting_;
};

}  // namespace echoreg::live
