#include "physical_alines.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>

namespace echoreg::test {

std::vector<LabelledRecord> PhysicalCapture::labelled() const {
  std::vector<LabelledRecord> records;
  records.reserve(frames.size());
  for (const PhysicalFrame& frame : frames) {
    LabelledRecord record;
    record.samples = &frame.samples;
    record.hasBone = frame.hasBone;
    record.ambiguous = frame.ambiguous;
    record.boneDepthMm = frame.boneDepthMm;
    records.push_back(record);
  }
  return records;
}

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kNepersPerDb = 1.0 / 8.685889638;

// Own distributions (not std::normal_distribution) so the bytes do not depend on the library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return double(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  double normal() {
    const double radius = std::sqrt(-2.0 * std::log(1.0 - uniform()));
    return radius * std::cos(2.0 * kPi * uniform());
  }
  bool chance(double probability) { return uniform() < probability; }
  int integer(int low, int high) {
    return std::min(high, low + static_cast<int>(uniform() * (high - low + 1)));
  }

 private:
  std::mt19937_64 engine_;
};

struct Layer {
  std::string name;
  double thicknessMm = 0.0;
  double speedMps = 1540.0;
  double densityKgM3 = 1000.0;
  double attenuationDbCmMhz = 0.0;  ///< one-way amplitude
  double scattererDensityPerMm2 = 0.0;
  double backscatterDb = -100.0;  ///< speckle rms re a perfect reflector at the same depth
  double fasciaReflection = 0.0;  ///< added to the reflection at the layer's top
  double waveAmplitudeMm = 0.0;   ///< lateral thickness variation
  double waveLengthMm = 20.0;
  double wavePhase = 0.0;

  double impedance() const { return speedMps * densityKgM3; }
};

struct Scatterer {
  double xMm = 0.0;
  int layer = 0;          ///< soft layer index; -1: the bone surface
  double fraction = 0.0;  ///< depth within the layer (0..1); surface: height in mm
  double amplitude = 0.0;
};

// Everything drawn for one capture.
struct Recipe {
  std::string name;
  double f0Hz = 7e6;
  double bandwidth = 0.6;
  double fsHz = 50e6;
  int samples = 2000;
  double delayS = 0.0;
  double assumedSpeedMps = 1540.0;
  int bits = 12;
  bool isSigned = true;
  bool leftJustified = false;
  std::optional<double> windowMinMm;
  std::optional<double> windowMaxMm;
  double beyondRecordFraction = 0.0;  ///< > 0: the record ends at this share of the bone's time

  std::vector<Layer> layers;
  double boneLeftMm = -1e9;
  double boneRightMm = 1e9;
  double shapeCentreMm = 0.0;
  double slopeDeg = 0.0;
  double undulationMm = 60.0;  ///< wavelength of the long undulation
  double bumpAmplitudeMm[2] = {0.0, 0.0};
  double bumpLengthMm[2] = {10.0, 10.0};
  double bumpPhase[2] = {0.0, 0.0};
  double outOfPlaneDeg = 0.0;
  double wobbleDeg = 0.0;
  double wobbleHz = 1.0;
  double boneSpeedMps = 3500.0;
  double boneDensityKgM3 = 1900.0;
  double boneAttenuationDbCmMhz = 12.0;
  double marrowSpeedMps = 1450.0;
  double marrowDensityKgM3 = 950.0;
  double corticalMm = 2.0;
  double roughnessMm = 0.01;
  double angleToleranceDeg = 6.0;
  double diffuseShare = 0.3;
  double beamRadiusMm = 0.8;
  double faceReflection = 0.4;

  int frames = 100;
  double frameRateHz = 50.0;
  double startXMm = 0.0;
  double speedMmS = 0.0;
  double slipMm = 0.0;
  double slipHz = 0.5;
  double compression = 0.0;
  double compressionHz = 1.0;
  std::vector<char> uncoupled;

  double snrDb = 30.0;
  double referenceFs = 0.5;  ///< nominal bone echo, share of full scale
  double ringDownS = 1e-6;
  double ringDownFs = 1.0;
  double ringFallS = 0.15e-6;
  double tailFs = 0.05;
  double tailS = 1e-6;
  double tailHz = 0.5e6;
  double tgcDbPerUs = 0.0;
  double wanderFs = 0.0;
  double wanderHz = 100e3;
  double toneFs = 0.0;
  double toneHz = 1e6;
  double burstChance = 0.0;
  double burstFs = 0.0;
  double dcFs = 0.0;
  double facePeriodS = 0.8e-6;
  double faceDecay = 0.7;
};

double spectralSigmaHz(const Recipe& recipe) {
  return recipe.bandwidth * recipe.f0Hz / 2.3548;
}

// The attenuated Gaussian spectrum: centre and peak factor after exp(-a f).
struct Spectrum {
  double centreHz;
  double factor;
};
Spectrum attenuated(const Recipe& recipe, double nepersPerHz) {
  const double sigma = spectralSigmaHz(recipe);
  const double centre = std::max(recipe.f0Hz - nepersPerHz * sigma * sigma, 2.0 * sigma);
  const double shift = centre - recipe.f0Hz;
  return {centre, std::exp(-shift * shift / (2.0 * sigma * sigma) - nepersPerHz * centre)};
}

double nepersPerHz(double dbCmMhz, double thicknessMm) {
  return 2.0 * (thicknessMm / 10.0) * dbCmMhz * kNepersPerDb / 1e6;  // round trip
}

double reflection(double z1, double z2) {
  return (z2 - z1) / (z2 + z1);
}

double tgcGain(const Recipe& recipe, double timeS) {
  return std::pow(10.0, std::min(40.0, recipe.tgcDbPerUs * timeS * 1e6) / 20.0);
}

// The geometry of the soft layers and the bone at the beam's lateral position.
struct Column {
  std::vector<double> thicknessMm;
  std::vector<double> topTimeS;         ///< one-way time to each layer's top
  std::vector<double> topNepers;        ///< round-trip attenuation to each layer's top (Np/Hz)
  std::vector<double> topTransmission;  ///< round-trip amplitude transmission to the layer
  std::vector<double> topReflection;    ///< reflection at each layer's top (0 for the first)
  double boneTimeS = 0.0;
  double boneNepers = 0.0;
  double boneTransmission = 1.0;
};

