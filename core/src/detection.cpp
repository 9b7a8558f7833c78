#include "echoreg/core/detection.hpp"

#include "echoreg/core/number_text.hpp"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

// A sample index far outside any record (a billion samples: 20 s at 50 MHz) that still fits an
// int with room to spare.
constexpr double kFarSample = 1e9;

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument(message);
}

std::string transducerFallbackWarning(double hz) {
  return "the capture's spectrum shows no transducer band between 1 MHz and 0.45 x the sampling "
         "frequency; assuming " +
         std::to_string(hz / 1e6) + " MHz (give --transducer-frequency)";
}

}  // namespace

std::vector<std::string> detectionPresetNames() {
  return {"default", "mozes2008", "calibration", "shadow"};
}

DetectionParams detectionPreset(std::string_view name) {
  DetectionParams params;
  if (name == "default") {
    // Any probe and digitiser, any anatomy: everything that depends on the hardware is measured
    // from the capture (adaptToCapture). The record is conditioned by a high-pass at half the
    // transducer frequency (DC offsets and the slow baseline drift of real front ends go), the
    // envelope is a Hann average over 1.25 periods of the transducer (7 samples for 9 MHz at
    // 50 MHz: shorter than a pulse, so an echo is not averaged into the speckle), the ring-down
    // ends where the median record's burst does, and the prominence policy picks the echo from
    // the record's own statistics. The temporal filter compares each depth with its neighbours
    // in time, allowing the bone to move; the spatial filter runs on tracked points only.
    params.envelope.method = EnvelopeMethod::Hann;
    params.envelope.windowSamples = 7;
    params.envelope.ringDownSamples = 0;
    params.adapt.ringDown = true;
    params.adapt.highPassOfTransducer = 0.5;
    params.adapt.envelopeCycles = 1.25;
    params.adapt.gain = true;
    params.peaks.policy = PeakPolicy::Prominence;
    params.interSignal.temporal = TemporalMode::Neighbours;
    params.interSignal.history = 2;
    return params;
  }
  if (name == "shadow") {
    // echoreg 0.x's default, kept for comparison: a 7-sample Hann envelope after a 200-sample
    // ring-down and the bone policy (tissue before, an acoustic shadow behind), with the
    // dissertation's run filter.
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
    params.depth.speedOfSoundMps = kWaterSpeedOfSoundMps;
    return params;
  }
  throw std::invalid_argument("unknown preset '" + std::string(name) +
                              "' (expected default, mozes2008, calibration or shadow)");
}

