#include "capture_detection.hpp"

#include "echoreg/core/error.hpp"

#include <stdexcept>

namespace echoreg::cli {

bool CaptureDetectionRequest::operator==(const CaptureDetectionRequest& other) const {
  return capture == other.capture && preset == other.preset && settings == other.settings &&
         poseTransform == other.poseTransform && referenceTransform == other.referenceTransform &&
         beamToProbe == other.beamToProbe;
}

nlohmann::json CaptureDetectionRequest::json() const {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < 4; ++r)
    rows.push_back({beamToProbe(r, 0), beamToProbe(r, 1), beamToProbe(r, 2), beamToProbe(r, 3)});
  return {{"capture", capture},
          {"preset", preset},
          {"settings", settingsJson(settings)},
          {"pose", poseTransform},
          {"reference", referenceTransform},
          {"beam_to_probe", rows}};
}

std::unique_ptr<CaptureDetection> openCapture(const std::string& path,
                                              const std::vector<std::string>& rigidPoses) {
  auto capture = std::make_unique<CaptureDetection>();
  capture->pipeline.open(path, rigidPoses);
  for (const auto& [transform, report] : capture->pipeline.reader->GetRigidPoseReports()) {
    capture->poseNotes.reorthonormalised += report.reorthonormalised;
    if (auto line = core::rigidPoseNote(report, path, transform))
      capture->poseNotes.lines.push_back(*line);
  }
  return capture;
}

void runDetection(CaptureDetection& capture, const core::DetectionParams& params,
                  const core::PointFrameOptions& points) {
  // Streamed in blocks of frames as `detect` does: the envelopes (4 bytes a sample) and the
  // reader's copy of the A-lines are one block's at any time, not the capture's; the detection is
  // the same (tests/cli/test_capture_detection.cpp).
  capture.pipeline.setFramesPerBlock(filters::DetectionPipeline::kStreamFramesPerBlock);
  try {
    capture.pipeline.configure(params, points);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(capture.pipeline.reader->GetFileName(), e.what());
  }
  capture.detection = capture.pipeline.run();
}

core::DetectionParams requestParams(const CaptureDetectionRequest& request,
                                    const core::Sequence& sequence) {
  try {
    core::detectionPreset(request.preset);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--preset: ") + e.what());
  }
  try {
    return resolveParams(request.preset, request.settings, sequence);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("bad parameter: ") + e.what());
  }
}

std::unique_ptr<CaptureDetection> detectCapture(const CaptureDetectionRequest& request) {
  std::unique_ptr<CaptureDetection> capture =
      openCapture(request.capture, {request.poseTransform, request.referenceTransform});
  const core::DetectionParams params = requestParams(request, capture->sequence());
  core::PointFrameOptions points;
  points.poseTransform = request.poseTransform;
  points.referenceTransform = request.referenceTransform;
  points.beamToProbe = request.beamToProbe;
  runDetection(*capture, params, points);
  return capture;
}

CaptureDetection& CaptureDetections::get(const CaptureDetectionRequest& request) {
  if (kept_ == nullptr || !(request_ == request)) {
    kept_.reset();
    kept_ = detectCapture(request);
    request_ = request;
    ++runs_;
  }
  return *kept_;
}

}  // namespace echoreg::cli
