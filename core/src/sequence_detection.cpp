#include "echoreg/core/sequence_detection.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <stdexcept>

namespace echoreg {

namespace {

void requireTransform(const Sequence& sequence, const std::string& name) {
  if (name.empty()) return;
  const std::vector<std::string> names = sequence.transformNames();
  if (std::find(names.begin(), names.end(), name) != names.end()) return;
  std::string known;
  for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("the capture has no transform " + name + " (it has: " +
                              (known.empty() ? "none" : known) + ")");
}

// The frame's transform when named, present and valid.
const Eigen::Matrix4d* validTransform(const SequenceFrame& frame, const std::string& name) {
  if (name.empty()) return nullptr;
  const auto it = frame.transforms.find(name);
  if (it == frame.transforms.end() || !it->second.valid()) return nullptr;
  return &it->second.matrix;
}

}  // namespace

std::optional<Eigen::Vector3d> beamPoint(double depthMm, const PointFrameOptions& points,
                                         const Eigen::Matrix4d* pose,
                                         const Eigen::Matrix4d* reference) {
  Eigen::Vector4d point(0.0, 0.0, depthMm, 1.0);
  if (points.poseTransform.empty()) return point.head<3>();
  if (!pose || (!points.referenceTransform.empty() && !reference)) return std::nullopt;
  point = *pose * points.beamToProbe * point;
  if (!points.referenceTransform.empty()) point = reference->inverse() * point;
  return point.head<3>();
}

DepthConversion depthFromSequence(const Sequence& sequence, const DepthConversion& fallback) {
  DepthConversion depth = fallback;
  const AcquisitionSettings& acquisition = sequence.acquisition;
  if (acquisition.samplingFrequencyHz) depth.samplingFrequencyHz = *acquisition.samplingFrequencyHz;
  if (acquisition.delayS) depth.delayS = *acquisition.delayS;
  if (acquisition.speedOfSoundMps) depth.speedOfSoundMps = *acquisition.speedOfSoundMps;
  return depth;
}

SequenceDetection detectSequence(const Sequence& sequence, const DetectionParams& params,
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

  SignalDetector detector(params);
  InterSignalFilter interSignal(params.interSignal);
  SequenceDetection result;
  const int frameCount = static_cast<int>(sequence.frameCount());
  const int samples = static_cast<int>(sequence.samplesPerFrame());
  std::vector<float> record;
  result.frames.reserve(sequence.frameCount());

  for (int f = 0; f < frameCount; ++f) {
    const SequenceFrame& frame = sequence.frames[static_cast<std::size_t>(f)];
    FrameDetection out;
    out.frame = f;
    out.timestampS = frame.timestampS;
    sequence.frameSamples(static_cast<std::size_t>(f), record);
    const SignalDetection detection = detector.detect(record.data(), samples);
    out.peakCount = static_cast<int>(detection.peaks.peaks.size());
    out.reason = detection.peaks.reason;

    if (detection.accepted()) {
      out.sampleIndex = detection.peaks.sampleIndex;
      const std::optional<Eigen::Vector3d> point =
          beamPoint(detection.depthMm, points, validTransform(frame, points.poseTransform),
                    validTransform(frame, points.referenceTransform));
      if (point) {
        out.reason = interSignal.judge(*point);
        if (out.reason == RejectReason::None) {
          out.depthMm = detection.depthMm;
          out.pointMm = point;
        }
      } else {
        out.reason = RejectReason::InvalidPose;
        interSignal.breakRun();
      }
    } else {
      interSignal.breakRun();
    }

    if (out.accepted()) {
      ++result.accepted;
    } else {
      ++result.rejectedByReason[std::string(rejectReasonName(out.reason))];
    }
    result.frames.push_back(std::move(out));
    if (progress && (f % 256 == 255 || f + 1 == frameCount)) progress(f + 1, frameCount);
  }
  return result;
}

}  // namespace echoreg
