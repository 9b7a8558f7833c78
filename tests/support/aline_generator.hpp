// Labelled synthetic A-lines for tests and benchmarks: a small pulse-echo model of what a
// single-element 9 MHz transducer with a water standoff records over the knee, with the troubles
// of real specimen signals (Mozes 2008, sections 5.3 and 6.3.2): ring-down, standoff and skin
// echoes (sometimes missing), speckle from the soft tissue, fascia echoes as strong as bone,
// reverberations, bone echoes lost at oblique incidence (the bone's shadow stays), captures with
// no coupling, bone beyond the record, and bursts of electrical noise. 8-bit, 50 MHz, 4096
// samples by default, like the dissertation's AlazarTech card.
//
// Each record is labelled the way the dissertation labelled its 20 signals, by what an expert
// sees: a clear bone echo (positive, with the true sample of the echo's centre) or no usable bone
// echo (negative). Ambiguous draws (a bone echo barely above the speckle) are redrawn, so the
// labels are unambiguous.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace echoreg::test {

struct EchoSpec {
  double centreSample = 0.0;  ///< sample index of the pulse's envelope maximum
  double amplitude = 0.0;     ///< peak amplitude in ADC counts
};

struct PulseModel {
  double samplingFrequencyHz = 50e6;
  double centreFrequencyHz = 9e6;
  double relativeBandwidth = 0.6;  ///< -6 dB, fraction of the centre frequency
};

/// A record of `count` float samples with Gaussian-modulated echoes at the given places, on a
/// DC offset of `offset` with white noise of `noiseSigma` (seeded). For unit tests of the chain.
std::vector<float> makeEchoRecord(int count, const std::vector<EchoSpec>& echoes,
                                  const PulseModel& pulse, double offset, double noiseSigma,
                                  std::uint64_t seed);

/// One labelled specimen A-line.
struct LabelledALine {
  std::vector<std::uint8_t> samples;
  bool hasBone = false;      ///< label: a usable bone echo is present
  double boneSample = -1.0;  ///< true centre of the bone echo (positives), samples
  std::string kind;          ///< what was drawn, e.g. "bone+fascia+burst", "oblique", "no-coupling"
};

struct SpecimenSetOptions {
  int records = 400;
  int samplesPerRecord = 4096;
  std::uint64_t seed = 2008;
  PulseModel pulse;
  double speedOfSoundTissueMps = 1540.0;
  double speedOfSoundWaterMps = 1480.0;
};

/// One specimen A-line for a given geometry: water standoff and soft tissue thickness (mm) and
/// the beam's incidence on the bone (degrees). Labelled positive when the bone echo is clear.
/// Random parts (speckle, echo strengths, fascia, bursts) come from `options.seed`.
LabelledALine makeSpecimenALine(double standoffMm, double tissueMm, double incidenceDeg,
                                const SpecimenSetOptions& options);

/// A labelled set of specimen A-lines (about 55 % positives), deterministic for a seed.
std::vector<LabelledALine> makeSpecimenSet(const SpecimenSetOptions& options);

}  // namespace echoreg::test
