#include "aline_generator.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace echoreg::test {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Gaussian-modulated cosine; sigma from the -6 dB bandwidth of its amplitude spectrum.
struct Pulse {
  double sigmaSamples;
  double cyclesPerSample;
  int halfLength;

  explicit Pulse(const PulseModel& model) {
    const double bandwidthHz = model.relativeBandwidth * model.centreFrequencyHz;
    const double sigmaHz = bandwidthHz / (2.0 * std::sqrt(2.0 * std::log(2.0)));
    sigmaSamples = model.samplingFrequencyHz / (2.0 * kPi * sigmaHz);
    cyclesPerSample = model.centreFrequencyHz / model.samplingFrequencyHz;
    halfLength = static_cast<int>(std::ceil(4.0 * sigmaSamples));
  }

  double at(double offsetSamples, double phase) const {
    return std::exp(-offsetSamples * offsetSamples / (2.0 * sigmaSamples * sigmaSamples)) *
           std::cos(2.0 * kPi * cyclesPerSample * offsetSamples + phase);
  }

  void add(std::vector<double>& record, double centre, double amplitude, double phase) const {
    const int count = static_cast<int>(record.size());
    const int first = std::max(0, static_cast<int>(std::floor(centre)) - halfLength);
    const int last = std::min(count - 1, static_cast<int>(std::ceil(centre)) + halfLength);
    for (int i = first; i <= last; ++i) {
      record[static_cast<std::size_t>(i)] += amplitude * at(i - centre, phase);
    }
  }
};

std::vector<std::uint8_t> quantise(const std::vector<double>& record) {
  std::vector<std::uint8_t> samples(record.size());
  for (std::size_t i = 0; i < record.size(); ++i) {
    samples[i] = static_cast<std::uint8_t>(std::clamp(std::lround(128.0 + record[i]), 0L, 255L));
  }
  return samples;
}

class SpecimenDrawer {
 public:
  SpecimenDrawer(const SpecimenSetOptions& options)
      : options_(options), pulse_(options.pulse), rng_(options.seed) {}

  LabelledALine draw() {
    const double kind = uniform(0.0, 1.0);
    if (kind < 0.55)
      return boneOrOblique(true);
    if (kind < 0.80)
      return boneOrOblique(false);
    if (kind < 0.92)
      return noCoupling();
    return boneBeyondRecord();
  }

 private:
  double uniform(double low, double high) {
    return std::uniform_real_distribution<double>(low, high)(rng_);
  }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
  double phase() { return uniform(0.0, 2.0 * kPi); }

  int count() const { return options_.samplesPerRecord; }
  double samplesPerMm(double speedMps) const {
    return 2.0 * options_.pulse.samplingFrequencyHz / (speedMps * 1000.0);
  }
  // Round-trip attenuation of soft tissue: 0.5 dB/cm/MHz at 9 MHz, there and back.
  double attenuation(double tissueMm) const {
    const double dbPerMm = 0.05 * options_.pulse.centreFrequencyHz / 1e6 * 2.0;
    return std::pow(10.0, -dbPerMm * tissueMm / 20.0);
  }

  // Ring-down of the transducer: a strong decaying oscillation at the start of every record.
  void addRingDown(std::vector<double>& record) {
    const double decay = uniform(20.0, 30.0);
    const double amplitude = uniform(300.0, 500.0);
    const double ph = phase();
    for (int i = 0; i < count(); ++i) {
      const double envelope = amplitude * std::exp(-i / decay);
      if (envelope < 0.01)
        break;
      record[static_cast<std::size_t>(i)] +=
          envelope * std::cos(2.0 * kPi * pulse_.cyclesPerSample * i + ph);
    }
  }

