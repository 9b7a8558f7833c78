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
