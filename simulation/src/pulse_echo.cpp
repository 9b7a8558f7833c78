#include "echoreg/simulation/pulse_echo.hpp"

#include "echoreg/core/number_text.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace echoreg::simulation {

namespace {

constexpr double kPi = 3.14159265358979323846;
// dB/(cm MHz^n) to Np/(mm MHz^n).
constexpr double kDbPerCmToNpPerMm = 0.1 * 2.302585092994046 / 20.0;
// Radius of the Gaussian aperture that gives a 6.35 mm piston's focal -6 dB beam width
// (1.02 lambda F / D): w = 1.665 * 2a / (1.02 pi) = 1.04 a.
constexpr double kGaussianApertureOverRadius = 1.04;
// Two-way attenuation beyond which nothing is worth drawing (Np).
constexpr double kNegligibleLossNp = 25.0;

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument(message);
}

bool isTarget(Tissue tissue) {
  return tissue == Tissue::CorticalBone || tissue == Tissue::CancellousBone ||
         tissue == Tissue::SawbonesShell || tissue == Tissue::SawbonesFoam ||
         tissue == Tissue::Steel;
}

bool endsBeam(Tissue tissue) {
  return isTarget(tissue) || tissue == Tissue::Air;
}

bool holdsFascia(Tissue tissue) {
  return tissue == Tissue::Skin || tissue == Tissue::Fat || tissue == Tissue::Muscle;
}

double layerSpeed(const PathLayer& layer) {
  return layer.speedMps > 0.0 ? layer.speedMps : properties(layer.tissue).speedMps;
}

double waterSpeedMps() {
  return properties(Tissue::Water).speedMps;
}

double degToRad(double degrees) {
  return degrees * kPi / 180.0;
}

// Two-way frequency-dependent attenuation, linearised around the centre frequency:
// alpha(f) ~ alpha0 + alpha1 (f - fc). A Gaussian spectrum times exp(-alpha(f)) stays Gaussian
// with the same width, its centre moved down by sigma_f^2 alpha1 (Narayana & Ophir 1983).
struct Loss {
  double alpha0Np = 0.0;        // at the centre frequency
  double alpha1NpPerMHz = 0.0;  // slope

  void add(Tissue tissue, double twoWayMm, double centreMHz) {
    const TissueProperties& p = properties(tissue);
    const double coefficient = p.attenuationDbPerCmMHz * kDbPerCmToNpPerMm * twoWayMm;
    const double n = p.attenuationPower;
    alpha0Np += coefficient * std::pow(centreMHz, n);
    alpha1NpPerMHz += coefficient * n * std::pow(centreMHz, n - 1.0);
  }
  Loss times(int k) const { return {alpha0Np * k, alpha1NpPerMHz * k}; }
};

// The spectrum's centre after the loss, and the amplitude factor of the echo.
struct Shifted {
  double frequencyHz;
  double amplitude;
};

Shifted applyLoss(const Loss& loss, double centreHz, double sigmaHz) {
  const double sigmaMHz = sigmaHz * 1e-6;
  const double shiftMHz = sigmaMHz * sigmaMHz * loss.alpha1NpPerMHz;
  const double exponent =
      -loss.alpha0Np + 0.5 * (sigmaMHz * loss.alpha1NpPerMHz) * (sigmaMHz * loss.alpha1NpPerMHz);
  // Past a quarter of the centre frequency the linearisation no longer holds; such echoes are
  // tens of dB below the noise anyway.
  const double frequencyHz = std::max(centreHz - shiftMHz * 1e6, 0.25 * centreHz);
  return {frequencyHz, std::exp(std::min(exponent, 0.0))};
}

// Gaussian-modulated cosine at a given centre frequency: exp(-t^2 / 2 s^2) cos(w t + phase).
class Pulse {
 public:
  Pulse(double samplingHz, double sigmaHz)
      : samplingHz_(samplingHz),
        sigmaSamples_(samplingHz / (2.0 * kPi * sigmaHz)),
        halfLength_(static_cast<int>(std::ceil(4.0 * sigmaSamples_))) {}

