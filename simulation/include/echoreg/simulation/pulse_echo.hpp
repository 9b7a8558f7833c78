// The pulse-echo model of one A-line: what a single-element focused transducer (Olympus V312,
// 9 MHz, 6.35 mm, focused at 25 mm), a pulser-receiver (5072PR, 40 dB) and an 8-bit 50 MHz card
// record along one beam path of tissue layers (Mozes 2008, sections 3.1, 4.1, 4.3.4 and 5.3);
// another centre frequency, or a 12-bit int16 front end with DC offset, baseline wander and a
// short ring-down with a tail, on request.
//
// The path, not a label, drives the record: every interface gives a specular echo from the
// impedances and the incidence, every soft tissue its speckle, the transducer its ring-down and
// the face-to-reflector reverberations; bone, steel and air end the beam (a shadow of noise behind
// them). Each choice, value and source is in docs/simulation.md.
#pragma once

#include "echoreg/core/random.hpp"
#include "echoreg/simulation/tissue.hpp"

#include <complex>
#include <cstdint>
#include <vector>

namespace echoreg::simulation {

/// The transducer: a spherically focused single element (defaults: Olympus V312).
struct Transducer {
  double centreFrequencyHz = 9e6;    ///< 10 MHz nominal, 9 MHz measured (Mozes 2008, 4.1)
  double fractionalBandwidth = 0.6;  ///< -6 dB pulse-echo bandwidth over the centre frequency
  double elementDiameterMm = 6.35;   ///< 0.25 inch
  double focalLengthMm = 25.0;       ///< in water
  /// Peak of the ring-down at the start of every record, relative to the unit echo (a perfect
  /// plane reflector at the focus in water). 10 at 40 dB saturates the 8-bit card for ~1.1 us.
  double ringDownAmplitude = 10.0;
  /// Time for the ring-down to decay by 60 dB from its peak.
  double ringDownDurationUs = 1.5;
  /// A slower tail under the ring-down's burst (the pulser's recovery and the backing's late
  /// ringing): its peak at the pulse relative to the unit echo, and its 60 dB decay time. 0 = no
  /// tail (the V312 on the 5072PR: one exponential).
  double ringDownTailAmplitude = 0.0;
  double ringDownTailDurationUs = 4.0;
  /// Pressure reflection coefficient of the transducer's face seen from the water (it sends
  /// echoes back out: the multiples between face and reflector).
  double faceReflection = 0.5;
  /// RMS speckle amplitude of muscle (backscatter 1 in the tissue table) relative to the unit
  /// echo, at the focus without attenuation; other tissues scale it by their `backscatter`.
  double muscleSpeckle = 0.025;
};

/// How the digitiser stores a sample. Both cover the same input range: one 8-bit count is 16
/// 12-bit codes, 256 int16 units.
enum class AdcFormat {
  UInt8,        ///< 8-bit unsigned, mid-scale 128 = 0 V (AlazarTech ATS850)
  Int16Left12,  ///< 12-bit signed codes left-justified in int16 (multiples of 16), 0 = 0 V
};

/// int16 units per 8-bit count (the unit of every amplitude in the model).
constexpr double kInt16PerCount = 256.0;

/// Pulser-receiver and digitiser (defaults: 5072PR at 40 dB, AlazarTech ATS850).
struct Receiver {
  double samplingFrequencyHz = 50e6;
  int samples = 4096;
  double delayS = 0.0;  ///< time from the pulse to sample 0 (>= 0)
  double gainDb = 40.0;
  double electronicNoiseCounts = 0.7;  ///< RMS in ADC counts after gain
  /// ADC counts of the unit echo (a perfect plane reflector at the focus in water, no
  /// attenuation) at 0 dB gain: the sensitivity of pulser, transducer and card together.
  double unitEchoCountsAt0Db = 25.0;
  AdcFormat adc = AdcFormat::UInt8;
  /// Int16Left12 only, in int16 units (16 per code): the front end's DC offset, and the slow
  /// wander of its baseline, per record a sinusoid of peak amplitude uniform in
  /// [baselineWanderMin, baselineWanderMax] and frequency uniform in [baselineWanderMinHz,
  /// baselineWanderMaxHz], random phase. Neither is clutter for `targetClear` (both lie far
  /// below the probe's band, where any detector filters).
  double dcOffset = 0.0;
  double baselineWanderMin = 0.0;
  double baselineWanderMax = 0.0;
  double baselineWanderMinHz = 20e3;
  double baselineWanderMaxHz = 200e3;
};

/// One homogeneous stretch of the beam, from the transducer face outward.
struct PathLayer {
  Tissue tissue = Tissue::Water;
  double lengthMm = 0.0;  ///< > 0; the last layer's may be +infinity
  /// Angle between the beam and the normal of the interface that ends this layer, degrees [0, 90].
  double exitIncidenceDeg = 0.0;
  /// Speed of sound of this layer, m/s; 0 = the tissue's table value (e.g. bath water warmer
  /// than the table's 20 C).
  double speedMps = 0.0;
};

/// The tissues along one beam.
struct BeamPath {
  /// The last layer is where the beam ends (bone, steel, air, or tissue running past the record);
  /// its length may be huge. The beam also ends at the first bone, steel or air layer.
  std::vector<PathLayer> layers;
  /// Thin specular sheets inside soft tissue (intermuscular septa), mm from the transducer face.
  /// Sheets outside skin, fat or muscle layers in front of the beam's end are ignored.
  std::vector<double> fasciaDepthsMm;
};

/// One simulated record with its ground truth.
struct ALine {
  std::vector<std::uint8_t> samples;       ///< AdcFormat::UInt8: 8-bit, mid-scale 128 = 0 V
  std::vector<std::int16_t> int16Samples;  ///< AdcFormat::Int16Left12 (samples then empty)
  int targetLayer = -1;                    ///< index of the first bone/steel layer, -1 if none
  double targetEchoSample = -1;    ///< true sample of the bone/steel echo (time of flight * fs)
  double targetEchoAmplitude = 0;  ///< counts (before clipping)
  double clutterRmsAtTarget = 0;   ///< speckle + noise RMS around the echo, counts
  bool targetClear = false;        ///< a correct detector should accept this line
  double timeOfFlightS = 0;        ///< round trip to the target interface
  double meanSpeedOfSoundMps = 0;  ///< path length / one-way time, to the target interface
  int ringDownEndSample = 0;       ///< first sample where the ring-down is below the noise
};

/// Rule of `targetClear`: the target echo is at least this many times the clutter RMS ...
constexpr double kClearContrast = 4.0;
/// ... and at least this many counts (over 5 % of the 8-bit range, 14 x the default noise) ...
constexpr double kClearMinimumCounts = 10.0;
/// ... and its pulse lies after the ring-down with this much record behind it (for its shadow).
constexpr double kClearShadowRoomS = 2e-6;
/// Pressure reflection coefficient of an intermuscular septum at normal incidence (a thin sheet
/// of connective tissue, about half a wavelength thick); each sheet varies by +-40 %.
constexpr double kFasciaReflection = 0.1;

/// How a surface of `tissue` reflects a beam off its normal: the 1/e half-width of the specular
/// lobe that the surface adds to the beam's own (degrees) and the diffuse part (amplitude
/// fraction of the normal-incidence echo that survives at any angle, times cos).
struct SurfaceScatter {
  double roughnessDeg;
  double diffuseFraction;
};
SurfaceScatter surfaceScatter(Tissue tissue);

/// Pressure reflection coefficient at incidence `incidenceDeg` from `from` into `to` (Mozes 2008
/// Eq. 3.1 for pressure, both media as fluids; 1 beyond the critical angle).
double obliqueReflectionCoefficient(Tissue from, Tissue to, double incidenceDeg);

/// Specular lobe of a surface of `surface` tilted by `incidenceDeg` in a beam of frequency
/// `frequencyHz`: exp(-(theta / width)^2), width^2 = beam^2 + roughness^2, where beam =
/// 1 / sqrt(k zR) is what tilting a plane mirror does to the focused Gaussian beam's pulse-echo.
double specularLobe(const Transducer& transducer, Tissue surface, double incidenceDeg,
                    double frequencyHz);

/// Echo of an interface from `from` into `to` at incidence `incidenceDeg`, relative to the unit
/// echo before focusing and losses: R(theta) (1 - d) lobe(theta) + R(0) d cos(theta), the
/// specular part with the oblique reflection coefficient, the diffuse part (d from
/// surfaceScatter(to)) with the normal one.
double interfaceEcho(const Transducer& transducer, Tissue from, Tissue to, double incidenceDeg,
                     double frequencyHz);

/// Complex pulse-echo response of a plane reflector (R = 1) at `waterDepthMm` (water-equivalent
/// distance: each layer's length times its speed over water's) for a Gaussian beam of the
/// transducer at `frequencyHz`, after `roundTrips` trips between face and reflector (1 = the
/// primary echo; each further trip reflects off the concave face). Normalised so the primary
/// echo of a reflector at the beam's waist has magnitude 1.
std::complex<double> focusingResponse(const Transducer& transducer, double waterDepthMm,
                                      double frequencyHz, int roundTrips = 1);

/// Checks the path, the transducer and the receiver; throws std::invalid_argument naming the
/// first bad value.
void validate(const BeamPath& path, const Transducer& transducer, const Receiver& receiver);

/// Turns `transducer` and `receiver` into an in-vivo A-mode front end (`echoreg simulate --adc
/// int16-12bit`): a 12-bit card left-justified in int16 with the DC offset `dcOffset` (int16
/// units), a baseline wandering by +-1000 to 3000 int16 units at 20-200 kHz, and a pulser that
/// damps the element within ~0.5 us (60 dB) over a weaker tail (2 % of the unit echo, 60 dB in
/// 4 us). The probe's frequency, focus and sensitivity stay as they are.
void useInt16FrontEnd(Transducer& transducer, Receiver& receiver, double dcOffset);

/// Simulates one A-line. Random parts (speckle, septa strengths, noise) come from `rng`; the same
/// inputs and generator state give the same bytes.
ALine simulateALine(const BeamPath& path, const Transducer& transducer, const Receiver& receiver,
                    core::Rng& rng);

}  // namespace echoreg::simulation
