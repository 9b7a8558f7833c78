// An independent, labelled, domain-randomised generator of A-mode ultrasound records.
//
// Written from first principles (a pulse-echo model with frequency-dependent attenuation,
// speckle, specular interfaces, ring-down, baseline drift and a digitiser), without sharing code
// or assumptions with the project's own simulators, so that a detector can be scored on records
// it was not tuned on. Each frame carries an expert-style label: a bone echo that is clearly
// visible above the clutter around it is a positive, a record without a usable bone echo is a
// negative, anything in between is ambiguous (excluded from scoring).
//
// Units: samples are stored ADC codes (as float); amplitudes in the truth fields are in the same
// codes (relative to dcOffset); times in seconds; depths in mm.
//
// What is drawn (per capture unless said otherwise):
//  - probe 3.5-15 MHz, -6 dB fractional bandwidth 40-90 %, pulse gaussian, asymmetric (fast rise,
//    slow decay) or gamma-shaped, with a low-frequency roll-off; sampling 20-100 MHz and at least
//    2.5x the upper band edge; 1000-12000 samples; uint8 (0 V at 128), int8, 12-bit left-justified
//    int16 (multiples of 16, DC offset 50-110 codes), int16 or uint16; clipping at the range;
//    delay 0 (40 %), inside the burst, or up to 3 us; assumed speed of sound 1480-1580 m/s while
//    the layers have their own (water ~1482, gel 1500-1540, skin ~1600, fat ~1450, muscle ~1580).
//  - ring-down: a burst of 0.2-4 us (often saturating) at the probe's frequency, then a tail
//    (oscillating and unipolar) of 2-50 % of full scale decaying to 5 % over 1-4 mm; a baseline
//    wander (1-3 sinusoids of 0.05-1 MHz and a recovery exponential, +-1000-3000 codes on the
//    16-bit scale) in 65 % of captures.
//  - standoff none, gel 1-3 mm or water 5-20 mm (nearly echo-free, a skin echo at its end, and
//    multiples at 2x and 3x its time); soft tissue 0-40 mm (skin, fat, muscle with their own
//    speckle levels, septa, striations, a fat/muscle fascia); attenuation 0.5-1 dB/cm/MHz round
//    trip, applied to each echo's spectrum (so deep echoes are lower in frequency), with a partial
//    gain ramp in half of the captures; bone 1-60 mm from the face.
//  - the bone echo 20-42 dB above the muscle speckle at its depth; behind it a shadow (3-35 % of
//    the speckle), an endosteal echo, a weak reverberation train, or (30 % of captures, 80 % in
//    vivo) a ringing of the cortex that keeps the envelope above half the bone echo for mm; a
//    second echo of similar strength 1-6 mm above the bone in 25 % of captures.
//  - incidence: the specular bone echo falls as exp(-(angle/theta0)^2), theta0 5-9 degrees, down
//    to a floor 25-40 dB below; the shadow stays.
//  - negatives: probe in air (ring-down and its reverberation inside the face), water with nothing
//    in it (no skin echo), bone beyond the record, a fascia as strong as bone with tissue behind
//    it and no bone, electrical noise over the whole trace; per frame: noise bursts of 0.5-5 us
//    over the bone, loss of contact in sweeps.
//  - motion: hand-held sweeps (100 Hz, 10-50 mm/s along a gently curved bone, tilt wander and
//    tremor, a tracked pose per frame) or a strapped holder (45 Hz, the bone moving < 0.3 mm a
//    frame, with occasional 1-2 mm jumps when the muscle contracts).
// The label: contrast = bone echo envelope peak / max(strongest ring-down, speckle, noise or other
// echo within its half-maximum width, 90th percentile of the speckle and noise envelope from 4 mm
// above to 2 mm below it); positive >= kClearContrast, negative < kLostContrast, else ambiguous.
// The shares of scenarios are drawn without replacement in blocks (see the .cpp), so a set of
// 40 captures has about the profile's shares: positives about 57 % (randomised), 70 % (in vivo),
// 50 % (specimen).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::test {

/// How the digitiser stores a sample.
enum class SampleStorage { UInt8, Int8, Int16, UInt16 };