void validate(const DetectionParams& params) {
  validate(params.envelope);
  const double fs = params.depth.samplingFrequencyHz;
  require(std::isfinite(fs) && fs >= 1e5 && fs <= 1e11,
          "sampling frequency must be between 100 kHz and 100 GHz");
  const double c = params.depth.speedOfSoundMps;
  // The same bounds as a flag or a capture header's value (core/depth.hpp), so that a --params
  // file or a manifest cannot hold what the flag refuses.
  require(std::isfinite(c) && c >= kMinSpeedOfSoundMps && c <= kMaxSpeedOfSoundMps,
          "speed of sound must be between 1000 and 2000 m/s (soft tissue 1450-1600, water 1480)");
  require(std::isfinite(params.depth.delayS) && params.depth.delayS >= 0.0 &&
              params.depth.delayS <= 1e-3,
          "delay must be between 0 and 1 ms (the time from the pulse to sample 0; a negative "
          "delay would put samples before the pulse, at negative depths)");
  if (params.transducerFrequencyHz) {
    require(std::isfinite(*params.transducerFrequencyHz) && *params.transducerFrequencyHz > 0.0 &&
                *params.transducerFrequencyHz < fs / 2.0,
            "transducer frequency must be between 0 and half the sampling frequency");
  }
  require(params.adapt.highPassOfTransducer >= 0.0 && params.adapt.highPassOfTransducer < 2.0,
          "high-pass fraction of the transducer frequency must be in [0, 2)");
  require(std::isfinite(params.adapt.highPassHz) && params.adapt.highPassHz >= 0.0 &&
              params.adapt.highPassHz < fs / 2.0,
          "high-pass corner must be between 0 (off) and half the sampling frequency");
  require(params.adapt.envelopeCycles >= 0.0 && params.adapt.envelopeCycles <= 100.0,
          "envelope window in transducer periods must be in [0, 100]");
  if (params.tgcDbPerMm) {
    require(std::isfinite(*params.tgcDbPerMm) && *params.tgcDbPerMm >= 0.0 &&
                *params.tgcDbPerMm <= kMaxTgcDbPerMm,
            "time-gain compensation must be between 0 and 10 dB per mm");
  }
  require(params.interSignal.maxDepthRateMmPerS >= 0.0 &&
              std::isfinite(params.interSignal.maxDepthRateMmPerS),
          "maximum depth rate must be >= 0 mm/s");
  require(params.interSignal.maxGapS > 0.0 && std::isfinite(params.interSignal.maxGapS),
          "maximum gap must be > 0 s");
  require(params.interSignal.frameRateHz > 0.0 && std::isfinite(params.interSignal.frameRateHz),
          "frame rate must be > 0 Hz");
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
  const double fs = params.depth.samplingFrequencyHz;
  const double transducer =
      params.transducerFrequencyHz.value_or(params.envelope.transducerFrequencyHz);
  if (transducer > 0.0)
    peaks.samplesPerCycle = fs / transducer;
  peaks.emissionSample = -params.depth.delayS * fs;
  peaks.ringDownEnd = std::max(peaks.ringDownEnd, params.envelope.ringDownSamples);
  // A depth far beyond any record (--window-mm 0 1e9: 6.5e10 samples) does not fit an int. The
  // window is clipped to the record where it is used, so a bound clipped to a billion samples
  // (beyond any record, well inside an int) keeps its meaning; the end is clipped one sample
  // further than the beginning, so that a window beyond reach stays a window (adaptToCapture
  // says it lies beyond the record).
  if (params.windowMinMm) {
    peaks.windowBegin = static_cast<int>(std::clamp(
        std::ceil(params.depth.sampleIndex(*params.windowMinMm)), -kFarSample, kFarSample));
  }
  if (params.windowMaxMm) {
    peaks.windowEnd =
        static_cast<int>(std::clamp(std::floor(params.depth.sampleIndex(*params.windowMaxMm)) + 1.0,
                                    -kFarSample + 1.0, kFarSample + 1.0));
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
  if (detection.accepted())
    detection.depthMm = params_.depth.depthMm(detection.peaks.sampleIndex);
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
  if (run_.size() > history)
    run_.erase(run_.begin());
  if (run_.size() < history)
    return RejectReason::Inconsistent;

  if (params_.minSpreadMm > 0.0) {
    for (const Eigen::Vector3d& accepted : accepted_) {
      if ((accepted - pointMm).norm() < params_.minSpreadMm)
        return RejectReason::TooClose;
    }
  }
  accepted_.push_back(pointMm);
  return RejectReason::None;
}

std::string_view temporalModeName(TemporalMode mode) {
  switch (mode) {
    case TemporalMode::Run:
      return "run";
    case TemporalMode::Neighbours:
      return "neighbours";
  }
  return "?";
}

TemporalMode parseTemporalMode(std::string_view name) {
  if (name == "run")
    return TemporalMode::Run;
  if (name == "neighbours")
    return TemporalMode::Neighbours;
  throw std::invalid_argument("unknown temporal filter '" + std::string(name) +
                              "' (expected run or neighbours)");
}

std::vector<RejectReason> applyInterSignal(const InterSignalParams& params,
                                           const std::vector<InterSignalInput>& frames,
                                           bool tracked) {
  std::vector<RejectReason> verdict(frames.size(), RejectReason::None);
  std::vector<Eigen::Vector3d> accepted;
  const auto spread = [&](const Eigen::Vector3d& point) {
    if (!tracked || params.minSpreadMm <= 0.0)
      return RejectReason::None;
    for (const Eigen::Vector3d& other : accepted) {
      if ((other - point).norm() < params.minSpreadMm)
        return RejectReason::TooClose;
    }
    accepted.push_back(point);
    return RejectReason::None;
  };

  if (params.temporal == TemporalMode::Run) {
    InterSignalParams run = params;
    if (!tracked)
      run.minSpreadMm = 0.0;
    InterSignalFilter filter(run);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      if (frames[f].detected) {
        verdict[f] = filter.judge(frames[f].pointMm);
      } else {
        filter.breakRun();
      }
    }
    return verdict;
  }

  // Neighbours: the detected frames in order, with their times.
  std::vector<std::size_t> detected;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    if (frames[f].detected)
      detected.push_back(f);
  }
  const auto timeOf = [&](std::size_t f) {
    return frames[f].timestampS ? *frames[f].timestampS
                                : static_cast<double>(f) / params.frameRateHz;
  };
  const int wanted = params.history - 1;
  for (std::size_t k = 0; k < detected.size(); ++k) {
    const std::size_t f = detected[k];
    bool keep = wanted <= 0;
    if (!keep) {
      int agreeing = 0;
      const auto agrees = [&](std::size_t g) {
        const double dt = std::fabs(timeOf(g) - timeOf(f));
        if (dt > params.maxGapS)
          return false;
        const double allowed = params.consistencyMm + params.maxDepthRateMmPerS * dt;
        return std::fabs(frames[g].depthMm - frames[f].depthMm) <= allowed;
      };
      for (int step = 1; step <= wanted && k >= static_cast<std::size_t>(step); ++step) {
        if (agrees(detected[k - static_cast<std::size_t>(step)]))
          ++agreeing;
      }
      for (int step = 1; step <= wanted && k + static_cast<std::size_t>(step) < detected.size();
           ++step) {
        if (agrees(detected[k + static_cast<std::size_t>(step)]))
          ++agreeing;
      }
      keep = agreeing >= wanted;
    }
    verdict[f] = keep ? spread(frames[f].pointMm) : RejectReason::Inconsistent;
  }
  return verdict;
}

