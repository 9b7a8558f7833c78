#include "echoreg/core/sequence_detection.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace echoreg::core {

namespace {

// The frame's transform when named, present and valid.
const Eigen::Matrix4d* validTransform(const SequenceFrame& frame, const std::string& name) {
  if (name.empty())
    return nullptr;
  const auto it = frame.transforms.find(name);
  if (it == frame.transforms.end() || !it->second.valid())
    return nullptr;
  return &it->second.matrix;
}

}  // namespace

std::optional<Eigen::Vector3d> beamPoint(double depthMm, const PointFrameOptions& points,
                                         const Eigen::Matrix4d* pose,
                                         const Eigen::Matrix4d* reference) {
  Eigen::Vector4d point(0.0, 0.0, depthMm, 1.0);
  if (points.poseTransform.empty())
    return point.head<3>();
  if (!pose || (!points.referenceTransform.empty() && !reference))
    return std::nullopt;
  point = *pose * points.beamToProbe * point;
  if (!points.referenceTransform.empty())
    point = reference->inverse() * point;
  return point.head<3>();
}

DepthConversion depthFromSequence(const Sequence& sequence, const DepthConversion& fallback) {
  DepthConversion depth = fallback;
  const AcquisitionSettings& acquisition = sequence.acquisition;
  if (acquisition.samplingFrequencyHz)
    depth.samplingFrequencyHz = *acquisition.samplingFrequencyHz;
  if (acquisition.delayS)
    depth.delayS = *acquisition.delayS;
  if (acquisition.speedOfSoundMps)
    depth.speedOfSoundMps = *acquisition.speedOfSoundMps;
  return depth;
}

void requireTransform(const Sequence& sequence, const std::string& name) {
  if (name.empty())
    return;
  const std::vector<std::string> names = sequence.transformNames();
  if (std::find(names.begin(), names.end(), name) != names.end())
    return;
  std::string known;
  for (const auto& n : names)
    known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("the capture has no transform " + name +
                              " (it has: " + (known.empty() ? "none" : known) + ")");
}

void requireSingleALineFrames(const Sequence& sequence) {
  if (sequence.hasPixels() && sequence.frameSize[1] > 1) {
    throw std::invalid_argument(
        "its frames hold " + std::to_string(sequence.frameSize[1]) + " rows of " +
        std::to_string(sequence.frameSize[0]) + " samples (DimSize " +
        std::to_string(sequence.frameSize[0]) + " " + std::to_string(sequence.frameSize[1]) +
        " F: several transducers per frame?); echoreg reads one A-line per frame: write one "
        "capture per transducer");
  }
}

DetectionParams adaptToSequence(const Sequence& sequence, const DetectionParams& params,
                                CaptureAnalysis* analysis) {
  requireSingleALineFrames(sequence);
  const RecordSource record = [&sequence](int index, std::vector<float>& out) {
    sequence.frameSamples(static_cast<std::size_t>(index), out);
  };
  return adaptToCapture(params, static_cast<int>(sequence.frameCount()),
                        static_cast<int>(sequence.samplesPerFrame()), record,
                        sequence.acquisition.transducerFrequencyHz, analysis);
}

SequenceDetection detectSequence(const Sequence& sequence, const DetectionParams& given,
                                 const PointFrameOptions& points,
                                 const std::function<void(int, int)>& progress) {
  if (!sequence.hasPixels()) {
    throw std::invalid_argument("the capture holds no A-lines (a tracker-only sequence)");
  }
  if (!points.referenceTransform.empty() && points.poseTransform.empty()) {
    throw std::invalid_argument("a reference transform needs a pose transform too");
  }
  requireTransform(sequence, points.poseTransform);
  requireTransform(sequence, points.referenceTransform);

  SequenceDetection result;
  result.params = adaptToSequence(sequence, given, &result.analysis);
  const DetectionParams& params = result.params;
  SignalDetector detector(params);
  EchoContext context(resolvePeakParams(params));
  const int frameCount = static_cast<int>(sequence.frameCount());
  const int samples = static_cast<int>(sequence.samplesPerFrame());
  std::vector<float> record;
  result.frames.reserve(sequence.frameCount());
  std::vector<InterSignalInput> inputs(sequence.frameCount());
  std::vector<double> depths(sequence.frameCount(), 0.0);

  for (int f = 0; f < frameCount; ++f) {
    const SequenceFrame& frame = sequence.frames[static_cast<std::size_t>(f)];
    FrameDetection out;
    out.frame = f;
    out.timestampS = frame.timestampS;
    sequence.frameSamples(static_cast<std::size_t>(f), record);
    SignalDetection detection = detector.detect(record.data(), samples);
    if (context.judge(detection.peaks, detector.envelope().data(), samples)) {
      detection.depthMm = params.depth.depthMm(detection.peaks.sampleIndex);
      ++result.fromContext;
    }
    out.peakCount = static_cast<int>(detection.peaks.peaks.size());
    out.reason = detection.peaks.reason;
    InterSignalInput& input = inputs[static_cast<std::size_t>(f)];
    input.timestampS = frame.timestampS;
    if (detection.accepted()) {
      out.sampleIndex = detection.peaks.sampleIndex;
      const std::optional<Eigen::Vector3d> point =
          beamPoint(detection.depthMm, points, validTransform(frame, points.poseTransform),
                    validTransform(frame, points.referenceTransform));
      if (point) {
        input.detected = true;
        input.depthMm = detection.depthMm;
        input.pointMm = *point;
        ++result.echoes;
      } else {
        out.reason = RejectReason::InvalidPose;
      }
    }
    result.frames.push_back(std::move(out));
    if (progress && (f % 256 == 255 || f + 1 == frameCount))
      progress(f + 1, frameCount);
  }

  const std::vector<RejectReason> verdicts =
      applyInterSignal(params.interSignal, inputs, !points.poseTransform.empty());
  for (std::size_t f = 0; f < result.frames.size(); ++f) {
    FrameDetection& out = result.frames[f];
    if (inputs[f].detected) {
      out.reason = verdicts[f];
      if (out.reason == RejectReason::None) {
        out.depthMm = inputs[f].depthMm;
        out.pointMm = inputs[f].pointMm;
      }
    }
    if (out.accepted()) {
      ++result.accepted;
    } else {
      ++result.rejectedByReason[std::string(rejectReasonName(out.reason))];
    }
  }
  return result;
}