  double sigmaSamples() const { return sigmaSamples_; }
  int halfLength() const { return halfLength_; }

  // Sum of squares of the sampled pulse (for white scatterers filtered by it).
  double energy(double frequencyHz) const {
    const double omega = 2.0 * kPi * frequencyHz / samplingHz_;
    return 0.5 * std::sqrt(kPi) * sigmaSamples_ *
           (1.0 + std::exp(-omega * omega * sigmaSamples_ * sigmaSamples_));
  }

  void add(std::vector<double>& record, double centre, double amplitude, double frequencyHz,
           double phase) const {
    const int count = static_cast<int>(record.size());
    const int first = std::max(0, static_cast<int>(std::floor(centre)) - halfLength_);
    const int last = std::min(count - 1, static_cast<int>(std::ceil(centre)) + halfLength_);
    const double omega = 2.0 * kPi * frequencyHz / samplingHz_;
    const double inverseTwoSigma2 = 1.0 / (2.0 * sigmaSamples_ * sigmaSamples_);
    for (int i = first; i <= last; ++i) {
      const double t = i - centre;
      record[static_cast<std::size_t>(i)] +=
          amplitude * std::exp(-t * t * inverseTwoSigma2) * std::cos(omega * t + phase);
    }
  }

 private:
  double samplingHz_;
  double sigmaSamples_;
  int halfLength_;
};

// Complex beam parameter at the face (reduced to water): 1/q0 = -1/F - i lambda / (pi w^2).
std::complex<double> faceBeamParameter(const Transducer& transducer, double frequencyHz) {
  const double lambdaMm = waterSpeedMps() * 1e3 / frequencyHz;
  const double apertureMm = kGaussianApertureOverRadius * 0.5 * transducer.elementDiameterMm;
  const std::complex<double> inverse(-1.0 / transducer.focalLengthMm,
                                     -lambdaMm / (kPi * apertureMm * apertureMm));
  return 1.0 / inverse;
}

// One specular reflector along the beam.
struct Reflector {
  double roundTripS;    // primary echo's arrival
  double waterDepthMm;  // water-equivalent depth (for the beam)
  double reflection;    // signed: interface echo x transmission both ways to it
  Loss loss;            // two-way attenuation to it
  bool target;
};

// Where an echo of `reflector` after k round trips lands and how strong it is (unit echo = 1).
struct EchoInstance {
  double sample;
  double frequencyHz;
  std::complex<double> amplitude;
};

EchoInstance echoOf(const Reflector& reflector, int k, const Transducer& transducer,
                    const Receiver& receiver, double sigmaHz) {
  const Shifted shifted = applyLoss(reflector.loss.times(k), transducer.centreFrequencyHz, sigmaHz);
  const std::complex<double> focus =
      focusingResponse(transducer, reflector.waterDepthMm, shifted.frequencyHz, k);
  const double strength = std::pow(reflector.reflection, k) *
                          std::pow(transducer.faceReflection, k - 1) * shifted.amplitude;
  const double sample = (k * reflector.roundTripS - receiver.delayS) * receiver.samplingFrequencyHz;
  return {sample, shifted.frequencyHz, strength * focus};
}

}  // namespace

SurfaceScatter surfaceScatter(Tissue tissue) {
  switch (tissue) {
    case Tissue::Steel:
      return {0.5, 0.01};        // polished sphere
    case Tissue::SawbonesShell:  // moulded, smooth
    case Tissue::SawbonesFoam:
      return {3.0, 0.03};
    case Tissue::CorticalBone:  // periosteum, curvature over the spot
    case Tissue::CancellousBone:
      return {6.0, 0.05};
    default:
      return {10.0, 0.1};  // skin, fat, muscle, gel, air: soft, rough
  }
}