struct RandomisedFrame {
  /// The stored ADC codes as float (integers: e.g. multiples of 16 for 12-bit left-justified).
  std::vector<float> samples;
  /// Label: an expert would mark a usable bone echo here.
  bool hasBone = false;
  /// True: excluded from scoring (a bone echo neither clearly present nor clearly absent).
  bool ambiguous = false;
  /// Positives and ambiguous frames with a bone echo in the record: fractional sample index of
  /// the maximum of the bone echo's own (noise-free) envelope; -1 otherwise.
  double boneSample = -1.0;
  /// (boneSample / fs + delayS) * speedOfSoundMps / 2 * 1000, or -1 when boneSample is -1.
  double boneDepthMm = -1.0;
  /// What was drawn: a base ("bone", "oblique", "uncoupled", "no-skin", "fascia-as-strong",
  /// "noise", "noise-burst", "bone-beyond-record") and, for bone frames, modifiers joined with
  /// '+' ("bone+reverb", "bone+similar-echo", "oblique+reverb", ...).
  std::string kind;
  /// When the capture is tracked (hand-held sweep): probe to tracker, mm; the beam is +z.
  bool hasPose = false;
  Eigen::Matrix4d probeToTracker = Eigen::Matrix4d::Identity();
  double timestampS = 0.0;

  // Truth beyond the label (for analysis; a detector must not read these).
  /// True physical distance from the transducer face to the bone along the beam (mm), or -1.
  double boneTrueDepthMm = -1.0;
  /// Angle between the beam and the bone surface normal (degrees), or -1 without bone.
  double incidenceDeg = -1.0;
  /// Peak of the bone echo's own envelope (codes), 0 without bone.
  double boneAmplitude = 0.0;
  /// The expert's visibility measure: bone envelope peak over the clutter at and around it.
  double boneContrast = 0.0;
  /// Behind the cortex the envelope stays high for a few mm (reverberation, cortical echoes).
  bool reverbBehindBone = false;
  /// Only with RandomisedSetOptions::keepCleanBoneEcho: the bone echo alone (its primary
  /// reflection, noise-free, unclipped, in codes relative to dcOffset), else empty.
  std::vector<float> cleanBoneEcho;
};

struct RandomisedCapture {
  /// "randomised", "invivo-holder" or "specimen-standoff".
  std::string profile;
  double samplingFrequencyHz = 0.0;
  /// Assumed speed of sound (the acquisition fact used to convert time of flight to depth).
  double speedOfSoundMps = 1540.0;
  /// Time of sample 0 after the transmit (s).
  double delayS = 0.0;
  /// The truth: the probe's centre frequency (a test may choose not to tell the detector).
  double transducerFrequencyHz = 0.0;
  SampleStorage storage = SampleStorage::Int16;
  int adcBits = 16;
  bool leftJustified = false;
  /// The stored code of 0 V (e.g. 128 for unsigned 8-bit, 50-110 for the in-vivo 12-bit data).
  double dcOffset = 0.0;
  /// Truth: the sample where the ring-down burst (not its tail) ends (0 when it ends before the
  /// record starts).
  double ringDownEndSample = 0.0;
  std::vector<RandomisedFrame> frames;
  /// One line: probe, fs, samples, bits, standoff, tissue range...
  std::string description;
  /// A suggested depth window, as a user would set it per transducer ("invivo-holder").
  std::optional<double> windowMinMm, windowMaxMm;

  // Truth beyond the acquisition facts.
  /// -6 dB fractional bandwidth of the transmit pulse.
  double fractionalBandwidth = 0.0;
  /// "gaussian", "asymmetric" (fast rise, slow decay) or "gamma" (t^k exp(-t/tau)).
  std::string pulseShape;
  /// Round-trip attenuation of the soft tissue (dB/cm/MHz).
  double attenuationDbPerCmMHz = 0.0;
  /// "none", "gel" or "water", and its thickness (mm).
  std::string standoff = "none";
  double standoffMm = 0.0;
  /// Nominal soft-tissue thickness above the bone (mm).
  double tissueMm = 0.0;
  bool handHeld = false;
  double frameRateHz = 0.0;
  /// Half of the ADC's range in codes (the code step of 1 V full scale): 128 or 32768.
  double halfRangeCodes = 0.0;
  /// The code step of a stored sample: 16 for 12-bit left-justified, else 1.
  double codeStep = 1.0;
  /// The smallest and largest stored codes.
  double minCode = 0.0, maxCode = 0.0;
};

struct RandomisedSetOptions {
  std::string profile = "randomised";
  int captures = 40;
  int framesPerCapture = 50;
  std::uint64_t seed = 1;
  /// Store each frame's noise-free bone echo (RandomisedFrame::cleanBoneEcho); memory heavy.
  bool keepCleanBoneEcho = false;
};

/// The captures of a set; deterministic in its options (capture k does not depend on how many
/// captures are asked for). Throws std::invalid_argument for an unknown profile.
std::vector<RandomisedCapture> makeRandomisedSet(const RandomisedSetOptions& options);

/// Expert thresholds on RandomisedFrame::boneContrast: at or above kClearContrast a positive,
/// below kLostContrast a negative, in between ambiguous.
inline constexpr double kClearContrast = 3.0;
inline constexpr double kLostContrast = 1.5;

}  // namespace echoreg::test
