#include "echoreg/live/live_detector.hpp"

#include <stdexcept>
#include <utility>

namespace echoreg::live {

LiveDetector::LiveDetector(LiveDetectorOptions options) : options_(std::move(options)) {
  validate(options_.params);
  if (options_.params.interSignal.temporal == TemporalMode::Neighbours &&
      options_.params.interSignal.history > 1) {
    throw std::invalid_argument(
        "the neighbours temporal filter (history above 1) judges a frame by the frames after it "
        "too; a live session decides each frame when it arrives: use a history of 1");
  }
  if (options_.adaptFrames < 1)
    throw std::invalid_argument("the A-lines to adapt on must be >= 1");
  adaptedParams_ = options_.params;
}

LiveDetector::~LiveDetector() = default;

void LiveDetector::adapt() {
  if (waiting_.empty())
    return;
  const int samples = static_cast<int>(waiting_.front().samples.size());
  const RecordSource source = [this](int i, std::vector<float>& out) {
    out = waiting_[static_cast<std::size_t>(i)].samples;
  };
  adaptedParams_ = adaptToCapture(options_.params, static_cast<int>(waiting_.size()), samples,
                                  source, options_.headerFrequencyHz, &analysis_);
  detector_ = std::make_unique<SignalDetector>(adaptedParams_);
  interSignal_ = std::make_unique<InterSignalFilter>(adaptedParams_.interSignal);
}

LiveFrame LiveDetector::decide(const Waiting& waiting) {
  LiveFrame out;
  out.frame = waiting.frame;
  out.timestampS = waiting.timestampS;
  out.arrival = waiting.arrival;
  const bool tracked = !options_.points.poseTransform.empty();
  const bool referenced = !options_.points.referenceTransform.empty();
  const PoseLookup* refused = nullptr;
  if (tracked && !waiting.pose.matrix)
    refused = &waiting.pose;
  else if (referenced && !waiting.reference.matrix)
    refused = &waiting.reference;
  if (refused != nullptr) {
    out.reason = refused->refusal.rfind("stale", 0) == 0 ? "stale-pose" : "invalid-pose";
    out.detail = refused->refusal;
    interSignal_->breakRun();
    return out;
  }
  const SignalDetection detection =
      detector_->detect(waiting.samples.data(), static_cast<int>(waiting.samples.size()));
  if (!detection.accepted()) {
    out.reason = std::string(rejectReasonName(detection.peaks.reason));
    interSignal_->breakRun();
    return out;
  }
  const Eigen::Matrix4d* pose = tracked ? &*waiting.pose.matrix : nullptr;
  const Eigen::Matrix4d* reference = referenced ? &*waiting.reference.matrix : nullptr;
  const std::optional<Eigen::Vector3d> point =
      beamPoint(detection.depthMm, options_.points, pose, reference);
  const RejectReason verdict = interSignal_->judge(*point);
  if (verdict != RejectReason::None) {
    out.reason = std::string(rejectReasonName(verdict));
    return out;
  }
  Eigen::Matrix4d beamToFrame = options_.points.beamToProbe;
  if (pose != nullptr)
    beamToFrame = *pose * beamToFrame;
  if (reference != nullptr)
    beamToFrame = reference->inverse() * beamToFrame;
  out.point = core::beamSurfacePoint(beamToFrame.topRightCorner<3, 1>(),
                                     beamToFrame.block<3, 1>(0, 2).normalized(), detection.depthMm,
                                     options_.ultrasoundSigmaMm);
  out.reason = "accepted";
  return out;
}

std::vector<LiveFrame> LiveDetector::add(int frame, double timestampS, std::vector<float> samples,
                                         PoseLookup pose, PoseLookup reference,
                                         std::chrono::steady_clock::time_point arrival) {
  Waiting waiting{frame,           timestampS,           std::move(samples),
                  std::move(pose), std::move(reference), arrival};
  std::vector<LiveFrame> decided;
  if (detector_ != nullptr) {
    decided.push_back(decide(waiting));
    return decided;
  }
  waiting_.push_back(std::move(waiting));
  if (static_cast<int>(waiting_.size()) >= options_.adaptFrames)
    decided = flush();
  return decided;
}

std::vector<LiveFrame> LiveDetector::flush() {
  std::vector<LiveFrame> decided;
  if (detector_ == nullptr)
    adapt();
  for (const Waiting& waiting : waiting_)
    decided.push_back(decide(waiting));
  waiting_.clear();
  return decided;
}

}  // namespace echoreg::live