namespace {

// Indices of up to `wanted` records spread evenly over `count`.
std::vector<int> spreadIndices(int count, int wanted) {
  std::vector<int> indices;
  const int n = std::min(count, wanted);
  for (int k = 0; k < n; ++k) {
    indices.push_back(static_cast<int>((static_cast<long long>(k) * count) / n));
  }
  return indices;
}

constexpr int kAnalysedRecords = 64;

// Time-gain compensation (measureDeepNoiseRise): the noise behind bone rises with depth at this
// many dB per mm or more where a front end amplifies it (0.29-1.26 dB/mm on the physical set's
// captures with TGC, 0.4-1.2 dB/us drawn; at most +0.06 on every capture of the three sets
// without it, seeds 1-3), over at least kMinTgcSpanMm of the record's deep half.
constexpr double kMinTgcDbPerMm = 0.15;
constexpr double kMinTgcSpanMm = 4.0;
// ... and rises steadily: the rise over the span at least this many times the RMS scatter of the
// levels about the fitted line (at least kMinTgcScatterDb). 6.5-154 on those captures with TGC,
// 0.7-4.9 on the 12 others whose deep level rose 0.15 dB/mm or more (a water standoff longer than
// half the record, bone's reverberation, the in-vivo baseline's wander).
constexpr double kMinTgcRiseOverScatter = 6.0;
constexpr double kMinTgcScatterDb = 0.5;
// The lower quantile across records of each 1 mm block's median: where bone shadows the deep
// half in a quarter of the records or more, the noise there.
constexpr double kDeepNoiseQuantile = 0.25;
// A capture in which at least this share of the analysed records shows bone with its shadow is
// judged with the shadow required.
constexpr double kShadowCaptureShare = 0.2;

// The rise of the capture's deep noise with depth, dB per mm: over up to 64 records spread
// through the capture, the median of each 1 mm block of the envelope (`params.envelope`, the
// band and the ring-down resolved, no gain undone); per block the lower quantile of those medians
// across the records (kDeepNoiseQuantile); the least-squares slope of those levels in dB over the
// record's deep half (after the ring-down). 0 when that half spans less than kMinTgcSpanMm.
double measureDeepNoiseRise(const DetectionParams& params, int recordCount, int samples,
                            const RecordSource& record, int ringDown) {
  const double mmPerSample = params.depth.mmPerSample();
  const int block = std::max(8, static_cast<int>(std::lround(1.0 / mmPerSample)));
  const int blocks = samples / block;
  const int first = std::max(blocks / 2, ringDown / block + 1);
  if ((blocks - first) * block * mmPerSample < kMinTgcSpanMm)
    return 0.0;
  EnvelopeParams envelope = params.envelope;
  envelope.ringDownSamples = 0;
  EnvelopeDetector detector(envelope);
  std::vector<std::vector<float>> medians(static_cast<std::size_t>(blocks - first));
  std::vector<float> raw, e(static_cast<std::size_t>(samples)), part;
  for (int index : spreadIndices(recordCount, kAnalysedRecords)) {
    record(index, raw);
    detector.compute(raw.data(), samples, e.data());
    for (int b = first; b < blocks; ++b) {
      part.assign(e.begin() + static_cast<std::ptrdiff_t>(b) * block,
                  e.begin() + static_cast<std::ptrdiff_t>(b + 1) * block);
      auto middle = part.begin() + static_cast<std::ptrdiff_t>(part.size() / 2);
      std::nth_element(part.begin(), middle, part.end());
      medians[static_cast<std::size_t>(b - first)].push_back(*middle);
    }
  }
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  const auto n = static_cast<double>(medians.size());
  std::vector<double> xs, levels;
  for (std::size_t k = 0; k < medians.size(); ++k) {
    std::vector<float>& v = medians[k];
    const auto at = static_cast<std::ptrdiff_t>(kDeepNoiseQuantile * static_cast<double>(v.size()));
    std::nth_element(v.begin(), v.begin() + at, v.end());
    const double level =
        20.0 * std::log10(std::max(1e-6, static_cast<double>(v[static_cast<std::size_t>(at)])));
    const double x = static_cast<double>(first + static_cast<int>(k)) * block * mmPerSample;
    sx += x;
    sy += level;
    sxx += x * x;
    sxy += x * level;
    xs.push_back(x);
    levels.push_back(level);
  }
  const double denominator = n * sxx - sx * sx;
  if (!(denominator > 0.0))
    return 0.0;
  const double slope = (n * sxy - sx * sy) / denominator;
  // A steady rise, not a step (water giving way to tissue, bone's echo and the reverberation
  // behind it) nor a wander: the rise over the span at least kMinTgcRiseOverScatter times the
  // levels' scatter about the line.
  double squares = 0.0;
  for (std::size_t k = 0; k < xs.size(); ++k) {
    const double residual = levels[k] - (sy / n + slope * (xs[k] - sx / n));
    squares += residual * residual;
  }
  const double scatter = std::max(kMinTgcScatterDb, std::sqrt(squares / n));
  return slope * (xs.back() - xs.front()) >= kMinTgcRiseOverScatter * scatter ? slope : 0.0;
}

}  // namespace

