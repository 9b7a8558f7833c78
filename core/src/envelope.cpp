#include "echoreg/core/envelope.hpp"

#include "sample_sum.hpp"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

// Hot loops compiled twice, for the baseline x86-64 and for AVX2, and chosen at load time (GCC's
// function multi-versioning through an ifunc); elsewhere once.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define ECHOREG_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#define ECHOREG_HAVE_AVX2_PATH 1
#include <immintrin.h>
#else
#define ECHOREG_VECTOR_CLONES
#endif

namespace echoreg::core {

namespace detail {

// Scratch of subtractMovingAverage: window sums (float records), the prefix sums of the record's
// whole-number codes.
struct MovingAverageScratch {
  std::vector<float> sums;
  std::vector<std::int32_t> prefix;
};

}  // namespace detail

namespace {

constexpr double kPi = 3.14159265358979323846;

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument(message);
}

}  // namespace

std::string_view envelopeMethodName(EnvelopeMethod method) {
  switch (method) {
    case EnvelopeMethod::Mozes:
      return "mozes";
    case EnvelopeMethod::Hann:
      return "hann";
    case EnvelopeMethod::StdDev:
      return "stddev";
    case EnvelopeMethod::Hilbert:
      return "hilbert";
  }
  return "?";
}

EnvelopeMethod parseEnvelopeMethod(std::string_view name) {
  for (auto method : {EnvelopeMethod::Mozes, EnvelopeMethod::Hann, EnvelopeMethod::StdDev,
                      EnvelopeMethod::Hilbert}) {
    if (name == envelopeMethodName(method))
      return method;
  }
  throw std::invalid_argument("unknown envelope '" + std::string(name) +
                              "' (expected mozes, hann, stddev or hilbert)");
}

void validate(const EnvelopeParams& p) {
  require(p.ringDownSamples >= 0, "ring-down samples must be >= 0");
  require(p.highPassSamples == 0 || p.highPassSamples >= 2,
          "high-pass length must be 0 (demean only) or >= 2 samples");
  require(p.butterworthOrder >= 1 && p.butterworthOrder <= 12, "Butterworth order must be 1..12");
  require(p.cutoffNormalized > 0.0 && p.cutoffNormalized < 1.0,
          "cutoff must be in (0, 1) of Nyquist");
  require(p.windowSamples >= 1, "envelope window must be >= 1 sample");
  require(p.samplingFrequencyHz > 0.0 && std::isfinite(p.samplingFrequencyHz),
          "sampling frequency must be > 0");
  require(p.transducerFrequencyHz > 0.0 && p.transducerFrequencyHz < p.samplingFrequencyHz / 2.0,
          "transducer frequency must be in (0, Nyquist)");
  require(p.relativeBandwidth > 0.0 && p.relativeBandwidth <= 2.0,
          "relative bandwidth must be in (0, 2]");
  require(p.smoothingSamples >= 1, "smoothing must be >= 1 sample");
}

namespace detail {

// out = x - (centred moving average of x over highPassSamples, clipped to the record). Inside
// the record the window sum is L vectorised passes over the record (L is a few dozen samples
// at most for a corner at half the transducer frequency); within L of the ends, where the
// window is clipped, the sums run.
namespace {

#if defined(ECHOREG_HAVE_AVX2_PATH)
// The same pass eight samples at a time where the CPU has AVX2 (the four-lane version is bound by
// its instruction count): a scan within each 128-bit half, the low half's total added to the high
// half, then the carry of the blocks before.
__attribute__((target("avx2"))) std::size_t wholeCodePrefixAvx2(const float* samples, std::size_t n,
                                                                std::int32_t* prefix, bool& whole) {
  const __m256 limit = _mm256_set1_ps(65535.F);
  const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256i last = _mm256_set1_epi32(7);
  __m256 bad = _mm256_setzero_ps();
  __m256i carry = _mm256_setzero_si256();
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(samples + i);
    const __m256i code = _mm256_cvttps_epi32(x);
    bad = _mm256_or_ps(
        bad, _mm256_or_ps(_mm256_cmp_ps(_mm256_cvtepi32_ps(code), x, _CMP_NEQ_UQ),
                          _mm256_cmp_ps(_mm256_and_ps(x, magnitude), limit, _CMP_NLE_UQ)));
    __m256i sum = _mm256_add_epi32(code, _mm256_slli_si256(code, 4));
    sum = _mm256_add_epi32(sum, _mm256_slli_si256(sum, 8));
    // The low half's total (its lane 3) into every lane of the high half.
    const __m256i lowTotal = _mm256_shuffle_epi32(sum, _MM_SHUFFLE(3, 3, 3, 3));
    sum = _mm256_add_epi32(sum, _mm256_permute2x128_si256(lowTotal, lowTotal, 0x08));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(prefix + i + 1), _mm256_add_epi32(sum, carry));
    // The block's total joins the carry by one addition: the cross-lane permute stays off the
    // chain from block to block.
    carry = _mm256_add_epi32(carry, _mm256_permutevar8x32_epi32(sum, last));
  }
  whole = _mm256_movemask_ps(bad) == 0;
  return i;
}

bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2") != 0;
  return has;
}
#endif

// prefix[i + 1] = samples[0] + ... + samples[i] in 32-bit integers, and whether every sample is
// a whole number within 16 bits (NaN is not): only then is the conversion exact and defined, and
// the prefix meaningful. One pass: four samples at a time with SSE2 (eight with AVX2, above), the
// conversion, the check and a four-lane scan with the carry of the lanes before (integer sums, so
// the same numbers as the scalar loop in any order).
bool wholeCodePrefix(const float* samples, std::size_t n, std::int32_t* prefix) {
  prefix[0] = 0;
  std::size_t i = 0;
  bool whole = true;
#if defined(ECHOREG_HAVE_AVX2_PATH)
  if (cpuHasAvx2()) {
    i = wholeCodePrefixAvx2(samples, n, prefix, whole);
  } else
#endif
  {
#if defined(__SSE2__)
    const __m128 limit = _mm_set1_ps(65535.F);
    const __m128 magnitude = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    __m128 bad = _mm_setzero_ps();
    __m128i carry = _mm_setzero_si128();
    for (; i + 4 <= n; i += 4) {
      const __m128 x = _mm_loadu_ps(samples + i);
      const __m128i code = _mm_cvttps_epi32(x);
      // Not whole (or NaN): converting back does not give x. Out of range (or NaN): |x| > 65535.
      bad = _mm_or_ps(bad, _mm_or_ps(_mm_cmpneq_ps(_mm_cvtepi32_ps(code), x),
                                     _mm_cmpnle_ps(_mm_and_ps(x, magnitude), limit)));
      __m128i sum = _mm_add_epi32(code, _mm_slli_si128(code, 4));
      sum = _mm_add_epi32(sum, _mm_slli_si128(sum, 8));
      sum = _mm_add_epi32(sum, carry);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(prefix + i + 1), sum);
      carry = _mm_shuffle_epi32(sum, _MM_SHUFFLE(3, 3, 3, 3));
    }
    whole = _mm_movemask_ps(bad) == 0;
#endif
  }
  for (; whole && i < n; ++i) {
    const float x = samples[i];
    if (!(std::fabs(x) <= 65535.F) || std::trunc(x) != x)
      return false;
    prefix[i + 1] = prefix[i] + static_cast<std::int32_t>(x);
  }
  return whole;
}

}  // namespace

