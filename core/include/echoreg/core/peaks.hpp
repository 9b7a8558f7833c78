// Peaks of an A-line envelope and the choice of the bone (or sphere) echo among them.
//
// A peak is the maximum of a contiguous run of envelope samples above the threshold (Mozes 2008,
// Fig. 4.10); the threshold is a factor of the envelope's mean (1.5 in the dissertation) or a
// fraction of its maximum. The policy then picks one peak or rejects the record with a reason.
#pragma once

#include <optional>
#include <string_view>
#include <tuple>
#include <vector>

namespace echoreg::core {

/// Why a frame gave no point. None means accepted.
enum class RejectReason {
  None,
  NoPeak,         ///< nothing above the threshold
  TooManyPeaks,   ///< more peaks than the policy allows (single, double)
  TooFewPeaks,    ///< fewer peaks than the policy needs (double)
  OutsideWindow,  ///< peaks exist, but none inside the processing window
  NotBone,        ///< bone policy: peaks exist, none has the bone's signature
  Inconsistent,   ///< temporal filter: not yet `history` frames agreeing
  TooClose,       ///< spatial filter: closer than the minimum spread to an accepted point
  InvalidPose,    ///< a pose needed for the point is missing or not OK
  InRingDown,     ///< the processing window starts inside the ring-down, and no echo came after it
};

/// "", "no-peak", "too-many-peaks", "too-few-peaks", "outside-window", "not-bone",
/// "inconsistent", "too-close", "invalid-pose", "in-ring-down".
std::string_view rejectReasonName(RejectReason reason);

enum class ThresholdMode {
  FactorOfMean,  ///< threshold = thresholdFactor * mean(envelope)
  FractionOfMax  ///< threshold = thresholdOfMax * max(envelope)
};

enum class PeakPolicy {
  Single,      ///< exactly one peak (phantom in water)
  Double,      ///< exactly two; the second is bone (standoff/skin, then bone)
  WindowMax,   ///< the largest value inside the window, if above the threshold (calibration)
  First,       ///< the shallowest peak
  Max,         ///< the strongest peak
  Bone,        ///< the deepest peak with a bone's signature (see BoneEchoParams)
  Prominence,  ///< the strongest prominent echo that is not a wall or a reverberation (see
               ///< ProminenceParams)
};

/// "single", "double", "window-max", "first", "max", "bone", "prominence".
std::string_view peakPolicyName(PeakPolicy policy);
/// Parses a name of peakPolicyName; throws std::invalid_argument listing the valid names.
PeakPolicy parsePeakPolicy(std::string_view name);

/// The bone echo's signature, used by PeakPolicy::Bone. Bone reflects almost all the energy that
/// reaches it, so it casts an acoustic shadow: behind a bone echo the envelope falls to the
/// electronic noise floor, while behind skin, fascia or a reverberation the tissue's speckle goes
/// on. Oblique incidence sends the echo away from the transducer, so a bone echo barely above the
/// speckle before it is not trusted. Electrical noise bursts last microseconds, an echo a pulse.
struct BoneEchoParams {
  /// Length of the tissue region before and the shadow region after a peak, mm (> 0).
  double regionMm = 3.0;
  /// Gap left between the peak and each region, mm (>= 0), so the echo's own tails are excluded.
  double gapMm = 0.3;
  /// Minimum ratio of the median envelope before the peak to the median after it (> 1).
  double minShadowRatio = 2.0;
  /// Minimum ratio of the peak value to the median envelope before it (> 1).
  double minContrast = 3.5;
  /// Maximum full width at half maximum of the peak, mm (> 0).
  double maxWidthMm = 1.0;
  /// Deep in tissue the speckle fades to the electronic noise: a median after the peak within
  /// this factor of the noise floor (10th percentile of the envelope) also counts as a shadow.
  double noiseFloorFactor = 1.2;
  /// Minimum ratio of the median envelope before the peak (the tissue's speckle) to the noise
  /// floor (>= 0): skin and standoff-wall echoes have water, not tissue, in front of them.
  double minTissueOverNoise = 1.5;
  /// 0: the deepest echo with the signature (echoreg's earlier default). In (0, 1]: the deepest
  /// of those at least this share of the strongest with the signature (the prominence policy's
  /// shadow mode uses its similarRatio).
  double minShareOfStrongest = 0.0;
  /// The shadow's noise test against the record's quiet level (the lower quartile of the
  /// medians of half-region blocks) instead of the noise floor: the median of pure noise lies
  /// well above its 10th percentile, so a shadow at the noise never reached noiseFloorFactor x
  /// the floor. It then also needs the tissue before the echo at least minShadowRatio x and the
  /// echo 5 x that level. The prominence policy's shadow mode sets it; the bone policy's
  /// default keeps echoreg's earlier rule.
  bool shadowAtQuietLevel = false;
  /// A shadow at the noise behind a strong echo (with shadowAtQuietLevel; 0 turns it off): an
  /// echo at least this many times the quiet level, at least half the record's strongest echo
  /// and 6 x the tissue before it, the tissue at least 1.7 x the quiet level, followed by the
  /// envelope within 1.4 x the quiet level and 1.4 x below the tissue before it. Where the tissue's
  /// speckle is barely above the digitiser's noise (8-bit records, a water standoff), bone's shadow
  /// at the noise is all there is to see.
  double noiseShadowEchoFactor = 0.0;
  /// ... with the echo at most this wide at half maximum, samples (a pulse; the shadow mode sets
  /// three periods of the transducer).
  double noiseShadowMaxWidthSamples = 0.0;
  /// An echo at twice the time of flight of a local maximum of the record after the ring-down
  /// (inside the window or above it) at least twice as strong as it arrived (before time-gain
  /// compensation), prominent as a candidate of the prominence policy must be, and the record's
  /// strongest echo, is that echo's reverberation and not bone, however quiet behind it. The
  /// prominence policy's shadow mode sets it; the bone policy's default keeps echoreg's earlier
  /// rule.
  bool rejectReverberations = false;
};

/// The prominence policy (the default), decided from the statistics of the record itself rather
/// than from fixed regions: the noise floor (10th percentile of the envelope after the ring-down)
/// and the record's median level, each echo's prominence (its height above the higher of the two
/// valleys that separate it from stronger echoes or the record's ends, as scipy.signal's
/// find_peaks defines it), its leading edge, and what lies just before and after it.
///
/// An echo is a candidate when it is a local maximum at least `minSnr` x the noise floor and
/// `minOverMedian` x the median, with a prominence of at least `minProminence` of its height and
/// a leading edge (half prominence to the peak) of at most `maxRiseCycles` periods of the
/// transducer frequency: a pulse, not a burst of electrical noise. It is rejected as a wall
/// (skin or standoff membrane: quiet water in front, the tissue's speckle behind) when the median
/// envelope after it is `wallStep` x the median before it or more, as
/// an air interface (an uncoupled probe) when its own echo returns at twice its time of flight at
/// `airReverberation` of its height or more (bone reflects half the energy at most, so its second
/// bounce is far weaker), and as speckle when it is below `minContrast` x the envelope before it.
/// Of the candidates within `similarRatio` of the strongest, the deepest that is not a
/// reverberation of a shallower one (at twice its time, or one spacing behind a pair) is bone: a
/// fascia or the skin lies above bone, never behind it.
/// How the prominence policy uses the acoustic shadow behind bone.
enum class ShadowRule {
  /// Per record: the deepest candidate followed by a shadow if there is one, else the strongest.
  /// adaptToCapture turns Auto into Required or Ignored for a whole capture.
  Auto,
  /// Bone must cast a shadow (specimens under several mm of tissue, phantoms in water): the
  /// deepest shadowed candidate, else not-bone.
  Required,
  /// Shallow bone in vivo, where reverberation and the cortex's own echoes keep the envelope up
  /// behind the bone: the strongest candidate (deeper ones of similar strength first).
  Ignored,
};

/// "auto", "required", "ignored".
std::string_view shadowRuleName(ShadowRule rule);
/// Parses a name of shadowRuleName; throws std::invalid_argument listing the valid names.
ShadowRule parseShadowRule(std::string_view name);

struct ProminenceParams {
  double minSnr = 6.0;             ///< peak / noise floor (> 1)
  double minOverMedian = 2.0;      ///< peak / median of the envelope after the ring-down (>= 1)
  double minProminence = 0.5;      ///< prominence / peak height, (0, 1]
  double maxRiseCycles = 3.0;      ///< leading edge, transducer periods (> 0)
  double minContrast = 2.0;        ///< peak / median of the envelope before it (>= 1)
  double regionMm = 2.0;           ///< before/after regions, mm (> 0), clipped to the record
  double wallStep = 3.0;           ///< median after / median before at which it is a wall (> 1)
  double airReverberation = 0.35;  ///< second bounce / peak at or above which it is air, (0, 1]
  double similarRatio = 0.6;       ///< echoes this close to the strongest compete on depth, (0, 1]
  ShadowRule shadow = ShadowRule::Auto;
  /// Shadow: the median envelope after the echo (over the near half of the region and all of it)
  /// is at most 1 / `shadowRatio` of the median before it (> 1), or within `shadowNoiseFactor`
  /// of the record's quiet level (the lower quartile of the medians of 1 mm blocks) while the
  /// tissue before the echo stands at least that factor above it (>= 0): where the speckle lies
  /// near the digitiser's noise (8-bit records, deep or water), a shadow is no quieter than the
  /// tissue, only as quiet as the quietest part of the record.
  double shadowRatio = 2.0;
  double shadowNoiseFactor = 1.2;
  /// A shadowed echo must be this many times the median before it (>= 1).
  double shadowContrast = 3.5;
  /// Ringing: the median envelope over the near half of the region behind the echo is at least
  /// this fraction of the echo, (0, 1].
  double ringingFraction = 0.4;
  /// Ringing counts only for an echo this many times the median before it (>= 1): bone is 20 dB
  /// and more above the speckle, while speckle maxima and the skin ring no more than tissue does.
  double ringingContrast = 6.0;
  /// An echo this many times stronger than the chosen one, within the bone region above it, is
  /// the bone and the chosen one its inner cortex or first bounce, with the shadow required and
  /// (where the stronger echo itself passed as an echo) in the per-record rule (>= 1; 0 turns
  /// the test off).
  double innerEchoRatio = 2.5;
  /// A strong echo with only noise behind it is bone (>= 1; 0 turns it off). With the shadow
  /// required: BoneEchoParams::noiseShadowEchoFactor (the capture's shadow trial, adaptToCapture,
  /// runs without it, so that a capture is judged by the shadow only where bone casts a clear
  /// one). Record by record: an echo this many times the quiet level with water before it (within
  /// 1.3 times that level from the ring-down on) and behind it no more than 1.4 times the noise
  /// (bare bone in water, whose inner cortex and marrow lift the median behind it a little).
  double noiseShadowEchoFactor = 10.0;
  /// With the shadow required, take only echoes with bone's shadow. When false (the default), a
  /// record in which no echo has it is judged by its own signature (the rule a capture without
  /// shadows gets), and its pick is taken when it rings (shallow bone's cortex and the tissue over
  /// it reverberate: no shadow), is the strongest echo after the ring-down, and is no object in
  /// water (water before it and the envelope back at the water's level 3 regions behind). The
  /// capture's shadow trial (adaptToCapture) runs with it true.
  bool shadowOnly = false;
  /// The capture's context (EchoContext, fed frame by frame in order): a record judged not-bone
  /// takes the echo that the `contextFrames` records before it agree on, when at least 0.6 of
  /// them were accepted on their own, their depths agree (median absolute deviation at most
  /// 0.5 mm), and the record holds a prominent echo within 0.75 mm of their median depth and at
  /// least half their median strength. 0 switches it off (>= 0, at most 1000).
  int contextFrames = 10;
};

struct PeakParams {
  ThresholdMode thresholdMode = ThresholdMode::FactorOfMean;
  double thresholdFactor = 1.5;  ///< FactorOfMean: multiple of the mean (> 0)
  double thresholdOfMax = 0.5;   ///< FractionOfMax: fraction of the maximum, (0, 1]
  /// Processing window in sample indices [begin, end) (from --window-mm through DepthConversion).
  std::optional<int> windowBegin;
  std::optional<int> windowEnd;
  PeakPolicy policy = PeakPolicy::Bone;
  BoneEchoParams bone;
  ProminenceParams prominence;
  /// First sample after the ring-down: the prominence policy looks for echoes from here on (the
  /// envelope before it is the transducer's own); 0 for none.
  int ringDownEnd = 0;
  /// Samples per period of the transducer frequency (the prominence policy's leading edge and
  /// reverberation tolerance), > 0.
  double samplesPerCycle = 5.5;
  /// Sample index of the moment of emission (negative: -delay x fs), for reverberation times.
  double emissionSample = 0.0;
  /// Refine the chosen peak to a fraction of a sample with a parabola through its neighbours.
  bool subsample = true;
  /// Millimetres per sample, for the bone policy's lengths (DepthConversion::mmPerSample()).
  double mmPerSample = 0.0154;
  /// The time-gain compensation the front end applied, dB per sample (0: none; measured per
  /// capture by adaptToCapture): the noise a shadow falls to rises with depth by this much, and
  /// the shadow tests judge each region against the record's quiet level at its own depth.
  double gainDbPerSample = 0.0;
};

/// Checks the parameters; throws std::invalid_argument naming the first bad one.
void validate(const PeakParams& params);

/// Field-by-field equality (a new field must be added here, or this stops compiling).
inline bool operator==(const BoneEchoParams& a, const BoneEchoParams& b) {
  const auto& [regionA, gapA, shadowA, contrastA, widthA, noiseA, tissueA, shareA, quietA, strongA,
               pulseA, reverbA] = a;
  const auto& [regionB, gapB, shadowB, contrastB, widthB, noiseB, tissueB, shareB, quietB, strongB,
               pulseB, reverbB] = b;
  return std::tie(regionA, gapA, shadowA, contrastA, widthA, noiseA, tissueA, shareA, quietA,
                  strongA, pulseA, reverbA) == std::tie(regionB, gapB, shadowB, contrastB, widthB,
                                                        noiseB, tissueB, shareB, quietB, strongB,
                                                        pulseB, reverbB);
}
inline bool operator==(const ProminenceParams& a, const ProminenceParams& b) {
  const auto& [snrA, medianA, promA, riseA, contrastA, regionA, wallA, airA, similarA, shadowA,
               ratioA, noiseA, shadowContrastA, ringingA, ringingContrastA, innerA, strongA, onlyA,
               contextA] = a;
  const auto& [snrB, medianB, promB, riseB, contrastB, regionB, wallB, airB, similarB, shadowB,
               ratioB, noiseB, shadowContrastB, ringingB, ringingContrastB, innerB, strongB, onlyB,
               contextB] = b;
  return std::tie(snrA, medianA, promA, riseA, contrastA, regionA, wallA, airA, similarA, shadowA,
                  ratioA, noiseA, shadowContrastA, ringingA, ringingContrastA, innerA, strongA,
                  onlyA, contextA) == std::tie(snrB, medianB, promB, riseB, contrastB, regionB,
                                               wallB, airB, similarB, shadowB, ratioB, noiseB,
                                               shadowContrastB, ringingB, ringingContrastB, innerB,
                                               strongB, onlyB, contextB);
}
inline bool operator==(const PeakParams& a, const PeakParams& b) {
  const auto& [modeA, factorA, ofMaxA, beginA, endA, policyA, boneA, promA, ringA, cycleA,
               emissionA, subsampleA, mmA, gainA] = a;
  const auto& [modeB, factorB, ofMaxB, beginB, endB, policyB, boneB, promB, ringB, cycleB,
               emissionB, subsampleB, mmB, gainB] = b;
  return std::tie(modeA, factorA, ofMaxA, beginA, endA, policyA, boneA, promA, ringA, cycleA,
                  emissionA, subsampleA, mmA,
                  gainA) == std::tie(modeB, factorB, ofMaxB, beginB, endB, policyB, boneB, promB,
                                     ringB, cycleB, emissionB, subsampleB, mmB, gainB);
}
inline bool operator!=(const PeakParams& a, const PeakParams& b) {
  return !(a == b);
}

struct Peak {
  int index = 0;      ///< sample index of the maximum of the run
  float value = 0.F;  ///< envelope value there
  int runBegin = 0;   ///< first sample of the run above the threshold
  int runEnd = 0;     ///< one past the last sample of the run
};

struct PeakResult {
  double threshold = 0.0;
  std::vector<Peak> peaks;  ///< every peak above the threshold (inside the window when one is set)
  RejectReason reason = RejectReason::NoPeak;
  int selected = -1;         ///< index into peaks of the chosen peak, -1 when rejected
  double sampleIndex = 0.0;  ///< chosen peak's (fractional) sample index
  bool accepted() const { return reason == RejectReason::None; }
};

/// Finds the peaks of `envelope` (count samples) and applies the policy.
PeakResult findPeaks(const PeakParams& params, const float* envelope, int count);

/// The capture's context for the prominence policy (ProminenceParams::contextFrames): bone is a
/// surface under a probe that moves little from one record to the next, so where most of the
/// records just before a record agree on bone's depth and the record holds a prominent echo there
/// as strong as theirs, that echo is bone even when the record alone shows no signature of it (a
/// shadow at the noise the medians cannot see, ringing lost in reverberation). Only records before
/// it count, so a live session decides each record when it comes, as `detect` does; only their
/// own verdicts count, so one record taken from its context does not carry the next. Fed every
/// record of one capture (one transducer) in order.
class EchoContext {
 public:
  /// `params`: the resolved peak parameters (mmPerSample, subsample) of the capture.
  explicit EchoContext(const PeakParams& params);

  /// Judges the record's single-signal `result` (envelope: the record's, count samples): a
  /// not-bone verdict becomes the echo its context agrees on (reason None, selected and
  /// sampleIndex set). Returns true when it did. Every record must be given, in order.
  bool judge(PeakResult& result, const float* envelope, int count);

  bool enabled() const { return frames_ > 0; }

 private:
  struct Record {
    bool accepted = false;
    double sampleIndex = 0.0;
    float value = 0.F;
  };
  int frames_ = 0;
  double mmPerSample_ = 0.0;
  bool subsample_ = true;
  int maxRise_ = 2;
  std::vector<Record> past_;                // the last frames_ records, oldest first
  std::vector<double> depths_, strengths_;  // of the accepted ones among them
};

}  // namespace echoreg::core