// Bone relief under the nominal depth (>= 0, so the tissue never thins below its drawn total):
// a long undulation whose steepest slope is `slopeDeg`, and two bumps.
double boneShapeMm(const Recipe& recipe, double xMm) {
  const double dx = xMm - recipe.shapeCentreMm;
  const double longAmplitude =
      std::fabs(std::tan(recipe.slopeDeg * kDegToRad)) * recipe.undulationMm / (2.0 * kPi);
  double shape =
      longAmplitude *
      (1.0 + std::sin(2.0 * kPi * dx / recipe.undulationMm + (recipe.slopeDeg < 0.0 ? kPi : 0.0)));
  for (int i = 0; i < 2; ++i)
    shape += recipe.bumpAmplitudeMm[i] *
             (1.0 + std::sin(2.0 * kPi * xMm / recipe.bumpLengthMm[i] + recipe.bumpPhase[i]));
  return shape;
}

Column columnAt(const Recipe& recipe, double xMm, double compressionFactor) {
  Column column;
  const std::size_t count = recipe.layers.size();
  double time = 0.0;
  double nepers = 0.0;
  double transmission = 1.0;
  for (std::size_t j = 0; j < count; ++j) {
    const Layer& layer = recipe.layers[j];
    double thickness =
        layer.thicknessMm * compressionFactor +
        layer.waveAmplitudeMm * std::sin(2.0 * kPi * xMm / layer.waveLengthMm + layer.wavePhase);
    if (j + 1 == count)
      thickness += boneShapeMm(recipe, xMm);
    thickness = std::max(thickness, j + 1 == count ? 0.3 : 0.05);
    double r = 0.0;
    if (j > 0) {
      r = reflection(recipe.layers[j - 1].impedance(), layer.impedance());
      r += r >= 0.0 ? layer.fasciaReflection : -layer.fasciaReflection;
      transmission *= 1.0 - r * r;
    }
    column.thicknessMm.push_back(thickness);
    column.topTimeS.push_back(time);
    column.topNepers.push_back(nepers);
    column.topTransmission.push_back(transmission);
    column.topReflection.push_back(r);
    time += thickness / 1000.0 / layer.speedMps;
    nepers += nepersPerHz(layer.attenuationDbCmMhz, thickness);
  }
  column.boneTimeS = time;
  column.boneNepers = nepers;
  column.boneTransmission = transmission;
  return column;
}

double boneSurfaceDepthMm(const Recipe& recipe, double xMm, double compressionFactor) {
  const Column column = columnAt(recipe, xMm, compressionFactor);
  double depth = 0.0;
  for (double thickness : column.thicknessMm)
    depth += thickness;
  return depth;
}

struct Echo {
  double timeS;  ///< two-way, from the transmission
  double amplitude;
  double nepers;
};

// Adds the analytic pulse of `echo` to `signal` (sample n at delay + n / fs).
void render(const Recipe& recipe, const Echo& echo, std::vector<std::complex<double>>& signal,
            double* peakEnvelope = nullptr) {
  const Spectrum spectrum = attenuated(recipe, echo.nepers);
  const double amplitude = echo.amplitude * spectrum.factor;
  if (peakEnvelope)
    *peakEnvelope = std::fabs(amplitude);
  const double width = 1.0 / (2.0 * kPi * spectralSigmaHz(recipe));
  const double dt = 1.0 / recipe.fsHz;
  const int first = std::max(
      0, static_cast<int>(std::ceil((echo.timeS - 4.0 * width - recipe.delayS) * recipe.fsHz)));
  const int last = std::min(
      static_cast<int>(signal.size()) - 1,
      static_cast<int>(std::floor((echo.timeS + 4.0 * width - recipe.delayS) * recipe.fsHz)));
  if (first > last)
    return;
  const double t0 = recipe.delayS + first * dt - echo.timeS;
  const double twoVar = 2.0 * width * width;
  double gaussian = amplitude * std::exp(-t0 * t0 / twoVar);
  double ratio = std::exp(-(2.0 * t0 * dt + dt * dt) / twoVar);
  const double ratioStep = std::exp(-2.0 * dt * dt / twoVar);
  std::complex<double> phasor = std::polar(1.0, 2.0 * kPi * spectrum.centreHz * t0);
  const std::complex<double> rotation = std::polar(1.0, 2.0 * kPi * spectrum.centreHz * dt);
  for (int n = first; n <= last; ++n) {
    signal[static_cast<std::size_t>(n)] += gaussian * phasor;
    gaussian *= ratio;
    ratio *= ratioStep;
    phasor *= rotation;
  }
}

// Soft-tissue scatterers over the lateral range the beam visits, sorted by x; and the bone's
// surface scatterers (the diffuse part).
struct ScattererField {
  std::vector<Scatterer> tissue;
  std::vector<Scatterer> surface;
};

double axialCellMm(const Recipe& recipe, double speedMps) {
  const double width = 1.0 / (2.0 * kPi * spectralSigmaHz(recipe));
  return std::sqrt(kPi) * width * speedMps * 1000.0 / 2.0;
}

ScattererField scatterField(const Recipe& recipe, Random& rng) {
  double lowX = recipe.startXMm;
  double highX = recipe.startXMm;
  for (int f = 0; f < recipe.frames; ++f) {
    const double x = recipe.startXMm + recipe.speedMmS * f / recipe.frameRateHz;
    lowX = std::min(lowX, x);
    highX = std::max(highX, x);
  }
  lowX -= recipe.slipMm + 3.0 * recipe.beamRadiusMm;
  highX += recipe.slipMm + 3.0 * recipe.beamRadiusMm;
  ScattererField field;
  const double beamArea = recipe.beamRadiusMm * std::sqrt(kPi / 2.0);
  for (std::size_t j = 0; j < recipe.layers.size(); ++j) {
    const Layer& layer = recipe.layers[j];
    if (layer.scattererDensityPerMm2 <= 0.0)
      continue;
    const double meanThickness = layer.thicknessMm + (j + 1 == recipe.layers.size() ? 2.0 : 0.0);
    const int count =
        static_cast<int>(layer.scattererDensityPerMm2 * meanThickness * (highX - lowX));
    const double strength =
        std::pow(10.0, layer.backscatterDb / 20.0) /
        std::sqrt(layer.scattererDensityPerMm2 * beamArea * axialCellMm(recipe, layer.speedMps));
    for (int i = 0; i < count; ++i)
      field.tissue.push_back(
          {rng.uniform(lowX, highX), static_cast<int>(j), rng.uniform(), strength * rng.normal()});
  }
  const double surfaceDensity = 20.0;
  const double surfaceStrength =
      std::sqrt(recipe.diffuseShare / (surfaceDensity * recipe.beamRadiusMm * std::sqrt(kPi / 2)));
  const double left = std::max(lowX, recipe.boneLeftMm);
  const double right = std::min(highX, recipe.boneRightMm);
  for (int i = 0; i < static_cast<int>(surfaceDensity * std::max(0.0, right - left)); ++i)
    field.surface.push_back({rng.uniform(left, right), -1, recipe.roughnessMm * rng.normal(),
                             surfaceStrength * rng.normal()});
  const auto byX = [](const Scatterer& a, const Scatterer& b) { return a.xMm < b.xMm; };
  std::sort(field.tissue.begin(), field.tissue.end(), byX);
  std::sort(field.surface.begin(), field.surface.end(), byX);
  return field;
}

