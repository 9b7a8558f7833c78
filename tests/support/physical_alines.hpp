// A second, independent generator of labelled A-mode records, written from the physics of pulse-
// echo ultrasound over bone (not from the detector, nor from the other generators), so the
// detector can be scored on signals its authors did not shape.
//
// Physics of one frame (all drawn per capture unless said per frame):
// - Transducer: a Gaussian band-pass pulse, centre f0 and -6 dB fractional bandwidth B (amplitude
//   spectrum exp(-(f-f0)^2 / 2 s^2), s = B f0 / 2.355). Frequency-dependent attenuation multiplies
//   the spectrum by exp(-a f) (a: round-trip nepers per Hz, the sum of 2 d alpha over the layers
//   crossed); the product is again Gaussian, centred f0 - a s^2 (floored at 2 s), so deep echoes
//   lose their high frequencies and amplitude exactly as the frequency-domain product says. Every
//   echo is rendered as the analytic pulse A exp(-t^2 / 2 T^2) exp(i 2 pi f t), T = 1 / (2 pi s);
//   the record holds its real part, the labels use its modulus (the noise-free envelope).
// - Tissue: layers from the face down (standoff water c 1470-1490 or gel c 1500-1560; skin c
//   1580-1650, 1.5-3 dB/cm/MHz; fat c 1430-1470, 0.5-0.8 dB/cm/MHz; muscle c 1560-1590, 0.7-1.2
//   dB/cm/MHz; attenuation one-way amplitude), each with its own density (kg/m3) and thus
//   impedance; every interface reflects R = (Z2 - Z1) / (Z2 + Z1) and passes 1 - R^2 round trip; a
//   fascia adds R 0.02-0.08 on top of the fat/muscle interface (0.25-0.45 where "fascia stronger
//   than bone" is drawn). Each soft layer is a 2-D field (lateral x, depth) of random point
//   scatterers, 10-60 per mm^2 with Gaussian amplitudes scaled to a backscatter of -32..-24 dB
//   (skin), -45..-35 (fat), -40..-28 (muscle) re a perfect reflector: speckle emerges from their
//   sum. The beam weights a scatterer at lateral offset dx by exp(-(dx / w)^2), w 0.5-1.2 mm, so a
//   moving probe decorrelates it. Layer thicknesses vary laterally (sinusoids) and with
//   compression in time (holder: 0-8 % at 0.3-1.5 Hz, with 0.2-1 mm of lateral slip).
// - Bone: its surface closes the last soft layer, at or below the drawn tissue depth: a long
//   undulation (wavelength 40-80 mm, steepest in-plane slope -8..8 deg, -10..10 in the tank) and
//   two bumps (0.05-0.5 mm), plus an out-of-plane tilt (0-5 deg; 0-6 in a holder) and a wobble
//   (0-4 deg). Cortex c 3000-4000, density 1800-2000, attenuation 8-20 dB/cm/MHz, thickness 1-5
//   mm, with the inner (marrow) surface's echo, one reverberation inside the cortex, and faint
//   marrow scatterers: behind bone lies a shadow. The specular echo is R exp(-2 k^2 h^2 cos^2
//   theta) exp(-(theta / theta0)^2) times the beam's share over the bone (bone has lateral edges),
//   with roughness h 0.002-0.01 mm (0.015-0.03 under a strong fascia) and theta0 6-15 deg
//   (aperture and curvature tolerance); a diffuse part is surface scatterers (20 per mm, height
//   jitter h) carrying 15-50 % of the energy the roughness removed from the specular part.
// - Reverberation: the transducer face reflects R_face 0.2-0.7; every interface with |R| > 0.1
//   returns a second (and third) multiple at 2x (3x) its time. Uncoupled frames (air): only the
//   face's ringing train (period 0.3-1.5 us, decay 0.5-0.85 per bounce).
// - Electronics: ring-down burst 0.2-4 us at f0, 0.3-2 full scale (clips), with a slow tail of
//   0-15 % full scale decaying over 0.5-3 us; receiver noise (SNR 24-50 dB against the nominal bone
//   echo) added before time-gain compensation (in ~40 % of hand-held captures: 0.4-1.2 dB/us,
//   capped at 40 dB); baseline wander 0-8 % full scale at 20-400 kHz drifting between frames;
//   interference tones (0-3 % FS) and bursts (0.3-3 us, 5-50 % FS, in some frames of some
//   captures); DC offset +-5 % FS.
// - Digitiser: 20-100 MHz, 8/10/12/14/16 bit, signed or unsigned (offset binary), left-justified
//   into 16 bits or not, clipping at full scale. Samples are the codes, as float.
//
// Labels (per frame, from the noise-free components): P_bone is the peak of the bone surface's
// envelope (specular + diffuse, after gain and TGC); P_other the largest envelope of every other
// component (tissue speckle, interfaces, fascia, reverberations, the cortex's inner echoes,
// interference bursts) within kCompetitorWindowMm of the bone's depth, and of the ring-down burst
// within kRingDownWindowMm (a burst that has ended 1 mm before the bone does not hide it); N = 3
// sigma of the receiver noise there (or an in-band tone's amplitude). contrastDb = 20 log10(P_bone
// / max(P_other, N)). Positive: contrast >= kPositiveContrastDb; negative: no bone in the beam
// (uncoupled, beam off the bone's edge, bone beyond the record) or contrast < kNegativeContrastDb;
// ambiguous (excluded from scoring) in between. Slow components (DC, the ring-down's tail, baseline
// wander, tones) are not competitors: they do not hide an echo from an eye. The depth is the bone
// envelope's peak sample (parabolic sub-sample), converted as the facts convert it: (i / fs +
// delay) c_assumed / 2.
//
// Profiles (per seed): "handheld" (6 captures x 120 frames: sweeps at 10-50 mm/s, 30-100 Hz,
// over a femur/tibia-like surface, half of them crossing the bone's edge; tissue thin 1-5 mm (30
// %, 5-15 MHz), medium 5-20 mm (40 %, 5-10 MHz) or thick 20-50 mm (30 %, 3.5-7.5 MHz, TGC in 80
// %); standoff none / gel 2-10 mm / water 5-15 mm; lift-off of 10-30 frames in half; c_assumed
// 1540, 1500 or 1580), "holder" (6 captures x 150 frames, one per strapped transducer at one
// 30-100 Hz rate, 5-10 MHz at 50 MHz, 12-bit left-justified in 60 % of seeds; tissue 1-10 mm (60
// %) or 10-25 mm; one transducer off the bone and, in half the seeds, one on its edge; the user's
// depth window: the expected depth -3..6 / +3..6 mm) and "phantom-water" (4 captures x 150 frames:
// bone specimens, bare or under 1-5 mm of soft tissue, in 3-40 mm of water under a stage moving
// 5-20 mm/s at 20-100 Hz; c_assumed 1480; 8-bit in half; a delay of 20-80 % of the water's time in
// half; bone beyond the record in 20 %; the probe lowered from air in 20 %). Records hold
// 1000-12000 samples, 5-25 mm past the deepest bone.
#pragma once

