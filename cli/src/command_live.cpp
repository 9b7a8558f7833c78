// `echoreg live`: a registration while the probe sweeps. A-lines and poses come in over
// OpenIGTLink (from PLUS, or `echoreg serve`), are recorded to a PLUS capture as they arrive,
// paired by timestamp, run through the detection chain frame by frame, and the points go into a
// surface registration refined as they come; the points, the registration and its state go back
// (to the server, or to --send-to, e.g. 3D Slicer). At the end `echoreg register`'s solver runs on
// the points detected live and writes register's result files; the recording is not read back,
// so the memory of a session does not grow with its length (docs/live.md).
#include "command_register.hpp"
#include "commands.hpp"
#include "detection_params.hpp"
#include "interrupt.hpp"
#include "path_check.hpp"
#include "validators.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/rigid_pose.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/live/capture_recorder.hpp"
#include "echoreg/live/connection.hpp"
#include "echoreg/live/igtl_messages.hpp"
#include "echoreg/live/incremental_registration.hpp"
#include "echoreg/live/live_detector.hpp"
#include "echoreg/live/pose_buffer.hpp"
#include "echoreg/live/stream_metadata.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::cli {

namespace {

using Clock = std::chrono::steady_clock;

struct LiveOptions {
  std::string connect;  // HOST:PORT
  int listenPort = -1;
  std::string host = "127.0.0.1";
  std::string sendTo;  // HOST:PORT
  std::string record;
  std::string sessionJson;
  std::string pose = "ProbeToTracker";
  double poseToleranceS = 0.1;
  int minPoints = 30;
  double updateHz = 20.0;
  int adaptFrames = 64;
  double durationS = 0.0;
  double idleTimeoutS = 30.0;
  double connectTimeoutS = 10.0;
  double reconnectS = 0.0;
  double sendTimeoutS = 5.0;
  double maxMessageMb = 64.0;
  double samplingFrequencyHz = 0.0;
};

std::pair<std::string, int> hostAndPort(const std::string& text, const std::string& flag) {
  const std::size_t colon = text.rfind(':');
  int port = -1;
  if (colon != std::string::npos && colon > 0) {
    try {
      std::size_t used = 0;
      port = std::stoi(text.substr(colon + 1), &used);
      if (used != text.size() - colon - 1)
        port = -1;
    } catch (const std::exception&) {
      port = -1;
    }
  }
  if (port < 1 || port > 65535)
    throw std::invalid_argument(flag + " must be HOST:PORT (port 1-65535), got '" + text + "'");
  return {text.substr(0, colon), port};
}

double percentile(std::vector<double> values, double fraction) {
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(
      std::min<double>(static_cast<double>(values.size() - 1),
                       std::ceil(fraction * static_cast<double>(values.size())) - 1.0));
  return values[index];
}

// Latencies in bounded memory (a session may run for hours): counts in log-spaced bins 0.5 %
// wide from 1 us to 1000 s, so a percentile is its bin's geometric centre (within 0.25 %, clamped
// to the smallest and largest value seen); the maximum is exact. The last 200 are kept for the
// progress line.
class LatencyStats {
 public:
  void add(double ms) {
    const double clamped = std::clamp(ms, kMinMs, kMaxMs);
    const auto bin = static_cast<std::size_t>(std::log(clamped / kMinMs) / std::log(kRatio));
    ++bins_[std::min(bin, bins_.size() - 1)];
    min_ = count_ == 0 ? ms : std::min(min_, ms);
    max_ = count_ == 0 ? ms : std::max(max_, ms);
    ++count_;
    recent_[next_++ % recent_.size()] = ms;
  }
  std::size_t count() const { return count_; }
  /// The value at `fraction` (0 when empty), ranked as the smallest value with at least that
  /// fraction of all at or below it.
  double at(double fraction) const {
    if (count_ == 0)
      return 0.0;
    if (fraction >= 1.0)
      return max_;
    const auto rank = static_cast<std::uint64_t>(
        std::max(1.0, std::ceil(fraction * static_cast<double>(count_))));
    std::uint64_t seen = 0;
    for (std::size_t bin = 0; bin < bins_.size(); ++bin) {
      seen += bins_[bin];
      if (seen >= rank) {
        const double centre = kMinMs * std::pow(kRatio, static_cast<double>(bin) + 0.5);
        return std::clamp(centre, min_, max_);
      }
    }
    return max_;
  }
  /// The median of the last 200.
  double recentMedian() const {
    std::vector<double> recent(
        recent_.begin(),
        recent_.begin() + static_cast<std::ptrdiff_t>(std::min(next_, recent_.size())));
    return percentile(std::move(recent), 0.5);
  }

 private:
  static constexpr double kMinMs = 1e-3, kMaxMs = 1e6, kRatio = 1.005;
  std::vector<std::uint64_t> bins_ = std::vector<std::uint64_t>(
      static_cast<std::size_t>(std::log(kMaxMs / kMinMs) / std::log(kRatio)) + 1);
  std::uint64_t count_ = 0;
  double min_ = 0.0, max_ = 0.0;
  std::array<double, 200> recent_{};
  std::size_t next_ = 0;
};

// A transform received but not yet put into a recorded frame.
struct PendingTransform {
  std::string name;
  double timestampS = 0.0;
  core::TrackedTransform transform;
};

class LiveSession {
 public:
  LiveSession(const LiveOptions& o, const RegisterOptions& r, const Streams& io)
      : o_(o), r_(r), io_(io), poses_(o.poseToleranceS) {}