ECHOREG_VECTOR_CLONES
void subtractMovingAverage(const float* samples, int count, int window, float* out,
                           MovingAverageScratch& scratch) {
  const int length = std::min(window, count);
  const int before = (length - 1) / 2;
  const int after = length - 1 - before;
  const auto clippedMean = [&](int i) {
    const int b = std::max(0, i - before), e = std::min(count, i + after + 1);
    double sum = 0.0;
    for (int j = b; j < e; ++j)
      sum += samples[j];
    return sum / (e - b);
  };
  const int interiorBegin = before, interiorEnd = count - after;
  if (interiorEnd <= interiorBegin) {
    for (int i = 0; i < count; ++i)
      out[i] = static_cast<float>(samples[i] - clippedMean(i));
    return;
  }
  // Digitiser codes are whole numbers of at most 16 bits: their prefix sums are exact in 32-bit
  // integers for records of up to 32768 samples, and each window sum is a difference of two of
  // them (two passes: the conversion with its check and the prefix, then the window, which
  // vectorises); anything else (float captures, longer records) sums in floats.
  const auto n = static_cast<std::size_t>(count);
  const int windowCount = interiorEnd - interiorBegin;
  const float inverse = 1.F / static_cast<float>(length);
  bool whole = count <= 32768;
  if (whole) {
    scratch.prefix.resize(n + 1);
    whole = wholeCodePrefix(samples, n, scratch.prefix.data());
  }
  if (whole) {
    const std::int32_t* prefix = scratch.prefix.data();
    const float* centre = samples + interiorBegin;
    float* target = out + interiorBegin;
    for (int i = 0; i < windowCount; ++i) {
      target[i] = centre[i] - static_cast<float>(prefix[i + length] - prefix[i]) * inverse;
    }
  } else {
    scratch.sums.assign(static_cast<std::size_t>(windowCount), 0.F);
    float* sums = scratch.sums.data();
    for (int k = 0; k < length; ++k) {
      const float* shifted = samples + k;
      for (int i = 0; i < windowCount; ++i)
        sums[i] += shifted[i];
    }
    for (int i = 0; i < windowCount; ++i) {
      out[interiorBegin + i] = samples[interiorBegin + i] - sums[i] * inverse;
    }
  }
  // The clipped ends with running sums in double (exact for whole codes; the same order of
  // magnitude of work as one pass, where summing each clipped window afresh cost L^2).
  double head = 0.0;
  for (int j = 0; j < after; ++j)
    head += samples[j];
  for (int i = 0; i < interiorBegin; ++i) {
    head += samples[i + after];
    out[i] = static_cast<float>(samples[i] - head / (i + after + 1));
  }
  double tail = 0.0;
  for (int j = interiorEnd - before - 1; j < count; ++j)
    tail += samples[j];
  for (int i = interiorEnd; i < count; ++i) {
    tail -= samples[i - before - 1];
    out[i] = static_cast<float>(samples[i] - tail / (count - i + before));
  }
}

}  // namespace detail

void subtractMovingAverage(const float* samples, int count, int window, float* out) {
  detail::MovingAverageScratch scratch;
  detail::subtractMovingAverage(samples, count, window, out, scratch);
}

int highPassLength(double cornerHz, double samplingFrequencyHz) {
  require(cornerHz > 0.0 && std::isfinite(cornerHz), "high-pass corner must be > 0 Hz");
  require(samplingFrequencyHz > 0.0 && std::isfinite(samplingFrequencyHz),
          "sampling frequency must be > 0 Hz");
  const double length = std::min(1.5 * samplingFrequencyHz / cornerHz, 1e6);
  int odd = static_cast<int>(std::lround(length));
  if (odd % 2 == 0)
    ++odd;
  return std::max(odd, 3);
}

struct EnvelopeDetector::Impl {
  EnvelopeParams params;
  IirCoefficients butterworth;
  std::vector<float> centred;                    // demeaned, ring-down zeroed record
  detail::MovingAverageScratch highPassScratch;  // high-pass
  std::vector<double> prefixA;                   // prefix sums for the O(1) moving windows
  std::vector<double> prefixB;
  std::vector<double> prefixC;
  std::vector<double> cosTable;  // Hann: cos/sin(theta * m) for the sample index m
  std::vector<double> sinTable;
  std::vector<float> hannWeights;  // Hann, short windows: normalised weights
  std::vector<float> padded;       // Hann, short windows: zero-padded |x|
  Eigen::FFT<float> fft;
  std::vector<std::complex<float>> spectrum;
  std::vector<std::complex<float>> analytic;
  std::vector<float> magnitude;
  std::vector<float> bandGain;  // Hilbert: one-sided band weights per FFT bin
  int bandSize = 0;

