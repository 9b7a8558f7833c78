#include "detection_scoring.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace echoreg::test {

double DetectionScore::wrongEchoRate() const {
  const int accepted = positives - falseNegatives;
  return accepted > 0 ? double(wrongEcho) / accepted : 0.0;
}

double DetectionScore::medianErrorMm() const {
  if (errorsMm.empty())
    return 0.0;
  std::vector<double> sorted = errorsMm;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  return sorted[sorted.size() / 2];
}

void DetectionScore::add(const DetectionScore& other) {
  positives += other.positives;
  negatives += other.negatives;
  falseNegatives += other.falseNegatives;
  falsePositives += other.falsePositives;
  wrongEcho += other.wrongEcho;
  errorsMm.insert(errorsMm.end(), other.errorsMm.begin(), other.errorsMm.end());
}

core::DetectionParams withFacts(const core::DetectionParams& preset,
                                const AcquisitionFacts& facts) {
  core::DetectionParams params = preset;
  params.depth.samplingFrequencyHz = facts.samplingFrequencyHz;
  params.depth.speedOfSoundMps = facts.speedOfSoundMps;
  params.depth.delayS = facts.delayS;
  params.envelope.samplingFrequencyHz = facts.samplingFrequencyHz;
  if (facts.windowMinMm)
    params.windowMinMm = facts.windowMinMm;
  if (facts.windowMaxMm)
    params.windowMaxMm = facts.windowMaxMm;
  return params;
}

DetectionScore scoreCapture(const core::DetectionParams& preset, const AcquisitionFacts& facts,
                            const std::vector<LabelledRecord>& records) {
  DetectionScore score;
  if (records.empty())
    return score;
  core::DetectionParams params = withFacts(preset, facts);
  const int samples = static_cast<int>(records.front().samples->size());
  const core::RecordSource source = [&records](int index, std::vector<float>& out) {
    out = *records[static_cast<std::size_t>(index)].samples;
  };
  params =
      core::adaptToCapture(params, static_cast<int>(records.size()), samples, source, std::nullopt);
  core::SignalDetector detector(params);
  // Every record in order, the ambiguous ones too: the capture's context (EchoContext) judges a
  // record by the ones before it, as detect does before the inter-signal filters.
  core::EchoContext context(core::resolvePeakParams(params));
  for (const LabelledRecord& record : records) {
    core::SignalDetection detection =
        detector.detect(record.samples->data(), static_cast<int>(record.samples->size()));
    if (context.judge(detection.peaks, detector.envelope().data(),
                      static_cast<int>(record.samples->size())))
      detection.depthMm = params.depth.depthMm(detection.peaks.sampleIndex);
    if (record.ambiguous)
      continue;
    if (record.hasBone) {
      ++score.positives;
      if (!detection.accepted()) {
        ++score.falseNegatives;
      } else {
        const double error = std::fabs(detection.depthMm - record.boneDepthMm);
        score.errorsMm.push_back(error);
        if (error > 0.5)
          ++score.wrongEcho;
      }
    } else {
      ++score.negatives;
      if (detection.accepted())
        ++score.falsePositives;
    }
  }
  return score;
}

std::string describe(const DetectionScore& score) {
  char text[160];
  std::snprintf(text, sizeof text,
                "FN %5.1f %%, FP %5.1f %%, wrong echo %5.1f %%, median %.3f mm (%d positives, %d "
                "negatives)",
                100.0 * score.falseNegativeRate(), 100.0 * score.falsePositiveRate(),
                100.0 * score.wrongEchoRate(), score.medianErrorMm(), score.positives,
                score.negatives);
  return text;
}

}  // namespace echoreg::test