  int run();

 private:
  void onMessage(const live::Message& message, Clock::time_point arrival);
  void onImage(const live::Message& message, Clock::time_point arrival);
  // `waited`: the frames waited for the chain's adaptation (their latency is not the chain's).
  void onDecided(const std::vector<live::LiveFrame>& frames, bool waited);
  // The first adaptation on stderr; then, when a measurement changed the shadow rule, the
  // session's verdicts and points become the new rule's (live::ShadowRuleSwitch).
  void onAdaptation(bool adaptedNow);
  void sendResults();
  void sendUpdate(std::optional<live::RegistrationUpdate> update);
  // After a disconnect: connects again (--connect) or waits for a client (--listen) with a
  // growing pause (0.1 s doubling up to 2 s) until --reconnect seconds have passed; false when it
  // gave up, was interrupted or --duration passed.
  bool reconnect(const std::string& why, const std::atomic<bool>* stop);
  void sendBack(const live::Packet& packet);
  // After the results' receiver (--send-to) closed the connection: connects to it again, at most
  // once a second unless `now` (the session's final registration); true when connected.
  bool reconnectResults(bool now);
  void progress(bool last);
  void note(const std::string& text) { io_.err << "echoreg live: " << text << "\n"; }
  nlohmann::json summary() const;

  const LiveOptions& o_;
  const RegisterOptions& r_;
  const Streams& io_;
  std::string bone_, reference_;
  Eigen::Matrix4d beamToProbe_ = Eigen::Matrix4d::Identity();
  RegistrationModel model_;
  RegistrationStart start_;
  PoseNotes startNotes_;  // what the rigid-pose rule did to the landmarks capture's poses
  // What the rule did to the received poses register uses (--pose and <Bone>ToTracker), counted
  // as register counts them in a capture.
  std::map<std::string, core::RigidPoseReport> rigidPoses_;
  core::DetectionParams params_;
  std::string preset_;
  TunableSettings settings_;

  std::optional<live::Connection> connection_;
  std::unique_ptr<live::Listener> listener_;  // --listen
  int reconnections_ = 0;
  double disconnectedSeconds_ = 0.0;
  std::optional<live::Connection> results_;
  bool resultsBroken_ = false;
  bool resultsClosed_ = false;  // the --send-to receiver went away (not: stopped reading)
  int resultsReconnections_ = 0;
  Clock::time_point lastResultsAttempt_;  // the first attempt after a close is at once
  live::PoseBuffer poses_;
  core::Sequence layout_;
  bool haveCaptureHeader_ = false;
  // Where the A-lines' sampling frequency came from: "header" (echoreg's capture header), "given"
  // (--sampling-frequency) or "assumed" (neither: the preset's). Decided at the first A-line.
  std::string samplingSource_;
  std::unique_ptr<live::CaptureRecorder> recorder_;
  std::unique_ptr<live::LiveDetector> detector_;
  std::unique_ptr<live::IncrementalRegistration> registration_;
  std::vector<PendingTransform> pending_;
  // echoreg serve's EchoregFrame of the next A-line, with the (1 ns) timestamp it came with.
  std::optional<std::pair<double, live::FrameMetadata>> frameMetadata_;
  core::Sequence unpaired_;  // transforms received at no A-line's time (a tracker-only capture)

