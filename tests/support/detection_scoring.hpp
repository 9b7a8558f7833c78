// Scores a detection preset on labelled A-lines, frame by frame, the way a user runs it: one
// capture at a time, with only the acquisition facts given (sampling frequency, speed of sound,
// delay, and a depth window where the recording has one); everything else is what the preset
// measures from the capture (adaptToCapture) or fixes.
#pragma once

#include "echoreg/core/detection.hpp"

#include <optional>
#include <string>
#include <vector>

namespace echoreg::test {

/// One labelled record of a capture.
struct LabelledRecord {
  const std::vector<float>* samples = nullptr;
  bool hasBone = false;
  bool ambiguous = false;     ///< excluded from the score
  double boneDepthMm = -1.0;  ///< positives: the true depth
};

/// What a user knows of the acquisition.
struct AcquisitionFacts {
  double samplingFrequencyHz = 50e6;
  double speedOfSoundMps = 1540.0;
  double delayS = 0.0;
  std::optional<double> windowMinMm;
  std::optional<double> windowMaxMm;
};

struct DetectionScore {
  int positives = 0;
  int negatives = 0;
  int falseNegatives = 0;
  int falsePositives = 0;
  int wrongEcho = 0;             ///< accepted positives more than 0.5 mm from the bone
  std::vector<double> errorsMm;  ///< |depth error| of the accepted positives

  double falseNegativeRate() const { return positives ? double(falseNegatives) / positives : 0.0; }
  double falsePositiveRate() const { return negatives ? double(falsePositives) / negatives : 0.0; }
  double wrongEchoRate() const;
  double medianErrorMm() const;
  void add(const DetectionScore& other);
};

/// `preset` with the acquisition facts in place (sampling frequency, speed, delay, window).
core::DetectionParams withFacts(const core::DetectionParams& preset, const AcquisitionFacts& facts);

/// Runs `preset` on one capture: the single-signal chain on every record in order, with the
/// capture's context (EchoContext) as detect runs it, inter-signal filters aside.
DetectionScore scoreCapture(const core::DetectionParams& preset, const AcquisitionFacts& facts,
                            const std::vector<LabelledRecord>& records);

/// "FN 3.1 %, FP 2.0 %, wrong echo 1.2 %, median 0.004 mm (230 positives, 170 negatives)".
std::string describe(const DetectionScore& score);

}  // namespace echoreg::test