// Nominal bone echo (normal incidence, whole beam on bone, centre of the sweep): sets the gain.
double nominalBoneEcho(const Recipe& recipe) {
  const double x = recipe.startXMm + 0.5 * recipe.speedMmS * recipe.frames / recipe.frameRateHz;
  const Column column = columnAt(recipe, x, 1.0);
  const Layer& last = recipe.layers.back();
  const double r = reflection(last.impedance(), recipe.boneSpeedMps * recipe.boneDensityKgM3);
  return std::fabs(r) * column.boneTransmission * attenuated(recipe, column.boneNepers).factor;
}

double nominalBoneTimeS(const Recipe& recipe) {
  const double x = recipe.startXMm + 0.5 * recipe.speedMmS * recipe.frames / recipe.frameRateHz;
  return 2.0 * columnAt(recipe, x, 1.0).boneTimeS;
}

struct InterferenceBurst {
  int first;
  int last;
  double amplitudeFs;
  double frequencyHz;
};

PhysicalFrame renderFrame(const Recipe& recipe, const ScattererField& field, int frameIndex,
                          double gain, double noiseSigma, Random& rng) {
  const std::size_t n = static_cast<std::size_t>(recipe.samples);
  const double fs = recipe.fsHz;
  const double timeS = frameIndex / recipe.frameRateHz;
  const double x = recipe.startXMm + recipe.speedMmS * timeS +
                   recipe.slipMm * std::sin(2.0 * kPi * recipe.slipHz * timeS);
  const double squeeze =
      1.0 + recipe.compression * std::sin(2.0 * kPi * recipe.compressionHz * timeS);
  const double w = recipe.beamRadiusMm;
  const double mmPerSample = recipe.assumedSpeedMps * 1000.0 / (2.0 * fs);
  const auto sampleTime = [&](std::size_t i) { return recipe.delayS + double(i) / fs; };

  std::vector<std::complex<double>> bone(n);
  std::vector<std::complex<double>> other(n);
  double strongestInterfaceFs = 0.0;
  const bool uncoupled = recipe.uncoupled[static_cast<std::size_t>(frameIndex)] != 0;
  const Column column = columnAt(recipe, x, squeeze);
  const double boneTime = 2.0 * column.boneTimeS;
  double coverage = 0.0;
  double incidenceDeg = 0.0;

  if (uncoupled) {
    // Air at the face: its ringing train, nothing from the tissue.
    double amplitude = 1.0;
    for (int k = 1; k <= 14; ++k) {
      amplitude *= recipe.faceDecay;
      render(recipe, {k * recipe.facePeriodS, (k % 2 ? -1.0 : 1.0) * amplitude, 0.0}, other);
    }
  } else {
    std::vector<Echo> strongEchoes;
    // Interfaces between soft layers (fascia included).
    for (std::size_t j = 1; j < recipe.layers.size(); ++j) {
      const double r = column.topReflection[j];
      const Echo echo{2.0 * column.topTimeS[j], r * column.topTransmission[j - 1],
                      column.topNepers[j]};
      double peak = 0.0;
      render(recipe, echo, other, &peak);
      strongestInterfaceFs =
          std::max(strongestInterfaceFs, peak * gain * tgcGain(recipe, echo.timeS));
      if (std::fabs(r) > 0.1)
        strongEchoes.push_back(echo);
    }
    // Tissue speckle.
    const auto firstNear =
        std::lower_bound(field.tissue.begin(), field.tissue.end(), x - 2.0 * w,
                         [](const Scatterer& s, double value) { return s.xMm < value; });
    for (auto it = firstNear; it != field.tissue.end() && it->xMm <= x + 2.0 * w; ++it) {
      const std::size_t j = static_cast<std::size_t>(it->layer);
      const Layer& layer = recipe.layers[j];
      const double dx = (it->xMm - x) / w;
      const double inside = it->fraction * column.thicknessMm[j];
      render(recipe,
             {2.0 * (column.topTimeS[j] + inside / 1000.0 / layer.speedMps),
              it->amplitude * std::exp(-dx * dx) * column.topTransmission[j],
              column.topNepers[j] + nepersPerHz(layer.attenuationDbCmMhz, inside)},
             other);
    }
    // Bone: specular and diffuse parts of the surface, the cortex's inner echoes, the marrow.
    const Layer& last = recipe.layers.back();
    const double boneImpedance = recipe.boneSpeedMps * recipe.boneDensityKgM3;
    const double rBone = reflection(last.impedance(), boneImpedance);
    const double slopeAt = (boneSurfaceDepthMm(recipe, x + 0.05, squeeze) -
                            boneSurfaceDepthMm(recipe, x - 0.05, squeeze)) /
                           0.1;
    const double inPlane = std::atan(slopeAt);
    const double outOfPlane =
        (recipe.outOfPlaneDeg + recipe.wobbleDeg * std::sin(2.0 * kPi * recipe.wobbleHz * timeS)) *
        kDegToRad;
    const double incidence = std::sqrt(inPlane * inPlane + outOfPlane * outOfPlane);
    incidenceDeg = incidence / kDegToRad;
    coverage =
        0.5 * (std::erf((recipe.boneRightMm - x) / w) - std::erf((recipe.boneLeftMm - x) / w));
    const Spectrum atBone = attenuated(recipe, column.boneNepers);
    const double k = 2.0 * kPi * atBone.centreHz / (last.speedMps * 1000.0);  // rad/mm
    const double kh = k * recipe.roughnessMm * std::cos(incidence);
    const double coherent = std::exp(-2.0 * kh * kh);
    const double angular =
        std::exp(-std::pow(incidence / (recipe.angleToleranceDeg * kDegToRad), 2));
    const Echo specular{boneTime, rBone * coherent * angular * coverage * column.boneTransmission,
                        column.boneNepers};
    render(recipe, specular, bone);
    if (std::fabs(specular.amplitude) > 0.1)
      strongEchoes.push_back(specular);
    const double diffuseScale = rBone * column.boneTransmission *
                                std::sqrt(1.0 - coherent * coherent) * std::cos(incidence);
    const double surfaceHere = boneSurfaceDepthMm(recipe, x, squeeze);
    const auto firstSurface =
        std::lower_bound(field.surface.begin(), field.surface.end(), x - 2.0 * w,
                         [](const Scatterer& s, double value) { return s.xMm < value; });
    for (auto it = firstSurface; it != field.surface.end() && it->xMm <= x + 2.0 * w; ++it) {
      const double dx = (it->xMm - x) / w;
      const double relief =
          boneSurfaceDepthMm(recipe, it->xMm, squeeze) - surfaceHere + it->fraction;
      render(recipe,
             {boneTime + 2.0 * relief / 1000.0 / last.speedMps,
              diffuseScale * it->amplitude * std::exp(-dx * dx), column.boneNepers},
             bone);
    }
    const double marrowImpedance = recipe.marrowSpeedMps * recipe.marrowDensityKgM3;
    const double rInner = reflection(boneImpedance, marrowImpedance);
    const double cortexTime = 2.0 * recipe.corticalMm / 1000.0 / recipe.boneSpeedMps;
    const double cortexNepers = nepersPerHz(recipe.boneAttenuationDbCmMhz, recipe.corticalMm);
    const double intoBone = (1.0 - rBone * rBone) * angular * coverage * column.boneTransmission;
    render(recipe, {boneTime + cortexTime, intoBone * rInner, column.boneNepers + cortexNepers},
           other);
    render(recipe,
           {boneTime + 2.0 * cortexTime, intoBone * rInner * rInner * -rBone,
            column.boneNepers + 2.0 * cortexNepers},
           other);
    const double intoMarrow = intoBone * (1.0 - rInner * rInner);
    for (int i = 0; i < 30; ++i) {
      const double behindMm = rng.uniform(0.0, 5.0);
      render(recipe,
             {boneTime + cortexTime + 2.0 * behindMm / 1000.0 / recipe.marrowSpeedMps,
              0.03 * intoMarrow * rng.normal(),
              column.boneNepers + cortexNepers + nepersPerHz(1.5, behindMm)},
             other);
    }
    // Reverberation between the face and the strong interfaces (second and third order).
    for (const Echo& echo : strongEchoes) {
      const double sign = recipe.faceReflection;
      render(recipe, {2.0 * echo.timeS, sign * echo.amplitude * echo.amplitude, 2.0 * echo.nepers},
             other);
      render(recipe,
             {3.0 * echo.timeS, sign * sign * std::pow(echo.amplitude, 3), 3.0 * echo.nepers},
             other);
    }
  }

  // Electronics: receiver noise before the TGC, then the ring-down, baseline, interference, DC.
  std::vector<double> analog(n);
  std::vector<double> otherEnvelopeFs(n);
  std::vector<double> boneEnvelopeFs(n);
  std::vector<double> ringEnvelopeFs(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double g = gain * tgcGain(recipe, sampleTime(i));
    analog[i] = (bone[i].real() + other[i].real() + noiseSigma * rng.normal()) * g;
    otherEnvelopeFs[i] = std::abs(other[i]) * g;
    boneEnvelopeFs[i] = std::abs(bone[i]) * g;
  }
  const double ringPhase = rng.uniform(-0.2, 0.2);
  const double wanderPhase = 0.9 * frameIndex + rng.uniform(-0.1, 0.1);
  const double tonePhase = rng.uniform(0.0, 2.0 * kPi);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = sampleTime(i);
    double ring = t < recipe.ringDownS ? std::min(1.0, t / 0.1e-6)
                                       : std::exp(-(t - recipe.ringDownS) / recipe.ringFallS);
    ring *= recipe.ringDownFs;
    ringEnvelopeFs[i] = ring;
    analog[i] += ring * std::cos(2.0 * kPi * recipe.f0Hz * t + ringPhase);
    if (t >= recipe.ringDownS)
      analog[i] += recipe.tailFs * std::exp(-(t - recipe.ringDownS) / recipe.tailS) *
                   std::cos(2.0 * kPi * recipe.tailHz * (t - recipe.ringDownS));
    analog[i] += recipe.wanderFs *
                 (std::sin(2.0 * kPi * recipe.wanderHz * t + wanderPhase) +
                  0.5 * std::sin(2.0 * kPi * 0.37 * recipe.wanderHz * t + 1.7 * wanderPhase));
    analog[i] += recipe.toneFs * std::sin(2.0 * kPi * recipe.toneHz * t + tonePhase) + recipe.dcFs;
  }
  std::optional<InterferenceBurst> burst;
  if (rng.chance(recipe.burstChance)) {
    const int length = static_cast<int>(rng.uniform(0.3e-6, 3e-6) * fs);
    const int first = rng.integer(0, std::max(0, static_cast<int>(n) - length - 1));
    burst = InterferenceBurst{first, std::min(static_cast<int>(n) - 1, first + length),
                              recipe.burstFs * rng.uniform(0.3, 1.0), rng.uniform(1e6, 0.4 * fs)};
    for (int i = burst->first; i <= burst->last; ++i) {
      const double hann = 0.5 - 0.5 * std::cos(2.0 * kPi * (i - burst->first) /
                                               std::max(1, burst->last - burst->first));
      const std::size_t index = static_cast<std::size_t>(i);
      analog[index] +=
          burst->amplitudeFs * hann * std::sin(2.0 * kPi * burst->frequencyHz * sampleTime(index));
      otherEnvelopeFs[index] = std::max(otherEnvelopeFs[index], burst->amplitudeFs * hann);
    }
  }

  // Digitiser.
  PhysicalFrame frame;
  frame.samples.resize(n);
  const double half = std::ldexp(1.0, recipe.bits - 1);
  const double justify = recipe.leftJustified ? std::ldexp(1.0, 16 - recipe.bits) : 1.0;
  for (std::size_t i = 0; i < n; ++i) {
    double code = std::round((analog[i] + 0.3 * rng.normal() / half) * half);
    code = std::clamp(code, -half, half - 1.0);
    if (!recipe.isSigned)
      code += half;
    frame.samples[i] = static_cast<float>(code * justify);
  }

  // Label from the noise-free components.
  const double endTime = sampleTime(n - 1);
  if (uncoupled) {
    frame.kind = "uncoupled";
    return frame;
  }
  if (coverage < 0.02) {
    frame.kind = "off-bone";
    return frame;
  }
  const double pulseWidth = 1.0 / (2.0 * kPi * spectralSigmaHz(recipe));
  if (boneTime > endTime - 3.0 * pulseWidth) {
    frame.kind = "beyond-record";
    return frame;
  }
  const std::size_t peak = static_cast<std::size_t>(
      std::max_element(boneEnvelopeFs.begin(), boneEnvelopeFs.end()) - boneEnvelopeFs.begin());
  double peakIndex = double(peak);
  if (peak > 0 && peak + 1 < n) {
    const double a = boneEnvelopeFs[peak - 1];
    const double b = boneEnvelopeFs[peak];
    const double c = boneEnvelopeFs[peak + 1];
    const double curvature = a - 2.0 * b + c;
    if (curvature < 0.0)
      peakIndex += 0.5 * (a - c) / curvature;
  }
  const double boneDepthMm =
      (peakIndex / fs + recipe.delayS) * recipe.assumedSpeedMps * 1000.0 / 2.0;
  const int reach = static_cast<int>(std::ceil(kCompetitorWindowMm / mmPerSample));
  const int low = std::max(0, static_cast<int>(peak) - reach);
  const int high = std::min(static_cast<int>(n) - 1, static_cast<int>(peak) + reach);
  double competitor = 0.0;
  for (int i = low; i <= high; ++i)
    competitor = std::max(competitor, otherEnvelopeFs[static_cast<std::size_t>(i)]);
  const int ringReach = static_cast<int>(std::ceil(kRingDownWindowMm / mmPerSample));
  for (int i = std::max(0, static_cast<int>(peak) - ringReach);
       i <= std::min(static_cast<int>(n) - 1, static_cast<int>(peak) + ringReach); ++i)
    competitor = std::max(competitor, ringEnvelopeFs[static_cast<std::size_t>(i)]);
  double floor = 3.0 * noiseSigma * gain * tgcGain(recipe, sampleTime(peak));
  if (recipe.toneHz > 0.5 * recipe.f0Hz && recipe.toneHz < 1.5 * recipe.f0Hz)
    floor = std::max(floor, recipe.toneFs);
  const double bonePeak = boneEnvelopeFs[peak];
  frame.boneDepthMm = boneDepthMm;
  frame.contrastDb = 20.0 * std::log10(std::max(bonePeak, 1e-300) / std::max(competitor, floor));
  frame.hasBone = frame.contrastDb >= kPositiveContrastDb;
  frame.ambiguous = !frame.hasBone && frame.contrastDb >= kNegativeContrastDb;
  frame.kind = "bone";
  if (boneDepthMm < 5.0)
    frame.kind += "+shallow";
  if (boneDepthMm > 20.0)
    frame.kind += "+deep";
  if (incidenceDeg > 5.0)
    frame.kind += "+oblique";
  if (coverage < 0.9)
    frame.kind += "+edge";
  if (strongestInterfaceFs > bonePeak)
    frame.kind += "+fascia";
  if (burst && burst->last >= low && burst->first <= high)
    frame.kind += "+burst";
  if (sampleTime(peak) < recipe.ringDownS + 5.0 * recipe.ringFallS)
    frame.kind += "+ring-down";
  return frame;
}