  int frames_ = 0, accepted_ = 0, updates_ = 0;
  std::map<std::string, int> reasons_;
  std::map<std::string, std::string> reasonExamples_;
  std::map<std::string, int> messagesByType_;
  std::map<std::string, int> problems_;
  std::vector<core::SurfacePoint> points_;
  LatencyStats latencies_;          // accepted echoes: arrival -> POINT sent
  LatencyStats decisionLatencies_;  // every frame: arrival -> its verdict
  std::optional<live::RegistrationUpdate> last_;
  std::string shadowNote_;  // the last switch of the shadow rule, for <Bone>Status
  int shadowSwitches_ = 0;
  std::string endedBy_;
  Clock::time_point started_ = Clock::now();
  Clock::time_point lastProgress_ = Clock::now();
  double streamSeconds_ = 0.0;  // connected until the stream ended
};

void LiveSession::sendBack(const live::Packet& packet) {
  if (resultsBroken_ && !reconnectResults(false))
    return;
  live::Connection& target = o_.sendTo.empty() ? *connection_ : *results_;
  try {
    target.send(packet, o_.sendTimeoutS, &interruptRequested());
  } catch (const live::SendTimedOut& e) {
    resultsBroken_ = true;
    note(
        fmt::format("warning: sending to the results' receiver failed: {}; nothing more is sent "
                    "back, the session goes on",
                    e.what()));
  } catch (const live::ConnectionClosed& e) {
    resultsBroken_ = true;
    // A --send-to receiver that closed (Slicer's connector switched off and on, a receiver that
    // takes a fixed number of messages per connection) is connected to again; one that stopped
    // reading is not (each attempt would wait --send-timeout). Back to the server, the stream's
    // own reconnection decides.
    resultsClosed_ = results_.has_value() && !interruptRequested().load();
    results_.reset();
    note(fmt::format("warning: sending to the results' receiver failed: {}; {}", e.what(),
                     resultsClosed_ ? "live connects to it again (at most once a second) and "
                                      "then sends the next update; the session goes on"
                                    : "nothing more is sent back, the session goes on"));
  }
}

bool LiveSession::reconnectResults(bool now) {
  if (!resultsClosed_ || o_.sendTo.empty() || interruptRequested().load())
    return false;
  if (!now && Clock::now() - lastResultsAttempt_ < std::chrono::seconds(1))
    return false;
  lastResultsAttempt_ = Clock::now();
  try {
    const auto [host, port] = hostAndPort(o_.sendTo, "--send-to");
    results_ = live::Connection::connect(host, port, 0.0, &interruptRequested());
  } catch (const std::exception&) {
    return false;  // not there (yet): the next message tries again after a second
  }
  resultsBroken_ = false;
  resultsClosed_ = false;
  ++resultsReconnections_;
  note(fmt::format("connected again to the results' receiver {}", results_->peer()));
  return true;
}

void LiveSession::onDecided(const std::vector<live::LiveFrame>& frames, bool waited) {
  for (const live::LiveFrame& frame : frames) {
    ++reasons_[frame.reason];
    if (!waited) {
      decisionLatencies_.add(
          std::chrono::duration<double, std::milli>(Clock::now() - frame.arrival).count());
    }
    if (!frame.detail.empty() && reasonExamples_.count(frame.reason) == 0)
      reasonExamples_[frame.reason] = fmt::format("frame {}: {}", frame.frame, frame.detail);
    if (!frame.accepted())
      continue;
    ++accepted_;
    points_.push_back(*frame.point);
    registration_->addPoint(*frame.point);
    sendBack(live::encodePoints(bone_ + "Point", bone_, {frame.point->point}, frame.timestampS));
    if (!waited) {
      latencies_.add(
          std::chrono::duration<double, std::milli>(Clock::now() - frame.arrival).count());
    }
  }
}

void LiveSession::onAdaptation(bool adaptedNow) {
  if (adaptedNow) {
    const core::CaptureAnalysis& a = detector_->analysis();
    note(fmt::format(
        "measured on the first {} A-line(s): transducer {:.2f} MHz ({}), ring-down {} samples, "
        "time-gain compensation {}, shadow rule {} (bone's shadow in {:.1f} % of them){}",
        frames_, a.transducerFrequencyHz / 1e6,
        a.transducerFrequencySource.empty() ? "not needed" : a.transducerFrequencySource,
        a.ringDownSamples,
        a.tgcDbPerMm > 0.0 ? fmt::format("{:.2f} dB/mm ({})", a.tgcDbPerMm, a.tgcSource)
                           : std::string("none"),
        a.shadowRule, 100.0 * a.shadowShare,
        detector_->measuresShadowRule()
            ? "; the shadow rule is measured again as the capture grows, over A-lines spread "
              "through all received"
            : ""));
  }
  std::optional<live::ShadowRuleSwitch> change = detector_->takeSwitch();
  if (!change)
    return;
  ++shadowSwitches_;
  const int before = accepted_;
  // The chain's verdicts of every frame so far become the new rule's.
  reasons_ = change->verdicts;
  accepted_ = static_cast<int>(change->accepted.size());
  points_.clear();
  for (const live::LiveFrame& frame : change->accepted)
    points_.push_back(*frame.point);
  registration_->replacePoints(points_);
  const core::ShadowTrial& trial = change->measurement.trial;
  shadowNote_ = fmt::format("shadow rule {} (measured again at frame {})",
                            core::shadowRuleName(change->to), change->measurement.frames);
  note(fmt::format(
      "the shadow rule is now {} (was {}): bone cast a shadow in {} of {} A-lines spread over "
      "the {} received ({:.1f} %; the rule requires the shadow from 20 %); every frame so far is "
      "judged by it from the first: {} echoes accepted instead of {}, the registration goes on "
      "with them",
      core::shadowRuleName(change->to), core::shadowRuleName(change->from), trial.shadowed,
      trial.records, change->measurement.frames, 100.0 * trial.share, accepted_, before));
}

void LiveSession::onImage(const live::Message& message, Clock::time_point arrival) {
  const double t = message.header.timestampS;
  if (message.rows != 1) {
    ++problems_[fmt::format("IMAGE '{}' of {} x {} is not an A-line (1 x N): not recorded",
                            message.header.deviceName, message.samples, message.rows)];
    return;
  }
  if (!recorder_) {
    layout_.elementType = message.elementType;
    layout_.frameSize = {message.samples, 1};
    // The capture header's sampling frequency, else --sampling-frequency, else the preset's,
    // which is said: every depth, and every length the detector takes in mm, scales with it.
    const bool fromHeader =
        haveCaptureHeader_ && layout_.acquisition.samplingFrequencyHz.has_value();
    if (!fromHeader && o_.samplingFrequencyHz > 0.0)
      layout_.acquisition.samplingFrequencyHz = o_.samplingFrequencyHz;
    samplingSource_ = fromHeader ? "header" : o_.samplingFrequencyHz > 0.0 ? "given" : "assumed";
    recorder_ = std::make_unique<live::CaptureRecorder>(o_.record, layout_);
    // As register resolves them: the preset, the stream's header, then the tunables given.
    params_ = resolveParams(preset_, settings_, layout_);
    if (samplingSource_ == "assumed")
      note(
          fmt::format("warning: the stream gives no sampling frequency (no capture header from "
                      "the server) and none was given: assumed {:g} MHz; every depth scales "
                      "with it (--sampling-frequency)",
                      params_.depth.samplingFrequencyHz / 1e6));
    live::LiveDetectorOptions detection;
    detection.params = params_;
    detection.headerFrequencyHz = layout_.acquisition.transducerFrequencyHz;
    detection.points.poseTransform = o_.pose;
    detection.points.referenceTransform = reference_;
    detection.points.beamToProbe = beamToProbe_;
    detection.ultrasoundSigmaMm = r_.ultrasoundSigma;
    detection.adaptFrames = o_.adaptFrames;
    detector_ = std::make_unique<live::LiveDetector>(detection);
  } else if (message.elementType != layout_.elementType ||
             message.samples != layout_.frameSize[0]) {
    ++problems_[fmt::format(
        "IMAGE '{}' of {} {} samples differs from the first A-line ({} {}): "
        "not recorded",
        message.header.deviceName, message.samples, core::elementTypeName(message.elementType),
        layout_.frameSize[0], core::elementTypeName(layout_.elementType))];
    return;
  }
  // The frame: the transforms and fields received with this A-line's timestamp.
  core::SequenceFrame frame;
  frame.timestampS = t;
  std::vector<PendingTransform> keep;
  for (PendingTransform& p : pending_) {
    if (p.timestampS == t) {
      frame.transforms[p.name] = p.transform;
    } else if (p.timestampS > t) {
      keep.push_back(std::move(p));
    } else {
      core::SequenceFrame tracked;
      tracked.timestampS = p.timestampS;
      tracked.transforms[p.name] = p.transform;
      unpaired_.frames.push_back(std::move(tracked));
    }
  }
  pending_ = std::move(keep);
  if (frameMetadata_ && frameMetadata_->first == t) {
    frame.timestampS = frameMetadata_->second.timestampS;
    frame.fields = frameMetadata_->second.fields;
  }
  frameMetadata_.reset();
  recorder_->add(frame, message.pixels.data(), message.pixels.size());

  core::Sequence single;
  single.elementType = message.elementType;
  single.frameSize = {message.samples, 1};
  single.frames.resize(1);
  single.pixels = message.pixels;
  std::vector<float> samples;
  single.frameSamples(0, samples);
  const int index = frames_++;
  const bool waited = !detector_->adapted();
  onDecided(detector_->add(index, t, std::move(samples), poses_.at(o_.pose, t),
                           poses_.at(reference_, t), arrival),
            waited);
  onAdaptation(waited && detector_->adapted());
}

void LiveSession::onMessage(const live::Message& message, Clock::time_point arrival) {
  ++messagesByType_[message.header.type];
  const std::string& name = message.header.deviceName;
  const double t = message.header.timestampS;
  switch (message.kind) {
    case live::MessageKind::Transform: {
      PendingTransform p{name, t, {}};
      p.transform.matrix = message.matrix;
      const std::string problem = core::poseProblem(message.matrix);
      if (!problem.empty()) {
        // Recorded as received; refused for pairing, with the reason.
        ++problems_[fmt::format("TRANSFORM '{}' is not a rigid pose ({}): used as INVALID", name,
                                problem)];
        poses_.add(name, {t, message.matrix, "INVALID"});
      } else {
        if (name == o_.pose || name == reference_) {
          core::RigidPoseReport& report = rigidPoses_[name];
          const double deviation = core::poseOrthonormalDeviation(message.matrix);
          ++report.checked;
          report.largestDeviation = std::max(report.largestDeviation, deviation);
          report.reorthonormalised += deviation > core::kPoseExactTolerance ? 1 : 0;
        }
        poses_.add(name, {t, core::reorthonormalised(message.matrix), "OK"});
      }
      pending_.push_back(std::move(p));
      break;
    }
    case live::MessageKind::Status:
      // echoreg serve's invalid pose: a STATUS named after the transform, its word as error name.
      if (name.find("To") != std::string::npos && !message.statusName.empty() &&
          message.statusCode != live::kStatusOk) {
        PendingTransform p{name, t, {}};
        p.transform.status = message.statusName;
        poses_.add(name, {t, Eigen::Matrix4d::Identity(), message.statusName});
        pending_.push_back(std::move(p));
      }
      break;
    case live::MessageKind::String:
      if (name == live::kCaptureHeaderName) {
        live::applyCaptureHeader(message.text, layout_);
        haveCaptureHeader_ = true;
      } else if (name == live::kFrameName) {
        frameMetadata_ = std::make_pair(t, live::parseFrameJson(message.text));
      }
      break;
    case live::MessageKind::Image:
      onImage(message, arrival);
      break;
    case live::MessageKind::Point:
    case live::MessageKind::Other:
      break;
  }
}

void LiveSession::sendResults() {
  sendUpdate(registration_->take());
}

void LiveSession::sendUpdate(std::optional<live::RegistrationUpdate> update) {
  if (!update)
    return;
  ++updates_;
  const core::SurfaceRegistrationResult& r = update->result;
  const double t = std::chrono::duration<double>(Clock::now() - started_).count();
  if (r.converged)
    sendBack(live::encodeTransform(bone_ + "ToCT", r.transform.matrix(), t));
  sendBack(
      live::encodeString(bone_ + "Status",
                         fmt::format("RMS {:.3f} mm, {}, {} points, update {}{}{}", r.rmsMm,
                                     r.converged ? "converged" : "not converged", update->points,
                                     update->run, r.converged ? "" : ": " + r.message,
                                     shadowNote_.empty() ? "" : "; " + shadowNote_),
                         t));
  std::vector<Eigen::Vector3d> cloud;
  cloud.reserve(points_.size());
  for (const core::SurfacePoint& p : points_)
    cloud.push_back(p.point);
  sendBack(live::encodePoints(bone_ + "Points", bone_, cloud, t));
  last_ = std::move(update);
}

void LiveSession::progress(bool last) {
  if (!io_.errIsTerminal)
    return;
  const Clock::time_point now = Clock::now();
  if (!last && now - lastProgress_ < std::chrono::milliseconds(250))
    return;
  lastProgress_ = now;
  io_.err << fmt::format(
      "\rlive: {} frames in, {} echoes accepted, {} points, RMS {}, latency {:.2f} ms   {}",
      frames_, accepted_, points_.size(),
      last_ ? fmt::format("{:.3f} mm{}", last_->result.rmsMm,
                          last_->result.converged ? "" : " (not converged)")
            : std::string("-"),
      latencies_.recentMedian(), last ? "\n" : "");
  io_.err.flush();
}

nlohmann::json LiveSession::summary() const {
  nlohmann::json reasons = nlohmann::json::object();
  for (const auto& [reason, count] : reasons_)
    reasons[reason] = count;
  const double seconds = std::chrono::duration<double>(Clock::now() - started_).count();
  // The worker's runs while points came (not the last one on every point after the stream) and
  // their rate from the first run's start to the last's.
  const live::WorkerRate rate = registration_->workerRate();
  nlohmann::json json = {{"record", o_.record},
                         {"frames", frames_},
                         {"accepted", accepted_},
                         {"verdicts", reasons},
                         {"refusal_examples", reasonExamples_},
                         {"messages", messagesByType_},
                         {"skipped", problems_},
                         {"sampling_frequency_source", samplingSource_},
                         {"unpaired_transforms", unpaired_.frames.size()},
                         {"latency_ms",
                          {{"count", latencies_.count()},
                           {"median", latencies_.at(0.5)},
                           {"p99", latencies_.at(0.99)},
                           {"max", latencies_.at(1.0)}}},
                         {"decision_latency_ms",
                          {{"count", decisionLatencies_.count()},
                           {"median", decisionLatencies_.at(0.5)},
                           {"p99", decisionLatencies_.at(0.99)},
                           {"max", decisionLatencies_.at(1.0)}}},
                         {"registration_updates", updates_},
                         {"registration_runs", rate.runs},
                         {"registration_rate_hz", rate.hz},
                         {"registration_longest_fit_s", rate.longestFitS},
                         {"reconnections", reconnections_},
                         {"results_reconnections", resultsReconnections_},
                         {"disconnected_seconds", disconnectedSeconds_},
                         {"seconds", seconds},
                         {"stream_seconds", streamSeconds_},
                         {"ended_by", endedBy_}};
  if (detector_ && detector_->adapted()) {
    // What the chain measured: the first adaptation, and every measurement of the shadow rule.
    const core::CaptureAnalysis& a = detector_->analysis();
    nlohmann::json measurements = nlohmann::json::array();
    for (const live::ShadowMeasurement& m : detector_->shadowMeasurements()) {
      measurements.push_back({{"frames", m.frames},
                              {"records", m.trial.records},
                              {"shadowed", m.trial.shadowed},
                              {"share", m.trial.share},
                              {"rule", core::shadowRuleName(m.trial.rule)}});
    }
    json["detection"] = {{"adapt_frames", o_.adaptFrames},
                         {"transducer_frequency_hz", a.transducerFrequencyHz},
                         {"transducer_frequency_source", a.transducerFrequencySource},
                         {"ring_down_samples", a.ringDownSamples},
                         {"tgc_db_per_mm", a.tgcDbPerMm},
                         {"tgc_source", a.tgcSource},
                         {"shadow_rule", a.shadowRule},
                         {"shadow_rule_measured", detector_->measuresShadowRule()},
                         {"shadow_rule_measurements", measurements},
                         {"shadow_rule_switches", shadowSwitches_}};
  }
  if (last_) {
    json["live_registration"] = {{"converged", last_->result.converged},
                                 {"rms_mm", last_->result.rmsMm},
                                 {"points", last_->points},
                                 {"matrix", core::matrixRows(last_->result.transform.matrix())}};
  }
  return json;
}

bool LiveSession::reconnect(const std::string& why, const std::atomic<bool>* stop) {
  connection_.reset();
  const Clock::time_point begin = Clock::now();
  const auto elapsed = [&begin] {
    return std::chrono::duration<double>(Clock::now() - begin).count();
  };
  const std::string target =
      listener_ ? fmt::format("a server to connect to {}:{}", o_.host, listener_->port())
                : o_.connect;
  note(fmt::format("{}; {} for up to {} s (--reconnect), recording on into {}", why,
                   listener_ ? "waiting for " + target : "reconnecting to " + target, o_.reconnectS,
                   o_.record));
  double pause = 0.1;
  int attempts = 0;
  std::string lastProblem;
  const auto pastDuration = [this] {
    return o_.durationS > 0.0 &&
           std::chrono::duration<double>(Clock::now() - started_).count() >= o_.durationS;
  };
  while (!stop->load() && !pastDuration()) {
    ++attempts;
    if (listener_) {
      connection_ =
          listener_->accept(std::min(pause, std::max(0.0, o_.reconnectS - elapsed())), stop);
    } else {
      try {
        const auto [host, port] = hostAndPort(o_.connect, "--connect");
        connection_ = live::Connection::connect(host, port, 0.0, stop);
      } catch (const std::exception& e) {
        lastProblem = e.what();
      }
    }
    if (connection_) {
      ++reconnections_;
      disconnectedSeconds_ += elapsed();
      note(fmt::format("reconnected to {} after {:.1f} s ({} attempt(s)); the session goes on",
                       connection_->peer(), elapsed(), attempts));
      return true;
    }
    if (elapsed() >= o_.reconnectS)
      break;
    if (!listener_) {
      const Clock::time_point wake =
          Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                             std::min(pause, std::max(0.0, o_.reconnectS - elapsed()))));
      while (Clock::now() < wake && !stop->load())
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    pause = std::min(2.0 * pause, 2.0);
  }
  disconnectedSeconds_ += elapsed();
  note(fmt::format("gave up reconnecting after {:.1f} s ({} attempt(s){})", elapsed(), attempts,
                   lastProblem.empty() ? std::string() : ", last: " + lastProblem));
  return false;
}

