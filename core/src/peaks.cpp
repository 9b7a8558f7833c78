#include "echoreg/core/peaks.hpp"

#include "sample_sum.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace echoreg {

namespace {

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

// Parabola through the peak and its neighbours: the vertex offset, within half a sample.
double refinedIndex(const float* envelope, int count, int index) {
  if (index <= 0 || index >= count - 1) return index;
  const double left = envelope[index - 1], centre = envelope[index], right = envelope[index + 1];
  const double curvature = left - 2.0 * centre + right;
  if (curvature >= 0.0) return index;
  const double offset = 0.5 * (left - right) / curvature;
  return index + std::clamp(offset, -0.5, 0.5);
}

// The k-th smallest of values[0, n) (values are reordered): Hoare quickselect with a
// median-of-three pivot. For the few dozen values of a region it is several times faster than
// std::nth_element, whose introselect was a quarter of the whole chain's time.
float selectKth(float* values, int n, int k) {
  int low = 0, high = n - 1;
  while (high > low) {
    const int middle = low + (high - low) / 2;
    if (values[middle] < values[low]) std::swap(values[middle], values[low]);
    if (values[high] < values[low]) std::swap(values[high], values[low]);
    if (values[high] < values[middle]) std::swap(values[high], values[middle]);
    const float pivot = values[middle];
    int i = low, j = high;
    while (i <= j) {
      while (values[i] < pivot) ++i;
      while (pivot < values[j]) --j;
      if (i <= j) {
        std::swap(values[i], values[j]);
        ++i;
        --j;
      }
    }
    if (k <= j) {
      high = j;
    } else if (k >= i) {
      low = i;
    } else {
      break;
    }
  }
  return values[k];
}

// The k-th smallest of a few dozen values by counting ranks: O(n^2) compares, but branch-free
// and vectorised, where a quickselect's data-dependent branches mispredict at every compare.
float rankSelect(const float* values, int n, int k) {
  for (int i = 0; i < n; ++i) {
    const float candidate = values[i];
    int below = 0, equalBefore = 0;
    for (int j = 0; j < n; ++j) below += values[j] < candidate ? 1 : 0;
    for (int j = 0; j < i; ++j) equalBefore += values[j] == candidate ? 1 : 0;
    // Ties take consecutive ranks in index order, so exactly one value has rank k.
    if (below + equalBefore == k) return candidate;
  }
  return values[k];
}

// Median of envelope[begin, end) clipped to the record, from every 8th sample (the envelope and
// the speckle are correlated over about a pulse, so neighbours add little); negative when the
// range is empty.
double medianOf(const float* envelope, int count, int begin, int end, std::vector<float>& scratch) {
  begin = std::max(begin, 0);
  end = std::min(end, count);
  if (end <= begin) return -1.0;
  scratch.clear();
  for (int i = begin; i < end; i += 8) scratch.push_back(envelope[i]);
  const int n = static_cast<int>(scratch.size());
  return n <= 48 ? rankSelect(scratch.data(), n, n / 2) : selectKth(scratch.data(), n, n / 2);
}

// Full width at half maximum of the peak at `index`, in samples.
int halfMaximumWidth(const float* envelope, int count, int index) {
  const float half = envelope[index] * 0.5F;
  int left = index, right = index;
  while (left > 0 && envelope[left - 1] > half) --left;
  while (right < count - 1 && envelope[right + 1] > half) ++right;
  return right - left + 1;
}

// Largest of eight consecutive values (branch-free, so it vectorises).
float blockMax8(const float* values) {
  float a = std::max(values[0], values[4]);
  float b = std::max(values[1], values[5]);
  float c = std::max(values[2], values[6]);
  float d = std::max(values[3], values[7]);
  return std::max(std::max(a, b), std::max(c, d));
}

// The electronic noise floor: a low percentile of the envelope where it is not zeroed (the
// ring-down), from every 32nd sample: 128 values of a 4096-sample record are plenty for a rough
// percentile, and selecting among more was a third of the whole chain's time.
double noiseFloorOf(const float* envelope, int count, std::vector<float>& scratch) {
  scratch.clear();
  for (int i = 0; i < count; i += 32) {
    if (envelope[i] > 0.F) scratch.push_back(envelope[i]);
  }
  if (scratch.empty()) return 0.0;
  const int n = static_cast<int>(scratch.size());
  return selectKth(scratch.data(), n, n / 10);
}

// Does the peak look like bone: narrow as a pulse, well above the speckle before it, and
// followed by an acoustic shadow?
bool hasBoneSignature(const BoneEchoParams& bone, double mmPerSample, double noiseFloor,
                      const float* envelope, int count, const Peak& peak,
                      std::vector<float>& scratch) {
  // Cheap screen first: with tissue at least minTissueOverNoise x the noise floor before it and
  // the peak minContrast x above that, the peak must clear their product of the noise floor.
  if (peak.value < bone.minContrast * bone.minTissueOverNoise * noiseFloor) return false;
  const int widthSamples = halfMaximumWidth(envelope, count, peak.index);
  if (widthSamples * mmPerSample > bone.maxWidthMm) return false;
  const int region = std::max(1, static_cast<int>(std::lround(bone.regionMm / mmPerSample)));
  const int gap = static_cast<int>(std::lround(bone.gapMm / mmPerSample));
  const int beforeBegin = peak.index - gap - region;
  const int beforeEnd = peak.index - gap;
  const int afterBegin = peak.index + gap + 1;
  const int afterEnd = afterBegin + region;
  // A shadow needs room behind the echo to be seen; require half a region at least.
  if (std::min(afterEnd, count) - afterBegin < region / 2) return false;
  const double before = medianOf(envelope, count, beforeBegin, beforeEnd, scratch);
  // Bone lies under soft tissue: its speckle stands above the noise floor before the echo. Skin
  // and standoff-wall echoes have water in front of them.
  if (before < 0.0 || before < bone.minTissueOverNoise * noiseFloor) return false;
  const double tiny = 1e-12;
  if (peak.value < bone.minContrast * std::max(before, tiny)) return false;
  // The shadow starts right behind bone: test the near half of the region on its own too, so an
  // echo a millimetre or two above the bone (a fascia) does not borrow the bone's shadow.
  const auto isShadow = [&](int begin, int end) {
    const double after = medianOf(envelope, count, begin, end, scratch);
    // Deep in the tissue the speckle itself fades to the noise floor; a shadow at the noise
    // floor still counts there.
    return before >= bone.minShadowRatio * std::max(after, tiny) ||
           after <= bone.noiseFloorFactor * noiseFloor;
  };
  return isShadow(afterBegin, afterBegin + region / 2) && isShadow(afterBegin, afterEnd);
}

}  // namespace