// --- Tissue and hardware draws ---------------------------------------------------------------

Layer water(Random& rng, double thicknessMm) {
  Layer layer;
  layer.name = "water";
  layer.thicknessMm = thicknessMm;
  layer.speedMps = rng.uniform(1470.0, 1490.0);
  layer.densityKgM3 = 998.0;
  layer.attenuationDbCmMhz = 0.002;
  layer.scattererDensityPerMm2 = rng.uniform(0.0, 0.5);
  layer.backscatterDb = rng.uniform(-70.0, -55.0);
  return layer;
}

Layer gel(Random& rng, double thicknessMm) {
  Layer layer;
  layer.name = "gel";
  layer.thicknessMm = thicknessMm;
  layer.speedMps = rng.uniform(1500.0, 1560.0);
  layer.densityKgM3 = rng.uniform(1010.0, 1040.0);
  layer.attenuationDbCmMhz = rng.uniform(0.05, 0.3);
  return layer;
}

Layer skin(Random& rng, double thicknessMm) {
  Layer layer;
  layer.name = "skin";
  layer.thicknessMm = thicknessMm;
  layer.speedMps = rng.uniform(1580.0, 1650.0);
  layer.densityKgM3 = rng.uniform(1090.0, 1150.0);
  layer.attenuationDbCmMhz = rng.uniform(1.5, 3.0);
  layer.scattererDensityPerMm2 = rng.uniform(30.0, 60.0);
  layer.backscatterDb = rng.uniform(-32.0, -24.0);
  layer.waveAmplitudeMm = 0.1 * thicknessMm;
  layer.waveLengthMm = rng.uniform(5.0, 30.0);
  layer.wavePhase = rng.uniform(0.0, 2.0 * kPi);
  return layer;
}

