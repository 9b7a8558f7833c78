// The A-line detection pipeline of `echoreg detect` (and, next, of every command that detects):
//
//   vtkEchoregSequenceReader -> vtkEchoregEnvelopeFilter -> vtkEchoregPeakFilter
//     -> vtkEchoregBeamPointsFilter -> vtkEchoregInterSignalFilter -> vtkEchoregDetectionWriter
//
// Demand-driven: set the parameters, update the last algorithm, and only the steps downstream of
// a change run again (a new BeamToProbe re-runs beam points and inter-signal, not the envelope).
// The envelope and peak filters split their frames over threads with vtkSMPTools. By default the
// envelopes of the whole capture are kept between updates; setFramesPerBlock() streams the capture
// through reader, envelope and peaks in blocks of frames instead (memory bounded by a block, what
// the commands that detect a capture once want: `detect`, and `register`, `calibrate` and the
// study through cli/src/capture_detection.hpp). The result is
// detectSequence's (tests/filters/detection_pipeline_test.cpp compares them frame by frame), so
// the commands that used to call it give the same bytes.
#pragma once

#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"
#include "echoreg/filters/vtkEchoregDetectionWriter.h"
#include "echoreg/filters/vtkEchoregEnvelopeFilter.h"
#include "echoreg/filters/vtkEchoregInterSignalFilter.h"
#include "echoreg/filters/vtkEchoregPeakFilter.h"
#include "echoreg/filters/vtkEchoregSequenceReader.h"

#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include <map>
#include <string>

class vtkStringOutputWindow;
class vtkOutputWindow;
class vtkTable;
class vtkAlgorithm;

namespace echoreg::filters {

/// Routes VTK's error and warning messages into a string while it lives, so a command reports
/// failures in its own words (the algorithms' GetLastError()) without VTK's file-and-line lines
/// on stderr.
class VtkMessageCapture {
 public:
  VtkMessageCapture();
  ~VtkMessageCapture();
  VtkMessageCapture(const VtkMessageCapture&) = delete;
  VtkMessageCapture& operator=(const VtkMessageCapture&) = delete;
  /// What VTK said so far.
  std::string text() const;

 private:
  vtkSmartPointer<vtkOutputWindow> previous_;
  int previousVerbosity_;
  vtkSmartPointer<vtkStringOutputWindow> window_;
};

class DetectionPipeline {
 public:
  DetectionPipeline();

  /// The capture to read and the transforms whose poses must be rigid (empty names ignored).
  /// Reads the file (RequestInformation) and returns the sequence; throws std::runtime_error
  /// with the reader's message ("PATH: problem") when it cannot be read.
  const core::Sequence& open(const std::string& capturePath,
                             const std::vector<std::string>& rigidPoses);

  /// Resolves the capture-dependent parameters (adaptToSequence on the opened capture) and sets
  /// every step's parameters; returns what adaptToSequence measured. Throws std::invalid_argument
  /// as detectSequence does, with its words: a capture without A-lines, a reference without a
  /// pose, a transform the capture does not hold (listing those it has), bad parameters.
  const core::CaptureAnalysis& configure(const core::DetectionParams& params,
                                         const core::PointFrameOptions& points);

  /// Updates the chain up to the inter-signal filter and returns the detection, with the params
  /// and analysis of configure(). Throws std::runtime_error with the first failing step's message.
  core::SequenceDetection run();

  /// Updates the chain up to the peak filter only (what `figure signals` draws: the envelopes and
  /// the verdicts, with the peak list when on), counting the executions as run() does. Throws
  /// std::runtime_error with the first failing step's message.
  void updatePeaks();

  /// Updates the chain and writes the CSV to `path` (atomically). Throws std::runtime_error with
  /// the failing step's message.
  void write(const std::string& path);

  /// Streams the capture through reader, envelope and peaks in blocks of `frames` frames (0: the
  /// whole capture at once, the default). The output is the same; the envelopes held at any time
  /// are one block's, but a later change of a peak parameter recomputes them.
  void setFramesPerBlock(int frames) { peaks->SetFramesPerBlock(frames); }
  /// The block size the commands stream with: 512 frames, 8 MB of float envelopes at 4096 samples,
  /// enough rows per block to keep every core busy.
  static constexpr int kStreamFramesPerBlock = 512;

  /// The parameters as configure() resolved them.
  const core::DetectionParams& params() const { return params_; }

  /// How often the envelope and the peak filter executed (RequestData) in the updates of run()
  /// and write(), and how many frames the envelope filter computed: a capture streamed in blocks
  /// runs the envelope once per block and the peak filter once, and envelopes its frames once.
  struct Executions {
    int envelope = 0;
    int peaks = 0;
    long long envelopeFrames = 0;
  };
  /// The executions of every DetectionPipeline of this process so far, by capture path as given
  /// to open(): how tests show that a command detects each capture once
  /// (tests/study/test_execution_counts.cpp).
  static std::map<std::string, Executions> executionsByCapture();

  vtkNew<vtkEchoregSequenceReader> reader;
  vtkNew<vtkEchoregEnvelopeFilter> envelope;
  vtkNew<vtkEchoregPeakFilter> peaks;
  vtkNew<vtkEchoregBeamPointsFilter> beamPoints;
  vtkNew<vtkEchoregInterSignalFilter> interSignal;
  vtkNew<vtkEchoregDetectionWriter> writer;

 private:
  /// Updates the chain up to `last` (the inter-signal filter unless given), counting the
  /// executions; throws the failing step's message.
  void update(vtkAlgorithm* last = nullptr);
  /// Throws the first upstream step's error, if any.
  void throwFirstError(const std::string& fallback) const;

  std::string capturePath_;
  core::DetectionParams params_;
  core::CaptureAnalysis analysis_;
};

}  // namespace echoreg::filters
