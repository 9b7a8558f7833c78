#include "echoreg/core/detection.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace echoreg {

namespace {

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

}  // namespace

std::vector<std::string> detectionPresetNames() { return {"default", "mozes2008", "calibration"}; }

DetectionParams detectionPreset(std::string_view name) {
  DetectionParams params;
  if (name == "default") {
    // Specimens: a short Hann envelope (7 samples, 0.14 us: shorter than a 9 MHz pulse, so an
    // echo's peak is not averaged down into the speckle) and the bone policy, which looks for the
    // deepest echo with tissue in front of it and a shadow behind it.
    params.envelope.method = EnvelopeMethod::Hann;
    params.envelope.windowSamples = 7;
    params.envelope.ringDownSamples = 200;
    params.peaks.policy = PeakPolicy::Bone;
    params.peaks.thresholdMode = ThresholdMode::FactorOfMean;
    params.peaks.thresholdFactor = 1.5;
    return params;
  }
  if (name == "mozes2008") {
    // The dissertation's chain as it ran (sections 4.3.3-4.3.4, 6.3.2): demean, zero the
    // ring-down, rectify, one causal pass of a 2nd-order Butterworth at 0.01 of Nyquist,
    // threshold 1.5 x mean, exactly two peaks (standoff/skin, then bone), no sub-sample peak.
    params.envelope.method = EnvelopeMethod::Mozes;
    params.envelope.butterworthOrder = 2;
    params.envelope.cutoffNormalized = 0.01;
    params.envelope.zeroPhase = false;
    params.envelope.ringDownSamples = 200;
    params.peaks.policy = PeakPolicy::Double;
    params.peaks.thresholdMode = ThresholdMode::FactorOfMean;
    params.peaks.thresholdFactor = 1.5;
    params.peaks.subsample = false;
    return params;
  }
  if (name == "calibration") {
    // A metal sphere in water (section 4.2.2): the largest echo inside the processing window.
    params.envelope.method = EnvelopeMethod::Hann;
    params.envelope.windowSamples = 21;
    params.envelope.ringDownSamples = 200;
    params.peaks.policy = PeakPolicy::WindowMax;
    params.depth.speedOfSoundMps = 1480.0;
    return params;
  }
  throw std::invalid_argument("unknown preset '" + std::string(name) +
                              "' (expected default, mozes2008 or calibration)");
}

void validate(const DetectionParams& params) {
  validate(params.envelope);
  require(params.depth.samplingFrequencyHz > 0.0 && std::isfinite(params.depth.samplingFrequencyHz),
          "sampling frequency must be > 0 Hz");
  require(params.depth.speedOfSoundMps > 0.0 && std::isfinite(params.depth.speedOfSoundMps),
          "speed of sound must be > 0 m/s");
  require(std::isfinite(params.depth.delayS), "delay must be finite");
  if (params.windowMinMm && params.windowMaxMm) {
    require(*params.windowMinMm < *params.windowMaxMm, "window min must be below window max");
  }
  require(params.interSignal.history >= 1, "history must be >= 1 frame");
  require(params.interSignal.consistencyMm > 0.0, "consistency must be > 0 mm");
  require(params.interSignal.minSpreadMm >= 0.0, "minimum spread must be >= 0 mm");
  validate(resolvePeakParams(params));
}

PeakParams resolvePeakParams(const DetectionParams& params) {
  PeakParams peaks = params.peaks;
  peaks.mmPerSample = params.depth.mmPerSample();
  if (params.windowMinMm) {
    peaks.windowBegin = static_cast<int>(std::ceil(params.depth.sampleIndex(*params.windowMinMm)));
  }
  if (params.windowMaxMm) {
    peaks.windowEnd =
        static_cast<int>(std::floor(params.depth.sampleIndex(*params.windowMaxMm))) + 1;
  }
  return peaks;
}

SignalDetector::SignalDetector(const DetectionParams& params)
    : params_(params), envelopeDetector_((validate(params), params.envelope)) {
  params_.peaks = resolvePeakParams(params);
}

SignalDetection SignalDetector::detect(const float* samples, int count) {
  envelope_.resize(static_cast<std::size_t>(count));
  envelopeDetector_.compute(samples, count, envelope_.data());
  SignalDetection detection;
  detection.peaks = findPeaks(params_.peaks, envelope_.data(), count);
  if (detection.accepted()) detection.depthMm = params_.depth.depthMm(detection.peaks.sampleIndex);
  return detection;
}

InterSignalFilter::InterSignalFilter(const InterSignalParams& params) : params_(params) {
  require(params.history >= 1, "history must be >= 1 frame");
  require(params.consistencyMm > 0.0, "consistency must be > 0 mm");
  require(params.minSpreadMm >= 0.0, "minimum spread must be >= 0 mm");
}

RejectReason InterSignalFilter::judge(const Eigen::Vector3d& pointMm) {
  // Keep the longest run of consecutive points that all agree with this one.
  std::size_t agreeing = 0;
  while (agreeing < run_.size() &&
         (run_[run_.size() - 1 - agreeing] - pointMm).norm() <= params_.consistencyMm) {
    ++agreeing;
  }
  run_.erase(run_.begin(), run_.end() - static_cast<std::ptrdiff_t>(agreeing));
  run_.push_back(pointMm);
  const auto history = static_cast<std::size_t>(params_.history);
  if (run_.size() > history) run_.erase(run_.begin());
  if (run_.size() < history) return RejectReason::Inconsistent;

  if (params_.minSpreadMm > 0.0) {
    for (const Eigen::Vector3d& accepted : accepted_) {
      if ((accepted - pointMm).norm() < params_.minSpreadMm) return RejectReason::TooClose;
    }
  }
  accepted_.push_back(pointMm);
  return RejectReason::None;
}

}  // namespace echoreg
