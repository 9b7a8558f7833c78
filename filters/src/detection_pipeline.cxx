#include "echoreg/filters/detection_pipeline.h"

#include "echoreg/filters/detection_table.h"

#include <vtkExecutive.h>
#include <vtkLogger.h>
#include <vtkOutputWindow.h>
#include <vtkStringOutputWindow.h>
#include <vtkTable.h>

#include <Eigen/Core>

#include <algorithm>
#include <mutex>
#include <stdexcept>

namespace echoreg::filters {

VtkMessageCapture::VtkMessageCapture()
    : previous_(vtkOutputWindow::GetInstance()),
      previousVerbosity_(static_cast<int>(vtkLogger::GetCurrentVerbosityCutoff())),
      window_(vtkSmartPointer<vtkStringOutputWindow>::New()) {
  vtkOutputWindow::SetInstance(window_);
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
}

VtkMessageCapture::~VtkMessageCapture() {
  vtkLogger::SetStderrVerbosity(static_cast<vtkLogger::Verbosity>(previousVerbosity_));
  vtkOutputWindow::SetInstance(previous_);
}

std::string VtkMessageCapture::text() const {
  return window_->GetOutput();
}

DetectionPipeline::DetectionPipeline() {
  envelope->SetInputConnection(reader->GetOutputPort());
  peaks->SetInputConnection(envelope->GetOutputPort());
  beamPoints->SetInputConnection(peaks->GetOutputPort());
  interSignal->SetInputConnection(beamPoints->GetOutputPort());
  writer->SetInputConnection(interSignal->GetOutputPort());
}

const core::Sequence& DetectionPipeline::open(const std::string& capturePath,
                                              const std::vector<std::string>& rigidPoses) {
  const VtkMessageCapture quiet;
  capturePath_ = capturePath;
  reader->SetFileName(capturePath);
  reader->SetRigidPoseTransforms(rigidPoses);
  reader->UpdateInformation();
  if (!reader->GetLastError().empty())
    throw std::runtime_error(reader->GetLastError());
  return reader->GetSequence();
}

const core::CaptureAnalysis& DetectionPipeline::configure(const core::DetectionParams& given,
                                                          const core::PointFrameOptions& points) {
  const core::Sequence& sequence = reader->GetSequence();
  if (!sequence.hasPixels()) {
    throw std::invalid_argument("the capture holds no A-lines (a tracker-only sequence)");
  }
  if (!points.referenceTransform.empty() && points.poseTransform.empty()) {
    throw std::invalid_argument("a reference transform needs a pose transform too");
  }
  core::requireTransform(sequence, points.poseTransform);
  core::requireTransform(sequence, points.referenceTransform);

  analysis_ = core::CaptureAnalysis();
  params_ = core::adaptToSequence(sequence, given, &analysis_);
  validate(params_);
  envelope->SetParams(params_.envelope);
  peaks->SetDetectionParams(params_);
  beamPoints->SetPoseTransformName(points.poseTransform);
  beamPoints->SetReferenceTransformName(points.referenceTransform);
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> beamToProbe = points.beamToProbe;
  beamPoints->SetBeamToProbe(beamToProbe.data());
  interSignal->SetInterSignalParams(params_.interSignal);
  return analysis_;
}

void DetectionPipeline::throwFirstError(const std::string& fallback) const {
  for (const std::string* error :
       {&reader->GetLastError(), &envelope->GetLastError(), &peaks->GetLastError(),
        &beamPoints->GetLastError(), &interSignal->GetLastError(), &writer->GetLastError()}) {
    if (!error->empty())
      throw std::runtime_error(*error);
  }
  throw std::runtime_error(fallback);
}

namespace {

std::mutex executionsMutex;
std::map<std::string, DetectionPipeline::Executions>& executionsTally() {
  static std::map<std::string, DetectionPipeline::Executions> tally;
  return tally;
}

}  // namespace

std::map<std::string, DetectionPipeline::Executions> DetectionPipeline::executionsByCapture() {
  const std::lock_guard<std::mutex> lock(executionsMutex);
  return executionsTally();
}

void DetectionPipeline::update(vtkAlgorithm* last) {
  const int envelopes = envelope->GetExecutionCount();
  const int detections = peaks->GetExecutionCount();
  const vtkIdType frames = envelope->GetFramesComputed();
  const int updated = (last != nullptr ? last : interSignal.GetPointer())->GetExecutive()->Update();
  {
    const std::lock_guard<std::mutex> lock(executionsMutex);
    Executions& executions = executionsTally()[capturePath_];
    executions.envelope += envelope->GetExecutionCount() - envelopes;
    executions.peaks += peaks->GetExecutionCount() - detections;
    executions.envelopeFrames += envelope->GetFramesComputed() - frames;
  }
  if (updated != 1)
    throwFirstError(capturePath_ + ": the detection pipeline failed");
}

core::SequenceDetection DetectionPipeline::run() {
  const VtkMessageCapture quiet;
  update();
  core::SequenceDetection detection = sequenceDetectionOf(interSignal->GetOutput());
  detection.params = params_;
  detection.analysis = analysis_;
  return detection;
}

void DetectionPipeline::updatePeaks() {
  const VtkMessageCapture quiet;
  update(peaks);
}

void DetectionPipeline::write(const std::string& path) {
  const VtkMessageCapture quiet;
  // The chain first: a writer whose input failed is never asked to write, and would not say so.
  update();
  writer->SetFileName(path);
  const int writes = writer->GetExecutionCount();
  if (writer->Write() != 1 || writer->GetExecutionCount() != writes + 1 ||
      !writer->GetLastError().empty()) {
    throwFirstError(path + ": the detection could not be written");
  }
}

}  // namespace echoreg::filters