  void centre(const float* samples, int count) {
    centred.resize(static_cast<std::size_t>(count));
    const int ringDown = std::min(params.ringDownSamples, count);
    if (params.highPassSamples > 0) {
      highPass(samples, count, centred.data());
    } else {
      const auto mean = static_cast<float>(detail::sumOfSamples(samples, count) / count);
      for (int i = ringDown; i < count; ++i)
        centred[static_cast<std::size_t>(i)] = samples[i] - mean;
    }
    for (int i = 0; i < ringDown; ++i)
      centred[static_cast<std::size_t>(i)] = 0.F;
  }

  void highPass(const float* samples, int count, float* out) {
    detail::subtractMovingAverage(samples, count, params.highPassSamples, out, highPassScratch);
  }

  void mozes(int count, float* out) {
    for (int i = 0; i < count; ++i)
      out[i] = std::fabs(centred[static_cast<std::size_t>(i)]);
    if (params.zeroPhase) {
      filterZeroPhase(butterworth, out, count, out);
    } else {
      filterCausal(butterworth, out, count, out);
    }
  }

  // Centred window [n - half, n - half + W) clipped to the record.
  int half() const { return (params.windowSamples - 1) / 2; }

  // Short windows: a direct weighted sum over a zero-padded copy, which vectorises; long windows:
  // the O(1) prefix-sum form below. Both compute the same definition.
  static constexpr int kDirectHannMaxWindow = 32;

  void hannDirect(const float* samples, int count, float mean, float* out) {
    const int window = params.windowSamples;
    const int h = half();
    if (hannWeights.size() != static_cast<std::size_t>(window)) {
      hannWeights.resize(static_cast<std::size_t>(window));
      double sum = 0.0;
      for (int k = 0; k < window; ++k)
        sum += 0.5 - 0.5 * std::cos(2.0 * kPi * (k + 1) / (window + 1));
      for (int k = 0; k < window; ++k) {
        hannWeights[static_cast<std::size_t>(k)] =
            static_cast<float>((0.5 - 0.5 * std::cos(2.0 * kPi * (k + 1) / (window + 1))) / sum);
      }
    }
    // padded[j] = |x[j - h] - mean|, zero in the ring-down and outside the record.
    padded.resize(static_cast<std::size_t>(count + window));
    const int ringDown = std::min(params.ringDownSamples, count);
    float* rectified = padded.data() + h;
    std::fill(padded.begin(), padded.begin() + h + ringDown, 0.F);
    for (int i = ringDown; i < count; ++i)
      rectified[i] = std::fabs(samples[i] - mean);
    std::fill(padded.begin() + h + count, padded.end(), 0.F);
    hannPasses(padded.data(), hannWeights.data(), window, count, out);
  }

  // out[i] = sum_k weights[k] * source[i + k], summed in k order from 0. With the window a
  // compile-time constant the taps unroll and the loop over i vectorises (unaligned loads, no
  // shuffles, out written once); longer windows take one vectorised pass per weight. Both add in
  // the same order, so they give the same floats.
  // Cloned for AVX2 where the CPU has it (chosen once at load time): eight outputs per step
  // instead of four, the same products added in the same order, so the same floats.
  template <int W>
  ECHOREG_VECTOR_CLONES static void hannFixed(const float* source, const float* weights, int count,
                                              float* out) {
    float w[W];
    for (int k = 0; k < W; ++k)
      w[k] = weights[k];
    for (int i = 0; i < count; ++i) {
      float sum = 0.F;
      for (int k = 0; k < W; ++k)
        sum += w[k] * source[i + k];
      out[i] = sum;
    }
  }

  using HannKernel = void (*)(const float*, const float*, int, float*);
  template <std::size_t... W>
  static constexpr std::array<HannKernel, sizeof...(W)> hannKernels(std::index_sequence<W...>) {
    return {&hannFixed<static_cast<int>(W) + 1>...};
  }

  static void hannPasses(const float* source, const float* weights, int window, int count,
                         float* out) {
    static constexpr auto kernels =
        hannKernels(std::make_index_sequence<static_cast<std::size_t>(kDirectHannMaxWindow)>());
    if (window >= 1 && window <= kDirectHannMaxWindow) {
      kernels[static_cast<std::size_t>(window - 1)](source, weights, count, out);
      return;
    }
    std::fill(out, out + count, 0.F);
    for (int k = 0; k < window; ++k) {
      const float weight = weights[k];
      const float* shifted = source + k;
      for (int i = 0; i < count; ++i)
        out[i] += weight * shifted[i];
    }
  }