double estimateTransducerFrequencyHz(int recordCount, int samples, const RecordSource& record,
                                     double samplingFrequencyHz) {
  if (recordCount <= 0 || samples < 16)
    return 0.0;
  int fftSize = 1;
  while (fftSize < samples)
    fftSize *= 2;
  EnvelopeParams conditioning;
  conditioning.samplingFrequencyHz = samplingFrequencyHz;
  const int highPass = highPassLength(1e6, samplingFrequencyHz);
  std::vector<double> power(static_cast<std::size_t>(fftSize / 2 + 1), 0.0);
  std::vector<float> raw, input(static_cast<std::size_t>(fftSize), 0.F);
  std::vector<std::complex<float>> spectrum;
  Eigen::FFT<float> fft;
  for (int index : spreadIndices(recordCount, kAnalysedRecords)) {
    record(index, raw);
    // A 1 MHz high-pass (moving average removed) so that baseline drift does not dominate.
    subtractMovingAverage(raw.data(), samples, highPass, input.data());
    fft.fwd(spectrum, input);
    for (std::size_t k = 0; k < power.size(); ++k)
      power[k] += std::norm(spectrum[k]);
  }
  const double binHz = samplingFrequencyHz / fftSize;
  const auto lo = static_cast<std::size_t>(std::ceil(1e6 / binHz));
  const auto hi = std::min(power.size() - 1, static_cast<std::size_t>(0.45 * fftSize));
  if (lo >= hi)
    return 0.0;
  // Smooth over +-0.25 MHz, then take the peak and the power-weighted mean of the bins above a
  // quarter of it around the peak.
  const int half = std::max(1, static_cast<int>(std::lround(0.25e6 / binHz)));
  std::vector<double> smooth(power.size(), 0.0);
  for (std::size_t k = lo; k <= hi; ++k) {
    double total = 0.0;
    int n = 0;
    for (int d = -half; d <= half; ++d) {
      const long long j = static_cast<long long>(k) + d;
      if (j < static_cast<long long>(lo) || j > static_cast<long long>(hi))
        continue;
      total += power[static_cast<std::size_t>(j)];
      ++n;
    }
    smooth[k] = total / n;
  }
  std::size_t peak = lo;
  for (std::size_t k = lo; k <= hi; ++k) {
    if (smooth[k] > smooth[peak])
      peak = k;
  }
  if (!(smooth[peak] > 0.0))
    return 0.0;
  std::size_t left = peak, right = peak;
  while (left > lo && smooth[left - 1] >= 0.25 * smooth[peak])
    --left;
  while (right < hi && smooth[right + 1] >= 0.25 * smooth[peak])
    ++right;
  double weighted = 0.0, total = 0.0;
  for (std::size_t k = left; k <= right; ++k) {
    weighted += smooth[k] * static_cast<double>(k);
    total += smooth[k];
  }
  return weighted / total * binHz;
}