double obliqueReflectionCoefficient(Tissue from, Tissue to, double incidenceDeg) {
  const TissueProperties& a = properties(from);
  const TissueProperties& b = properties(to);
  const double theta = degToRad(incidenceDeg);
  const double sinTransmitted = std::sin(theta) * b.speedMps / a.speedMps;
  if (sinTransmitted >= 1.0)
    return 1.0;  // total reflection past the critical angle
  const double cosTransmitted = std::sqrt(1.0 - sinTransmitted * sinTransmitted);
  const double z1 = a.impedanceMRayl();
  const double z2 = b.impedanceMRayl();
  const double cosIncident = std::cos(theta);
  return (z2 * cosIncident - z1 * cosTransmitted) / (z2 * cosIncident + z1 * cosTransmitted);
}

double specularLobe(const Transducer& transducer, Tissue surface, double incidenceDeg,
                    double frequencyHz) {
  const std::complex<double> q0 = faceBeamParameter(transducer, frequencyHz);
  const double k = 2.0 * kPi * frequencyHz / (waterSpeedMps() * 1e3);  // 1/mm
  // Tilting a plane mirror by theta in a Gaussian beam of Rayleigh range zR multiplies the
  // pulse-echo overlap by exp(-k zR theta^2), wherever the mirror is.
  const double beamWidthRad = 1.0 / std::sqrt(k * q0.imag());
  const double roughRad = degToRad(surfaceScatter(surface).roughnessDeg);
  const double theta = degToRad(incidenceDeg);
  return std::exp(-theta * theta / (beamWidthRad * beamWidthRad + roughRad * roughRad));
}

double interfaceEcho(const Transducer& transducer, Tissue from, Tissue to, double incidenceDeg,
                     double frequencyHz) {
  const double diffuse = surfaceScatter(to).diffuseFraction;
  return obliqueReflectionCoefficient(from, to, incidenceDeg) * (1.0 - diffuse) *
             specularLobe(transducer, to, incidenceDeg, frequencyHz) +
         reflectionCoefficient(from, to) * diffuse * std::cos(degToRad(incidenceDeg));
}

std::complex<double> focusingResponse(const Transducer& transducer, double waterDepthMm,
                                      double frequencyHz, int roundTrips) {
  // A Gaussian field a exp(-i k r^2 / 2q): propagation by d multiplies a by q / (q + d) and adds
  // d to q; the concave face (radius F) is a mirror of focal length F/2. The received signal is
  // the overlap with the transducer's own field at the face, a q q0 / (q + q0) (times a
  // constant); a plane mirror at depth z gives q0^2 / 2 (q0 + z), largest at the waist z = -Re q0.
  const std::complex<double> q0 = faceBeamParameter(transducer, frequencyHz);
  std::complex<double> q = q0;
  std::complex<double> a = 1.0;
  for (int trip = 0; trip < roundTrips; ++trip) {
    if (trip > 0)
      q = 1.0 / (1.0 / q - 2.0 / transducer.focalLengthMm);
    a *= q / (q + 2.0 * waterDepthMm);
    q += 2.0 * waterDepthMm;
  }
  const std::complex<double> received = a * q * q0 / (q + q0);
  const std::complex<double> atWaist = q0 * q0 / (2.0 * std::complex<double>(0.0, q0.imag()));
  return received / atWaist;
}