#include "detection_scoring.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::test {

inline constexpr double kPositiveContrastDb = 6.0;
inline constexpr double kNegativeContrastDb = 0.0;
inline constexpr double kCompetitorWindowMm = 2.0;
inline constexpr double kRingDownWindowMm = 1.0;

struct PhysicalFrame {
  std::vector<float> samples;
  bool hasBone = false;    ///< positive label
  bool ambiguous = false;  ///< excluded from scoring
  /// Depth (acquisition facts' conversion) of the bone surface echo's peak where it lies in the
  /// record (positives, ambiguous and buried frames), else -1.
  double boneDepthMm = -1.0;
  double contrastDb = -1000.0;  ///< -1000 when there is no bone echo in the record
  /// "uncoupled", "off-bone", "beyond-record", or "bone" with qualifiers joined by '+': shallow
  /// (< 5 mm), deep (> 20 mm), oblique (> 5 deg), edge (beam partly off bone), fascia (an
  /// interface echo anywhere stronger than bone), burst (interference near the bone), ring-down.
  std::string kind;
};

struct PhysicalCapture {
  std::string name;  ///< e.g. "handheld-3 thick gel 5.2 MHz 12-bit"
  AcquisitionFacts facts;
  double transducerFrequencyHz = 0.0;
  int bits = 16;
  bool isSigned = true;
  bool leftJustified = false;
  std::vector<PhysicalFrame> frames;

  /// The frames as the scoring harness reads them (pointers into `frames`).
  std::vector<LabelledRecord> labelled() const;
};

struct PhysicalSet {
  std::string profile;
  std::uint64_t seed = 0;
  std::vector<PhysicalCapture> captures;
};

/// "handheld", "holder", "phantom-water".
std::vector<std::string> physicalProfileNames();

/// The captures of `profile` for `seed` (deterministic). Throws std::invalid_argument naming an
/// unknown profile and the valid ones.
PhysicalSet generatePhysicalSet(const std::string& profile, std::uint64_t seed);

}  // namespace echoreg::test