std::string_view rejectReasonName(RejectReason reason) {
  switch (reason) {
    case RejectReason::None: return "";
    case RejectReason::NoPeak: return "no-peak";
    case RejectReason::TooManyPeaks: return "too-many-peaks";
    case RejectReason::TooFewPeaks: return "too-few-peaks";
    case RejectReason::OutsideWindow: return "outside-window";
    case RejectReason::NotBone: return "not-bone";
    case RejectReason::Inconsistent: return "inconsistent";
    case RejectReason::TooClose: return "too-close";
    case RejectReason::InvalidPose: return "invalid-pose";
  }
  return "?";
}

std::string_view peakPolicyName(PeakPolicy policy) {
  switch (policy) {
    case PeakPolicy::Single: return "single";
    case PeakPolicy::Double: return "double";
    case PeakPolicy::WindowMax: return "window-max";
    case PeakPolicy::First: return "first";
    case PeakPolicy::Max: return "max";
    case PeakPolicy::Bone: return "bone";
  }
  return "?";
}

PeakPolicy parsePeakPolicy(std::string_view name) {
  for (auto policy : {PeakPolicy::Single, PeakPolicy::Double, PeakPolicy::WindowMax,
                      PeakPolicy::First, PeakPolicy::Max, PeakPolicy::Bone}) {
    if (name == peakPolicyName(policy)) return policy;
  }
  throw std::invalid_argument("unknown peak policy '" + std::string(name) +
                              "' (expected single, double, window-max, first, max or bone)");
}

void validate(const PeakParams& p) {
  require(p.thresholdFactor > 0.0 && std::isfinite(p.thresholdFactor),
          "threshold factor must be > 0");
  require(p.thresholdOfMax > 0.0 && p.thresholdOfMax <= 1.0, "threshold of max must be in (0, 1]");
  if (p.windowBegin && p.windowEnd) {
    require(*p.windowBegin < *p.windowEnd, "processing window must have min < max");
  }
  require(p.mmPerSample > 0.0 && std::isfinite(p.mmPerSample), "mm per sample must be > 0");
  require(p.bone.regionMm > 0.0, "bone region must be > 0 mm");
  require(p.bone.gapMm >= 0.0, "bone gap must be >= 0 mm");
  require(p.bone.minShadowRatio > 1.0, "bone shadow ratio must be > 1");
  require(p.bone.minContrast > 1.0, "bone contrast must be > 1");
  require(p.bone.maxWidthMm > 0.0, "bone echo width must be > 0 mm");
  require(p.bone.noiseFloorFactor >= 0.0, "bone noise floor factor must be >= 0");
  require(p.bone.minTissueOverNoise >= 0.0, "bone tissue-over-noise ratio must be >= 0");
}