void validate(const BeamPath& path, const Transducer& transducer, const Receiver& receiver) {
  require(!path.layers.empty(), "beam path has no layers");
  for (std::size_t i = 0; i < path.layers.size(); ++i) {
    const PathLayer& layer = path.layers[i];
    const std::string name = "layer " + std::to_string(i);
    require(static_cast<std::size_t>(layer.tissue) < static_cast<std::size_t>(Tissue::Count),
            name + " has an unknown tissue");
    const bool last = i + 1 == path.layers.size();
    require(layer.lengthMm > 0.0 &&
                (std::isfinite(layer.lengthMm) ||
                 (last && layer.lengthMm == std::numeric_limits<double>::infinity())),
            name + " length must be > 0 mm and finite (only the last may be infinite), got " +
                core::number(layer.lengthMm, "%.6g"));
    require(layer.exitIncidenceDeg >= 0.0 && layer.exitIncidenceDeg <= 90.0,
            name + " exit incidence must be in [0, 90] degrees, got " +
                core::number(layer.exitIncidenceDeg, "%.6g"));
    require(std::isfinite(layer.speedMps) && layer.speedMps >= 0.0,
            name + " speed of sound must be >= 0 m/s (0 = the table's), got " +
                core::number(layer.speedMps, "%.6g"));
  }
  for (std::size_t i = 0; i < path.fasciaDepthsMm.size(); ++i) {
    require(std::isfinite(path.fasciaDepthsMm[i]) && path.fasciaDepthsMm[i] >= 0.0,
            "fascia depth " + std::to_string(i) + " must be finite and >= 0 mm, got " +
                core::number(path.fasciaDepthsMm[i], "%.6g"));
  }
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  require(
      positive(transducer.centreFrequencyHz),
      "centre frequency must be > 0 Hz, got " + core::number(transducer.centreFrequencyHz, "%.6g"));
  require(positive(transducer.fractionalBandwidth) && transducer.fractionalBandwidth <= 2.0,
          "fractional bandwidth must be in (0, 2], got " +
              core::number(transducer.fractionalBandwidth, "%.6g"));
  require(
      positive(transducer.elementDiameterMm),
      "element diameter must be > 0 mm, got " + core::number(transducer.elementDiameterMm, "%.6g"));
  require(positive(transducer.focalLengthMm),
          "focal length must be > 0 mm, got " + core::number(transducer.focalLengthMm, "%.6g"));
  require(std::isfinite(transducer.ringDownAmplitude) && transducer.ringDownAmplitude >= 0.0,
          "ring-down amplitude must be >= 0, got " +
              core::number(transducer.ringDownAmplitude, "%.6g"));
  require(positive(transducer.ringDownDurationUs),
          "ring-down duration must be > 0 us, got " +
              core::number(transducer.ringDownDurationUs, "%.6g"));
  require(
      transducer.faceReflection >= 0.0 && transducer.faceReflection <= 1.0,
      "face reflection must be in [0, 1], got " + core::number(transducer.faceReflection, "%.6g"));
  require(std::isfinite(transducer.muscleSpeckle) && transducer.muscleSpeckle >= 0.0,
          "muscle speckle must be >= 0, got " + core::number(transducer.muscleSpeckle, "%.6g"));
  require(positive(receiver.samplingFrequencyHz),
          "sampling frequency must be > 0 Hz, got " +
              core::number(receiver.samplingFrequencyHz, "%.6g"));
  require(transducer.centreFrequencyHz < 0.5 * receiver.samplingFrequencyHz,
          "centre frequency " + core::number(transducer.centreFrequencyHz, "%.6g") +
              " Hz must be below half the sampling frequency");
  require(receiver.samples >= 1 && receiver.samples <= (1 << 24),
          "samples must be in [1, 16777216], got " + std::to_string(receiver.samples));
  require(std::isfinite(receiver.delayS) && receiver.delayS >= 0.0,
          "delay must be >= 0 s, got " + core::number(receiver.delayS, "%.6g"));
  require(std::isfinite(receiver.gainDb) && std::fabs(receiver.gainDb) <= 200.0,
          "gain must be in [-200, 200] dB, got " + core::number(receiver.gainDb, "%.6g"));
  require(std::isfinite(receiver.electronicNoiseCounts) && receiver.electronicNoiseCounts >= 0.0,
          "electronic noise must be >= 0 counts, got " +
              core::number(receiver.electronicNoiseCounts, "%.6g"));
  require(
      positive(receiver.unitEchoCountsAt0Db),
      "unit echo counts must be > 0, got " + core::number(receiver.unitEchoCountsAt0Db, "%.6g"));
  require(
      std::isfinite(transducer.ringDownTailAmplitude) && transducer.ringDownTailAmplitude >= 0.0,
      "ring-down tail amplitude must be >= 0, got " +
          core::number(transducer.ringDownTailAmplitude, "%.6g"));
  require(positive(transducer.ringDownTailDurationUs),
          "ring-down tail duration must be > 0 us, got " +
              core::number(transducer.ringDownTailDurationUs, "%.6g"));
  require(receiver.adc == AdcFormat::UInt8 || receiver.adc == AdcFormat::Int16Left12,
          "unknown ADC format");
  require(
      std::isfinite(receiver.dcOffset) && std::fabs(receiver.dcOffset) <= 32768.0,
      "DC offset must be within the int16 range, got " + core::number(receiver.dcOffset, "%.6g"));
  require(std::isfinite(receiver.baselineWanderMin) && receiver.baselineWanderMin >= 0.0 &&
              std::isfinite(receiver.baselineWanderMax) &&
              receiver.baselineWanderMax >= receiver.baselineWanderMin,
          "baseline wander must be 0 <= min <= max, got " +
              core::number(receiver.baselineWanderMin, "%.6g") + " and " +
              core::number(receiver.baselineWanderMax, "%.6g"));
  require(positive(receiver.baselineWanderMinHz) &&
              receiver.baselineWanderMaxHz >= receiver.baselineWanderMinHz &&
              receiver.baselineWanderMaxHz < 0.5 * receiver.samplingFrequencyHz,
          "baseline wander frequencies must be 0 < min <= max < half the sampling frequency, got " +
              core::number(receiver.baselineWanderMinHz, "%.6g") + " and " +
              core::number(receiver.baselineWanderMaxHz, "%.6g"));
}