Layer fat(Random& rng, double thicknessMm) {
  Layer layer;
  layer.name = "fat";
  layer.thicknessMm = thicknessMm;
  layer.speedMps = rng.uniform(1430.0, 1470.0);
  layer.densityKgM3 = rng.uniform(910.0, 960.0);
  layer.attenuationDbCmMhz = rng.uniform(0.5, 0.8);
  layer.scattererDensityPerMm2 = rng.uniform(10.0, 30.0);
  layer.backscatterDb = rng.uniform(-45.0, -35.0);
  layer.waveAmplitudeMm = 0.15 * thicknessMm;
  layer.waveLengthMm = rng.uniform(10.0, 40.0);
  layer.wavePhase = rng.uniform(0.0, 2.0 * kPi);
  return layer;
}

Layer muscle(Random& rng, double thicknessMm, double fasciaReflection) {
  Layer layer;
  layer.name = "muscle";
  layer.thicknessMm = thicknessMm;
  layer.speedMps = rng.uniform(1560.0, 1590.0);
  layer.densityKgM3 = rng.uniform(1040.0, 1090.0);
  layer.attenuationDbCmMhz = rng.uniform(0.7, 1.2);
  layer.scattererDensityPerMm2 = rng.uniform(20.0, 50.0);
  layer.backscatterDb = rng.uniform(-40.0, -28.0);
  layer.fasciaReflection = fasciaReflection;
  layer.waveAmplitudeMm = 0.05 * thicknessMm;
  layer.waveLengthMm = rng.uniform(10.0, 40.0);
  layer.wavePhase = rng.uniform(0.0, 2.0 * kPi);
  return layer;
}

