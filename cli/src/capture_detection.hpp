// A tracked capture run once through filters::DetectionPipeline (reader -> envelope -> peaks ->
// beam points -> inter-signal), for the commands that use its points: `register` (the bone's
// sweeps), `calibrate` (the sphere shots) and, in one process, the study, whose sweep points and
// registration share one detection (CaptureDetections).
#pragma once

#include "detection_params.hpp"
#include "pose_check.hpp"

#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/detection_pipeline.h"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>
#include <vector>

namespace echoreg::cli {

/// The settings that decide a tracked capture's detection, as `register` and the study give them:
/// a preset, the capture header, then the tunables (detection_params.hpp).
struct CaptureDetectionRequest {
  std::string capture;
  std::string preset = "default";
  TunableSettings settings;
  std::string poseTransform = "ProbeToTracker";
  std::string referenceTransform;  ///< e.g. FemurToTracker; empty: points in the tracker
  Eigen::Matrix4d beamToProbe = Eigen::Matrix4d::Identity();

  bool operator==(const CaptureDetectionRequest& other) const;
  /// The request as JSON, for the study's cache key and its report.
  nlohmann::json json() const;
};

/// One capture through the pipeline: the pipeline keeps the sequence (its poses made rigid) and
/// the per-frame output of the peaks and every step after them, so writing the points afterwards
/// runs nothing again. The A-lines are streamed through the envelope in blocks of
/// DetectionPipeline::kStreamFramesPerBlock frames, so only one block's envelopes are held.
struct CaptureDetection {
  filters::DetectionPipeline pipeline;
  core::SequenceDetection detection;
  PoseNotes poseNotes;
  const core::Sequence& sequence() const { return pipeline.reader->GetSequence(); }
};

/// Reads the capture (FileError naming it when it cannot be read or a pose is refused) and
/// notes what the rigid-pose rule did to `rigidPoses`.
std::unique_ptr<CaptureDetection> openCapture(const std::string& path,
                                              const std::vector<std::string>& rigidPoses);

/// Configures the opened capture's pipeline with `params` (the capture-dependent parameters
/// resolved by adaptToSequence) and runs it, streamed in blocks of frames (a later change of a
/// peak parameter recomputes the envelopes; one of BeamToProbe does not). Bad parameters or a
/// transform the capture lacks are FileErrors naming the capture.
void runDetection(CaptureDetection& capture, const core::DetectionParams& params,
                  const core::PointFrameOptions& points);

/// The request's parameters through the one resolver (resolveParams): its preset, the capture
/// header's acquisition settings, then its settings. std::invalid_argument for an unknown preset
/// ("--preset: ...") or a bad value ("bad parameter: ...").
core::DetectionParams requestParams(const CaptureDetectionRequest& request,
                                    const core::Sequence& sequence);

/// openCapture, requestParams and runDetection for a request.
std::unique_ptr<CaptureDetection> detectCapture(const CaptureDetectionRequest& request);

/// The last detection kept inside one process, by its request: the study's sweep is detected once
/// for its points and its registration (steps that follow each other). Only the last is kept, so
/// a study of many sweeps holds one sweep's envelopes at a time.
class CaptureDetections {
 public:
  /// The request's detection: the kept one when the request is the same, else run now (and the
  /// kept one forgotten).
  CaptureDetection& get(const CaptureDetectionRequest& request);
  /// How many detections get() ran.
  int runs() const { return runs_; }

 private:
  CaptureDetectionRequest request_;
  std::unique_ptr<CaptureDetection> kept_;
  int runs_ = 0;
};

}  // namespace echoreg::cli
