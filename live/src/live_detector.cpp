#include "echoreg/live/live_detector.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace echoreg::live {

namespace {

// The measurements' records: at least this many spread over the session (at most twice as many
// are held), the number adaptToCapture's trial judges.
constexpr std::size_t kMeasuredRecords = 64;

}  // namespace

LiveDetector::LiveDetector(LiveDetectorOptions options) : options_(std::move(options)) {
  validate(options_.params);
  if (options_.params.interSignal.temporal == core::TemporalMode::Neighbours &&
      options_.params.interSignal.history > 1) {
    throw std::invalid_argument(
        "the neighbours temporal filter (history above 1) judges a frame by the frames after it "
        "too; a live session decides each frame when it arrives: use a history of 1");
  }
  if (options_.adaptFrames < 1)
    throw std::invalid_argument("the A-lines to adapt on must be >= 1");
  adaptedParams_ = options_.params;
  nextMeasurement_ = 2LL * options_.adaptFrames;
}

LiveDetector::~LiveDetector() = default;

void LiveDetector::keepForMeasurement(const std::vector<float>& samples) {
  if (received_ % keepStride_ != 0)
    return;
  kept_.push_back(samples);
  if (kept_.size() < 2 * kMeasuredRecords)
    return;
  // Every other one goes: the rest are every (2 x stride)-th A-line from the first.
  std::size_t kept = 1;
  for (std::size_t i = 2; i < kept_.size(); i += 2)
    kept_[kept++] = std::move(kept_[i]);
  kept_.resize(kept);
  keepStride_ *= 2;
}

void LiveDetector::adapt() {
  if (waiting_.empty())
    return;
  const int samples = static_cast<int>(waiting_.front().samples.size());
  const core::RecordSource source = [this](int i, std::vector<float>& out) {
    out = waiting_[static_cast<std::size_t>(i)].samples;
  };
  adaptedParams_ = core::adaptToCapture(options_.params, static_cast<int>(waiting_.size()), samples,
                                        source, options_.headerFrequencyHz, &analysis_);
  validate(adaptedParams_);
  envelope_ = std::make_unique<core::EnvelopeDetector>(adaptedParams_.envelope);
  const bool measured = options_.params.peaks.policy == core::PeakPolicy::Prominence &&
                        options_.params.peaks.prominence.shadow == core::ShadowRule::Auto &&
                        analysis_.ringDownSamples < samples;
  std::vector<core::ShadowRule> rules = {adaptedParams_.peaks.prominence.shadow};
  if (measured) {
    rules = {core::ShadowRule::Auto, core::ShadowRule::Required};
    active_ = adaptedParams_.peaks.prominence.shadow == core::ShadowRule::Required ? 1 : 0;
    ShadowMeasurement first;
    first.frames = static_cast<long long>(waiting_.size());
    first.trial.records = static_cast<int>(std::min(waiting_.size(), kMeasuredRecords));
    first.trial.share = analysis_.shadowShare;
    first.trial.shadowed =
        static_cast<int>(std::lround(analysis_.shadowShare * first.trial.records));
    first.trial.rule = adaptedParams_.peaks.prominence.shadow;
    measurements_.push_back(first);
  }
  for (core::ShadowRule rule : rules) {
    core::DetectionParams params = adaptedParams_;
    params.peaks.prominence.shadow = rule;
    Judge judge;
    judge.rule = rule;
    judge.peaks = core::resolvePeakParams(params);
    judge.interSignal = std::make_unique<core::InterSignalFilter>(params.interSignal);
    judge.context = std::make_unique<core::EchoContext>(judge.peaks);
    judges_.push_back(std::move(judge));
  }
}

void LiveDetector::remeasure() {
  if (!measuresShadowRule() || kept_.empty())
    return;
  const int samples = static_cast<int>(kept_.front().size());
  const core::RecordSource source = [this](int i, std::vector<float>& out) {
    out = kept_[static_cast<std::size_t>(i)];
  };
  ShadowMeasurement measurement;
  measurement.frames = received_;
  measurement.trial =
      core::measureShadowRule(adaptedParams_, static_cast<int>(kept_.size()), samples, source);
  measurements_.push_back(measurement);
  analysis_.shadowShare = measurement.trial.share;
  const std::size_t wanted = measurement.trial.rule == core::ShadowRule::Required ? 1 : 0;
  if (wanted == active_)
    return;
  ShadowRuleSwitch change;
  change.from = switch_ ? switch_->from : judges_[active_].rule;
  active_ = wanted;
  change.to = judges_[active_].rule;
  change.measurement = measurement;
  change.accepted = judges_[active_].accepted;
  change.verdicts = judges_[active_].verdicts;
  adaptedParams_.peaks.prominence.shadow = change.to;
  analysis_.shadowRule = std::string(core::shadowRuleName(change.to));
  switch_ = std::move(change);
}

