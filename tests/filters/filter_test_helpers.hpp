// Synthetic A-line captures with known echo positions and poses, the same capture as a
// vtkImageData (without going through a file), the detection parameters the filter tests use,
// and a VTK output window that keeps error messages out of the test log and available to check.
#pragma once

#include "echoreg/core/detection.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/filters/sequence_field_data.h"

#include <vtkImageData.h>
#include <vtkLogger.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStringOutputWindow.h>
#include <vtkUnsignedCharArray.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace echoreg::test {

/// A capture of `frames` uint8 A-lines at 50 MHz: a noise floor around 128 and one
/// Gaussian-modulated 9 MHz echo per frame centred on echoSample(frame).
struct SyntheticCapture {
  int frames = 12;
  int samples = 1500;
  double samplingFrequencyHz = 50e6;
  double transducerFrequencyHz = 9e6;
  double echoSigmaS = 0.15e-6;  ///< Gaussian envelope's standard deviation
  double echoAmplitude = 90.0;  ///< counts
  double noiseCounts = 2.0;     ///< uniform noise half-width, counts
  double firstEchoSample = 700.25;
  double echoStepSamples = 0.5;  ///< the echo moves deeper by this much per frame
  double probeStepMm = 0.0;      ///< ProbeToTracker translates by this much along x per frame
  /// Frames whose ProbeToTracker status is INVALID.
  std::vector<int> invalidProbeFrames;
  /// When set, every frame carries FemurToTracker = translation by this offset.
  bool withFemur = false;
  Eigen::Vector3d femurOffsetMm = Eigen::Vector3d(10.0, -20.0, 30.0);
  double speedOfSoundMps = 1540.0;

  double echoSample(int frame) const { return firstEchoSample + echoStepSamples * frame; }
  double timestampS(int frame) const { return 100.0 + 0.05 * frame; }
  Eigen::Matrix4d probeToTracker(int frame) const {
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    pose(0, 3) = probeStepMm * frame;
    pose(1, 3) = 5.0;
    return pose;
  }
  core::DepthConversion depth() const {
    core::DepthConversion conversion;
    conversion.samplingFrequencyHz = samplingFrequencyHz;
    conversion.speedOfSoundMps = speedOfSoundMps;
    return conversion;
  }
};

inline core::Sequence makeCapture(const SyntheticCapture& capture) {
  core::Sequence sequence;
  sequence.elementType = core::ElementType::UInt8;
  sequence.frameSize = {capture.samples, 1};
  sequence.acquisition.samplingFrequencyHz = capture.samplingFrequencyHz;
  sequence.acquisition.speedOfSoundMps = capture.speedOfSoundMps;
  sequence.acquisition.delayS = 0.0;
  std::mt19937 random(20240601);
  std::uniform_real_distribution<double> noise(-capture.noiseCounts, capture.noiseCounts);
  const double pi = 3.14159265358979323846;
  for (int frame = 0; frame < capture.frames; ++frame) {
    core::SequenceFrame metadata;
    metadata.timestampS = capture.timestampS(frame);
    core::TrackedTransform probe;
    probe.matrix = capture.probeToTracker(frame);
    const auto& invalid = capture.invalidProbeFrames;
    probe.status =
        std::find(invalid.begin(), invalid.end(), frame) != invalid.end() ? "INVALID" : "OK";
    metadata.transforms["ProbeToTracker"] = probe;
    if (capture.withFemur) {
      core::TrackedTransform femur;
      femur.matrix = Eigen::Matrix4d::Identity();
      femur.matrix.block<3, 1>(0, 3) = capture.femurOffsetMm;
      metadata.transforms["FemurToTracker"] = femur;
    }
    sequence.frames.push_back(metadata);
    for (int i = 0; i < capture.samples; ++i) {
      const double t = (i - capture.echoSample(frame)) / capture.samplingFrequencyHz;
      const double echo = capture.echoAmplitude *
                          std::exp(-t * t / (2.0 * capture.echoSigmaS * capture.echoSigmaS)) *
                          std::cos(2.0 * pi * capture.transducerFrequencyHz * t);
      const double value = std::round(128.0 + echo + noise(random));
      sequence.pixels.push_back(static_cast<std::uint8_t>(std::clamp(value, 0.0, 255.0)));
    }
  }
  return sequence;
}

/// The image vtkEchoregSequenceReader makes of an A-line sequence, built in memory.
inline vtkSmartPointer<vtkImageData> imageOf(const core::Sequence& sequence) {
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetExtent(0, sequence.frameSize[0] - 1, 0, static_cast<int>(sequence.frameCount()) - 1, 0,
                   0);
  if (sequence.hasPixels()) {
    image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    image->GetPointData()->GetScalars()->SetName("ALines");
    std::memcpy(image->GetScalarPointer(), sequence.pixels.data(), sequence.pixels.size());
  }
  filters::SequenceFieldData::write(sequence, image->GetFieldData());
  return image;
}

/// Parameters that find the synthetic echo: short Hann envelope, strongest peak above half the
/// maximum, the capture's depth conversion; inter-signal filters off.
inline core::DetectionParams testDetectionParams(const SyntheticCapture& capture) {
  core::DetectionParams params;
  params.envelope.method = core::EnvelopeMethod::Hann;
  params.envelope.windowSamples = 21;
  params.peaks.policy = core::PeakPolicy::Max;
  params.peaks.thresholdMode = core::ThresholdMode::FractionOfMax;
  params.peaks.thresholdOfMax = 0.5;
  params.depth = capture.depth();
  params.interSignal.history = 1;
  params.interSignal.minSpreadMm = 0.0;
  return params;
}

/// Routes VTK's messages into a string for the lifetime of the object, and silences the copy that
/// vtkLogger prints on stderr.
class CapturedVtkOutput {
 public:
  CapturedVtkOutput()
      : previous_(vtkOutputWindow::GetInstance()),
        previousVerbosity_(vtkLogger::GetCurrentVerbosityCutoff()) {
    vtkOutputWindow::SetInstance(window_);
    vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  }
  ~CapturedVtkOutput() {
    vtkLogger::SetStderrVerbosity(previousVerbosity_);
    vtkOutputWindow::SetInstance(previous_);
  }
  CapturedVtkOutput(const CapturedVtkOutput&) = delete;
  CapturedVtkOutput& operator=(const CapturedVtkOutput&) = delete;
  std::string text() const { return window_->GetOutput(); }

 private:
  vtkSmartPointer<vtkOutputWindow> previous_;
  vtkLogger::Verbosity previousVerbosity_;
  vtkSmartPointer<vtkStringOutputWindow> window_ = vtkSmartPointer<vtkStringOutputWindow>::New();
};

}  // namespace echoreg::test