// Soft tissue over bone whose total is `totalMm`: skin, then fat and muscle sharing the rest.
void addSoftTissue(Recipe& recipe, Random& rng, double totalMm, bool strongFascia) {
  const double skinMm = std::min(totalMm * 0.8, rng.uniform(1.0, 2.5));
  recipe.layers.push_back(skin(rng, skinMm));
  const double rest = totalMm - skinMm;
  if (rest < 0.3)
    return;
  const double fatShare = rng.uniform(0.15, 0.6);
  const double fascia = strongFascia ? rng.uniform(0.25, 0.45) : rng.uniform(0.02, 0.08);
  if (rest * fatShare >= 0.3)
    recipe.layers.push_back(fat(rng, rest * fatShare));
  recipe.layers.push_back(muscle(rng, rest * (1.0 - fatShare), fascia));
}

void drawBone(Recipe& recipe, Random& rng, bool strongFascia) {
  recipe.slopeDeg = rng.uniform(-8.0, 8.0);
  recipe.undulationMm = rng.uniform(40.0, 80.0);
  for (int i = 0; i < 2; ++i) {
    recipe.bumpAmplitudeMm[i] = rng.uniform(0.05, 0.5) * (i ? 0.3 : 1.0);
    recipe.bumpLengthMm[i] = i ? rng.uniform(3.0, 8.0) : rng.uniform(10.0, 40.0);
    recipe.bumpPhase[i] = rng.uniform(0.0, 2.0 * kPi);
  }
  recipe.outOfPlaneDeg = rng.uniform(0.0, 5.0);
  recipe.boneSpeedMps = rng.uniform(3000.0, 4000.0);
  recipe.boneDensityKgM3 = rng.uniform(1800.0, 2000.0);
  recipe.boneAttenuationDbCmMhz = rng.uniform(8.0, 20.0);
  recipe.marrowSpeedMps = rng.uniform(1420.0, 1480.0);
  recipe.marrowDensityKgM3 = rng.uniform(920.0, 980.0);
  recipe.corticalMm = rng.uniform(1.0, 5.0);
  recipe.roughnessMm = strongFascia ? rng.uniform(0.015, 0.03) : rng.uniform(0.002, 0.01);
  recipe.angleToleranceDeg = rng.uniform(6.0, 15.0);
  recipe.diffuseShare = rng.uniform(0.15, 0.5);
}

void drawTransducer(Recipe& recipe, Random& rng, double lowHz, double highHz,
                    std::optional<double> fixedFsHz) {
  recipe.f0Hz = rng.uniform(lowHz, highHz);
  recipe.bandwidth = rng.uniform(0.3, 0.9);
  const double needed = 2.4 * recipe.f0Hz * (1.0 + recipe.bandwidth / 2.0);
  if (fixedFsHz && *fixedFsHz >= needed) {
    recipe.fsHz = *fixedFsHz;
  } else {
    const double rates[] = {20e6, 25e6, 40e6, 50e6, 62.5e6, 80e6, 100e6};
    std::vector<double> allowed;
    for (double rate : rates)
      if (rate >= needed)
        allowed.push_back(rate);
    recipe.fsHz = allowed[static_cast<std::size_t>(rng.integer(0, int(allowed.size()) - 1))];
  }
  recipe.beamRadiusMm = rng.uniform(0.5, 1.2);
  recipe.faceReflection = rng.uniform(0.2, 0.7);
  recipe.facePeriodS = rng.uniform(0.3e-6, 1.5e-6);
  recipe.faceDecay = rng.uniform(0.5, 0.85);
}

void drawDigitiser(Recipe& recipe, Random& rng) {
  const int bits[] = {8, 10, 12, 14, 16};
  recipe.bits = bits[rng.integer(0, 4)];
  recipe.isSigned = rng.chance(0.6);
  recipe.leftJustified = recipe.bits < 16 && rng.chance(0.5);
}

void drawElectronics(Recipe& recipe, Random& rng, double tgcChance) {
  recipe.snrDb = rng.uniform(24.0, 50.0);
  recipe.referenceFs = rng.uniform(0.2, 1.0);
  recipe.ringDownS = rng.uniform(0.2e-6, 4e-6);
  recipe.ringDownFs = rng.uniform(0.3, 2.0);
  recipe.ringFallS = rng.uniform(0.05e-6, 0.3e-6);
  recipe.tailFs = rng.uniform(0.0, 0.15);
  recipe.tailS = rng.uniform(0.5e-6, 3e-6);
  recipe.tailHz = rng.chance(0.5) ? 0.0 : rng.uniform(0.2e6, 1.5e6);
  recipe.tgcDbPerUs = rng.chance(tgcChance) ? rng.uniform(0.4, 1.2) : 0.0;
  recipe.wanderFs = rng.uniform(0.0, 0.08);
  recipe.wanderHz = rng.uniform(20e3, 400e3);
  recipe.toneFs = rng.chance(0.3) ? rng.uniform(0.002, 0.03) : 0.0;
  recipe.toneHz = rng.uniform(0.2e6, recipe.fsHz / 2.5);
  recipe.burstChance = rng.chance(0.25) ? rng.uniform(0.05, 0.2) : 0.0;
  recipe.burstFs = rng.uniform(0.05, 0.5);
  recipe.dcFs = rng.uniform(-0.05, 0.05);
}