LiveFrame LiveDetector::judge(Judge& judge, const Waiting& waiting, const core::PeakResult& peaks) {
  LiveFrame out;
  out.frame = waiting.frame;
  out.timestampS = waiting.timestampS;
  out.arrival = waiting.arrival;
  if (!peaks.accepted()) {
    out.reason = std::string(core::rejectReasonName(peaks.reason));
    judge.interSignal->breakRun();
    return out;
  }
  const double depthMm = adaptedParams_.depth.depthMm(peaks.sampleIndex);
  const bool tracked = !options_.points.poseTransform.empty();
  const bool referenced = !options_.points.referenceTransform.empty();
  const Eigen::Matrix4d* pose = tracked ? &*waiting.pose.matrix : nullptr;
  const Eigen::Matrix4d* reference = referenced ? &*waiting.reference.matrix : nullptr;
  const std::optional<Eigen::Vector3d> point =
      core::beamPoint(depthMm, options_.points, pose, reference);
  const core::RejectReason verdict = judge.interSignal->judge(*point);
  if (verdict != core::RejectReason::None) {
    out.reason = std::string(core::rejectReasonName(verdict));
    return out;
  }
  Eigen::Matrix4d beamToFrame = options_.points.beamToProbe;
  if (pose != nullptr)
    beamToFrame = *pose * beamToFrame;
  if (reference != nullptr)
    beamToFrame = reference->inverse() * beamToFrame;
  out.point = core::beamSurfacePoint(beamToFrame.topRightCorner<3, 1>(),
                                     beamToFrame.block<3, 1>(0, 2).normalized(), depthMm,
                                     options_.ultrasoundSigmaMm);
  out.reason = "accepted";
  return out;
}

LiveFrame LiveDetector::decide(const Waiting& waiting) {
  const bool tracked = !options_.points.poseTransform.empty();
  const bool referenced = !options_.points.referenceTransform.empty();
  const PoseLookup* refused = nullptr;
  if (tracked && !waiting.pose.matrix)
    refused = &waiting.pose;
  else if (referenced && !waiting.reference.matrix)
    refused = &waiting.reference;
  // One envelope, then each rule's peaks on it. A frame whose pose is refused is judged as
  // register judges it: its reason is the pose's only where its echo would have been accepted
  // (an A-line without bone is not-bone whatever its pose), so that the two count alike.
  const int count = static_cast<int>(waiting.samples.size());
  envelopeSamples_.resize(waiting.samples.size());
  envelope_->compute(waiting.samples.data(), count, envelopeSamples_.data());
  LiveFrame decided;
  for (std::size_t k = 0; k < judges_.size(); ++k) {
    Judge& judge = judges_[k];
    core::PeakResult peaks = core::findPeaks(judge.peaks, envelopeSamples_.data(), count);
    judge.context->judge(peaks, envelopeSamples_.data(), count);
    LiveFrame frame;
    if (refused != nullptr && peaks.accepted()) {
      frame.frame = waiting.frame;
      frame.timestampS = waiting.timestampS;
      frame.arrival = waiting.arrival;
      frame.reason = refused->refusal.rfind("stale", 0) == 0 ? "stale-pose" : "invalid-pose";
      frame.detail = refused->refusal;
      judge.interSignal->breakRun();
    } else {
      frame = this->judge(judge, waiting, peaks);
    }
    ++judge.verdicts[frame.reason];
    if (frame.accepted())
      judge.accepted.push_back(frame);
    if (k == active_)
      decided = std::move(frame);
  }
  return decided;
}

std::vector<LiveFrame> LiveDetector::add(int frame, double timestampS, std::vector<float> samples,
                                         PoseLookup pose, PoseLookup reference,
                                         std::chrono::steady_clock::time_point arrival) {
  keepForMeasurement(samples);
  ++received_;
  Waiting waiting{frame,           timestampS,           std::move(samples),
                  std::move(pose), std::move(reference), arrival};
  std::vector<LiveFrame> decided;
  if (adapted()) {
    decided.push_back(decide(waiting));
  } else {
    waiting_.push_back(std::move(waiting));
    if (static_cast<int>(waiting_.size()) < options_.adaptFrames)
      return decided;
    adapt();
    for (const Waiting& w : waiting_)
      decided.push_back(decide(w));
    waiting_.clear();
  }
  if (received_ >= nextMeasurement_) {
    remeasure();
    nextMeasurement_ *= 2;
  }
  return decided;
}

std::vector<LiveFrame> LiveDetector::flush() {
  std::vector<LiveFrame> decided;
  if (!adapted())
    adapt();
  if (!adapted())
    return decided;
  for (const Waiting& waiting : waiting_)
    decided.push_back(decide(waiting));
  waiting_.clear();
  if (measurements_.empty() || measurements_.back().frames != received_)
    remeasure();
  return decided;
}

std::optional<ShadowRuleSwitch> LiveDetector::takeSwitch() {
  std::optional<ShadowRuleSwitch> change = std::move(switch_);
  switch_.reset();
  return change;
}

}  // namespace echoreg::live