ShadowTrial measureShadowRule(const DetectionParams& adapted, int recordCount, int samples,
                              const RecordSource& record) {
  ShadowTrial out;
  if (recordCount <= 0 || samples <= 0)
    return out;
  DetectionParams trial = adapted;
  trial.peaks.prominence.shadow = ShadowRule::Required;
  // A capture is judged by the shadow where bone casts a clear one; the shadow at the noise
  // behind a strong echo then finds bone in the records whose tissue is at the noise too.
  trial.peaks.prominence.noiseShadowEchoFactor = 0.0;
  // The trial counts records in which an echo casts bone's shadow; a record judged by its own
  // signature casts none.
  trial.peaks.prominence.shadowOnly = true;
  // Shadows as recorded, the time-gain compensation not allowed for: a shadow that stands out
  // only against the noise's rise with depth is no clear shadow of bone under tissue, and the
  // rule it would set judges bone in water by the shadow too (physical generator, phantom in
  // water with TGC, seeds 10-18: 27 of 229 bone echoes lost when the trial allowed for it).
  trial.peaks.gainDbPerSample = 0.0;
  SignalDetector detector(trial);
  std::vector<float> raw;
  const std::vector<int> indices = spreadIndices(recordCount, kAnalysedRecords);
  for (int index : indices) {
    record(index, raw);
    if (detector.detect(raw.data(), samples).accepted())
      ++out.shadowed;
  }
  out.records = static_cast<int>(indices.size());
  out.share = static_cast<double>(out.shadowed) / static_cast<double>(out.records);
  out.rule = out.share >= kShadowCaptureShare ? ShadowRule::Required : ShadowRule::Auto;
  return out;
}

