// The randomised A-mode generator: a pulse-echo model drawn from wide ranges (see the header).
//
// Signal chain of one record, in units of the ADC's half range (1 = positive full scale):
//   ring-down burst + its tail (transducer ringing and receiver recovery)
// + a slow baseline (low-frequency wander, recovery after the transmit)
// + speckle: white scatterers per layer convolved with the depth-dependent pulse
// + specular echoes (skin/standoff wall, fascia, septa, bone, its cortical echoes and
// reverberation,
//   standoff multiples), each the pulse attenuated by the tissue in front of it
// + electronic noise, noise bursts
// then the digitiser: DC offset, quantisation to its code step, clipping at its range.
// The pulse at tissue depth z is the transmit pulse filtered by exp(-a f z) (round-trip
// attenuation a in Np/cm/MHz), which lowers its centre frequency with depth.
#include "randomised_alines.hpp"

#include <Eigen/Geometry>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <utility>

namespace echoreg::test {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kFine = 8;  // oversampling of the stored pulses
using Cplx = std::complex<double>;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27U)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31U);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uni(double a, double b) {
    return a + (b - a) * std::uniform_real_distribution<double>(0.0, 1.0)(engine_);
  }
  double logUni(double a, double b) { return std::exp(uni(std::log(a), std::log(b))); }
  double normal() { return normal_(engine_); }
  bool chance(double p) { return uni(0.0, 1.0) < p; }
  int integer(int a, int b) { return std::uniform_int_distribution<int>(a, b)(engine_); }
  /// Index drawn with the given weights.
  int pick(const std::vector<double>& weights) {
    double total = 0.0;
    for (double w : weights) {
      total += w;
    }
    double u = uni(0.0, total);
    for (std::size_t i = 0; i < weights.size(); ++i) {
      if (u < weights[i]) {
        return static_cast<int>(i);
      }
      u -= weights[i];
    }
    return static_cast<int>(weights.size()) - 1;
  }

 private:
  std::mt19937_64 engine_;
  std::normal_distribution<double> normal_;
};

std::size_t nextPow2(std::size_t n) {
  std::size_t m = 1;
  while (m < n) {
    m <<= 1U;
  }
  return m;
}

Eigen::FFT<double>& fftEngine() {
  thread_local Eigen::FFT<double> engine;
  return engine;
}

void fftForward(std::vector<Cplx>& data) {
  std::vector<Cplx> out(data.size());
  fftEngine().fwd(out.data(), data.data(), static_cast<Eigen::Index>(data.size()));
  data.swap(out);
}

void fftInverse(std::vector<Cplx>& data) {
  std::vector<Cplx> out(data.size());
  fftEngine().inv(out.data(), data.data(), static_cast<Eigen::Index>(data.size()));
  data.swap(out);
}

/// Envelope (magnitude of the analytic signal) of x[lo, hi), computed on a padded window.
std::vector<double> envelopeOf(const std::vector<double>& x, int lo, int hi) {
  const int n = static_cast<int>(x.size());
  const int pad = 48;
  const int a = std::max(0, lo - pad);
  const int b = std::min(n, hi + pad);
  const std::size_t m = nextPow2(static_cast<std::size_t>(std::max(2, b - a)));
  std::vector<Cplx> buf(m, Cplx(0.0, 0.0));
  for (int i = a; i < b; ++i) {
    buf[static_cast<std::size_t>(i - a)] = Cplx(x[static_cast<std::size_t>(i)], 0.0);
  }
  fftForward(buf);
  for (std::size_t k = 1; k < m / 2; ++k) {
    buf[k] *= 2.0;
  }
  for (std::size_t k = m / 2 + 1; k < m; ++k) {
    buf[k] = 0.0;
  }
  fftInverse(buf);
  std::vector<double> env(static_cast<std::size_t>(std::max(0, hi - lo)), 0.0);
  for (int i = lo; i < hi; ++i) {
    if (i >= a && i < b) {
      env[static_cast<std::size_t>(i - lo)] = std::abs(buf[static_cast<std::size_t>(i - a)]);
    }
  }
  return env;
}

// ---------------------------------------------------------------------------------------------
// The pulse: a transmit shape, attenuated per tissue depth, stored oversampled with its quadrature
// (Hilbert) partner so an echo of any phase has the same envelope.

enum class PulseShape { Gaussian, Asymmetric, Gamma };

struct Pulse {
  std::vector<double> re, im;  // at fs * kFine, normalised to a unit envelope peak
  int zeroIndex = 0;           // fine index of the echo's arrival time (t = 0)
  double envPeak = 0.0;        // envelope peak relative to the arrival, base samples
  double halfWidth = 1.0;      // half of the envelope's width at half maximum, base samples
  double energy = 1.0;         // sum of re^2 at the base rate
  int first = 0, last = 0;     // support relative to the arrival, base samples
  /// Value at base-sample offset x from the arrival, with phase phi.
  double at(double x, double cosPhi, double sinPhi) const {
    const double f = x * kFine + zeroIndex;
    if (f < 0.0 || f >= static_cast<double>(re.size() - 1)) {
      return 0.0;
    }
    const auto i = static_cast<std::size_t>(f);
    const double w = f - static_cast<double>(i);
    const double r = re[i] + w * (re[i + 1] - re[i]);
    const double q = im[i] + w * (im[i + 1] - im[i]);
    return cosPhi * r + sinPhi * q;
  }
};

class PulseBank {
 public:
  PulseBank(PulseShape shape, double fcHz, double fractionalBandwidth, double asym, double gammaK,
            double fsHz, double attenuationDbPerCmMHz)
      : shape_(shape),
        fc_(fcHz),
        bw_(fractionalBandwidth * fcHz),
        asym_(asym),
        k_(gammaK),
        fs_(fsHz),
        aNp_(attenuationDbPerCmMHz / 8.685889638),
        lowRollOff_(0.6 * fcHz * (1.0 - fractionalBandwidth / 2.0)) {}

  /// The pulse after zTissueMm of soft tissue (binned by 1 mm).
  const Pulse& at(double zTissueMm) {
    const int bin = std::max(0, static_cast<int>(std::lround(zTissueMm)));
    auto it = cache_.find(bin);
    if (it == cache_.end()) {
      it = cache_.emplace(bin, build(static_cast<double>(bin))).first;
    }
    return it->second;
  }

 private:
  double envelope(double t) const {
    const double b = bw_;
    switch (shape_) {
      case PulseShape::Gaussian: {
        const double s = std::sqrt(2.0 * std::log(2.0)) / (kPi * b);
        return std::exp(-t * t / (2.0 * s * s));
      }
      case PulseShape::Asymmetric: {
        const double s = std::sqrt(2.0 * std::log(2.0)) / (kPi * b);
        const double sr = s * 2.0 / (1.0 + asym_);
        const double sd = s * 2.0 * asym_ / (1.0 + asym_);
        const double ss = t < 0.0 ? sr : sd;
        return std::exp(-t * t / (2.0 * ss * ss));
      }
      case PulseShape::Gamma: {
        // t^k exp(-t/tau), peak at k tau (placed at t = 0); -6 dB width of (1+x^2)^-(k+1)/2.
        const double x = std::sqrt(std::pow(2.0, 2.0 / (k_ + 1.0)) - 1.0);
        const double tau = x / (kPi * b);
        const double u = t / tau + k_;
        if (u <= 0.0) {
          return 0.0;
        }
        return std::exp(k_ * std::log(u / k_) - (u - k_));
      }
    }
    return 0.0;
  }

  Pulse build(double zMm) const {
    const double fsF = fs_ * kFine;
    // Support of the transmit envelope (generous), in seconds.
    const double s = std::sqrt(2.0 * std::log(2.0)) / (kPi * bw_);
    double tMin = -4.5 * s, tMax = 4.5 * s;
    if (shape_ == PulseShape::Asymmetric) {
      tMin = -4.5 * s * 2.0 / (1.0 + asym_);
      tMax = 4.5 * s * 2.0 * asym_ / (1.0 + asym_);
    } else if (shape_ == PulseShape::Gamma) {
      const double x = std::sqrt(std::pow(2.0, 2.0 / (k_ + 1.0)) - 1.0);
      const double tau = x / (kPi * bw_);
      tMin = -k_ * tau;
      tMax = (k_ + 6.0 * std::sqrt(k_ + 1.0) + 6.0) * tau;
    }
    const int nLead = static_cast<int>(std::ceil(-tMin * fsF));
    const int nTrail = static_cast<int>(std::ceil(tMax * fsF));
    const int len = nLead + nTrail + 1;
    const std::size_t m = nextPow2(static_cast<std::size_t>(2 * len));
    const int offset = static_cast<int>(m / 4);  // arrival sits here in the FFT buffer
    std::vector<Cplx> buf(m, Cplx(0.0, 0.0));
    for (int i = -nLead; i <= nTrail; ++i) {
      const double t = i / fsF;
      const double v = envelope(t) * std::cos(2.0 * kPi * fc_ * t);
      buf[static_cast<std::size_t>(offset + i)] = Cplx(v, 0.0);
    }
    fftForward(buf);
    // Attenuation exp(-a |f| z) (round trip, a in Np/cm/MHz, z in cm), then the analytic signal.
    const double zCm = zMm / 10.0;
    for (std::size_t k = 0; k < m; ++k) {
      const double fIdx =
          k <= m / 2 ? static_cast<double>(k) : static_cast<double>(k) - static_cast<double>(m);
      const double fMHz = std::abs(fIdx) * fsF / static_cast<double>(m) / 1e6;
      // The transducer's low-frequency roll-off (no response at DC, -35 dB at a third of its
      // lower band edge), then the tissue.
      const double r4 = std::pow(fMHz * 1e6 / lowRollOff_, 4.0);
      double h = r4 / (1.0 + r4) * std::exp(-aNp_ * fMHz * zCm);
      if (fIdx < 0.0 || (k == m / 2)) {
        h = 0.0;
      } else if (k > 0) {
        h *= 2.0;
      }
      if (k == 0) {
        h = 0.0;  // no DC in an echo
      }
      buf[k] *= h;
    }
    fftInverse(buf);
    std::vector<double> env(m);
    double peak = 0.0;
    std::size_t peakIdx = 0;
    for (std::size_t i = 0; i < m; ++i) {
      env[i] = std::abs(buf[i]);
      if (env[i] > peak) {
        peak = env[i];
        peakIdx = i;
      }
    }
    // Trim to where the envelope exceeds 1e-4 of its peak.
    std::size_t lo = 0, hi = m - 1;
    while (lo < peakIdx && env[lo] < 1e-4 * peak) {
      ++lo;
    }
    while (hi > peakIdx && env[hi] < 1e-4 * peak) {
      --hi;
    }
    lo = lo >= 2 ? lo - 2 : 0;
    hi = std::min(m - 1, hi + 2);
    Pulse p;
    p.re.resize(hi - lo + 1);
    p.im.resize(hi - lo + 1);
    for (std::size_t i = lo; i <= hi; ++i) {
      p.re[i - lo] = buf[i].real() / peak;
      p.im[i - lo] = buf[i].imag() / peak;
    }
    p.zeroIndex = offset - static_cast<int>(lo);
    // Sub-sample envelope peak (parabola through the fine samples).
    double refined = static_cast<double>(peakIdx);
    if (peakIdx > 0 && peakIdx + 1 < m) {
      const double y0 = env[peakIdx - 1], y1 = env[peakIdx], y2 = env[peakIdx + 1];
      const double den = y0 - 2.0 * y1 + y2;
      if (den < 0.0) {
        refined += 0.5 * (y0 - y2) / den;
      }
    }
    p.envPeak = (refined - offset) / kFine;
    std::size_t a = peakIdx, b = peakIdx;
    while (a > 0 && env[a] > 0.5 * peak) {
      --a;
    }
    while (b + 1 < m && env[b] > 0.5 * peak) {
      ++b;
    }
    p.halfWidth = 0.5 * static_cast<double>(b - a) / kFine;
    p.first = static_cast<int>(std::floor(-static_cast<double>(p.zeroIndex) / kFine));
    p.last =
        static_cast<int>(std::ceil(static_cast<double>(p.re.size() - 1 - p.zeroIndex) / kFine));
    double e = 0.0;
    for (std::size_t i = 0; i < p.re.size(); i += kFine) {
      e += p.re[i] * p.re[i];
    }
    p.energy = std::max(e, 1e-12);
    return p;
  }