void useInt16FrontEnd(Transducer& transducer, Receiver& receiver, double dcOffset) {
  receiver.adc = AdcFormat::Int16Left12;
  receiver.dcOffset = dcOffset;
  receiver.baselineWanderMin = 1000.0;
  receiver.baselineWanderMax = 3000.0;
  receiver.baselineWanderMinHz = 20e3;
  receiver.baselineWanderMaxHz = 200e3;
  transducer.ringDownDurationUs = 0.5;
  transducer.ringDownTailAmplitude = 0.02;
  transducer.ringDownTailDurationUs = 4.0;
}

ALine simulateALine(const BeamPath& path, const Transducer& transducer, const Receiver& receiver,
                    core::Rng& rng) {
  validate(path, transducer, receiver);
  const double fs = receiver.samplingFrequencyHz;
  const double fc = transducer.centreFrequencyHz;
  const double fcMHz = fc * 1e-6;
  const double sigmaHz =
      transducer.fractionalBandwidth * fc / (2.0 * std::sqrt(2.0 * std::log(2.0)));
  const Pulse pulse(fs, sigmaHz);
  const double counts = receiver.unitEchoCountsAt0Db * std::pow(10.0, receiver.gainDb / 20.0);
  const double recordEndS = receiver.delayS + receiver.samples / fs;
  const double waterSpeed = waterSpeedMps();
  const auto& layers = path.layers;
  const std::size_t layerCount = layers.size();

  // The beam ends at the first bone, steel or air layer; before it, layers propagate.
  std::size_t end = layerCount;
  for (std::size_t i = 0; i < layerCount; ++i) {
    if (endsBeam(layers[i].tissue)) {
      end = i;
      break;
    }
  }

  // Septa: inside skin, fat or muscle before the end; each with its own strength.
  struct Sheet {
    double depthMm;
    std::size_t layer;
    double reflection;
  };
  std::vector<Sheet> sheets;
  {
    double start = 0.0;
    std::vector<double> depths = path.fasciaDepthsMm;
    std::vector<double> strengths;
    strengths.reserve(depths.size());
    for (std::size_t i = 0; i < depths.size(); ++i) {
      strengths.push_back(kFasciaReflection * rng.uniform(0.6, 1.4));
    }
    for (std::size_t layer = 0; layer < end; ++layer) {
      const double stop = start + layers[layer].lengthMm;
      if (holdsFascia(layers[layer].tissue)) {
        for (std::size_t i = 0; i < depths.size(); ++i) {
          if (depths[i] > start && depths[i] < stop)
            sheets.push_back({depths[i], layer, strengths[i]});
        }
      }
      start = stop;
    }
    std::sort(sheets.begin(), sheets.end(),
              [](const Sheet& x, const Sheet& y) { return x.depthMm < y.depthMm; });
  }

  // Walk the layers: start depth, one-way time, water-equivalent depth, loss and two-way
  // transmission at the start of each.
  struct LayerStart {
    double depthMm = 0.0;
    double oneWayS = 0.0;
    double waterDepthMm = 0.0;
    Loss loss;
    double transmission = 1.0;  // through the interfaces before it (septa apart)
  };
  std::vector<LayerStart> starts(layerCount + 1);
  std::vector<Reflector> reflectors;
  ALine line;
  const std::size_t interfaces = std::min(end, layerCount - 1);
  for (std::size_t i = 0; i < end; ++i) {
    const PathLayer& layer = layers[i];
    const double speed = layerSpeed(layer);
    LayerStart next = starts[i];
    const double length = std::min(layer.lengthMm, 1e6);  // the infinite last layer
    next.depthMm += length;
    next.oneWayS += length * 1e-3 / speed;
    next.waterDepthMm += length * speed / waterSpeed;
    next.loss.add(layer.tissue, 2.0 * length, fcMHz);
    if (i < interfaces) {
      const Tissue to = layers[i + 1].tissue;
      const double r = obliqueReflectionCoefficient(layer.tissue, to, layer.exitIncidenceDeg);
      const double echo = interfaceEcho(transducer, layer.tissue, to, layer.exitIncidenceDeg,
                                        applyLoss(next.loss, fc, sigmaHz).frequencyHz);
      double sheetTransmission = 1.0;
      for (const Sheet& sheet : sheets) {
        if (sheet.layer <= i)
          sheetTransmission *= 1.0 - sheet.reflection * sheet.reflection;
      }
      reflectors.push_back({2.0 * next.oneWayS, next.waterDepthMm,
                            echo * next.transmission * sheetTransmission, next.loss,
                            i + 1 == end && isTarget(to)});
      next.transmission *= 1.0 - r * r;
    }
    starts[i + 1] = next;
  }
  for (const Sheet& sheet : sheets) {
    const LayerStart& s = starts[sheet.layer];
    const Tissue tissue = layers[sheet.layer].tissue;
    const double speed = layerSpeed(layers[sheet.layer]);
    const double into = sheet.depthMm - s.depthMm;
    Loss loss = s.loss;
    loss.add(tissue, 2.0 * into, fcMHz);
    double sheetTransmission = 1.0;
    for (const Sheet& other : sheets) {
      if (other.depthMm < sheet.depthMm)
        sheetTransmission *= 1.0 - other.reflection * other.reflection;
    }
    reflectors.push_back({2.0 * (s.oneWayS + into * 1e-3 / speed),
                          s.waterDepthMm + into * speed / waterSpeed,
                          sheet.reflection * s.transmission * sheetTransmission, loss, false});
  }

  // Ground truth of the target.
  const auto samples = static_cast<std::size_t>(receiver.samples);
  std::vector<double> record(samples, 0.0);
  std::vector<double> targetEcho(samples, 0.0);
  if (end < layerCount && isTarget(layers[end].tissue)) {
    line.targetLayer = static_cast<int>(end);
    line.timeOfFlightS = 2.0 * starts[end].oneWayS;
    line.targetEchoSample = (line.timeOfFlightS - receiver.delayS) * fs;
    if (starts[end].oneWayS > 0.0) {
      line.meanSpeedOfSoundMps = starts[end].depthMm * 1e-3 / starts[end].oneWayS;
    }
  }

  // Specular echoes and their multiples between face and reflector.
  for (const Reflector& reflector : reflectors) {
    for (int k = 1; k <= 64; ++k) {
      if (k * reflector.roundTripS > recordEndS + pulse.halfLength() / fs)
        break;
      if (reflector.loss.alpha0Np * k > kNegligibleLossNp)
        break;
      const EchoInstance echo = echoOf(reflector, k, transducer, receiver, sigmaHz);
      const double amplitude = std::abs(echo.amplitude) * counts;
      if (amplitude < 1e-3)
        break;
      pulse.add(record, echo.sample, amplitude, echo.frequencyHz, std::arg(echo.amplitude));
      if (reflector.target && k == 1) {
        pulse.add(targetEcho, echo.sample, amplitude, echo.frequencyHz, std::arg(echo.amplitude));
        line.targetEchoAmplitude = amplitude;
      }
    }
  }

  // Speckle: white scatterers on the sample grid, filtered by the local pulse, RMS from the
  // tissue's backscatter, the attenuation, the transmission and the beam's focusing.
  for (std::size_t i = 0; i < end; ++i) {
    const Tissue tissue = layers[i].tissue;
    const double backscatter = properties(tissue).backscatter;
    if (backscatter <= 0.0 || transducer.muscleSpeckle <= 0.0)
      continue;
    const LayerStart& s = starts[i];
    const double speed = layerSpeed(layers[i]);
    const double beginS = 2.0 * s.oneWayS;
    const double endS = std::min(2.0 * starts[i + 1].oneWayS, recordEndS + pulse.halfLength() / fs);
    const double firstSample = std::ceil((beginS - receiver.delayS) * fs);
    const double lastSample = (endS - receiver.delayS) * fs;
    for (double sample = std::max(firstSample, -static_cast<double>(pulse.halfLength()));
         sample < lastSample; sample += 1.0) {
      const double t = sample / fs + receiver.delayS;
      const double into = (0.5 * t - s.oneWayS) * speed * 1e3;  // mm into the layer
      Loss loss = s.loss;
      loss.add(tissue, 2.0 * into, fcMHz);
      if (loss.alpha0Np > kNegligibleLossNp)
        break;
      double transmission = s.transmission;
      for (const Sheet& sheet : sheets) {
        if (sheet.depthMm < s.depthMm + into)
          transmission *= 1.0 - sheet.reflection * sheet.reflection;
      }
      const Shifted shifted = applyLoss(loss, fc, sigmaHz);
      const double focus = std::abs(focusingResponse(
          transducer, s.waterDepthMm + into * speed / waterSpeed, shifted.frequencyHz));
      const double rms = transducer.muscleSpeckle * backscatter * shifted.amplitude * transmission *
                         focus * counts;
      const double scatterer = rng.normal() * rms / std::sqrt(pulse.energy(shifted.frequencyHz));
      pulse.add(record, sample, scatterer, shifted.frequencyHz, 0.0);
    }
  }

  // Ring-down: the excitation and the element ringing, the same every shot; a slower tail under
  // it when the transducer has one.
  const double tau = transducer.ringDownDurationUs * 1e-6 / std::log(1000.0);
  const double ringPeak = transducer.ringDownAmplitude * counts;
  for (std::size_t i = 0; i < samples; ++i) {
    const double t = static_cast<double>(i) / fs + receiver.delayS;
    const double envelope = ringPeak * std::exp(-t / tau);
    if (envelope < 1e-3)
      break;
    record[i] += envelope * std::cos(2.0 * kPi * fc * t);
  }
  const double tailTau = transducer.ringDownTailDurationUs * 1e-6 / std::log(1000.0);
  const double tailPeak = transducer.ringDownTailAmplitude * counts;
  if (tailPeak > 0.0) {
    for (std::size_t i = 0; i < samples; ++i) {
      const double t = static_cast<double>(i) / fs + receiver.delayS;
      const double envelope = tailPeak * std::exp(-t / tailTau);
      if (envelope < 1e-3)
        break;
      record[i] += envelope * std::cos(2.0 * kPi * fc * t);
    }
  }
  {
    const double floor = std::max(receiver.electronicNoiseCounts, 0.5);
    double endS = ringPeak > floor ? tau * std::log(ringPeak / floor) : 0.0;
    if (tailPeak > floor)
      endS = std::max(endS, tailTau * std::log(tailPeak / floor));
    line.ringDownEndSample =
        std::clamp(static_cast<int>(std::ceil((endS - receiver.delayS) * fs)), 0, receiver.samples);
  }

  // Electronic noise, then the card: 8 bits around mid-scale, or 12 bits in int16, clipped.
  if (receiver.electronicNoiseCounts > 0.0) {
    for (double& v : record)
      v += rng.normal() * receiver.electronicNoiseCounts;
  }
  if (receiver.adc == AdcFormat::UInt8) {
    line.samples.resize(samples);
    for (std::size_t i = 0; i < samples; ++i) {
      line.samples[i] =
          static_cast<std::uint8_t>(std::clamp(128L + std::lround(record[i]), 0L, 255L));
    }
  } else {
    // 12 bits left-justified in int16: the front end's DC offset and the baseline's slow wander
    // join the signal before the card, which keeps 16 int16 units per code.
    const double wander = rng.uniform(receiver.baselineWanderMin, receiver.baselineWanderMax);
    const double wanderHz = rng.uniform(receiver.baselineWanderMinHz, receiver.baselineWanderMaxHz);
    const double wanderPhase = rng.uniform(0.0, 2.0 * kPi);
    line.int16Samples.resize(samples);
    for (std::size_t i = 0; i < samples; ++i) {
      const double t = static_cast<double>(i) / fs + receiver.delayS;
      const double value = record[i] * kInt16PerCount + receiver.dcOffset +
                           wander * std::sin(2.0 * kPi * wanderHz * t + wanderPhase);
      const long code = std::clamp(std::lround(value / 16.0), -2048L, 2047L);
      line.int16Samples[i] = static_cast<std::int16_t>(code * 16);
    }
  }

  // Clutter around the target echo: RMS of everything else in the 2 us before and after the
  // echo's pulse (the larger of the two), and the rule for a clear echo.
  if (line.targetLayer >= 0) {
    const double t0 = line.targetEchoSample;
    const double half = 4.0 * pulse.sigmaSamples();
    const double window = 2e-6 * fs;
    const auto rmsOver = [&](double from, double to) {
      const auto first = static_cast<long>(std::max(0.0, std::ceil(from)));
      const auto last = static_cast<long>(std::min(static_cast<double>(samples), std::floor(to)));
      double sum = 0.0;
      long n = 0;
      for (long i = first; i < last; ++i) {
        const auto index = static_cast<std::size_t>(i);
        const double clutter = record[index] - targetEcho[index];
        sum += clutter * clutter;
        ++n;
      }
      return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : receiver.electronicNoiseCounts;
    };
    line.clutterRmsAtTarget =
        std::max(rmsOver(t0 - half - window, t0 - half), rmsOver(t0 + half, t0 + half + window));
    const bool afterRingDown = t0 - half >= line.ringDownEndSample;
    const bool insideRecord = t0 + half + kClearShadowRoomS * fs <= receiver.samples;
    line.targetClear = afterRingDown && insideRecord &&
                       line.targetEchoAmplitude >= kClearMinimumCounts &&
                       line.targetEchoAmplitude >= kClearContrast * line.clutterRmsAtTarget;
  }
  return line;
}

}  // namespace echoreg::simulation