DetectionParams adaptToCapture(const DetectionParams& given, int recordCount, int samples,
                               const RecordSource& record, std::optional<double> headerFrequencyHz,
                               CaptureAnalysis* analysis) {
  DetectionParams params = given;
  CaptureAnalysis local;
  CaptureAnalysis& out = analysis ? *analysis : local;
  out = CaptureAnalysis{};
  const double fs = params.depth.samplingFrequencyHz;
  params.envelope.samplingFrequencyHz = fs;

  const bool needFrequency = params.adapt.highPassOfTransducer > 0.0 ||
                             params.adapt.envelopeCycles > 0.0 ||
                             params.peaks.policy == PeakPolicy::Prominence;
  if (params.transducerFrequencyHz) {
    out.transducerFrequencyHz = *params.transducerFrequencyHz;
    out.transducerFrequencySource = "given";
  } else if (headerFrequencyHz && *headerFrequencyHz > 0.0 && *headerFrequencyHz < fs / 2.0) {
    out.transducerFrequencyHz = *headerFrequencyHz;
    out.transducerFrequencySource = "header";
  } else if (needFrequency && recordCount > 0) {
    out.transducerFrequencyHz = estimateTransducerFrequencyHz(recordCount, samples, record, fs);
    out.transducerFrequencySource = "spectrum";
    if (out.transducerFrequencyHz <= 0.0) {
      out.transducerFrequencyHz = std::min(9e6, 0.2 * fs);
      out.warnings.push_back(transducerFallbackWarning(out.transducerFrequencyHz));
    }
  }
  if (out.transducerFrequencyHz > 0.0) {
    params.transducerFrequencyHz = out.transducerFrequencyHz;
    params.envelope.transducerFrequencyHz = std::min(out.transducerFrequencyHz, 0.49 * fs);
    const double cycle = fs / out.transducerFrequencyHz;
    if (params.adapt.highPassOfTransducer > 0.0) {
      params.envelope.highPassSamples =
          highPassLength(params.adapt.highPassOfTransducer * out.transducerFrequencyHz, fs);
    }
    if (params.adapt.envelopeCycles > 0.0) {
      params.envelope.windowSamples =
          std::max(1, static_cast<int>(std::lround(params.adapt.envelopeCycles * cycle)));
    }
  }
  if (params.adapt.highPassHz > 0.0) {
    params.envelope.highPassSamples = highPassLength(params.adapt.highPassHz, fs);
  }
  out.highPassSamples = params.envelope.highPassSamples;
  out.envelopeWindowSamples = params.envelope.windowSamples;
  // A processing window wholly outside the record finds nothing in any record.
  if (samples > 0 && (params.windowMinMm || params.windowMaxMm)) {
    const PeakParams resolved = resolvePeakParams(params);
    const double firstMm = params.depth.depthMm(0.0);
    const double lastMm = params.depth.depthMm(samples - 1.0);
    const std::string window = "the processing window (" +
                               number(params.windowMinMm.value_or(firstMm), "%.6g") + " to " +
                               number(params.windowMaxMm.value_or(lastMm), "%.6g") + " mm)";
    if (resolved.windowBegin && *resolved.windowBegin >= samples) {
      throw std::invalid_argument(window + " starts beyond the record, whose last sample lies at " +
                                  number(lastMm, 1) + " mm");
    }
    if (resolved.windowEnd && *resolved.windowEnd <= 0) {
      throw std::invalid_argument(window + " ends before the record, whose first sample lies at " +
                                  number(firstMm, 1) + " mm");
    }
  }
  // Lengths in samples longer than the record mean nothing for it (every sample's window would
  // be the whole record), and the envelope's weights alone take memory in proportion to them
  // (--envelope-window 1000000000: 24 GB before the kernel stopped it): refused before any
  // envelope is computed.
  if (samples > 0 && params.envelope.windowSamples > samples) {
    throw std::invalid_argument(
        "the envelope window (" + std::to_string(params.envelope.windowSamples) +
        " samples) is longer than the whole " + std::to_string(samples) + "-sample record");
  }
  if (samples > 0 && params.envelope.method == EnvelopeMethod::Hilbert &&
      params.envelope.smoothingSamples > samples) {
    throw std::invalid_argument(
        "the envelope's smoothing (" + std::to_string(params.envelope.smoothingSamples) +
        " samples) is longer than the whole " + std::to_string(samples) + "-sample record");
  }

  if (params.adapt.ringDown && recordCount > 0 && samples > 0) {
    // The median envelope over records spread through the capture: the ring-down is the same in
    // every record, echoes and speckle are not.
    EnvelopeParams envelope = params.envelope;
    envelope.ringDownSamples = 0;
    EnvelopeDetector detector(envelope);
    const std::vector<int> indices = spreadIndices(recordCount, kAnalysedRecords);
    std::vector<std::vector<float>> envelopes;
    std::vector<float> raw;
    for (int index : indices) {
      record(index, raw);
      std::vector<float> e(static_cast<std::size_t>(samples));
      detector.compute(raw.data(), samples, e.data());
      envelopes.push_back(std::move(e));
    }
    std::vector<float> median(static_cast<std::size_t>(samples));
    std::vector<float> column(envelopes.size());
    for (int i = 0; i < samples; ++i) {
      for (std::size_t r = 0; r < envelopes.size(); ++r)
        column[r] = envelopes[r][static_cast<std::size_t>(i)];
      auto middle = column.begin() + static_cast<std::ptrdiff_t>(column.size() / 2);
      std::nth_element(column.begin(), middle, column.end());
      median[static_cast<std::size_t>(i)] = *middle;
    }
    // The level the record settles to: the median of its second half.
    std::vector<float> tail(median.begin() + samples / 2, median.end());
    std::nth_element(tail.begin(), tail.begin() + static_cast<std::ptrdiff_t>(tail.size() / 2),
                     tail.end());
    const double settled = tail.empty() ? 0.0 : tail[tail.size() / 2];
    const double cycle = out.transducerFrequencyHz > 0.0 ? fs / out.transducerFrequencyHz : 5.0;
    // The burst peaks within a few periods of the start (plus the envelope's own spread), or
    // within the first microsecond.
    const int head = std::clamp(
        std::max(static_cast<int>(std::lround(4.0 * cycle)) + params.envelope.windowSamples,
                 static_cast<int>(std::lround(1e-6 * fs))),
        std::min(4, samples), std::max(std::min(4, samples), samples / 4));
    const auto burstPeak = std::max_element(median.begin(), median.begin() + head);
    int ringDown = 0;
    if (*burstPeak > 8.0 * settled && *burstPeak > 0.F) {
      const double level = 0.5 * *burstPeak;
      int i = static_cast<int>(burstPeak - median.begin());
      while (i < samples && median[static_cast<std::size_t>(i)] >= level)
        ++i;
      ringDown = std::min(samples, i + static_cast<int>(std::lround(cycle)));
    }
    params.envelope.ringDownSamples = params.peaks.policy == PeakPolicy::Prominence ? 0 : ringDown;
    params.peaks.ringDownEnd = ringDown;
    out.ringDownSamples = ringDown;
    out.ringDownSource = "measured";
  } else {
    out.ringDownSamples = params.envelope.ringDownSamples;
    out.ringDownSource = "given";
    if (params.peaks.policy == PeakPolicy::Prominence) {
      // The prominence policy reads the envelope through the ring-down (so that an echo on its
      // tail keeps its prominence) and starts looking after it.
      params.peaks.ringDownEnd = params.envelope.ringDownSamples;
      params.envelope.ringDownSamples = 0;
    }
  }
  // Time-gain compensation: given, or measured from the rise of the capture's deep noise; the
  // shadow tests then judge each region against the noise at its depth (PeakParams).
  if (params.tgcDbPerMm) {
    out.tgcDbPerMm = *params.tgcDbPerMm;
    out.tgcSource = "given";
  } else if (params.adapt.gain && recordCount > 0 && samples > 0) {
    out.deepNoiseRiseDbPerMm =
        measureDeepNoiseRise(params, recordCount, samples, record,
                             std::max(params.peaks.ringDownEnd, params.envelope.ringDownSamples));
    if (out.deepNoiseRiseDbPerMm >= kMinTgcDbPerMm) {
      out.tgcDbPerMm = std::min(out.deepNoiseRiseDbPerMm, kMaxTgcDbPerMm);
      out.tgcSource = "measured";
    } else {
      out.tgcSource = "none";
    }
  }
  params.peaks.gainDbPerSample = std::min(1.0, out.tgcDbPerMm * params.depth.mmPerSample());
  // The shadow rule for the whole capture: where bone under tissue casts a shadow in many
  // records, the shadow is required of every record (the bone policy, proven on specimens);
  // elsewhere (shallow bone in vivo whose cortex rings, a phantom in water) each record is
  // judged by the signature behind its echo, a shadow or the cortex's ringing.
  if (params.peaks.policy == PeakPolicy::Prominence &&
      params.peaks.prominence.shadow == ShadowRule::Auto && recordCount > 0 &&
      out.ringDownSamples < samples) {
    const ShadowTrial trial = measureShadowRule(params, recordCount, samples, record);
    out.shadowShare = trial.share;
    params.peaks.prominence.shadow = trial.rule;
  }
  out.shadowRule = std::string(shadowRuleName(params.peaks.prominence.shadow));
  if (out.ringDownSamples >= samples && samples > 0) {
    throw std::invalid_argument("the ring-down (" + std::to_string(out.ringDownSamples) +
                                " samples) covers the whole " + std::to_string(samples) +
                                "-sample record");
  }
  if (samples > 0 && out.ringDownSamples > samples / 2) {
    out.warnings.push_back("the ring-down covers " + std::to_string(out.ringDownSamples) + " of " +
                           std::to_string(samples) + " samples");
  }
  return params;
}

}  // namespace echoreg::core