  PulseShape shape_;
  double fc_, bw_, asym_, k_, fs_, aNp_, lowRollOff_;
  std::map<int, Pulse> cache_;
};

// ---------------------------------------------------------------------------------------------

// BoneObliqueProne: a bone capture held at a steep angle (a strapped transducer) or swept with
// large tilts; it becomes Bone once drawn.
enum class Scenario {
  Bone,
  Uncoupled,
  NoSkin,
  BeyondRecord,
  FasciaAsStrong,
  Noise,
  BoneObliqueProne
};

struct FrameGeom {
  double standoffMm = 0.0;  // physical path through the standoff
  double tissueMm = 0.0;    // physical path through soft tissue to the bone
  double incidenceDeg = 0.0;
  bool hasPose = false;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  double xi = 0.0;  // speckle decorrelation coordinate (template units)
  bool liftOff = false;
};

/// Everything drawn for one capture.
struct Params {
  std::string profile;
  Scenario scenario = Scenario::Bone;
  // Probe and pulse.
  double fc = 7e6, fbw = 0.6, asym = 1.0, gammaK = 3.0;
  PulseShape shape = PulseShape::Gaussian;
  double fs = 50e6;
  int n = 1500;
  double cAssumed = 1540.0;
  double delay = 0.0;
  // Digitiser.
  SampleStorage storage = SampleStorage::Int16;
  int bits = 16;
  bool leftJustified = false;
  double dc = 0.0, halfRange = 32768.0, step = 1.0, minCode = -32768.0, maxCode = 32767.0;
  double noiseSigma = 1e-4;  // electronic noise, fraction of half range
  // Ring-down.
  double burstEnd = 0.5e-6, burstAmp = 1.0, ringFreq = 7e6, ringPhase = 0.0;
  double tailAmp = 0.1, tailTau = 1e-6, tailOscFraction = 0.5, tailSign = 1.0;
  bool lensReverb = false;  // (uncoupled)
  double lensPeriod = 1e-6, lensAmp = 0.3, lensRatio = 0.6;
  // Baseline.
  bool drift = false;
  double driftAmp[3] = {0.0, 0.0, 0.0}, driftFreq[3] = {1e5, 2e5, 3e5},
         driftPhase[3] = {0.0, 0.0, 0.0};
  double recoveryAmp = 0.0, recoveryTau = 5e-6;
  // Anatomy.
  std::string standoffType = "none";
  double standoffMm = 0.0, cStandoff = 1482.0;
  double tissueMm = 10.0;  // nominal
  double skinMm = 1.2, fatFraction = 0.3;
  double cSkin = 1600.0, cFat = 1450.0, cMuscle = 1580.0;
  double attenuation = 0.7;  // dB/cm/MHz round trip
  double tgc = 0.0;          // fraction of the attenuation compensated by a gain ramp
  double boneAmp = 0.3;      // bone echo at normal incidence, nominal depth (half-range units)
  double bonePhase = 0.0;
  double speckleToBone = 0.05;  // muscle speckle RMS / bone echo at the nominal depth
  double skinLevel = 1.8, fatLevel = 0.4, standoffLevel = 0.01, shadow = 0.1;
  double skinEchoRatio = 0.3, standoffMultipleRatio = 0.2;
  double fasciaRatio = 0.0;                           // fat/muscle interface echo / bone
  std::vector<std::pair<double, double>> septa;       // (fraction of fat, ratio)
  std::vector<std::pair<double, double>> striations;  // (fraction of muscle, ratio)
  double similarRatio = 0.0, similarAboveMm = 2.0;    // similar echo above the bone
  double strongFasciaFraction = 0.5;                  // FasciaAsStrong: where in the tissue
  // Behind the bone.
  double cortexMm = 2.0, cCortex = 3800.0, cortexRatio = 0.15;
  double reverbFirst = 0.2, reverbRatio = 0.4, reverbSpacingMm = 0.5, reverbPhaseJitter = 0.4;
  bool strongReverb = false;
  bool reverbCoherent = false;  // the reverberation's echoes in phase (a ringing tail)
  double diffuseReverb = 0.0, diffuseReverbMm = 2.0;
  double ghostStandoff = 0.0, ghostDouble = 0.0;
  // Oblique incidence.
  double theta0Deg = 7.0, obliqueFloorDb = 35.0;
  // Per-frame events.
  double burstNoiseProb = 0.0;
  double noiseScenarioSigma = 0.0;
  double interferenceAmp = 0.0, interferenceFreq = 1e6;
  // Motion.
  bool handHeld = false;
  double frameRate = 45.0;
  double beamWidthMm = 3.0;
};

double twoWayTime(double mm, double c) {
  return 2.0 * mm * 1e-3 / c;
}

// Layer boundaries of one frame, as two-way times after the transmit (s).
struct Layers {
  double tStandoff = 0.0, tSkin = 0.0, tFat = 0.0, tBone = 0.0;
  double skinMm = 0.0, fatMm = 0.0, muscleMm = 0.0;
  bool tissue = true;
};

Layers layersOf(const Params& p, const FrameGeom& g) {
  Layers l;
  l.tStandoff = twoWayTime(g.standoffMm, p.cStandoff);
  const double t = std::max(0.0, g.tissueMm);
  l.skinMm = std::min(t, p.skinMm);
  const double rest = t - l.skinMm;
  l.fatMm = t > 3.0 ? rest * p.fatFraction : 0.0;
  l.muscleMm = rest - l.fatMm;
  l.tSkin = l.tStandoff + twoWayTime(l.skinMm, p.cSkin);
  l.tFat = l.tSkin + twoWayTime(l.fatMm, p.cFat);
  l.tBone = l.tFat + twoWayTime(l.muscleMm, p.cMuscle);
  l.tissue = t > 0.0;
  return l;
}

/// Soft-tissue depth (mm) reached at two-way time t.
double tissueDepthAt(const Layers& l, const Params& p, double t) {
  if (t <= l.tStandoff) {
    return 0.0;
  }
  if (t <= l.tSkin) {
    return (t - l.tStandoff) * p.cSkin / 2.0 * 1e3;
  }
  if (t <= l.tFat) {
    return l.skinMm + (t - l.tSkin) * p.cFat / 2.0 * 1e3;
  }
  return l.skinMm + l.fatMm + (t - l.tFat) * p.cMuscle / 2.0 * 1e3;
}