  void hann(int count, float* out) {
    const int window = params.windowSamples;
    const int period = window + 1;
    const auto n = static_cast<std::size_t>(count);
    if (cosTable.size() != static_cast<std::size_t>(period)) {
      // w[k] = 0.5 - 0.5 cos(theta (k + 1)), k = 0..W-1, theta = 2 pi / (W + 1): MATLAB's
      // hanning(W), with no zero end points. cos(theta j) has period W + 1 in j.
      const double theta = 2.0 * kPi / period;
      cosTable.resize(static_cast<std::size_t>(period));
      sinTable.resize(static_cast<std::size_t>(period));
      for (int j = 0; j < period; ++j) {
        cosTable[static_cast<std::size_t>(j)] = std::cos(theta * j);
        sinTable[static_cast<std::size_t>(j)] = std::sin(theta * j);
      }
    }
    prefixA.assign(n + 1, 0.0);
    prefixB.assign(n + 1, 0.0);
    prefixC.assign(n + 1, 0.0);
    std::size_t m = 0;
    for (std::size_t j = 0; m < n;
         ++m, j = (j + 1 == static_cast<std::size_t>(period) ? 0 : j + 1)) {
      const double a = std::fabs(centred[m]);
      prefixA[m + 1] = prefixA[m] + a;
      prefixB[m + 1] = prefixB[m] + a * cosTable[j];
      prefixC[m + 1] = prefixC[m] + a * sinTable[j];
    }
    // Sum_k w[k] a[m] over m = i - h + k: with s = i - h - 1, cos(theta (m - s)) expands into the
    // cos/sin prefix sums, so each output costs O(1) whatever the window.
    const double norm = 2.0 / period;  // 1 / sum(w)
    const int h = half();
    // Phase of sample i - h - 1 modulo the period, advanced by one per output.
    int shift = ((-h - 1) % period + period) % period;
    for (int i = 0; i < count; ++i) {
      const int begin = std::max(0, i - h);
      const int end = std::min(count, i - h + window);
      const auto b = static_cast<std::size_t>(begin), e = static_cast<std::size_t>(end);
      const double s0 = prefixA[e] - prefixA[b];
      const double sc = prefixB[e] - prefixB[b];
      const double ss = prefixC[e] - prefixC[b];
      const auto phase = static_cast<std::size_t>(shift);
      const double weighted = 0.5 * s0 - 0.5 * (cosTable[phase] * sc + sinTable[phase] * ss);
      out[i] = static_cast<float>(std::max(0.0, weighted) * norm);
      if (++shift == period)
        shift = 0;
    }
  }

  void stddev(int count, float* out) {
    const auto n = static_cast<std::size_t>(count);
    prefixA.assign(n + 1, 0.0);
    prefixB.assign(n + 1, 0.0);
    for (std::size_t m = 0; m < n; ++m) {
      const double x = centred[m];
      prefixA[m + 1] = prefixA[m] + x;
      prefixB[m + 1] = prefixB[m] + x * x;
    }
    const int h = half();
    for (int i = 0; i < count; ++i) {
      const int begin = std::max(0, i - h);
      const int end = std::min(count, i - h + params.windowSamples);
      const auto b = static_cast<std::size_t>(begin), e = static_cast<std::size_t>(end);
      const double samples = end - begin;
      const double mean = (prefixA[e] - prefixA[b]) / samples;
      const double variance = (prefixB[e] - prefixB[b]) / samples - mean * mean;
      out[i] = static_cast<float>(std::sqrt(std::max(0.0, variance)));
    }
  }

