// Every envelope against a slow, obvious implementation written here from its definition.
#include "aline_generator.hpp"

#include "echoreg/core/envelope.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <stdexcept>
#include <vector>

namespace echoreg::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<float> randomRecord(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(0, 255);
  std::vector<float> x(static_cast<std::size_t>(count));
  for (float& v : x)
    v = static_cast<float>(u(rng));
  return x;
}

std::vector<double> centred(const std::vector<float>& x, int ringDown) {
  double mean = 0.0;
  for (float v : x)
    mean += v;
  mean /= static_cast<double>(x.size());
  std::vector<double> c(x.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    c[i] = static_cast<int>(i) < ringDown ? 0.0 : x[i] - mean;
  return c;
}

std::vector<float> run(const EnvelopeParams& params, const std::vector<float>& x) {
  EnvelopeDetector detector(params);
  std::vector<float> out(x.size());
  detector.compute(x.data(), static_cast<int>(x.size()), out.data());
  return out;
}

TEST(Envelope, HannIsTheWeightedMovingAverageOfTheRectifiedSignal) {
  for (int window : {1, 2, 7, 8, 153}) {
    const auto x = randomRecord(1000, 3);
    EnvelopeParams params;
    params.method = EnvelopeMethod::Hann;
    params.windowSamples = window;
    params.ringDownSamples = 40;
    const auto fast = run(params, x);
    const auto c = centred(x, 40);
    const int h = (window - 1) / 2;
    double weightSum = 0.0;
    for (int k = 0; k < window; ++k)
      weightSum += 0.5 - 0.5 * std::cos(2.0 * kPi * (k + 1) / (window + 1));
    for (int i = 0; i < 1000; ++i) {
      double acc = 0.0;
      for (int k = 0; k < window; ++k) {
        const int m = i - h + k;
        if (m < 0 || m >= 1000)
          continue;
        acc += (0.5 - 0.5 * std::cos(2.0 * kPi * (k + 1) / (window + 1))) *
               std::fabs(c[static_cast<std::size_t>(m)]);
      }
      ASSERT_NEAR(fast[static_cast<std::size_t>(i)], acc / weightSum, 1e-3)
          << "window " << window << " i " << i;
    }
  }
}

TEST(Envelope, StdDevIsTheMovingStandardDeviation) {
  const auto x = randomRecord(800, 5);
  EnvelopeParams params;
  params.method = EnvelopeMethod::StdDev;
  params.windowSamples = 25;
  const auto fast = run(params, x);
  const auto c = centred(x, 0);
  for (int i = 0; i < 800; ++i) {
    const int begin = std::max(0, i - 12), end = std::min(800, i - 12 + 25);
    double mean = 0.0;
    for (int m = begin; m < end; ++m)
      mean += c[static_cast<std::size_t>(m)];
    mean /= end - begin;
    double var = 0.0;
    for (int m = begin; m < end; ++m)
      var += std::pow(c[static_cast<std::size_t>(m)] - mean, 2);
    var /= end - begin;
    ASSERT_NEAR(fast[static_cast<std::size_t>(i)], std::sqrt(var), 1e-3) << i;
  }
}

TEST(Envelope, MozesIsTheFilteredRectifiedSignal) {
  const auto x = randomRecord(600, 9);
  EnvelopeParams params;
  params.method = EnvelopeMethod::Mozes;
  params.zeroPhase = false;
  params.cutoffNormalized = 0.05;
  params.ringDownSamples = 30;
  const auto fast = run(params, x);
  const auto c = centred(x, 30);
  const IirCoefficients f = designButterworthLowPass(2, 0.05);
  std::vector<double> y(c.size(), 0.0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    double acc = 0.0;
    for (std::size_t k = 0; k < 3 && k <= i; ++k)
      acc += f.b[k] * std::fabs(c[i - k]);
    for (std::size_t k = 1; k < 3 && k <= i; ++k)
      acc -= f.a[k] * y[i - k];
    y[i] = acc;
  }
  for (std::size_t i = 0; i < c.size(); ++i)
    ASSERT_NEAR(fast[i], y[i], 1e-3) << i;
}

TEST(Envelope, HilbertIsTheMagnitudeOfTheBandLimitedAnalyticSignal) {
  const int n = 256;
  const auto x = randomRecord(n, 13);
  EnvelopeParams params;
  params.method = EnvelopeMethod::Hilbert;
  params.smoothingSamples = 3;
  const auto fast = run(params, x);
  const auto c = centred(x, 0);
  // Slow DFT, one-sided raised-cosine band, inverse DFT, magnitude, centred box of 3.
  std::vector<std::complex<double>> spectrum(n);
  for (int k = 0; k < n; ++k) {
    for (int m = 0; m < n; ++m)
      spectrum[static_cast<std::size_t>(k)] +=
          c[static_cast<std::size_t>(m)] * std::polar(1.0, -2.0 * kPi * k * m / n);
  }
  const double f0 = 9e6, bw = 0.8 * 9e6;
  for (int k = 0; k < n; ++k) {
    double gain = 0.0;
    if (k > 0 && k < n / 2) {
      const double off = std::fabs(50e6 * k / n - f0);
      if (off <= bw / 4)
        gain = 1.0;
      else if (off < 3 * bw / 4)
        gain = 0.5 * (1 + std::cos(kPi * (off - bw / 4) / (bw / 2)));
    }
    spectrum[static_cast<std::size_t>(k)] *= 2.0 * gain;
  }
  std::vector<double> magnitude(n);
  for (int m = 0; m < n; ++m) {
    std::complex<double> acc = 0.0;
    for (int k = 0; k < n; ++k)
      acc += spectrum[static_cast<std::size_t>(k)] * std::polar(1.0, 2.0 * kPi * k * m / n);
    magnitude[static_cast<std::size_t>(m)] = std::abs(acc) / n;
  }
  for (int i = 0; i < n; ++i) {
    const int begin = std::max(0, i - 1), end = std::min(n, i + 2);
    double acc = 0.0;
    for (int m = begin; m < end; ++m)
      acc += magnitude[static_cast<std::size_t>(m)];
    ASSERT_NEAR(fast[static_cast<std::size_t>(i)], acc / (end - begin),
                2e-3 * (1.0 + acc / (end - begin)))
        << i;
  }
}

TEST(Envelope, EveryMethodPeaksAtAnIsolatedEcho) {
  test::PulseModel pulse;
  const auto x = test::makeEchoRecord(4096, {{1500.0, 60.0}}, pulse, 128.0, 0.5, 21);
  for (auto method : {EnvelopeMethod::Mozes, EnvelopeMethod::Hann, EnvelopeMethod::StdDev,
                      EnvelopeMethod::Hilbert}) {
    EnvelopeParams params;
    params.method = method;
    params.windowSamples = 11;
    const auto envelope = run(params, x);
    const auto peak = std::max_element(envelope.begin(), envelope.end()) - envelope.begin();
    EXPECT_NEAR(static_cast<double>(peak), 1500.0, 2.0) << envelopeMethodName(method);
  }
}

// The high-pass's moving average against the definition (each window clipped to the record and
// summed afresh in double): whole 12-bit codes (the integer prefix path, four or eight samples at
// a time and every remainder), a fraction, a whole code beyond 16 bits or a NaN anywhere (the
// float path, including in either half of an eight-wide block and in the last samples a wide pass
// leaves to the scalar tail), and windows longer than the record.
TEST(Envelope, MovingAverageMatchesItsDefinitionOnEveryPath) {
  const auto reference = [](const std::vector<float>& x, int window) {
    const int count = static_cast<int>(x.size());
    const int length = std::min(window, count);
    const int before = (length - 1) / 2, after = length - 1 - before;
    std::vector<double> out(x.size());
    for (int i = 0; i < count; ++i) {
      const int b = std::max(0, i - before), e = std::min(count, i + after + 1);
      double sum = 0.0;
      for (int j = b; j < e; ++j)
        sum += x[static_cast<std::size_t>(j)];
      out[static_cast<std::size_t>(i)] = x[static_cast<std::size_t>(i)] - sum / (e - b);
    }
    return out;
  };
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> code(-2048, 2047);
  for (int count : {4096, 4097, 4099, 4100, 4103, 30}) {
    for (int window : {3, 21, 85, 5001}) {
      for (int fraction : {-1, 0, count - 1, count / 2, 13}) {
        std::vector<float> x(static_cast<std::size_t>(count));
        for (float& v : x)
          v = static_cast<float>(code(rng) * 16);
        if (fraction >= 0)
          x[static_cast<std::size_t>(fraction)] += 0.5F;
        if (fraction == 13)  // and a whole code that 16 bits cannot hold, in a block's high half
          x[22] = 70000.F;
        std::vector<float> out(x.size());
        subtractMovingAverage(x.data(), count, window, out.data());
        const auto expected = reference(x, window);
        for (std::size_t i = 0; i < x.size(); ++i) {
          // float rounding of values up to 2^15: a few 1e-3 at most; truncating the 0.5 to a
          // whole code would be off by 0.5 / window (>= 1e-4) and is caught for small windows.
          ASSERT_NEAR(out[i], expected[i], 4e-3 + 1e-7 * std::fabs(expected[i]))
              << "count " << count << ", window " << window << ", fraction at " << fraction
              << ", sample " << i;
        }
      }
    }
  }
  // A NaN is never taken for a whole code: the windows over it are NaN, the others are not.
  std::vector<float> x(4097, 32.F);
  x[4096] = std::nanf("");
  std::vector<float> out(x.size());
  subtractMovingAverage(x.data(), 4097, 5, out.data());
  EXPECT_TRUE(std::isnan(out[4096]));
  EXPECT_TRUE(std::isnan(out[4094]));
  EXPECT_FLOAT_EQ(out[100], 0.F);
}

TEST(Envelope, NamesRoundTripAndBadParametersAreRefused) {
  for (auto method : {EnvelopeMethod::Mozes, EnvelopeMethod::Hann, EnvelopeMethod::StdDev,
                      EnvelopeMethod::Hilbert}) {
    EXPECT_EQ(parseEnvelopeMethod(envelopeMethodName(method)), method);
  }
  EXPECT_THROW(parseEnvelopeMethod("gauss"), std::invalid_argument);
  EnvelopeParams bad;
  bad.windowSamples = 0;
  EXPECT_THROW(EnvelopeDetector{bad}, std::invalid_argument);
  bad = EnvelopeParams{};
  bad.ringDownSamples = -1;
  EXPECT_THROW(EnvelopeDetector{bad}, std::invalid_argument);
  bad = EnvelopeParams{};
  bad.transducerFrequencyHz = 30e6;  // above Nyquist at 50 MHz
  EXPECT_THROW(EnvelopeDetector{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace echoreg::core