Eigen::Matrix3d rotX(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
}
Eigen::Matrix3d rotY(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

// ---------------------------------------------------------------------------------------------

class CaptureSynth {
 public:
  CaptureSynth(const std::string& profile, Scenario scenario, std::uint64_t seed, int frames,
               bool keepClean)
      : rng_(seed), frames_(frames), keepClean_(keepClean) {
    p_.profile = profile;
    p_.scenario = scenario == Scenario::BoneObliqueProne ? Scenario::Bone : scenario;
    obliqueProne_ = scenario == Scenario::BoneObliqueProne;
    t0_ = rng_.uni(0.0, 100.0);
    if (profile == "randomised") {
      drawRandomised();
    } else if (profile == "invivo-holder") {
      drawInvivo();
    } else if (profile == "specimen-standoff") {
      drawSpecimen();
    } else {
      throw std::invalid_argument("makeRandomisedSet: unknown profile '" + profile +
                                  "' (randomised, invivo-holder, specimen-standoff)");
    }
    drawMotion();
    fitRecord();
    bank_ = std::make_unique<PulseBank>(p_.shape, p_.fc, p_.fbw, p_.asym, p_.gammaK, p_.fs,
                                        p_.attenuation);
  }

  RandomisedCapture run() {
    RandomisedCapture c;
    c.profile = p_.profile;
    c.samplingFrequencyHz = p_.fs;
    c.speedOfSoundMps = p_.cAssumed;
    c.delayS = p_.delay;
    c.transducerFrequencyHz = p_.fc;
    c.storage = p_.storage;
    c.adcBits = p_.bits;
    c.leftJustified = p_.leftJustified;
    c.dcOffset = p_.dc;
    c.ringDownEndSample = std::max(0.0, (p_.burstEnd - p_.delay) * p_.fs);
    c.fractionalBandwidth = p_.fbw;
    c.pulseShape = p_.shape == PulseShape::Gaussian     ? "gaussian"
                   : p_.shape == PulseShape::Asymmetric ? "asymmetric"
                                                        : "gamma";
    c.attenuationDbPerCmMHz = p_.attenuation;
    c.standoff = p_.standoffType;
    c.standoffMm = p_.standoffMm;
    c.tissueMm = p_.tissueMm;
    c.handHeld = p_.handHeld;
    c.frameRateHz = p_.frameRate;
    c.halfRangeCodes = p_.halfRange;
    c.codeStep = p_.step;
    c.minCode = p_.minCode;
    c.maxCode = p_.maxCode;
    if (p_.profile == "invivo-holder") {
      c.windowMinMm = windowMin_;
      c.windowMaxMm = windowMax_;
    }
    makeTemplates();
    precomputeRingDown();
    c.frames.reserve(static_cast<std::size_t>(frames_));
    for (int k = 0; k < frames_; ++k) {
      c.frames.push_back(frame(k));
    }
    c.description = describe();
    return c;
  }

 private:
  // --- drawing the capture -------------------------------------------------------------------

  void drawProbe(double fcLo, double fcHi, double bwLo, double bwHi) {
    p_.fc = rng_.uni(fcLo, fcHi) * 1e6;
    p_.fbw = rng_.uni(bwLo, bwHi);
    const int shape = rng_.pick({0.4, 0.35, 0.25});
    p_.shape = shape == 0 ? PulseShape::Gaussian
                          : (shape == 1 ? PulseShape::Asymmetric : PulseShape::Gamma);
    p_.asym = rng_.uni(1.5, 3.0);
    p_.gammaK = rng_.uni(1.5, 4.0);
  }

  void setStorage(SampleStorage s, int bits, bool lj) {
    p_.storage = s;
    p_.bits = bits;
    p_.leftJustified = lj;
    if (s == SampleStorage::UInt8 || s == SampleStorage::Int8) {
      p_.halfRange = 128.0;
      p_.step = 1.0;
      p_.minCode = s == SampleStorage::UInt8 ? 0.0 : -128.0;
      p_.maxCode = s == SampleStorage::UInt8 ? 255.0 : 127.0;
      p_.dc = s == SampleStorage::UInt8 ? 128.0 + rng_.uni(-2.0, 2.0) : rng_.uni(-2.0, 2.0);
      p_.noiseSigma = rng_.uni(0.3, 1.5) / 128.0;
    } else {
      p_.halfRange = 32768.0;
      p_.step = lj ? std::pow(2.0, 16 - bits) : 1.0;
      const double lo = s == SampleStorage::UInt16 ? 0.0 : -32768.0;
      p_.minCode = lo;
      p_.maxCode = lo + 65536.0 - p_.step;
      const double mid = s == SampleStorage::UInt16 ? 32768.0 : 0.0;
      if (lj) {
        const double off = rng_.uni(50.0, 110.0);
        p_.dc = mid + (rng_.chance(0.8) ? off : -off);
        p_.noiseSigma = rng_.uni(0.7, 3.0) * p_.step / 32768.0;
      } else {
        p_.dc = mid + rng_.uni(-250.0, 250.0);
        p_.noiseSigma = rng_.uni(3.0, 25.0) / 32768.0;
      }
    }
  }

  void drawRingDown(double endLo, double endHi, double tailLo, double tailHi, double decayLoMm,
                    double decayHiMm) {
    p_.burstEnd = rng_.logUni(endLo, endHi);
    p_.burstAmp = rng_.uni(0.7, 2.0);
    p_.ringFreq = p_.fc * rng_.uni(0.93, 1.07);
    p_.ringPhase = rng_.uni(0.0, 2.0 * kPi);
    p_.tailAmp = rng_.logUni(tailLo, tailHi);
    // Decays to 5 % over the drawn distance (apparent mm).
    p_.tailTau = twoWayTime(rng_.uni(decayLoMm, decayHiMm), p_.cAssumed) / 3.0;
    p_.tailOscFraction = rng_.uni(0.3, 1.0);
    p_.tailSign = rng_.chance(0.5) ? 1.0 : -1.0;
  }

  void drawDrift(double ampLoCodes16, double ampHiCodes16) {
    p_.drift = true;
    const double total = rng_.uni(ampLoCodes16, ampHiCodes16) / 32768.0;
    const int comps = rng_.integer(1, 3);
    double weights[3] = {0.0, 0.0, 0.0};
    double sum = 0.0;
    for (int j = 0; j < comps; ++j) {
      weights[j] = rng_.uni(0.3, 1.0);
      sum += weights[j];
    }
    for (int j = 0; j < 3; ++j) {
      p_.driftAmp[j] = total * weights[j] / sum * 0.8;
      p_.driftFreq[j] = rng_.logUni(0.05e6, 1.0e6);
      p_.driftPhase[j] = rng_.uni(0.0, 2.0 * kPi);
    }
    p_.recoveryAmp = (rng_.chance(0.5) ? 1.0 : -1.0) * total * rng_.uni(0.2, 1.0);
    p_.recoveryTau = rng_.uni(2e-6, 20e-6);
  }

  void drawTissueLevels() {
    p_.skinMm = rng_.uni(0.8, 2.0);
    p_.fatFraction = rng_.uni(0.1, 0.6);
    p_.cSkin = rng_.uni(1580.0, 1620.0);
    p_.cFat = rng_.uni(1430.0, 1470.0);
    p_.cMuscle = rng_.uni(1560.0, 1600.0);
    p_.skinLevel = rng_.uni(1.2, 2.5);
    p_.fatLevel = rng_.uni(0.2, 0.6);
    p_.bonePhase = rng_.uni(0.0, 2.0 * kPi);
    p_.cortexMm = rng_.uni(1.0, 5.0);
    p_.cCortex = rng_.uni(3400.0, 4000.0);
    p_.theta0Deg = rng_.uni(5.0, 9.0);
    p_.obliqueFloorDb = rng_.uni(25.0, 40.0);
    p_.beamWidthMm = rng_.uni(1.5, 4.0);
    // Occasional layer interfaces.
    const int nSepta = rng_.integer(0, 3);
    for (int i = 0; i < nSepta; ++i) {
      const double where = rng_.uni(0.1, 0.9);
      p_.septa.emplace_back(where, rng_.uni(0.04, 0.2));
    }
    const int nStri = rng_.integer(0, 4);
    for (int i = 0; i < nStri; ++i) {
      const double where = rng_.uni(0.05, 0.9);
      p_.striations.emplace_back(where, rng_.uni(0.03, 0.15));
    }
    p_.fasciaRatio = rng_.chance(0.6) ? rng_.uni(0.1, 0.5) : 0.0;
  }

  void drawBehindBone(bool strongReverbAllowed, double strongProb) {
    p_.cortexRatio = rng_.uni(0.05, 0.3);
    p_.reverbFirst = rng_.uni(0.1, 0.4);
    p_.reverbRatio = rng_.uni(0.3, 0.6);
    p_.reverbSpacingMm = rng_.uni(0.3, 1.2);
    p_.strongReverb = strongReverbAllowed && rng_.chance(strongProb);
    if (p_.strongReverb) {
      // Echoes closer than the pulse is long, merging into a tail that halves over 2.5-5 mm.
      const double fwhmMm = 0.882 / (p_.fbw * p_.fc) * p_.cAssumed / 2.0 * 1e3;
      const double spacing = rng_.uni(0.3, 0.6);
      p_.reverbSpacingMm = spacing * fwhmMm;
      p_.reverbRatio = std::pow(0.5, p_.reverbSpacingMm / rng_.uni(3.0, 6.0));
      // In phase with each other (a ringing of the cortex), overlapping echoes add up to about
      // 1.06 / spacing times one of them: the tail starts at 0.75-1 of the bone echo.
      p_.reverbFirst = rng_.uni(0.75, 1.0) * spacing / 1.064;
      p_.reverbCoherent = true;
      p_.reverbPhaseJitter = 0.15;
      p_.diffuseReverb = rng_.uni(0.1, 0.25);
      p_.diffuseReverbMm = rng_.uni(2.0, 5.0);
    }
  }

  void drawRandomised() {
    const double cAssumedChoices[] = {1480.0, 1500.0, 1540.0, 1540.0, 1560.0, 1580.0};
    p_.cAssumed = rng_.chance(0.5) ? cAssumedChoices[rng_.integer(0, 5)] : rng_.uni(1480.0, 1580.0);
    // Probe and sampling.
    for (;;) {
      drawProbe(3.5, 15.0, 0.4, 0.9);
      const double fsMin = std::max(20e6, 2.5 * p_.fc * (1.0 + p_.fbw / 2.0));
      if (fsMin <= 100e6) {
        const double fsList[] = {20e6, 25e6, 40e6, 50e6, 60e6, 62.5e6, 80e6, 100e6};
        std::vector<double> ok;
        for (double f : fsList) {
          if (f >= fsMin) {
            ok.push_back(f);
          }
        }
        p_.fs = rng_.chance(0.7)
                    ? ok[static_cast<std::size_t>(rng_.integer(0, static_cast<int>(ok.size()) - 1))]
                    : rng_.uni(fsMin, 100e6);
        break;
      }
    }
    const int st = rng_.pick({0.2, 0.15, 0.3, 0.2, 0.15});
    switch (st) {
      case 0:
        setStorage(SampleStorage::UInt8, 8, false);
        break;
      case 1:
        setStorage(SampleStorage::Int8, 8, false);
        break;
      case 2:
        setStorage(SampleStorage::Int16, 12, true);
        break;
      case 3:
        setStorage(SampleStorage::Int16, 16, false);
        break;
      default:
        setStorage(SampleStorage::UInt16, 16, false);
        break;
    }
    drawRingDown(0.2e-6, 4e-6, 0.02, 0.5, 1.0, 4.0);
    if (rng_.chance(0.65)) {
      drawDrift(1000.0, 3000.0);
    }
    p_.attenuation = rng_.uni(0.5, 1.0);
    p_.tgc = rng_.chance(0.5) ? rng_.uni(0.0, 0.9) : 0.0;
    drawTissueLevels();
    // Standoff and tissue.
    const int so = rng_.pick({0.5, 0.2, 0.3});
    if (so == 1) {
      p_.standoffType = "gel";
      p_.standoffMm = rng_.uni(1.0, 3.0);
      p_.cStandoff = rng_.uni(1500.0, 1540.0);
    } else if (so == 2) {
      p_.standoffType = "water";
      p_.standoffMm = rng_.uni(5.0, 20.0);
      p_.cStandoff = rng_.uni(1478.0, 1490.0);
    }
    const int tb = rng_.pick({0.3, 0.45, 0.25});
    p_.tissueMm =
        tb == 0 ? rng_.uni(0.7, 5.0) : (tb == 1 ? rng_.uni(5.0, 20.0) : rng_.uni(20.0, 40.0));
    if (p_.standoffType == "water" && rng_.chance(0.2)) {
      p_.tissueMm = 0.0;  // bone (phantom) in water
    }
    if (p_.standoffMm + p_.tissueMm > 58.0) {
      p_.tissueMm = 58.0 - p_.standoffMm;
    }
    if (p_.standoffMm + p_.tissueMm < 1.0) {
      p_.tissueMm = 1.0 - p_.standoffMm;
    }
    p_.boneAmp = rng_.logUni(0.06, 1.3);
    p_.speckleToBone = std::pow(10.0, -rng_.uni(20.0, 42.0) / 20.0);
    p_.standoffLevel = std::pow(10.0, -rng_.uni(25.0, 45.0) / 20.0);
    p_.shadow = rng_.logUni(0.03, 0.35);
    p_.skinEchoRatio = rng_.uni(0.15, 0.7);
    p_.standoffMultipleRatio = rng_.uni(0.1, 0.4);
    drawBehindBone(true, 0.3);
    if (p_.standoffType == "water") {
      p_.ghostStandoff = rng_.uni(0.02, 0.12);
      p_.ghostDouble = rng_.uni(0.05, 0.25);
    } else if (rng_.chance(0.5)) {
      p_.ghostDouble = rng_.uni(0.02, 0.15);
    }
    if (rng_.chance(0.25)) {
      p_.similarRatio = rng_.uni(0.7, 1.3);
      p_.similarAboveMm = rng_.uni(1.0, 6.0);
    } else if (rng_.chance(0.08)) {
      p_.fasciaRatio = rng_.uni(0.8, 1.4);  // a fascia as strong as bone, higher up
    }
    p_.burstNoiseProb = 0.03;
    p_.handHeld = rng_.chance(0.5);
    limitGain();
    scenarioSpecifics();
  }

  void drawInvivo() {
    p_.cAssumed = rng_.chance(0.7) ? 1540.0 : rng_.uni(1500.0, 1580.0);
    drawProbe(7.0, 7.6, 0.5, 0.8);
    p_.fs = 50e6;
    setStorage(SampleStorage::Int16, 12, true);
    p_.dc = std::abs(p_.dc);
    drawRingDown(22.0 / 50e6, 28.0 / 50e6, 2000.0 / 32768.0, 4000.0 / 32768.0, 2.5, 3.5);
    p_.tailOscFraction = rng_.uni(0.2, 0.7);
    drawDrift(1000.0, 3000.0);
    p_.attenuation = rng_.uni(0.5, 1.0);
    p_.tgc = 0.0;
    drawTissueLevels();
    p_.skinMm = rng_.uni(0.8, 1.5);
    p_.tissueMm = std::clamp(std::exp(std::log(3.5) + 0.55 * rng_.normal()), 1.0, 10.0);
    p_.boneAmp = rng_.logUni(0.12, 0.8);
    p_.speckleToBone = std::pow(10.0, -rng_.uni(20.0, 36.0) / 20.0);
    p_.shadow = rng_.logUni(0.05, 0.4);
    drawBehindBone(true, 0.8);
    p_.ghostDouble = rng_.uni(0.02, 0.12);
    if (rng_.chance(0.5)) {
      p_.similarRatio = rng_.uni(0.6, 1.25);
      p_.similarAboveMm = rng_.uni(0.8, 3.0);
    }
    p_.burstNoiseProb = 0.02;
    p_.handHeld = false;
    windowMin_ = rng_.uni(0.3, 1.0);
    windowMax_ = rng_.uni(12.0, 18.0);
    limitGain();
    scenarioSpecifics();
  }

  void drawSpecimen() {
    p_.cAssumed = rng_.chance(0.6) ? 1540.0 : rng_.uni(1480.0, 1580.0);
    drawProbe(7.0, 10.0, 0.45, 0.8);
    p_.fs = 50e6;
    if (rng_.chance(0.5)) {
      setStorage(SampleStorage::UInt8, 8, false);
    } else {
      setStorage(SampleStorage::Int8, 8, false);
    }
    drawRingDown(0.4e-6, 2.0e-6, 0.05, 0.4, 1.0, 3.0);
    if (rng_.chance(0.4)) {
      drawDrift(1000.0, 3000.0);
    }
    p_.attenuation = rng_.uni(0.5, 1.0);
    p_.tgc = rng_.chance(0.5) ? rng_.uni(0.0, 0.8) : 0.0;
    drawTissueLevels();
    p_.fasciaRatio = rng_.chance(0.5) ? rng_.uni(0.1, 0.4) : 0.0;
    p_.standoffType = "water";
    p_.standoffMm = rng_.uni(5.0, 20.0);
    p_.cStandoff = rng_.uni(1478.0, 1490.0);
    p_.tissueMm = std::min(rng_.uni(2.0, 30.0), 52.0 - p_.standoffMm);
    p_.boneAmp = rng_.logUni(0.2, 1.2);
    p_.speckleToBone = std::pow(10.0, -rng_.uni(18.0, 38.0) / 20.0);
    p_.standoffLevel = std::pow(10.0, -rng_.uni(30.0, 45.0) / 20.0);
    p_.shadow = 0.0;  // only noise behind the bone
    p_.skinEchoRatio = rng_.uni(0.15, 0.6);
    p_.standoffMultipleRatio = rng_.uni(0.1, 0.35);
    drawBehindBone(false, 0.0);
    p_.cortexRatio = 0.0;
    p_.reverbFirst = 0.0;
    p_.ghostStandoff = 0.0;
    p_.ghostDouble = 0.0;
    p_.burstNoiseProb = 0.0;
    p_.handHeld = rng_.chance(0.5);
    limitGain();
    scenarioSpecifics();
  }

  /// The gain is set so the speckle near the skin (brightest without a full TGC) stays within
  /// the ADC's range: 3x its RMS under 0.35 of full scale.
  void limitGain() {
    const double nearRms = p_.boneAmp * p_.speckleToBone * std::max(1.0, p_.skinLevel) *
                           std::max(1.0, depthFactor(0.0));
    if (3.0 * nearRms > 0.35) {
      p_.boneAmp *= 0.35 / (3.0 * nearRms);
    }
  }

  void scenarioSpecifics() {
    switch (p_.scenario) {
      case Scenario::Uncoupled:
        // Probe in air: no standoff, no tissue; the face reverberates, the ringing lasts longer.
        p_.standoffType = "none";
        p_.standoffMm = 0.0;
        p_.tailTau *= rng_.uni(1.5, 3.0);
        p_.lensReverb = true;
        p_.lensPeriod = rng_.uni(0.6e-6, 2.5e-6);
        p_.lensAmp = rng_.uni(0.1, 0.6);
        p_.lensRatio = rng_.uni(0.4, 0.8);
        break;
      case Scenario::NoSkin:
        p_.standoffType = "water";
        p_.cStandoff = rng_.uni(1478.0, 1490.0);
        p_.standoffMm = 0.0;  // no wall echo: the water extends past the record
        break;
      case Scenario::BeyondRecord:
        p_.tissueMm = std::max(p_.tissueMm, rng_.uni(20.0, 45.0));
        break;
      case Scenario::FasciaAsStrong:
        p_.tissueMm = std::max(p_.tissueMm, rng_.uni(15.0, 40.0));
        p_.fasciaRatio = 0.0;
        p_.similarRatio = rng_.uni(0.8, 1.3);
        p_.strongFasciaFraction = rng_.uni(0.3, 0.8);
        break;
      case Scenario::Noise:
        p_.noiseScenarioSigma = p_.boneAmp / rng_.uni(0.5, 3.0);
        if (rng_.chance(0.4)) {
          p_.interferenceAmp = p_.boneAmp * rng_.uni(0.3, 1.0);
          p_.interferenceFreq = p_.fc * rng_.uni(0.5, 1.5);
        }
        break;
      case Scenario::Bone:
      case Scenario::BoneObliqueProne:
        break;
    }
    // The acquisition delay: often 0, sometimes inside the burst, sometimes past it.
    const int d = rng_.pick({0.4, 0.35, 0.25});
    if (p_.profile == "invivo-holder") {
      p_.delay = 0.0;
    } else if (d == 1) {
      p_.delay = rng_.uni(0.0, 0.8 * p_.burstEnd);
    } else if (d == 2) {
      p_.delay = rng_.uni(0.0, 3e-6);
    }
  }

  /// Frame kinematics: a tracked hand-held sweep or a strapped holder.
  void drawMotion() {
    p_.frameRate = p_.handHeld ? 100.0 : 45.0;
    geoms_.resize(static_cast<std::size_t>(frames_));
    if (p_.handHeld) {
      drawSweep();
    } else {
      drawHolder();
    }
  }

  void drawSweep() {
    // Leg frame: skin plane z = 0, +z into the leg, x along the sweep. Bone surface
    // z = T0 + a x + b x^2 + c y^2 (gently curved).
    const double v = rng_.uni(10.0, 50.0) * (rng_.chance(0.5) ? 1.0 : -1.0);
    const double duration = frames_ / p_.frameRate;
    const double x0 = -v * duration / 2.0 + rng_.uni(-5.0, 5.0);
    const double slope = rng_.uni(-0.06, 0.06);
    const double radius = rng_.uni(100.0, 400.0);
    const double curv = (rng_.chance(0.8) ? 1.0 : -1.0) / (2.0 * radius);
    const double curvY = 1.0 / (2.0 * rng_.uni(30.0, 200.0));
    const double t0 = p_.tissueMm;
    // Tilt about y (in the sweep plane) and roll about x: slow wander + tremor.
    const int tiltKind = obliqueProne_ ? 2 : rng_.pick({0.78, 0.22});
    const double tiltAmp = tiltKind == 0
                               ? rng_.uni(0.0, 3.0)
                               : (tiltKind == 1 ? rng_.uni(3.0, 8.0) : rng_.uni(10.0, 20.0));
    const double tiltBase = rng_.uni(-3.0, 3.0), rollBase = rng_.uni(-2.0, 2.0);
    const double tiltF = rng_.uni(0.3, 2.0), tiltPh = rng_.uni(0.0, 2.0 * kPi);
    double tremF[4], tremPh[4];
    for (int j = 0; j < 4; ++j) {
      tremF[j] = rng_.uni(6.0, 12.0);
      tremPh[j] = rng_.uni(0.0, 2.0 * kPi);
    }
    const double tremMm = rng_.uni(0.05, 0.3), tremDeg = rng_.uni(0.1, 0.5);
    // The leg in the tracker.
    double qc[4];
    for (double& component : qc) {
      component = rng_.normal();
    }
    Eigen::Quaterniond q(qc[0], qc[1], qc[2], qc[3]);
    q.normalize();
    Eigen::Matrix4d legToTracker = Eigen::Matrix4d::Identity();
    legToTracker.block<3, 3>(0, 0) = q.toRotationMatrix();
    const double lx = rng_.uni(-300.0, 300.0);
    const double ly = rng_.uni(-300.0, 300.0);
    const double lz = rng_.uni(-2000.0, -800.0);
    legToTracker.block<3, 1>(0, 3) = Eigen::Vector3d(lx, ly, lz);
    // Lift-off (loss of contact) for a few frames, not with a water standoff.
    int liftStart = -1, liftLen = 0;
    if (p_.scenario == Scenario::Bone && p_.standoffType != "water" && rng_.chance(0.2)) {
      liftLen = rng_.integer(3, 8);
      liftStart = rng_.integer(0, std::max(0, frames_ - liftLen));
    }
    const double deg = kPi / 180.0;
    for (int k = 0; k < frames_; ++k) {
      const double tau = k / p_.frameRate;
      FrameGeom& g = geoms_[static_cast<std::size_t>(k)];
      const double tx = tremMm * std::sin(2.0 * kPi * tremF[0] * tau + tremPh[0]);
      const double ty = tremMm * std::sin(2.0 * kPi * tremF[1] * tau + tremPh[1]);
      const double press = 0.5 * tremMm * (1.0 + std::sin(2.0 * kPi * tremF[2] * tau + tremPh[2]));
      const double tilt = (tiltBase + tiltAmp * std::sin(2.0 * kPi * tiltF * tau + tiltPh) +
                           tremDeg * std::sin(2.0 * kPi * tremF[3] * tau + tremPh[3])) *
                          deg;
      const double roll = (rollBase + tremDeg * std::cos(2.0 * kPi * tremF[3] * tau)) * deg;
      const Eigen::Matrix3d r = rotY(tilt) * rotX(roll);
      const Eigen::Vector3d dir = r * Eigen::Vector3d::UnitZ();
      const double faceZ = p_.standoffMm > 0.0 ? -p_.standoffMm + press : press;
      const Eigen::Vector3d pos(x0 + v * tau + tx, ty, faceZ);
      // Ray/bone intersection by Newton's method.
      double lam = (t0 - pos.z()) / dir.z();
      for (int it = 0; it < 20; ++it) {
        const double x = pos.x() + lam * dir.x(), y = pos.y() + lam * dir.y();
        const double gval =
            t0 + slope * x + curv * x * x + curvY * y * y - (pos.z() + lam * dir.z());
        const double dg = (slope + 2.0 * curv * x) * dir.x() + 2.0 * curvY * y * dir.y() - dir.z();
        const double stepL = gval / dg;
        lam -= stepL;
        if (std::abs(stepL) < 1e-9) {
          break;
        }
      }
      const double x = pos.x() + lam * dir.x(), y = pos.y() + lam * dir.y();
      Eigen::Vector3d nrm(-(slope + 2.0 * curv * x), -2.0 * curvY * y, 1.0);
      nrm.normalize();
      g.incidenceDeg = std::acos(std::min(1.0, std::abs(nrm.dot(dir)))) / deg;
      g.standoffMm = faceZ < 0.0 ? -faceZ / dir.z() : 0.0;
      g.tissueMm = std::max(0.0, lam - g.standoffMm);
      if (t0 <= 0.0) {
        g.tissueMm = 0.0;
        g.standoffMm = lam;
      }
      Eigen::Matrix4d probeInLeg = Eigen::Matrix4d::Identity();
      probeInLeg.block<3, 3>(0, 0) = r;
      probeInLeg.block<3, 1>(0, 3) = pos;
      g.pose = legToTracker * probeInLeg;
      g.hasPose = true;
      g.xi = std::max(0.0, (pos.x() - x0) / p_.beamWidthMm * (v >= 0.0 ? 1.0 : -1.0));
      g.liftOff = k >= liftStart && k < liftStart + liftLen;
    }
  }

  void drawHolder() {
    // Strapped to the leg: a fixed angle, the soft tissue moving the bone a little.
    const bool oblique = obliqueProne_;
    const double theta = oblique ? rng_.uni(8.0, 20.0) : rng_.uni(0.0, 4.0);
    double depth = 0.0, rate = 0.0, xi = 0.0;
    const double breathAmp = rng_.uni(0.02, 0.15), breathF = rng_.uni(0.2, 1.2);
    const double breathPh = rng_.uni(0.0, 2.0 * kPi);
    const double xiRate = rng_.uni(0.005, 0.03);
    double contraction = 0.0;
    for (int k = 0; k < frames_; ++k) {
      FrameGeom& g = geoms_[static_cast<std::size_t>(k)];
      const double tau = k / p_.frameRate;
      rate = 0.8 * rate + 0.02 * rng_.normal();
      depth += rate;
      depth *= 0.99;
      if (rng_.chance(0.012)) {
        contraction = (rng_.chance(0.5) ? 1.0 : -1.0) * rng_.uni(1.0, 2.0);
        xi += 0.3;
      }
      contraction *= 0.9;
      xi += xiRate;
      const double change =
          depth + breathAmp * std::sin(2.0 * kPi * breathF * tau + breathPh) + contraction;
      const double scale = p_.tissueMm > 0.0 ? 1.0 : 0.0;
      g.tissueMm = std::max(0.3 * scale, p_.tissueMm + change * scale);
      g.standoffMm = p_.standoffMm + (scale > 0.0 ? 0.0 : change);
      g.incidenceDeg = std::max(0.0, theta + 0.5 * rng_.normal());
      g.xi = xi;
    }
  }

  /// Record length, given the bone's range of depths.
  void fitRecord() {
    double tMax = 0.0, tMin = 1.0;
    for (const FrameGeom& g : geoms_) {
      const Layers l = layersOf(p_, g);
      tMax = std::max(tMax, l.tBone);
      tMin = std::min(tMin, g.standoffMm > 0.0 ? l.tStandoff : l.tBone);
    }
    // The delay must leave the first echo in the record.
    p_.delay = std::clamp(p_.delay, 0.0, std::max(0.0, tMin - 1e-6));
    if (p_.profile == "invivo-holder") {
      p_.n = 1500;
      return;
    }
    if (p_.profile == "specimen-standoff") {
      p_.n = 4096;
      const double tEnd = p_.delay + p_.n / p_.fs;
      if (p_.scenario == Scenario::FasciaAsStrong) {
        // The bone is beyond the record.
        for (FrameGeom& g : geoms_) {
          g.tissueMm += std::max(0.0, (tEnd - tMax) * p_.cMuscle / 2.0 * 1e3 + 5.0);
        }
      }
      return;
    }
    const double sPerMm = twoWayTime(1.0, p_.cAssumed) * p_.fs;
    const bool noBone =
        p_.scenario == Scenario::BeyondRecord || p_.scenario == Scenario::FasciaAsStrong;
    if (noBone) {
      // The record ends 2-20 mm before the shallowest bone.
      double tShallow = 1.0;
      for (const FrameGeom& g : geoms_) {
        tShallow = std::min(tShallow, layersOf(p_, g).tBone);
      }
      const double gap = rng_.uni(2.0, 20.0);
      int n = static_cast<int>((tShallow - p_.delay) * p_.fs - gap * sPerMm);
      if (n < 1000) {
        const double push = (1000 - n) / sPerMm * p_.cMuscle / p_.cAssumed;
        for (FrameGeom& g : geoms_) {
          g.tissueMm += push;
        }
        n = 1000;
      }
      p_.n = std::min(n, 12000);
      return;
    }
    const double behindMm = rng_.uni(3.0, 25.0);
    int need = static_cast<int>((tMax - p_.delay) * p_.fs + behindMm * sPerMm);
    need = static_cast<int>(need * rng_.uni(1.0, 1.5));
    p_.n = std::clamp(need, 1000, 12000);
  }

  // --- per capture signals ------------------------------------------------------------------

  /// Speckle templates: unit-RMS white scatterers convolved with the depth-dependent pulse, at
  /// 2 fs. Frames sample and mix them (decorrelation with lateral motion, axial warp).
  void makeTemplates() {
    double xiMax = 0.0;
    for (const FrameGeom& g : geoms_) {
      xiMax = std::max(xiMax, g.xi);
    }
    const int count = static_cast<int>(std::floor(xiMax)) + 3;  // + 1 for the bone's own
    // Room for the axial warp (the bone's movement relative to frame 0) and the bursts' offsets.
    double maxShift = 0.0;
    const double s0 = layersOf(p_, geoms_[0]).tBone;
    for (const FrameGeom& g : geoms_) {
      maxShift = std::max(maxShift, std::abs(layersOf(p_, g).tBone - s0) * p_.fs);
    }
    margin_ = static_cast<int>(std::ceil(twoWayTime(2.0, p_.cAssumed) * p_.fs + maxShift)) + 16;
    const int len2 = 2 * (p_.n + 2 * margin_);
    // Depth segments (by the nominal layers).
    FrameGeom nominal = geoms_[geoms_.size() / 2];
    const Layers l = layersOf(p_, nominal);
    const int kSeg = 3;
    std::vector<double> segCentre(kSeg), segDepth(kSeg);
    for (int s = 0; s < kSeg; ++s) {
      segCentre[static_cast<std::size_t>(s)] = (s + 0.5) / kSeg * len2;
      const double t = p_.delay + (segCentre[static_cast<std::size_t>(s)] / 2.0 - margin_) / p_.fs;
      segDepth[static_cast<std::size_t>(s)] = l.tissue ? tissueDepthAt(l, p_, t) : 0.0;
    }
    int plen = 0;
    std::vector<std::vector<double>> pulses(kSeg);
    std::vector<int> zeros(kSeg);
    for (int s = 0; s < kSeg; ++s) {
      const Pulse& pu = bank_->at(segDepth[static_cast<std::size_t>(s)]);
      std::vector<double>& v = pulses[static_cast<std::size_t>(s)];
      for (std::size_t i = 0; i < pu.re.size(); i += kFine / 2) {
        v.push_back(pu.re[i]);
      }
      const double norm = 1.0 / std::sqrt(2.0 * pu.energy);
      for (double& x : v) {
        x *= norm;
      }
      zeros[static_cast<std::size_t>(s)] = pu.zeroIndex / (kFine / 2);
      plen = std::max(plen, static_cast<int>(v.size()));
    }
    const std::size_t m = nextPow2(static_cast<std::size_t>(len2 + plen));
    std::vector<std::vector<Cplx>> pulseSpec(kSeg);
    for (int s = 0; s < kSeg; ++s) {
      std::vector<Cplx>& ps = pulseSpec[static_cast<std::size_t>(s)];
      ps.assign(m, Cplx(0.0, 0.0));
      const std::vector<double>& v = pulses[static_cast<std::size_t>(s)];
      const int z = zeros[static_cast<std::size_t>(s)];
      for (std::size_t i = 0; i < v.size(); ++i) {
        // Circularly placed so the arrival is at index 0.
        const long idx = (static_cast<long>(i) - z + static_cast<long>(m)) % static_cast<long>(m);
        ps[static_cast<std::size_t>(idx)] = Cplx(v[i], 0.0);
      }
      fftForward(ps);
    }
    templates_.assign(static_cast<std::size_t>(count), std::vector<double>());
    std::vector<double> white(static_cast<std::size_t>(len2));
    for (int j = 0; j < count; ++j) {
      for (double& w : white) {
        w = rng_.normal();
      }
      std::vector<Cplx> sum(m, Cplx(0.0, 0.0));
      for (int s = 0; s < kSeg; ++s) {
        std::vector<Cplx> buf(m, Cplx(0.0, 0.0));
        const double c0 = segCentre[static_cast<std::size_t>(s)];
        const double width = static_cast<double>(len2) / kSeg;
        for (int i = 0; i < len2; ++i) {
          double w = 1.0 - std::abs(i - c0) / width;
          if ((s == 0 && i < c0) || (s == kSeg - 1 && i > c0)) {
            w = 1.0;
          }
          if (w > 0.0) {
            // Square-root weights keep the variance constant across the crossfade.
            buf[static_cast<std::size_t>(i)] =
                Cplx(white[static_cast<std::size_t>(i)] * std::sqrt(w), 0.0);
          }
        }
        fftForward(buf);
        const std::vector<Cplx>& ps = pulseSpec[static_cast<std::size_t>(s)];
        for (std::size_t k = 0; k < m; ++k) {
          sum[k] += buf[k] * ps[k];
        }
      }
      fftInverse(sum);
      std::vector<double>& t = templates_[static_cast<std::size_t>(j)];
      t.resize(static_cast<std::size_t>(len2));
      for (int i = 0; i < len2; ++i) {
        t[static_cast<std::size_t>(i)] = sum[static_cast<std::size_t>(i)].real();
      }
    }
  }

  /// Template j at 2fs position x (cubic interpolation).
  double templateAt(int j, double x) const {
    const std::vector<double>& t = templates_[static_cast<std::size_t>(
        std::clamp(j, 0, static_cast<int>(templates_.size()) - 1))];
    const int n = static_cast<int>(t.size());
    const int i = static_cast<int>(std::floor(x));
    if (i < 1 || i + 2 >= n) {
      return 0.0;
    }
    const double f = x - i;
    const double p0 = t[static_cast<std::size_t>(i - 1)], p1 = t[static_cast<std::size_t>(i)];
    const double p2 = t[static_cast<std::size_t>(i + 1)], p3 = t[static_cast<std::size_t>(i + 2)];
    return p1 + 0.5 * f *
                    (p2 - p0 +
                     f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)));
  }

  // --- one frame ------------------------------------------------------------------------------
  /// The ring-down and the baseline's components, the same in every frame of the capture.
  void precomputeRingDown() {
    const int n = p_.n;
    const auto un = static_cast<std::size_t>(n);
    ringC_.assign(un, 0.0);
    ringS_.assign(un, 0.0);
    tailBase_.assign(un, 0.0);
    recovery_.assign(un, 0.0);
    lens_.assign(un, 0.0);
    for (auto& v : driftS_) {
      v.assign(un, 0.0);
    }
    for (auto& v : driftC_) {
      v.assign(un, 0.0);
    }
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const double t = p_.delay + i / p_.fs;
      // A burst at the ring frequency, then an exponential tail: an oscillating part and a
      // unipolar receiver recovery.
      const double theta = 2.0 * kPi * p_.ringFreq * t + p_.ringPhase;
      const double edge = 1.0 / (1.0 + std::exp((t - p_.burstEnd) * p_.ringFreq * 8.0));
      const double rise = 1.0 - std::exp(-t * p_.ringFreq * 3.0);
      const double tail = p_.tailAmp * std::exp(-std::max(0.0, t - p_.burstEnd) / p_.tailTau);
      const double a = p_.burstAmp * rise * edge + p_.tailOscFraction * tail * (1.0 - edge);
      ringC_[u] = a * std::cos(theta);
      ringS_[u] = a * std::sin(theta);
      tailBase_[u] = p_.tailSign * (1.0 - p_.tailOscFraction) * tail * (1.0 - edge);
      if (p_.drift) {
        recovery_[u] = p_.recoveryAmp * std::exp(-t / p_.recoveryTau);
        for (std::size_t j = 0; j < 3; ++j) {
          const double ph = 2.0 * kPi * p_.driftFreq[j] * t + p_.driftPhase[j];
          driftS_[j][u] = std::sin(ph);
          driftC_[j][u] = std::cos(ph);
        }
      }
      if (t > p_.burstEnd) {
        // Probe in air (used by uncoupled frames only): a longer ringing.
        lens_[u] = 0.3 * p_.tailAmp * std::exp(-(t - p_.burstEnd) / (2.0 * p_.tailTau)) *
                   std::sin(2.0 * kPi * p_.ringFreq * 1.01 * t);
      }
    }
    // ... and the reverberation inside the lens/matching layer.
    double a = p_.lensAmp;
    for (int r = 1; a > 0.003 && r < 64; ++r, a *= p_.lensRatio) {
      addEcho(lens_, Echo{p_.burstEnd + r * p_.lensPeriod, a, p_.ringPhase + r * kPi, 0.0});
    }
  }

  struct Echo {
    double t;  // two-way arrival time (s)
    double amp;
    double phase;
    double zMm;  // tissue depth in front of it (attenuation of its spectrum)
  };

  void addEcho(std::vector<double>& x, const Echo& e) {
    const Pulse& pu = bank_->at(e.zMm);
    const double s = (e.t - p_.delay) * p_.fs;
    const int lo = std::max(0, static_cast<int>(std::floor(s)) + pu.first);
    const int hi = std::min(p_.n - 1, static_cast<int>(std::ceil(s)) + pu.last);
    const double cp = std::cos(e.phase) * e.amp, sp = std::sin(e.phase) * e.amp;
    for (int i = lo; i <= hi; ++i) {
      x[static_cast<std::size_t>(i)] += pu.at(i - s, cp, sp);
    }
  }

  double depthFactor(double zMm) const {
    const double beta = p_.attenuation / 8.685889638 * (p_.fc / 1e6) * (1.0 - p_.tgc) / 10.0;
    const double ref = p_.tissueMm;
    return std::exp(std::clamp(-beta * (zMm - ref), -4.0, 4.0));
  }

  RandomisedFrame frame(int k) {
    const FrameGeom& g = geoms_[static_cast<std::size_t>(k)];
    RandomisedFrame f;
    f.timestampS = t0_ + k / p_.frameRate;
    f.hasPose = g.hasPose;
    f.probeToTracker = g.pose;
    const int n = p_.n;
    const double fs = p_.fs;
    std::vector<double> ring(static_cast<std::size_t>(n), 0.0);   // oscillating ring-down
    std::vector<double> base(static_cast<std::size_t>(n), 0.0);   // baseline (below the band)
    std::vector<double> diff(static_cast<std::size_t>(n), 0.0);   // speckle + noise + bursts
    std::vector<double> other(static_cast<std::size_t>(n), 0.0);  // other specular echoes
    std::vector<double> bone(static_cast<std::size_t>(n), 0.0);   // the bone's primary echo
    std::vector<double> own(static_cast<std::size_t>(n), 0.0);    // its cortex & reverberation

    const bool uncoupled = p_.scenario == Scenario::Uncoupled || g.liftOff;
    const bool noSkin = p_.scenario == Scenario::NoSkin;
    const double jitterPh = 0.05 * rng_.normal();
    // Ring-down (precomputed per capture), with a small phase jitter per frame; the baseline.
    const double cj = std::cos(jitterPh), sj = std::sin(jitterPh);
    const double cd = std::cos(0.02 * k), sd = std::sin(0.02 * k);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      ring[u] = ringC_[u] * cj - ringS_[u] * sj;
      double b = tailBase_[u];
      if (p_.drift) {
        b += recovery_[u];
        for (int j = 0; j < 3; ++j) {
          b += p_.driftAmp[j] * (driftS_[static_cast<std::size_t>(j)][u] * cd +
                                 driftC_[static_cast<std::size_t>(j)][u] * sd);
        }
      }
      base[u] = b;
      if (uncoupled) {
        ring[u] += lens_[u];
      }
    }
    if (uncoupled) {
      f.kind = "uncoupled";
    }

    // Layers of this frame.
    const Layers l = layersOf(p_, g);
    const double tBone = l.tBone;
    const double sBone = (tBone - p_.delay) * fs;
    const double sNominal = (layersOf(p_, geoms_[0]).tBone - p_.delay) * fs;
    const double boneDepth = tissueDepthAt(l, p_, tBone);
    const bool boneScenario = p_.scenario == Scenario::Bone || p_.scenario == Scenario::Noise;
    const bool haveBone = boneScenario && !uncoupled;
    const bool tissue = !uncoupled && !noSkin && l.tissue;

    // Speckle.
    if (!uncoupled) {
      const int j0 = static_cast<int>(std::floor(g.xi));
      const double fr = g.xi - j0;
      const double wa = std::cos(fr * kPi / 2.0), wb = std::sin(fr * kPi / 2.0);
      const double sigmaRef = p_.boneAmp * p_.speckleToBone;
      const double smooth = std::max(1.0, bank_->at(0.0).halfWidth);
      std::vector<double> level(static_cast<std::size_t>(n), 0.0);
      const bool isNone = p_.standoffType == "none";
      // The attenuation's depth factor, evaluated every 8 samples and interpolated.
      std::vector<double> atten(static_cast<std::size_t>(n / 8 + 2), 1.0);
      for (std::size_t j = 0; j < atten.size(); ++j) {
        const double t = p_.delay + static_cast<double>(8 * j) / fs;
        atten[j] = depthFactor(tissueDepthAt(l, p_, t));
      }
      for (int i = 0; i < n; ++i) {
        const double t = p_.delay + i / fs;
        double lv;
        if (noSkin || t < l.tStandoff) {
          lv = isNone && !noSkin ? 0.0 : p_.standoffLevel;
        } else if (!tissue) {
          lv = 0.0;
        } else if (t < l.tSkin) {
          lv = p_.skinLevel;
        } else if (t < l.tFat) {
          lv = p_.fatLevel;
        } else if (t < tBone || !haveBone) {
          lv = 1.0;
        } else {
          lv = p_.shadow;
        }
        if (tissue && t >= l.tStandoff) {
          const auto j = static_cast<std::size_t>(i / 8);
          const double w = (i % 8) / 8.0;
          lv *= atten[j] + w * (atten[j + 1] - atten[j]);
        }
        level[static_cast<std::size_t>(i)] = lv * sigmaRef;
      }
      smoothInPlace(level, static_cast<int>(std::lround(smooth)));
      const double shift = sBone - sNominal;  // axial warp with the bone's movement
      const double sTop = (l.tStandoff - p_.delay) * fs;
      for (int i = 0; i < n; ++i) {
        double u = 0.0;
        if (tissue && i > sTop) {
          u = i >= sBone ? shift : shift * (i - sTop) / std::max(1.0, sBone - sTop);
        }
        const double x2 = 2.0 * (i - u + margin_);
        const double v = wa * templateAt(j0, x2) + wb * templateAt(j0 + 1, x2);
        diff[static_cast<std::size_t>(i)] = v * level[static_cast<std::size_t>(i)];
      }
    }

    // Specular echoes.
    std::vector<Echo> others;
    bool similarAdded = false;
    const double frameJit = std::pow(10.0, 0.05 * rng_.normal());  // +-1 dB
    if (tissue) {
      if (g.standoffMm > 0.0) {
        const double a = p_.boneAmp * p_.skinEchoRatio;
        others.push_back(Echo{l.tStandoff, a, p_.bonePhase + 2.0, 0.0});
        if (p_.standoffType == "water") {
          // Multiples of the water path; the specimen profile keeps only noise behind the bone.
          const bool clearBehind = p_.profile == "specimen-standoff";
          for (int r = 2; r <= 3; ++r) {
            if (!clearBehind || r * l.tStandoff < tBone) {
              others.push_back(Echo{r * l.tStandoff, a * std::pow(p_.standoffMultipleRatio, r - 1),
                                    1.0 * r, 0.0});
            }
          }
        }
      }
      if (l.fatMm > 0.5 && p_.fasciaRatio > 0.0) {
        const double z = l.skinMm + l.fatMm;
        others.push_back(Echo{l.tFat, p_.boneAmp * p_.fasciaRatio * depthFactor(z) * frameJit,
                              p_.bonePhase + 1.0, z});
      }
      for (const auto& s : p_.septa) {
        if (l.fatMm > 1.0) {
          const double t = l.tSkin + s.first * (l.tFat - l.tSkin);
          const double z = tissueDepthAt(l, p_, t);
          others.push_back(Echo{t, p_.boneAmp * s.second * depthFactor(z), s.first * 7.0, z});
        }
      }
      for (const auto& s : p_.striations) {
        if (l.muscleMm > 2.0) {
          const double t = l.tFat + s.first * (tBone - l.tFat);
          const double z = tissueDepthAt(l, p_, t);
          others.push_back(Echo{t, p_.boneAmp * s.second * depthFactor(z), s.first * 11.0, z});
        }
      }
      if (p_.scenario == Scenario::FasciaAsStrong) {
        const double tEnd = p_.delay + n / fs;
        const double t = l.tSkin + p_.strongFasciaFraction * (std::min(tEnd, tBone) - l.tSkin);
        const double z = tissueDepthAt(l, p_, t);
        others.push_back(Echo{t, p_.boneAmp * p_.similarRatio * frameJit, p_.bonePhase, z});
      } else if (haveBone && p_.similarRatio > 0.0 && l.muscleMm + l.fatMm > p_.similarAboveMm) {
        const double t = tBone - twoWayTime(p_.similarAboveMm, p_.cMuscle);
        const double z = tissueDepthAt(l, p_, t);
        const double perFrame = std::pow(10.0, 0.08 * rng_.normal());
        others.push_back(Echo{t, p_.boneAmp * p_.similarRatio * depthFactor(boneDepth) * perFrame,
                              p_.bonePhase + 0.7, z});
        similarAdded = true;
      }
    }
    for (const Echo& e : others) {
      addEcho(other, e);
    }

    // The bone.
    double boneAmp = 0.0;
    double obliqueLossDb = 0.0;
    bool reverbFrame = false;
    if (haveBone) {
      double oblique = std::exp(-std::pow(g.incidenceDeg / p_.theta0Deg, 2.0));
      oblique = std::max(oblique, std::pow(10.0, -p_.obliqueFloorDb / 20.0));
      boneAmp = p_.boneAmp * depthFactor(boneDepth) * oblique * frameJit;
      obliqueLossDb = -20.0 * std::log10(oblique);
      const double phase = p_.bonePhase + 0.1 * rng_.normal();
      const Echo primary{tBone, boneAmp, phase, boneDepth};
      addEcho(bone, primary);
      // Cortical (endosteal) echo and reverberation trains, scaled with the primary.
      if (p_.cortexRatio > 0.0) {
        addEcho(own, Echo{tBone + twoWayTime(p_.cortexMm, p_.cCortex), boneAmp * p_.cortexRatio,
                          phase + kPi, boneDepth});
      }
      if (p_.reverbFirst > 0.0) {
        double a = boneAmp * p_.reverbFirst * std::pow(10.0, 0.04 * rng_.normal());
        const double dt = twoWayTime(p_.reverbSpacingMm, p_.cAssumed);
        for (int r = 1; a > 0.03 * boneAmp && r < 600; ++r, a *= p_.reverbRatio) {
          const double jitterT = dt * (p_.reverbCoherent ? 0.03 : 0.15) * rng_.normal();
          const double step = p_.reverbCoherent ? -2.0 * kPi * p_.fc * dt : 1.3;
          addEcho(own, Echo{tBone + r * dt + jitterT, a,
                            phase + step * r + p_.reverbPhaseJitter * rng_.normal(), boneDepth});
        }
      }
      if (p_.diffuseReverb > 0.0) {
        const double tau = twoWayTime(p_.diffuseReverbMm, p_.cAssumed);
        const int last = static_cast<int>(templates_.size()) - 1;
        for (int i = std::max(0, static_cast<int>(sBone)); i < n; ++i) {
          const double dtb = (i - sBone) / fs;
          const double env = boneAmp * p_.diffuseReverb * std::exp(-dtb / tau) *
                             (1.0 - std::exp(-dtb * p_.fc * 2.0));
          own[static_cast<std::size_t>(i)] +=
              env * templateAt(last, 2.0 * (i + margin_) +
                                         std::fmod(3.0 * k, static_cast<double>(margin_)));
        }
      }
      reverbFrame = p_.strongReverb;
      // Multiples: bone via the skin wall, and bone-face-bone.
      if (p_.ghostStandoff > 0.0 && g.standoffMm > 0.0) {
        addEcho(own, Echo{tBone + l.tStandoff, boneAmp * p_.ghostStandoff, phase + kPi, boneDepth});
      }
      if (p_.ghostDouble > 0.0) {
        addEcho(own, Echo{2.0 * tBone, boneAmp * p_.ghostDouble * depthFactor(2.0 * boneDepth),
                          phase + kPi, 2.0 * boneDepth});
      }
      f.boneTrueDepthMm = g.standoffMm + g.tissueMm;
      f.incidenceDeg = g.incidenceDeg;
    }

    // Noise: electronic, bursts, the whole-trace kind.
    std::vector<double> noise(static_cast<std::size_t>(n));
    double sigma = p_.noiseSigma;
    if (p_.scenario == Scenario::Noise) {
      sigma = std::max(sigma, p_.noiseScenarioSigma);
    }
    for (int i = 0; i < n; ++i) {
      noise[static_cast<std::size_t>(i)] = sigma * rng_.normal();
    }
    if (p_.interferenceAmp > 0.0) {
      const double ph = rng_.uni(0.0, 2.0 * kPi);
      for (int i = 0; i < n; ++i) {
        noise[static_cast<std::size_t>(i)] +=
            p_.interferenceAmp * std::sin(2.0 * kPi * p_.interferenceFreq * (i / fs) + ph);
      }
    }
    bool burstFrame = false;
    if (haveBone && rng_.chance(p_.burstNoiseProb)) {
      burstFrame = true;
      const double dur = rng_.uni(0.5e-6, 5e-6) * fs;
      const double centre = sBone + rng_.uni(-0.3, 0.3) * dur;
      const double amp = boneAmp * rng_.uni(0.15, 1.0);
      const bool banded = rng_.chance(0.5);
      const double off = rng_.uni(0.0, 2.0 * margin_ - 4.0);
      for (int i = std::max(0, static_cast<int>(centre - dur / 2)); i < n && i < centre + dur / 2;
           ++i) {
        const double w = 0.5 + 0.5 * std::cos(2.0 * kPi * (i - centre) / dur);
        const double v = banded ? templateAt(0, 2.0 * (i + margin_) + off) : rng_.normal();
        noise[static_cast<std::size_t>(i)] += amp * w * v;
      }
    }
    for (int i = 0; i < n; ++i) {
      diff[static_cast<std::size_t>(i)] += noise[static_cast<std::size_t>(i)];
    }

    // The record: sum, then the digitiser.
    f.samples.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const double x = ring[u] + base[u] + diff[u] + other[u] + bone[u] + own[u];
      double code = p_.dc + x * p_.halfRange;
      code = p_.step * std::round(code / p_.step);
      code = std::clamp(code, p_.minCode, p_.maxCode);
      f.samples[u] = static_cast<float>(code);
    }

    // Label.
    std::string kindBase;
    if (uncoupled) {
      kindBase = "uncoupled";
    } else if (noSkin) {
      kindBase = "no-skin";
    } else if (p_.scenario == Scenario::BeyondRecord) {
      kindBase = "bone-beyond-record";
    } else if (p_.scenario == Scenario::FasciaAsStrong) {
      kindBase = "fascia-as-strong";
    } else if (p_.scenario == Scenario::Noise) {
      kindBase = "noise";
    } else if (burstFrame) {
      kindBase = "noise-burst";
    } else {
      kindBase = obliqueLossDb >= 10.0 ? "oblique" : "bone";
      if (reverbFrame) {
        kindBase += "+reverb";
      }
      if (similarAdded) {
        kindBase += "+similar-echo";
      } else if (p_.fasciaRatio >= 0.7 && l.fatMm > 0.5) {
        kindBase += "+similar-echo";
      }
    }
    f.kind = kindBase;
    f.reverbBehindBone = haveBone && reverbFrame;
    if (haveBone) {
      const Pulse& pu = bank_->at(boneDepth);
      const double peak = sBone + pu.envPeak;
      f.boneAmplitude = boneAmp * p_.halfRange;
      if (peak < 0.0 || peak > n - 1) {
        f.kind = "bone-beyond-record";
      } else {
        label(f, peak, pu.halfWidth, boneAmp, ring, diff, other);
        if (peak > n - 1 - pu.halfWidth && f.hasBone) {
          f.hasBone = false;
          f.ambiguous = true;  // cut by the record's end
        }
      }
      if (keepClean_) {
        f.cleanBoneEcho.resize(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) {
          f.cleanBoneEcho[static_cast<std::size_t>(i)] =
              static_cast<float>(bone[static_cast<std::size_t>(i)] * p_.halfRange);
        }
      }
    }
    return f;
  }

  static void smoothInPlace(std::vector<double>& v, int half) {
    if (half <= 0 || v.empty()) {
      return;
    }
    const int n = static_cast<int>(v.size());
    std::vector<double> prefix(static_cast<std::size_t>(n) + 1, 0.0);
    for (int i = 0; i < n; ++i) {
      prefix[static_cast<std::size_t>(i) + 1] =
          prefix[static_cast<std::size_t>(i)] + v[static_cast<std::size_t>(i)];
    }
    for (int i = 0; i < n; ++i) {
      const int a = std::max(0, i - half), b = std::min(n, i + half + 1);
      v[static_cast<std::size_t>(i)] =
          (prefix[static_cast<std::size_t>(b)] - prefix[static_cast<std::size_t>(a)]) / (b - a);
    }
  }

  /// The expert's judgement: the bone echo's peak over (1) the strongest clutter at the bone
  /// (ring-down, other echoes, speckle, noise within its half-maximum width) and (2) the 90th
  /// percentile of the speckle and noise envelope 4 mm above to 2 mm below it, (3) that of the
  /// quantisation noise.
  void label(RandomisedFrame& f, double peak, double halfWidth, double boneAmp,
             const std::vector<double>& ring, const std::vector<double>& diff,
             const std::vector<double>& other) {
    const int n = p_.n;
    const double sPerMm = twoWayTime(1.0, p_.cAssumed) * p_.fs;
    const int lo = std::max(0, static_cast<int>(std::floor(peak - 4.0 * sPerMm)));
    const int hi = std::min(n, static_cast<int>(std::ceil(peak + 2.0 * sPerMm)) + 1);
    std::vector<double> clutter(static_cast<std::size_t>(n), 0.0);
    for (int i = lo; i < hi; ++i) {
      const auto u = static_cast<std::size_t>(i);
      clutter[u] = ring[u] + diff[u] + other[u];
    }
    const std::vector<double> envClutter = envelopeOf(clutter, lo, hi);
    const std::vector<double> envDiffuse = envelopeOf(diff, lo, hi);
    const int spotLo = std::max(lo, static_cast<int>(std::floor(peak - halfWidth)));
    const int spotHi = std::min(hi - 1, static_cast<int>(std::ceil(peak + halfWidth)));
    double spot = 0.0;
    for (int i = spotLo; i <= spotHi; ++i) {
      spot = std::max(spot, envClutter[static_cast<std::size_t>(i - lo)]);
    }
    std::vector<double> around;
    const double excl = 1.5 * halfWidth;
    for (int i = lo; i < hi; ++i) {
      if (std::abs(i - peak) > excl) {
        around.push_back(envDiffuse[static_cast<std::size_t>(i - lo)]);
      }
    }
    double context = 0.0;
    if (!around.empty()) {
      const auto q = static_cast<std::size_t>(0.9 * static_cast<double>(around.size() - 1));
      std::nth_element(around.begin(), around.begin() + static_cast<long>(q), around.end());
      context = around[q];
    }
    // Quantisation adds its own noise (step^2 / 12): its envelope's 90th percentile is a floor.
    const double quantisation = 2.15 * p_.step / std::sqrt(12.0) / p_.halfRange;
    const double contrast = boneAmp / std::max({spot, context, quantisation, 1e-12});
    f.boneContrast = contrast;
    f.boneSample = peak;
    f.boneDepthMm = (peak / p_.fs + p_.delay) * p_.cAssumed / 2.0 * 1000.0;
    if (contrast >= kClearContrast) {
      f.hasBone = true;
    } else if (contrast >= kLostContrast) {
      f.ambiguous = true;
    } else {
      f.boneSample = -1.0;
      f.boneDepthMm = -1.0;
    }
  }

  std::string describe() const {
    double lo = 1e9, hi = -1e9;
    for (const FrameGeom& g : geoms_) {
      lo = std::min(lo, g.tissueMm);
      hi = std::max(hi, g.tissueMm);
    }
    const char* storage = p_.storage == SampleStorage::UInt8   ? "uint8"
                          : p_.storage == SampleStorage::Int8  ? "int8"
                          : p_.storage == SampleStorage::Int16 ? "int16"
                                                               : "uint16";
    const char* scen[] = {"bone",  "uncoupled", "no-skin", "bone-beyond-record", "fascia-as-strong",
                          "noise", "bone"};
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s: %.2f MHz %.0f%% %s pulse, fs %.1f MHz, %d samples, %d-bit%s in %s, dc %.0f, "
                  "delay %.2f us, c %.0f m/s, standoff %s %.1f mm, tissue %.1f-%.1f mm, %s, %s",
                  p_.profile.c_str(), p_.fc / 1e6, p_.fbw * 100.0,
                  p_.shape == PulseShape::Gaussian     ? "gaussian"
                  : p_.shape == PulseShape::Asymmetric ? "asymmetric"
                                                       : "gamma",
                  p_.fs / 1e6, p_.n, p_.bits, p_.leftJustified ? " left-justified" : "", storage,
                  p_.dc, p_.delay * 1e6, p_.cAssumed, p_.standoffType.c_str(), p_.standoffMm, lo,
                  hi, p_.handHeld ? "hand-held sweep 100 Hz" : "strapped holder 45 Hz",
                  scen[static_cast<int>(p_.scenario)]);
    return buf;
  }

  Rng rng_;
  int frames_;
  bool keepClean_;
  Params p_;
  std::vector<FrameGeom> geoms_;
  std::unique_ptr<PulseBank> bank_;
  std::vector<std::vector<double>> templates_;
  int margin_ = 0;
  bool obliqueProne_ = false;
  std::vector<double> ringC_, ringS_, tailBase_, recovery_, lens_;
  std::vector<double> driftS_[3], driftC_[3];
  double t0_ = 0.0;
  double windowMin_ = 0.5, windowMax_ = 15.0;
};