int LiveSession::run() {
  bone_ = r_.bone;
  reference_ = bone_ + "ToTracker";
  model_ = loadRegistrationModel(r_);
  beamToProbe_ = core::readTransformFile(r_.calibration, "Beam", "Probe").matrix;
  start_ = registrationStart(r_, model_.options, startNotes_);
  // The detection's settings as register takes them (flags over --params over register's own
  // defaults: each echo judged alone, points at least 1 mm apart), resolved against the stream's
  // header when its first A-line arrives; a bad value is refused now, before connecting.
  preset_ = r_.preset;
  settings_ = r_.detection;
  if (!r_.paramsFile.empty())
    mergeParamsFile(r_.paramsFile, preset_, settings_);
  settings_.emplace("history", 1);
  settings_.emplace("min-spread-mm", 1.0);
  if (preset_.empty())
    preset_ = "default";
  params_ = resolveParams(preset_, settings_, core::Sequence{});
  registration_ = std::make_unique<live::IncrementalRegistration>(
      *model_.model, model_.options, start_.landmarks, static_cast<std::size_t>(o_.minPoints),
      o_.updateHz);

  InterruptScope interrupt;
  const std::atomic<bool>* stop = &interruptRequested();
  if (!o_.connect.empty()) {
    const auto [host, port] = hostAndPort(o_.connect, "--connect");
    connection_ = live::Connection::connect(host, port, o_.connectTimeoutS, stop);
  } else {
    listener_ = std::make_unique<live::Listener>(o_.host, o_.listenPort);
    note(fmt::format("waiting for a server to connect to {}:{}", o_.host, listener_->port()));
    connection_ = listener_->accept(o_.connectTimeoutS, stop);
    if (!connection_) {
      throw std::runtime_error(fmt::format("nothing connected to {}:{} within {} s", o_.host,
                                           listener_->port(), o_.connectTimeoutS));
    }
  }
  if (!o_.sendTo.empty()) {
    const auto [host, port] = hostAndPort(o_.sendTo, "--send-to");
    results_ = live::Connection::connect(host, port, o_.connectTimeoutS, stop);
  }
  note(fmt::format("connected to {}; recording to {}", connection_->peer(), o_.record));
  started_ = Clock::now();

  live::MessageReader reader(static_cast<std::size_t>(o_.maxMessageMb * 1024.0 * 1024.0));
  std::string failure;
  Clock::time_point lastMessage = Clock::now();
  while (true) {
    if (stop->load()) {
      endedBy_ = "interrupted (SIGINT)";
      break;
    }
    if (o_.durationS > 0.0 &&
        std::chrono::duration<double>(Clock::now() - started_).count() >= o_.durationS) {
      endedBy_ = fmt::format("--duration {} s", o_.durationS);
      break;
    }
    std::optional<live::MessageReader::Received> received;
    try {
      received = reader.next(*connection_, 0.1, stop);
    } catch (const live::ConnectionClosed& e) {
      endedBy_ = fmt::format("the server closed the connection ({})", e.what());
      if (o_.reconnectS <= 0.0)
        break;
      if (!reconnect(endedBy_, stop)) {
        if (stop->load()) {
          endedBy_ = "interrupted (SIGINT) while reconnecting";
        } else if (o_.durationS > 0.0 &&
                   std::chrono::duration<double>(Clock::now() - started_).count() >= o_.durationS) {
          endedBy_ = fmt::format("--duration {} s (while reconnecting)", o_.durationS);
        } else {
          failure = fmt::format(
              "{} and did not come back within --reconnect {} s; the recording holds the {} "
              "frames received",
              endedBy_, o_.reconnectS, frames_);
          endedBy_ += fmt::format(", not back within --reconnect {} s", o_.reconnectS);
        }
        break;
      }
      // A new stream: a message cut by the disconnect is gone, poses before the gap are not
      // paired with A-lines after it (a restarted server may start its clock again).
      reader = live::MessageReader(static_cast<std::size_t>(o_.maxMessageMb * 1024.0 * 1024.0));
      frameMetadata_.reset();
      poses_ = live::PoseBuffer(o_.poseToleranceS);
      if (o_.sendTo.empty())
        resultsBroken_ = false;
      lastMessage = Clock::now();
      continue;
    } catch (const live::ProtocolError& e) {
      failure = e.what();
      endedBy_ = "a message broke the protocol";
      break;
    }
    if (!received) {
      if (std::chrono::duration<double>(Clock::now() - lastMessage).count() >= o_.idleTimeoutS) {
        endedBy_ = fmt::format("no message for --idle-timeout {} s", o_.idleTimeoutS);
        break;
      }
    } else {
      const Clock::time_point arrival = Clock::now();
      lastMessage = arrival;
      if (received->message) {
        try {
          onMessage(*received->message, arrival);
        } catch (const std::invalid_argument& e) {
          ++problems_[e.what()];
        }
      } else {
        ++problems_[received->problem];
      }
    }
    sendResults();
    progress(false);
  }
  streamSeconds_ = std::chrono::duration<double>(Clock::now() - started_).count();
  if (detector_) {
    const bool waited = !detector_->adapted();
    onDecided(detector_->flush(), true);
    onAdaptation(waited && detector_->adapted());
  }
  connection_.reset();  // the server's graceful close waits for it
  // The live registration on every point received (the stream may have ended between updates),
  // sent to a results' receiver (--send-to) that is still there: its last FemurToCT is the
  // session's result, not whichever update last converged while the stream ran.
  if (std::optional<live::RegistrationUpdate> update = registration_->finish()) {
    if (!o_.sendTo.empty()) {
      if (resultsBroken_)
        reconnectResults(true);
      sendUpdate(std::move(update));
    } else {
      ++updates_;
      last_ = std::move(update);
    }
  }
  results_.reset();
  progress(true);
  for (const auto& [problem, count] : problems_)
    note(fmt::format("{} message(s) skipped: {}", count, problem));
  if (!failure.empty())
    note("error: " + failure);
  if (!reasonExamples_.empty()) {
    for (const auto& [reason, example] : reasonExamples_)
      note(fmt::format("{} frame(s) refused as {}, e.g. {}", reasons_[reason], reason, example));
  }

  for (const PendingTransform& p : pending_) {
    core::SequenceFrame tracked;
    tracked.timestampS = p.timestampS;
    tracked.transforms[p.name] = p.transform;
    unpaired_.frames.push_back(std::move(tracked));
  }
  std::string trackingPath;
  if (!unpaired_.frames.empty()) {
    const std::filesystem::path path(o_.record);
    trackingPath =
        (path.parent_path() / (path.stem().string() + ".tracking" + path.extension().string()))
            .string();
    core::writeSequence(unpaired_, trackingPath);
  }
  if (!recorder_) {
    throw std::runtime_error(
        fmt::format("no A-line (IMAGE of 1 x N) received ({}): nothing registered{}", endedBy_,
                    trackingPath.empty() ? std::string()
                                         : fmt::format("; the {} transforms received are in {}",
                                                       unpaired_.frames.size(), trackingPath)));
  }
  const std::size_t recorded = recorder_->finish();
  nlohmann::json session = summary();
  session["recorded_frames"] = recorded;
  if (!trackingPath.empty())
    session["tracking_record"] = trackingPath;
  io_.out << fmt::format(
      "{}: {} frames recorded; {} echoes accepted live; latency median {:.2f} ms, p99 {:.2f} ms "
      "over {} points; {} registration updates; ended by {}\n",
      o_.record, recorded, accepted_, latencies_.at(0.5), latencies_.at(0.99), latencies_.count(),
      updates_, endedBy_);
  if (!trackingPath.empty()) {
    io_.out << fmt::format("{}: {} transforms received at no A-line's time\n", trackingPath,
                           unpaired_.frames.size());
  }
  if (!o_.sessionJson.empty()) {
    core::AtomicFile file(o_.sessionJson);
    file.stream() << session.dump(2) << "\n";
    file.commit();
  }

  // The result: register's solver and files on the points detected while the A-lines came
  // (register's chain, frame by frame), instead of reading the recording back: that held the
  // whole capture and every step's output in memory (11.2 GB for 150 s at 3000 A-lines/s).
  RegisterOptions final = r_;
  final.captures = {o_.record};
  RegistrationPoints gathered;
  gathered.points = std::move(points_);
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, count] : reasons_) {
    if (reason != "accepted")
      rejected[reason] = count;
  }
  gathered.speedOfSoundMps = detector_->params().depth.speedOfSoundMps;
  gathered.sources.push_back({{"capture", o_.record},
                              {"frames", frames_},
                              {"accepted", accepted_},
                              {"rejected_by_reason", rejected},
                              {"speed_of_sound_mps", *gathered.speedOfSoundMps},
                              {"detected", "live"}});
  gathered.poseNotes = startNotes_;
  for (const auto& [name, report] : rigidPoses_) {
    gathered.poseNotes.reorthonormalised += report.reorthonormalised;
    if (auto line = core::rigidPoseNote(report, o_.record, name))
      gathered.poseNotes.lines.push_back(*line);
  }
  checkRegistrationPoints(final, gathered.points);
  const int code = solveAndWrite(final, model_, start_, gathered, io_, "live");
  return failure.empty() ? code : 1;
}

}  // namespace