  void prepareBand(int fftSize) {
    if (bandSize == fftSize)
      return;
    bandSize = fftSize;
    bandGain.assign(static_cast<std::size_t>(fftSize), 0.F);
    const double centreHz = params.transducerFrequencyHz;
    const double bandwidthHz = params.relativeBandwidth * centreHz;  // -6 dB full width
    // Raised-cosine band: flat within B/4 of the centre, 0.5 at B/2, zero beyond 3B/4.
    for (int k = 1; k < fftSize / 2; ++k) {
      const double frequencyHz = params.samplingFrequencyHz * k / fftSize;
      const double offset = std::fabs(frequencyHz - centreHz);
      double gain = 0.0;
      if (offset <= bandwidthHz / 4.0) {
        gain = 1.0;
      } else if (offset < 3.0 * bandwidthHz / 4.0) {
        gain = 0.5 * (1.0 + std::cos(kPi * (offset - bandwidthHz / 4.0) / (bandwidthHz / 2.0)));
      }
      bandGain[static_cast<std::size_t>(k)] = static_cast<float>(2.0 * gain);  // one-sided
    }
  }

  void hilbert(int count, float* out) {
    int fftSize = 1;
    while (fftSize < count)
      fftSize *= 2;
    prepareBand(fftSize);
    const auto size = static_cast<std::size_t>(fftSize);
    analytic.assign(size, {0.F, 0.F});
    for (int i = 0; i < count; ++i)
      analytic[static_cast<std::size_t>(i)] = centred[static_cast<std::size_t>(i)];
    fft.fwd(spectrum, analytic);
    for (std::size_t k = 0; k < size; ++k)
      spectrum[k] *= bandGain[k];
    fft.inv(analytic, spectrum);
    magnitude.resize(static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i)
      magnitude[static_cast<std::size_t>(i)] = std::abs(analytic[static_cast<std::size_t>(i)]);
    boxAverage(magnitude.data(), count, params.smoothingSamples, out);
  }

  void boxAverage(const float* in, int count, int window, float* out) {
    const auto n = static_cast<std::size_t>(count);
    prefixA.assign(n + 1, 0.0);
    for (std::size_t m = 0; m < n; ++m)
      prefixA[m + 1] = prefixA[m] + in[m];
    const int h = (window - 1) / 2;
    for (int i = 0; i < count; ++i) {
      const int begin = std::max(0, i - h);
      const int end = std::min(count, i - h + window);
      out[i] = static_cast<float>(
          (prefixA[static_cast<std::size_t>(end)] - prefixA[static_cast<std::size_t>(begin)]) /
          (end - begin));
    }
  }
};

EnvelopeDetector::EnvelopeDetector(const EnvelopeParams& params) : impl_(std::make_unique<Impl>()) {
  validate(params);
  impl_->params = params;
  if (params.method == EnvelopeMethod::Mozes) {
    impl_->butterworth = designButterworthLowPass(params.butterworthOrder, params.cutoffNormalized);
  }
}

EnvelopeDetector::~EnvelopeDetector() = default;
EnvelopeDetector::EnvelopeDetector(EnvelopeDetector&&) noexcept = default;
EnvelopeDetector& EnvelopeDetector::operator=(EnvelopeDetector&&) noexcept = default;

const EnvelopeParams& EnvelopeDetector::params() const {
  return impl_->params;
}

void EnvelopeDetector::compute(const float* samples, int count, float* envelope) {
  if (count <= 0)
    return;
  if (impl_->params.method == EnvelopeMethod::Hann &&
      impl_->params.windowSamples <= Impl::kDirectHannMaxWindow &&
      impl_->params.highPassSamples == 0) {
    const auto mean = static_cast<float>(detail::sumOfSamples(samples, count) / count);
    impl_->hannDirect(samples, count, mean, envelope);
    return;
  }
  impl_->centre(samples, count);
  switch (impl_->params.method) {
    case EnvelopeMethod::Mozes:
      impl_->mozes(count, envelope);
      break;
    case EnvelopeMethod::Hann:
      if (impl_->params.windowSamples <= Impl::kDirectHannMaxWindow) {
        impl_->hannDirect(impl_->centred.data(), count, 0.F, envelope);
      } else {
        impl_->hann(count, envelope);
      }
      break;
    case EnvelopeMethod::StdDev:
      impl_->stddev(count, envelope);
      break;
    case EnvelopeMethod::Hilbert:
      impl_->hilbert(count, envelope);
      break;
  }
}

}  // namespace echoreg::core