  // Speckle: white scatterers convolved with the pulse, RMS `rmsAtSkin` attenuated with depth.
  void addSpeckle(std::vector<double>& record, double beginSample, double endSample,
                  double rmsAtSkin) {
    const int begin = std::max(0, static_cast<int>(beginSample));
    const int end = std::min(count(), static_cast<int>(endSample));
    if (end <= begin)
      return;
    std::normal_distribution<double> scatter(0.0, 1.0);
    // The pulse's energy sets the RMS of white noise filtered by it.
    double energy = 0.0;
    for (int k = -pulse_.halfLength; k <= pulse_.halfLength; ++k) {
      energy += std::pow(pulse_.at(k, 0.0), 2);
    }
    const double norm = 1.0 / std::sqrt(energy);
    const double tissuePerSample = 1.0 / samplesPerMm(options_.speedOfSoundTissueMps);
    for (int s = begin; s < end; ++s) {
      const double depthMm = (s - beginSample) * tissuePerSample;
      const double strength = scatter(rng_) * rmsAtSkin * norm * attenuation(depthMm);
      for (int k = -pulse_.halfLength; k <= pulse_.halfLength; ++k) {
        const int i = s + k;
        if (i >= 0 && i < count())
          record[static_cast<std::size_t>(i)] += strength * pulse_.at(k, 0.0);
      }
    }
  }

  void addBurst(std::vector<double>& record) {
    if (!chance(0.3))
      return;
    const int length = static_cast<int>(uniform(15.0, 60.0));
    const int start = static_cast<int>(uniform(200.0, count() - 100.0));
    const double sigma = uniform(15.0, 45.0);
    std::normal_distribution<double> noise(0.0, sigma);
    for (int i = start; i < std::min(count(), start + length); ++i) {
      record[static_cast<std::size_t>(i)] += noise(rng_);
    }
  }

  void addElectronicNoise(std::vector<double>& record) {
    std::normal_distribution<double> noise(0.0, uniform(0.4, 1.0));
    for (double& v : record)
      v += noise(rng_);
  }

  // A standoff of water, the skin, tissue with speckle and maybe a fascia, then bone. A positive
  // has a clear bone echo (incidence within 12 degrees); an oblique negative has lost it (25 to
  // 45 degrees) while the bone's shadow remains.
  LabelledALine boneOrOblique(bool clearEcho) {
    for (;;) {
      const double standoffMm = uniform(6.0, 12.0);
      const double tissueMm = uniform(3.0, 18.0);
      const double angleDeg = clearEcho ? uniform(0.0, 12.0) : uniform(25.0, 45.0);
      std::optional<LabelledALine> line = drawGeometry(standoffMm, tissueMm, angleDeg, true);
      if (line)
        return *line;
    }
  }

 public:
  // One record for a given geometry. With `strictLabels`, ambiguous draws give nothing (the
  // caller redraws); otherwise the label says whether the bone echo is clear.
  std::optional<LabelledALine> drawGeometry(double standoffMm, double tissueMm, double angleDeg,
                                            bool strictLabels) {
    const bool clearEcho = angleDeg < 18.0;
    {
      std::vector<double> record(static_cast<std::size_t>(count()), 0.0);
      LabelledALine line;
      std::vector<std::string> parts{clearEcho ? "bone" : "oblique"};
      addRingDown(record);
      const double skinSample = standoffMm * samplesPerMm(options_.speedOfSoundWaterMps);
      const double boneSample =
          skinSample + tissueMm * samplesPerMm(options_.speedOfSoundTissueMps);
      if (boneSample > count() - 300)
        return std::nullopt;

      const bool skinMissing = chance(0.2);
      const double skinAmplitude = skinMissing ? uniform(0.0, 3.0) : uniform(20.0, 60.0);
      if (skinMissing)
        parts.push_back("no-skin");
      pulse_.add(record, skinSample, skinAmplitude, phase());
      pulse_.add(record, 2.0 * skinSample, 0.25 * skinAmplitude,
                 phase());  // standoff reverberation

      const double speckleRms = uniform(6.0, 14.0);
      addSpeckle(record, skinSample, boneSample, speckleRms);
      const double speckleAtBone = speckleRms * attenuation(tissueMm);

      const double nominalBone = uniform(140.0, 220.0) * attenuation(tissueMm);
      const double boneAmplitude = nominalBone * std::exp(-std::pow(angleDeg / 12.0, 2));
      pulse_.add(record, boneSample, boneAmplitude, phase());
      if (2.0 * boneSample < count() - pulse_.halfLength) {
        pulse_.add(record, 2.0 * boneSample, 0.15 * boneAmplitude, phase());  // bone reverberation
      }
      if (chance(0.35) && tissueMm > 2.5) {
        // A fascia (muscle sheath) as strong as the bone echo would be at normal incidence.
        const double fasciaMm = uniform(1.0, tissueMm - 1.5);
        const double fasciaSample =
            skinSample + fasciaMm * samplesPerMm(options_.speedOfSoundTissueMps);
        pulse_.add(record, fasciaSample, uniform(0.7, 1.3) * nominalBone, phase());
        parts.push_back("fascia");
      }
      addBurst(record);
      addElectronicNoise(record);

      // Label like an expert would; redraw the ambiguous middle ground.
      const bool clear = boneAmplitude >= 5.0 * speckleAtBone;
      const bool lost = boneAmplitude <= 1.0 * speckleAtBone;
      if (strictLabels && (clearEcho ? !clear : !lost))
        return std::nullopt;
      line.samples = quantise(record);
      line.hasBone = clear;
      line.boneSample = line.hasBone ? boneSample : -1.0;
      line.kind = parts.front();
      for (std::size_t i = 1; i < parts.size(); ++i)
        line.kind += "+" + parts[i];
      return line;
    }
  }