CommandAction addLiveCommand(CLI::App& app) {
  auto o = std::make_shared<LiveOptions>();
  auto r = std::make_shared<RegisterOptions>();
  CLI::App* cmd = app.add_subcommand(
      "live",
      "Register while the probe sweeps (docs/live.md): A-lines (IMAGE 1 x N) and poses (TRANSFORM\n"
      "ProbeToTracker and <Bone>ToTracker) in over OpenIGTLink from a PLUS server or echoreg\n"
      "serve (--connect), or from a client that connects (--listen). Everything received is\n"
      "recorded to --record as it arrives (appended to <stem>.partial.mhd/.raw each second).\n"
      "A-lines are paired with poses by timestamp (interpolated between the two nearest; stale\n"
      "or INVALID poses refused with the reason), run through the detection chain and mapped to "
      "the bone;\n"
      "once --min-points have come, the surface registration runs on all points so far, again\n"
      "as more arrive (at most --update-hz), each time from --initial or the landmarks as\n"
      "register starts; and once more on every point when the stream ends. Sent back:\n"
      "TRANSFORM <Bone>ToCT, POINT <Bone>Point (each accepted echo), POINT <Bone>Points (all),\n"
      "STRING <Bone>Status (RMS, converged, points). Ends when the server closes (with\n"
      "--reconnect: when it has not come back within that time), on SIGINT, after --duration or\n"
      "--idle-timeout; then runs register's solver (its options and start) on the points\n"
      "detected live and writes register's files (--out and its .tfm); the recording is not\n"
      "read back.");
  auto* connect = cmd->add_option("--connect", o->connect, "HOST:PORT of the server (PLUS: 18944)")
                      ->group("Connection");
  auto* listen = cmd->add_option("--listen", o->listenPort, "Port to wait on for a server instead")
                     ->check(wholeNumber(0, 65535))
                     ->group("Connection");
  connect->excludes(listen);
  cmd->add_option("--host", o->host, "Address --listen binds")
      ->capture_default_str()
      ->group("Connection");
  cmd->add_option("--send-to", o->sendTo,
                  "HOST:PORT to send the results to (3D Slicer's OpenIGTLinkIF server) instead of "
                  "back to the server")
      ->group("Connection");
  cmd->add_option("--connect-timeout", o->connectTimeoutS, "Seconds to wait for the connection")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Connection");
  cmd->add_option("--reconnect", o->reconnectS,
                  "When the server closes the connection, connect again (--listen: wait for a "
                  "client) for up to this many seconds, pausing 0.1 s doubling to 2 s between "
                  "tries, and go on into the same recording; gives up with exit 1 after writing "
                  "the recording and the result (0: the session ends at the disconnect)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, true))
      ->group("Connection");
  cmd->add_option("--send-timeout", o->sendTimeoutS,
                  "Seconds the results' receiver may leave its socket full (not reading) before "
                  "live stops sending back; the session goes on")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Connection");
  cmd->add_option("--idle-timeout", o->idleTimeoutS,
                  "End after this many seconds without a message")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Connection");
  cmd->add_option("--duration", o->durationS, "End after this many seconds (0: no limit)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, true))
      ->group("Connection");
  cmd->add_option("--max-message-mb", o->maxMessageMb,
                  "Refuse a message whose body is larger (the connection is then closed)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Connection");
  cmd->add_option("--record", o->record, "PLUS capture to record everything received to")
      ->required()
      ->group("Live");
  cmd->add_option("--session-json", o->sessionJson,
                  "Write the session's counts, refusals and latencies (JSON)")
      ->group("Live");
  cmd->add_option("--pose", o->pose, "The probe's transform")->capture_default_str()->group("Live");
  cmd->add_option("--pose-tolerance", o->poseToleranceS,
                  "Seconds a pose may be from its A-line (and half the widest gap interpolated)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Live");
  cmd->add_option("--adapt-frames", o->adaptFrames,
                  "A-lines the chain measures its capture-dependent settings on (band, ring-down, "
                  "time-gain compensation, shadow rule) before deciding the first. A measured "
                  "shadow rule (--echo-shadow "
                  "auto) is measured again on A-lines spread over all received each time their "
                  "count doubles and at the end; when it changes, every frame so far is judged by "
                  "the new rule (said on stderr and in <Bone>Status)")
      ->capture_default_str()
      ->check(wholeNumber(1, 100000))
      ->group("Live");
  cmd->add_option("--min-points", o->minPoints, "Points before the registration starts")
      ->capture_default_str()
      ->check(wholeNumber(3, 100000000))
      ->group("Live");
  cmd->add_option("--update-hz", o->updateHz,
                  "Most registration updates per second while points come (each update starts "
                  "1/this after the previous one's start; a fit that takes longer is followed "
                  "at once by the next)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false))
      ->group("Live");
  cmd->add_option(
         "--sampling-frequency", o->samplingFrequencyHz,
         "A-lines' sampling frequency, Hz, when the server sends no capture header of "
         "echoreg's with one (without either, the preset's 50 MHz is assumed, with a warning)")
      ->check(finiteNumber(0.0, false))
      ->group("Live");
  addRegistrationOptions(cmd, r, {"sampling-frequency"})->required();
  cmd->parse_complete_callback([o, r] {
    if (o->connect.empty() && o->listenPort < 0)
      throw CLI::ValidationError("live", "give --connect HOST:PORT or --listen PORT");
    try {
      if (!o->connect.empty())
        hostAndPort(o->connect, "--connect");
      if (!o->sendTo.empty())
        hostAndPort(o->sendTo, "--send-to");
    } catch (const std::invalid_argument& e) {
      throw CLI::ValidationError("live", e.what());
    }
    checkRegistrationStart("live", *r);
    if (!r->landmarksCt.empty() && r->tipFile.empty())
      throw CLI::ValidationError("live", "--landmarks-capture needs --stylus-tip-to-stylus");
  });
  return [o, r](const Streams& io) {
    CommandPaths()
        .input("--model", r->model)
        .input("--calibration", r->calibration)
        .input("--initial", r->initial)
        .input("--landmarks-ct", r->landmarksCt)
        .input("--landmarks-capture", r->landmarksCapture)
        .input("--stylus-tip-to-stylus", r->tipFile)
        .input("--hip-centre", r->hipCentre)
        .output("--record", o->record)
        .optionalOutput("--session-json", o->sessionJson)
        .transformOutput("--out", r->out)
        .check();
    LiveSession session(*o, *r, io);
    return session.run();
  };
}

}  // namespace echoreg::cli