// Record length: past the deepest bone of the capture by 5-25 mm (or ending before the bone).
void sizeRecord(Recipe& recipe, Random& rng) {
  double shallowest = 1e9;
  double deepest = 0.0;
  for (int f = 0; f < recipe.frames; f += 5) {
    const double x = recipe.startXMm + recipe.speedMmS * f / recipe.frameRateHz;
    for (double squeeze : {1.0 - recipe.compression, 1.0 + recipe.compression}) {
      const double time = 2.0 * columnAt(recipe, x, squeeze).boneTimeS;
      shallowest = std::min(shallowest, time);
      deepest = std::max(deepest, time);
    }
  }
  double endTime = deepest + 2.0 * rng.uniform(5.0, 25.0) / 1000.0 / recipe.assumedSpeedMps;
  if (recipe.beyondRecordFraction > 0.0)
    endTime = recipe.beyondRecordFraction * shallowest;
  recipe.samples =
      std::clamp(static_cast<int>(std::ceil((endTime - recipe.delayS) * recipe.fsHz)), 1000, 12000);
}

std::string describeRecipe(const Recipe& recipe, const std::string& label) {
  char text[160];
  std::snprintf(text, sizeof text, "%s %.1f MHz %d-bit%s%s fs %.1f MHz", label.c_str(),
                recipe.f0Hz / 1e6, recipe.bits, recipe.isSigned ? "" : " unsigned",
                recipe.leftJustified ? " left-justified" : "", recipe.fsHz / 1e6);
  return text;
}

std::vector<Recipe> handheldRecipes(Random& rng) {
  std::vector<Recipe> recipes;
  for (int c = 0; c < 6; ++c) {
    Recipe recipe;
    const double tissueDraw = rng.uniform();
    const std::string tissue = tissueDraw < 0.3 ? "thin" : tissueDraw < 0.7 ? "medium" : "thick";
    const double totalMm = tissue == "thin"     ? rng.uniform(1.0, 5.0)
                           : tissue == "medium" ? rng.uniform(5.0, 20.0)
                                                : rng.uniform(20.0, 50.0);
    if (tissue == "thin")
      drawTransducer(recipe, rng, 5e6, 15e6, std::nullopt);
    else if (tissue == "medium")
      drawTransducer(recipe, rng, 5e6, 10e6, std::nullopt);
    else
      drawTransducer(recipe, rng, 3.5e6, 7.5e6, std::nullopt);
    const double standoffDraw = rng.uniform();
    std::string standoff = "no-standoff";
    if (standoffDraw < 0.25) {
      recipe.layers.push_back(gel(rng, rng.uniform(2.0, 10.0)));
      standoff = "gel";
    } else if (standoffDraw < 0.4) {
      recipe.layers.push_back(water(rng, rng.uniform(5.0, 15.0)));
      standoff = "water";
    }
    const bool strongFascia = tissue != "thin" && rng.chance(0.2);
    addSoftTissue(recipe, rng, totalMm, strongFascia);
    drawBone(recipe, rng, strongFascia);
    recipe.wobbleDeg = rng.uniform(0.0, 4.0);
    recipe.wobbleHz = rng.uniform(0.5, 2.0);
    recipe.frames = 120;
    recipe.frameRateHz = rng.uniform(30.0, 100.0);
    recipe.speedMmS = rng.uniform(10.0, 50.0) * (rng.chance(0.5) ? 1.0 : -1.0);
    const double sweepMm = std::fabs(recipe.speedMmS) * recipe.frames / recipe.frameRateHz;
    recipe.startXMm = 0.0;
    recipe.shapeCentreMm = 0.5 * recipe.speedMmS * recipe.frames / recipe.frameRateHz;
    if (rng.chance(0.5)) {
      // The sweep crosses an edge of the bone (a condyle's rim, the tibia's crest).
      const double edge = rng.uniform(0.15, 0.4) * sweepMm;
      if (recipe.speedMmS > 0.0)
        recipe.boneRightMm = sweepMm - edge;
      else
        recipe.boneLeftMm = -sweepMm + edge;
    }
    recipe.uncoupled.assign(static_cast<std::size_t>(recipe.frames), 0);
    if (rng.chance(0.5)) {
      const int length = rng.integer(10, 30);
      const int first = rng.integer(0, recipe.frames - length);
      std::fill(recipe.uncoupled.begin() + first, recipe.uncoupled.begin() + first + length, 1);
    }
    const double speedDraw = rng.uniform();
    recipe.assumedSpeedMps = speedDraw < 0.7 ? 1540.0 : speedDraw < 0.85 ? 1500.0 : 1580.0;
    drawDigitiser(recipe, rng);
    drawElectronics(recipe, rng, tissue == "thick" ? 0.8 : 0.3);
    sizeRecord(recipe, rng);
    recipe.name = describeRecipe(recipe, "handheld-" + std::to_string(c) + " " + tissue + " " +
                                             standoff + (strongFascia ? " strong-fascia" : ""));
    recipes.push_back(recipe);
  }
  return recipes;
}

std::vector<Recipe> holderRecipes(Random& rng) {
  std::vector<Recipe> recipes;
  const double rateHz = rng.uniform(30.0, 100.0);
  const double compressionHz = rng.uniform(0.3, 1.5);
  const int offBone = rng.integer(0, 5);
  const int edgeOrOff = rng.chance(0.5) ? rng.integer(0, 5) : -1;
  const bool twelveBitLeft = rng.chance(0.6);
  for (int c = 0; c < 6; ++c) {
    Recipe recipe;
    drawTransducer(recipe, rng, 5e6, 10e6, 50e6);
    const double totalMm = rng.chance(0.6) ? rng.uniform(1.0, 10.0) : rng.uniform(10.0, 25.0);
    const bool strongFascia = totalMm > 5.0 && rng.chance(0.25);
    addSoftTissue(recipe, rng, totalMm, strongFascia);
    drawBone(recipe, rng, strongFascia);
    recipe.outOfPlaneDeg = rng.uniform(0.0, 6.0);
    recipe.wobbleDeg = rng.uniform(0.0, 2.0);
    recipe.wobbleHz = compressionHz;
    recipe.frames = 150;
    recipe.frameRateHz = rateHz;
    recipe.startXMm = 0.0;
    recipe.speedMmS = 0.0;
    recipe.slipMm = rng.uniform(0.2, 1.0);
    recipe.slipHz = compressionHz;
    recipe.compression = rng.uniform(0.0, 0.08);
    recipe.compressionHz = compressionHz;
    std::string placement = "on-bone";
    if (c == offBone) {
      recipe.boneLeftMm = rng.uniform(2.5, 5.0) * recipe.beamRadiusMm + recipe.slipMm;
      placement = "off-bone";
    } else if (c == edgeOrOff) {
      recipe.boneLeftMm = rng.uniform(-0.5, 0.5);
      placement = "edge";
    }
    recipe.uncoupled.assign(static_cast<std::size_t>(recipe.frames), 0);
    recipe.assumedSpeedMps = 1540.0;
    if (twelveBitLeft) {
      recipe.bits = 12;
      recipe.isSigned = true;
      recipe.leftJustified = true;
    } else {
      drawDigitiser(recipe, rng);
    }
    drawElectronics(recipe, rng, 0.2);
    recipe.ringDownS = rng.uniform(0.3e-6, 1.5e-6);
    sizeRecord(recipe, rng);
    // The user sets a window around where this transducer should see the bone.
    const double expectedMm = nominalBoneTimeS(recipe) * recipe.assumedSpeedMps * 1000.0 / 2.0;
    recipe.windowMinMm = std::max(0.5, expectedMm - rng.uniform(3.0, 6.0));
    recipe.windowMaxMm = expectedMm + rng.uniform(3.0, 6.0);
    recipe.name = describeRecipe(recipe, "holder-" + std::to_string(c) + " " + placement);
    recipes.push_back(recipe);
  }
  return recipes;
}