 private:
  // The standoff is not coupled to the skin: its far wall against air rings back and forth.
  LabelledALine noCoupling() {
    std::vector<double> record(static_cast<std::size_t>(count()), 0.0);
    addRingDown(record);
    const double wallSample = uniform(6.0, 12.0) * samplesPerMm(options_.speedOfSoundWaterMps);
    double amplitude = uniform(80.0, 120.0);
    for (double s = wallSample; s < count() - pulse_.halfLength; s += wallSample) {
      pulse_.add(record, s, amplitude, phase());
      amplitude *= 0.5;
    }
    addBurst(record);
    addElectronicNoise(record);
    return {quantise(record), false, -1.0, "no-coupling"};
  }

  // Thick soft tissue: the bone lies beyond the end of the record.
  LabelledALine boneBeyondRecord() {
    std::vector<double> record(static_cast<std::size_t>(count()), 0.0);
    addRingDown(record);
    const double skinSample = uniform(6.0, 12.0) * samplesPerMm(options_.speedOfSoundWaterMps);
    pulse_.add(record, skinSample, uniform(20.0, 60.0), phase());
    addSpeckle(record, skinSample, count(), uniform(6.0, 14.0));
    if (chance(0.5)) {
      const double fasciaSample = uniform(skinSample + 100.0, count() - 200.0);
      pulse_.add(record, fasciaSample, uniform(20.0, 60.0), phase());
    }
    addBurst(record);
    addElectronicNoise(record);
    return {quantise(record), false, -1.0, "beyond-record"};
  }

  SpecimenSetOptions options_;
  Pulse pulse_;
  std::mt19937_64 rng_;
};

}  // namespace

std::vector<float> makeEchoRecord(int count, const std::vector<EchoSpec>& echoes,
                                  const PulseModel& pulseModel, double offset, double noiseSigma,
                                  std::uint64_t seed) {
  const Pulse pulse(pulseModel);
  std::vector<double> record(static_cast<std::size_t>(count), 0.0);
  for (const EchoSpec& echo : echoes)
    pulse.add(record, echo.centreSample, echo.amplitude, 0.0);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, noiseSigma > 0.0 ? noiseSigma : 1.0);
  std::vector<float> samples(static_cast<std::size_t>(count));
  for (std::size_t i = 0; i < record.size(); ++i) {
    samples[i] = static_cast<float>(offset + record[i] + (noiseSigma > 0.0 ? noise(rng) : 0.0));
  }
  return samples;
}

LabelledALine makeSpecimenALine(double standoffMm, double tissueMm, double incidenceDeg,
                                const SpecimenSetOptions& options) {
  SpecimenDrawer drawer(options);
  std::optional<LabelledALine> line =
      drawer.drawGeometry(standoffMm, tissueMm, incidenceDeg, false);
  if (!line)
    return {std::vector<std::uint8_t>(static_cast<std::size_t>(options.samplesPerRecord), 128),
            false, -1.0, "beyond-record"};
  return *line;
}

std::vector<LabelledALine> makeSpecimenSet(const SpecimenSetOptions& options) {
  SpecimenDrawer drawer(options);
  std::vector<LabelledALine> set;
  set.reserve(static_cast<std::size_t>(options.records));
  for (int i = 0; i < options.records; ++i)
    set.push_back(drawer.draw());
  return set;
}

}  // namespace echoreg::test
