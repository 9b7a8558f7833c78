// The A-line chain over a whole capture: single-signal detection of every frame, then the points
// (in Beam, or through tracked poses in Tracker or a reference frame) and the inter-signal
// filters in frame order.
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence.hpp"

#include <Eigen/Core>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::core {

/// Where a frame's point lives. Without a pose transform the point is (0, 0, depth) in Beam.
/// With `poseTransform` (e.g. "ProbeToTracker"): p = ProbeToTracker * beamToProbe * (0, 0, d, 1);
/// with `referenceTransform` too (e.g. "FemurToTracker"): p = inv(FemurToTracker) * that.
struct PointFrameOptions {
  std::string poseTransform;
  std::string referenceTransform;
  Eigen::Matrix4d beamToProbe = Eigen::Matrix4d::Identity();
};

/// The point at `depthMm` on the beam, in the frame `points` names: (0, 0, depth) in Beam without
/// a pose transform; ProbeToTracker * beamToProbe * (0, 0, depth, 1) with one, and inv(reference)
/// times that with a reference. `pose` and `reference` are this frame's valid matrices or null;
/// nullopt when a transform `points` needs is null (the frame is invalid-pose).
std::optional<Eigen::Vector3d> beamPoint(double depthMm, const PointFrameOptions& points,
                                         const Eigen::Matrix4d* pose,
                                         const Eigen::Matrix4d* reference);

/// One frame's verdict.
struct FrameDetection {
  int frame = 0;
  std::optional<double> timestampS;
  RejectReason reason = RejectReason::NoPeak;
  int peakCount = 0;
  std::optional<double> sampleIndex;  ///< the chosen peak, also when a later filter rejected it
  std::optional<double> depthMm;      ///< only when accepted
  std::optional<Eigen::Vector3d> pointMm;  ///< only when accepted
  bool accepted() const { return reason == RejectReason::None; }
};

struct SequenceDetection {
  std::vector<FrameDetection> frames;
  int accepted = 0;
  std::map<std::string, int> rejectedByReason;  ///< reason name -> count
  /// The parameters as run (after adaptToCapture) and what was measured from the capture.
  DetectionParams params;
  CaptureAnalysis analysis;
  /// Frames the single-signal chain accepted (before the inter-signal filters).
  int echoes = 0;
  /// Of those, frames judged not-bone alone whose echo the frames before them agreed on
  /// (EchoContext, the prominence policy's `echo-context`).
  int fromContext = 0;
};

/// What a user should know about a detection, one sentence each: what adaptToCapture warned of,
/// a processing window that starts inside the ring-down, an inter-signal filter that removed more
/// than half of the echoes, and, when fewer than 20 % of the frames were accepted, the dominant
/// reason with the setting most likely to blame.
std::vector<std::string> detectionWarnings(const SequenceDetection& detection);

/// adaptToCapture on a sequence's records, with its header's transducer frequency.
DetectionParams adaptToSequence(const Sequence& sequence, const DetectionParams& params,
                                CaptureAnalysis* analysis = nullptr);

/// Throws std::invalid_argument unless the sequence holds one A-line per frame (frames of N x 1
/// samples): a holder of many transducers stored as rows of one frame is refused until echoreg
/// reads them.
void requireSingleALineFrames(const Sequence& sequence);

/// Throws std::invalid_argument naming the transforms the capture has unless `name` is empty or
/// one of them (a pose or reference transform asked for by name).
void requireTransform(const Sequence& sequence, const std::string& name);

/// The depth conversion a capture implies: echoreg's acquisition header keys where present,
/// `fallback` otherwise.
DepthConversion depthFromSequence(const Sequence& sequence, const DepthConversion& fallback);

/// Runs the chain on every frame of an A-line sequence: adaptToSequence, the single-signal chain
/// on every frame, then the inter-signal filters (applyInterSignal). `progress(done, total)` is
/// called now and then when given. Throws std::invalid_argument for bad parameters, for a
/// sequence without pixels or with several rows per frame, or for a pose/reference transform the
/// sequence does not have (listing those it has).
SequenceDetection detectSequence(const Sequence& sequence, const DetectionParams& params,
                                 const PointFrameOptions& points = {},
                                 const std::function<void(int, int)>& progress = {});

}  // namespace echoreg::core