std::vector<std::string> detectionWarnings(const SequenceDetection& detection) {
  std::vector<std::string> warnings = detection.analysis.warnings;
  const DetectionParams& params = detection.params;
  const auto count = [&](const char* reason) {
    const auto it = detection.rejectedByReason.find(reason);
    return it == detection.rejectedByReason.end() ? 0 : it->second;
  };
  const auto mm = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", value);
    return std::string(text);
  };
  const int ringDown = std::max(params.peaks.ringDownEnd, params.envelope.ringDownSamples);
  if (params.windowMinMm && ringDown > 0) {
    const double ringDownMm = params.depth.depthMm(ringDown);
    if (*params.windowMinMm < ringDownMm) {
      warnings.push_back("the processing window starts at " + mm(*params.windowMinMm) +
                         " mm, inside the ring-down (which ends at " + mm(ringDownMm) +
                         " mm, sample " + std::to_string(ringDown) +
                         "): echoes there cannot be told from the transducer's own; " +
                         std::to_string(count("in-ring-down")) +
                         " frames found nothing after it (in-ring-down); set --ring-down to "
                         "shorten it if the burst ends earlier");
    }
  }
  const int echoes = detection.echoes;
  const int inconsistent = count("inconsistent"), tooClose = count("too-close");
  if (echoes > 0 && 2 * inconsistent > echoes) {
    warnings.push_back("the temporal filter removed " + std::to_string(inconsistent) + " of " +
                       std::to_string(echoes) +
                       " echoes (inconsistent): the depth changes faster than it allows; "
                       "--history 1 switches it off, --max-depth-rate and --consistency-mm "
                       "widen it");
  }
  if (echoes > 0 && 2 * tooClose > echoes) {
    warnings.push_back("the spatial filter removed " + std::to_string(tooClose) + " of " +
                       std::to_string(echoes) +
                       " echoes (too-close): the probe stayed within --min-spread-mm of earlier "
                       "points; --min-spread-mm 0 switches it off");
  }
  const std::size_t frames = detection.frames.size();
  if (frames > 0 && 5 * static_cast<std::size_t>(detection.accepted) < frames) {
    std::string dominant;
    int most = 0;
    for (const auto& [reason, n] : detection.rejectedByReason) {
      if (n > most) {
        most = n;
        dominant = reason;
      }
    }
    static const std::map<std::string, std::string> blame{
        {"no-peak",
         "nothing stood above the detection level: check --sampling-frequency and the "
         "records, or lower --echo-snr / --echo-over-median"},
        {"not-bone",
         "echoes were found but none passed the policy's tests: see the prominence "
         "policy's settings (--echo-contrast, --echo-max-rise, "
         "--echo-air-reverberation), or --peaks max"},
        {"outside-window", "the echoes lie outside --window-mm"},
        {"in-ring-down", "--window-mm starts inside the ring-down; --ring-down sets its length"},
        {"inconsistent", "the temporal filter: --history 1, --max-depth-rate or --consistency-mm"},
        {"too-close", "the spatial filter: --min-spread-mm 0"},
        {"invalid-pose",
         "--pose / --reference: the transform is missing or not OK in those "
         "frames"},
        {"too-many-peaks", "--peaks: single and double need exactly one or two peaks"},
        {"too-few-peaks", "--peaks: double needs exactly two peaks"},
    };
    const auto advice = blame.find(dominant);
    char share[32];
    std::snprintf(share, sizeof share, "%.1f",
                  100.0 * detection.accepted / static_cast<double>(frames));
    warnings.push_back(
        "only " + std::string(share) + " % of the frames were accepted (" +
        std::to_string(detection.accepted) + " of " + std::to_string(frames) +
        "); most were rejected as " + dominant + " (" + std::to_string(most) +
        " frames): " + (advice == blame.end() ? "see docs/detection.md" : advice->second));
  }
  return warnings;
}

}  // namespace echoreg::core