std::vector<Recipe> phantomRecipes(Random& rng) {
  std::vector<Recipe> recipes;
  for (int c = 0; c < 4; ++c) {
    Recipe recipe;
    const bool beyond = rng.chance(0.2);
    const std::optional<double> fixedFs =
        beyond || rng.chance(0.5) ? std::optional<double>(50e6) : std::nullopt;
    drawTransducer(recipe, rng, 5e6, 15e6, fixedFs);
    const double waterMm = beyond ? rng.uniform(25.0, 40.0) : rng.uniform(3.0, 40.0);
    recipe.layers.push_back(water(rng, waterMm));
    std::string specimen = "bare";
    if (rng.chance(0.4)) {
      Layer soft = skin(rng, rng.uniform(1.0, 5.0));
      soft.name = "soft";
      soft.speedMps = rng.uniform(1540.0, 1600.0);
      recipe.layers.push_back(soft);
      specimen = "soft-tissue";
    }
    drawBone(recipe, rng, false);
    recipe.slopeDeg = rng.uniform(-10.0, 10.0);
    recipe.outOfPlaneDeg = rng.uniform(0.0, 4.0);
    recipe.frames = 150;
    recipe.frameRateHz = rng.uniform(20.0, 100.0);
    recipe.speedMmS = rng.uniform(5.0, 20.0);
    recipe.startXMm = 0.0;
    const double sweepMm = recipe.speedMmS * recipe.frames / recipe.frameRateHz;
    recipe.shapeCentreMm = 0.5 * sweepMm;
    if (rng.chance(0.6)) {
      recipe.boneLeftMm = rng.uniform(0.1, 0.3) * sweepMm;
      recipe.boneRightMm = recipe.boneLeftMm + rng.uniform(20.0, 40.0);
    }
    recipe.uncoupled.assign(static_cast<std::size_t>(recipe.frames), 0);
    if (rng.chance(0.2))
      std::fill(recipe.uncoupled.begin(), recipe.uncoupled.begin() + rng.integer(10, 30), 1);
    recipe.assumedSpeedMps = 1480.0;
    if (rng.chance(0.5)) {
      recipe.bits = 8;
      recipe.isSigned = rng.chance(0.5);
      recipe.leftJustified = false;
    } else {
      drawDigitiser(recipe, rng);
    }
    drawElectronics(recipe, rng, 0.2);
    recipe.ringDownS = rng.uniform(0.2e-6, 2e-6);
    if (!beyond && rng.chance(0.5))
      recipe.delayS = rng.uniform(0.2, 0.8) * 2.0 * waterMm / 1000.0 / recipe.layers[0].speedMps;
    recipe.beyondRecordFraction = beyond ? rng.uniform(0.6, 0.9) : 0.0;
    sizeRecord(recipe, rng);
    recipe.name = describeRecipe(recipe, "phantom-" + std::to_string(c) + " " + specimen +
                                             (beyond ? " bone-beyond-record" : "") +
                                             (recipe.delayS > 0.0 ? " delayed" : ""));
    recipes.push_back(recipe);
  }
  return recipes;
}

PhysicalCapture generateCapture(const Recipe& recipe, Random& rng) {
  const ScattererField field = scatterField(recipe, rng);
  const double nominal = nominalBoneEcho(recipe);
  const double gain = recipe.referenceFs / (nominal * tgcGain(recipe, nominalBoneTimeS(recipe)));
  const double noiseSigma = nominal / std::pow(10.0, recipe.snrDb / 20.0);
  PhysicalCapture capture;
  capture.name = recipe.name;
  capture.facts.samplingFrequencyHz = recipe.fsHz;
  capture.facts.speedOfSoundMps = recipe.assumedSpeedMps;
  capture.facts.delayS = recipe.delayS;
  capture.facts.windowMinMm = recipe.windowMinMm;
  capture.facts.windowMaxMm = recipe.windowMaxMm;
  capture.transducerFrequencyHz = recipe.f0Hz;
  capture.bits = recipe.bits;
  capture.isSigned = recipe.isSigned;
  capture.leftJustified = recipe.leftJustified;
  for (int f = 0; f < recipe.frames; ++f)
    capture.frames.push_back(renderFrame(recipe, field, f, gain, noiseSigma, rng));
  return capture;
}

}  // namespace

std::vector<std::string> physicalProfileNames() {
  return {"handheld", "holder", "phantom-water"};
}

PhysicalSet generatePhysicalSet(const std::string& profile, std::uint64_t seed) {
  const std::vector<std::string> names = physicalProfileNames();
  const auto found = std::find(names.begin(), names.end(), profile);
  if (found == names.end())
    throw std::invalid_argument("physical A-line profile '" + profile +
                                "' is unknown (valid: handheld, holder, phantom-water)");
  const std::uint64_t profileIndex = static_cast<std::uint64_t>(found - names.begin());
  Random rng(seed * 0x9E3779B97F4A7C15ULL + (profileIndex + 1) * 0xD1B54A32D192ED03ULL);
  std::vector<Recipe> recipes = profile == "handheld" ? handheldRecipes(rng)
                                : profile == "holder" ? holderRecipes(rng)
                                                      : phantomRecipes(rng);
  PhysicalSet set;
  set.profile = profile;
  set.seed = seed;
  for (const Recipe& recipe : recipes)
    set.captures.push_back(generateCapture(recipe, rng));
  return set;
}

}  // namespace echoreg::test