/// What capture c shows: drawn without replacement from blocks of captures with fixed shares,
/// so a set's label shares vary little, and capture c does not depend on the set's size.
Scenario scenarioOf(const std::string& profile, std::uint64_t seed, int c) {
  std::vector<std::pair<Scenario, int>> block;
  if (profile == "invivo-holder") {
    block = {{Scenario::Bone, 15},
             {Scenario::BoneObliqueProne, 2},
             {Scenario::Uncoupled, 1},
             {Scenario::Noise, 2}};
  } else if (profile == "specimen-standoff") {
    block = {{Scenario::Bone, 12},  {Scenario::BoneObliqueProne, 2}, {Scenario::Uncoupled, 1},
             {Scenario::NoSkin, 1}, {Scenario::FasciaAsStrong, 2},   {Scenario::Noise, 2}};
  } else {
    block = {{Scenario::Bone, 18},  {Scenario::BoneObliqueProne, 2}, {Scenario::Uncoupled, 1},
             {Scenario::NoSkin, 1}, {Scenario::BeyondRecord, 1},     {Scenario::FasciaAsStrong, 1},
             {Scenario::Noise, 1}};
  }
  std::vector<Scenario> order;
  for (const auto& [scenario, count] : block) {
    order.insert(order.end(), static_cast<std::size_t>(count), scenario);
  }
  const int size = static_cast<int>(order.size());
  std::mt19937_64 engine(splitmix64(seed ^ 0xA5A5A5A5ULL) + static_cast<std::uint64_t>(c / size));
  std::shuffle(order.begin(), order.end(), engine);
  return order[static_cast<std::size_t>(c % size)];
}

}  // namespace

std::vector<RandomisedCapture> makeRandomisedSet(const RandomisedSetOptions& options) {
  if (options.captures < 0 || options.framesPerCapture < 1) {
    throw std::invalid_argument("makeRandomisedSet: captures >= 0 and framesPerCapture >= 1");
  }
  std::vector<RandomisedCapture> out;
  out.reserve(static_cast<std::size_t>(options.captures));
  for (int c = 0; c < options.captures; ++c) {
    const std::uint64_t seed =
        splitmix64(options.seed * 0x100000001B3ULL + static_cast<std::uint64_t>(c) + 1U);
    CaptureSynth synth(options.profile, scenarioOf(options.profile, options.seed, c), seed,
                       options.framesPerCapture, options.keepCleanBoneEcho);
    out.push_back(synth.run());
  }
  return out;
}

}  // namespace echoreg::test