PeakResult findPeaks(const PeakParams& params, const float* envelope, int count) {
  PeakResult result;
  if (count <= 0) return result;

  if (params.thresholdMode == ThresholdMode::FactorOfMean) {
    result.threshold = params.thresholdFactor * detail::sumOfSamples(envelope, count) / count;
  } else {
    result.threshold = params.thresholdOfMax * *std::max_element(envelope, envelope + count);
  }
  const auto threshold = static_cast<float>(result.threshold);

  const int windowBegin = std::clamp(params.windowBegin.value_or(0), 0, count);
  const int windowEnd = std::clamp(params.windowEnd.value_or(count), 0, count);
  const auto insideWindow = [&](int index) { return index >= windowBegin && index < windowEnd; };

  bool anyOutside = false;
  for (int i = 0; i < count;) {
    if (!(envelope[i] > threshold)) {
      // Most of a record lies below the threshold: skip it eight samples at a time.
      while (i + 8 <= count && blockMax8(envelope + i) <= threshold) i += 8;
      if (i < count && !(envelope[i] > threshold)) ++i;
      continue;
    }
    Peak peak;
    peak.runBegin = i;
    peak.index = i;
    peak.value = envelope[i];
    while (i < count && envelope[i] > threshold) {
      if (envelope[i] > peak.value) {
        peak.value = envelope[i];
        peak.index = i;
      }
      ++i;
    }
    peak.runEnd = i;
    if (insideWindow(peak.index)) {
      result.peaks.push_back(peak);
    } else {
      anyOutside = true;
    }
  }

  const auto accept = [&](int selected, int index) {
    result.selected = selected;
    result.reason = RejectReason::None;
    result.sampleIndex = params.subsample ? refinedIndex(envelope, count, index) : index;
  };
  const int found = static_cast<int>(result.peaks.size());
  const RejectReason nothing = anyOutside ? RejectReason::OutsideWindow : RejectReason::NoPeak;

  switch (params.policy) {
    case PeakPolicy::WindowMax: {
      if (windowEnd <= windowBegin) {
        result.reason = nothing;
        break;
      }
      const int index = static_cast<int>(
          std::max_element(envelope + windowBegin, envelope + windowEnd) - envelope);
      if (!(envelope[index] > threshold)) {
        result.reason = nothing;
        break;
      }
      int selected = 0;
      for (; selected < found; ++selected) {
        const Peak& p = result.peaks[static_cast<std::size_t>(selected)];
        if (index >= p.runBegin && index < p.runEnd) break;
      }
      if (selected == found) {  // the run's maximum lies outside the window
        Peak clipped;
        clipped.index = index;
        clipped.value = envelope[index];
        clipped.runBegin = windowBegin;
        clipped.runEnd = windowEnd;
        result.peaks.push_back(clipped);
      }
      accept(selected, index);
      break;
    }
    case PeakPolicy::Single:
      if (found == 1) {
        accept(0, result.peaks[0].index);
      } else {
        result.reason = found == 0 ? nothing : RejectReason::TooManyPeaks;
      }
      break;
    case PeakPolicy::Double:
      if (found == 2) {
        accept(1, result.peaks[1].index);
      } else {
        result.reason = found == 0   ? nothing
                        : found == 1 ? RejectReason::TooFewPeaks
                                     : RejectReason::TooManyPeaks;
      }
      break;
    case PeakPolicy::First:
      if (found > 0) {
        accept(0, result.peaks[0].index);
      } else {
        result.reason = nothing;
      }
      break;
    case PeakPolicy::Max: {
      if (found == 0) {
        result.reason = nothing;
        break;
      }
      const auto strongest = std::max_element(
          result.peaks.begin(), result.peaks.end(),
          [](const Peak& a, const Peak& b) { return a.value < b.value; });
      accept(static_cast<int>(strongest - result.peaks.begin()), strongest->index);
      break;
    }
    case PeakPolicy::Bone: {
      if (found == 0) {
        result.reason = nothing;
        break;
      }
      // Deepest first: skin, fascia and speckle lie before the bone, and what lies behind the
      // bone (its reverberation, noise) sits in its shadow and fails the shadow test.
      std::vector<float> scratch;
      const double noiseFloor = noiseFloorOf(envelope, count, scratch);
      result.reason = RejectReason::NotBone;
      for (int candidate = found - 1; candidate >= 0; --candidate) {
        const Peak& peak = result.peaks[static_cast<std::size_t>(candidate)];
        if (hasBoneSignature(params.bone, params.mmPerSample, noiseFloor, envelope, count, peak,
                             scratch)) {
          accept(candidate, peak.index);
          break;
        }
      }
      break;
    }
  }
  return result;
}

}  // namespace echoreg
