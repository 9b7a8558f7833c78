#include "echoreg/core/butterworth.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace echoreg::core {
namespace {

void expectCoefficients(const IirCoefficients& actual, const std::vector<double>& b,
                        const std::vector<double>& a) {
  ASSERT_EQ(actual.b.size(), b.size());
  ASSERT_EQ(actual.a.size(), a.size());
  for (std::size_t i = 0; i < b.size(); ++i)
    EXPECT_NEAR(actual.b[i], b[i], 1e-12 * std::fabs(b[i]) + 1e-15);
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_NEAR(actual.a[i], a[i], 1e-12);
}

// Reference values: scipy.signal.butter(order, cutoff) (identical to MATLAB's butter).
TEST(Butterworth, MatchesScipyAndMatlabDesigns) {
  expectCoefficients(designButterworthLowPass(2, 0.01),
                     {0.00024135904904198, 0.00048271809808396, 0.00024135904904198},
                     {1.0, -1.9555782403150352, 0.9565436765112031});
  expectCoefficients(designButterworthLowPass(2, 0.004),
                     {3.913020539914435e-05, 7.826041079828870e-05, 3.913020539914435e-05},
                     {1.0, -1.9822289297925284, 0.9823854506141251});
  expectCoefficients(designButterworthLowPass(2, 0.03),
                     {0.00208056713549229, 0.00416113427098458, 0.00208056713549229},
                     {1.0, -1.866892279711715, 0.875214548253684});
  expectCoefficients(
      designButterworthLowPass(3, 0.1),
      {0.00289819463372143, 0.00869458390116429, 0.00869458390116429, 0.00289819463372143},
      {1.0, -2.374094743709352, 1.929355669091215, -0.5320753683120918});
  expectCoefficients(
      designButterworthLowPass(4, 0.2),
      {0.00482434335771623, 0.01929737343086492, 0.02894606014629739, 0.01929737343086492,
       0.00482434335771623},
      {1.0, -2.3695130071820376, 2.31398841441588, -1.0546654058785676, 0.18737949236818488});
}

TEST(Butterworth, GroupDelayOfTheDissertationFilter) {
  // scipy.signal.group_delay at w -> 0: 45.012 samples, i.e. 0.69 mm at 50 MHz and 1540 m/s.
  const IirCoefficients filter = designButterworthLowPass(2, 0.01);
  EXPECT_NEAR(groupDelaySamples(filter, 1e-6), 45.0121, 1e-3);
  const double mm = groupDelaySamples(filter, 1e-6) / 50e6 * 1540.0 * 1000.0 / 2.0;
  EXPECT_NEAR(mm, 0.693, 0.001);
}

TEST(Butterworth, RefusesBadDesigns) {
  EXPECT_THROW(designButterworthLowPass(0, 0.1), std::invalid_argument);
  EXPECT_THROW(designButterworthLowPass(13, 0.1), std::invalid_argument);
  EXPECT_THROW(designButterworthLowPass(2, 0.0), std::invalid_argument);
  EXPECT_THROW(designButterworthLowPass(2, 1.0), std::invalid_argument);
  EXPECT_THROW(designButterworthLowPass(2, std::nan("")), std::invalid_argument);
}

// The difference equation written out, in double.
std::vector<double> slowFilter(const IirCoefficients& f, const std::vector<double>& x,
                               std::vector<double> initialState = {}) {
  // Direct form I with the initial conditions converted from scipy's DF2T state: simulate by
  // running DF2T element by element, written as plainly as possible.
  const std::size_t n = f.a.size() - 1;
  std::vector<double> z = initialState.empty() ? std::vector<double>(n, 0.0) : initialState;
  std::vector<double> y(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    y[i] = f.b[0] * x[i] + z[0];
    for (std::size_t k = 0; k + 1 < n; ++k)
      z[k] = f.b[k + 1] * x[i] - f.a[k + 1] * y[i] + z[k + 1];
    z[n - 1] = f.b[n] * x[i] - f.a[n] * y[i];
  }
  return y;
}

TEST(Butterworth, CausalPassIsTheDifferenceEquation) {
  const IirCoefficients f = designButterworthLowPass(2, 0.05);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  std::vector<double> x(500);
  for (double& v : x)
    v = u(rng);
  // y[n] = sum b[k] x[n-k] - sum a[k] y[n-k], computed naively.
  std::vector<double> expected(x.size(), 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    double acc = 0.0;
    for (std::size_t k = 0; k < f.b.size() && k <= i; ++k)
      acc += f.b[k] * x[i - k];
    for (std::size_t k = 1; k < f.a.size() && k <= i; ++k)
      acc -= f.a[k] * expected[i - k];
    expected[i] = acc;
  }
  std::vector<float> in(x.begin(), x.end()), out(x.size());
  filterCausal(f, in.data(), static_cast<int>(in.size()), out.data());
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_NEAR(out[i], expected[i], 1e-3);
}

TEST(Butterworth, ZeroPhaseMatchesScipyFiltfiltDefinition) {
  const IirCoefficients f = designButterworthLowPass(2, 0.01);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 50.0);
  std::vector<double> x(2000);
  for (double& v : x)
    v = u(rng);
  // filtfilt: odd extension of 3 * len(a) samples, steady-state initial conditions.
  const std::size_t pad = 3 * f.a.size();
  std::vector<double> ext;
  for (std::size_t i = pad; i >= 1; --i)
    ext.push_back(2.0 * x.front() - x[i]);
  ext.insert(ext.end(), x.begin(), x.end());
  for (std::size_t i = 1; i <= pad; ++i)
    ext.push_back(2.0 * x.back() - x[x.size() - 1 - i]);
  // Steady state: the state after a long run of ones.
  std::vector<double> ones(20000, 1.0);
  const std::size_t n = f.a.size() - 1;
  std::vector<double> zi(n, 0.0);
  {
    std::vector<double> z(n, 0.0);
    for (double v : ones) {
      const double y = f.b[0] * v + z[0];
      for (std::size_t k = 0; k + 1 < n; ++k)
        z[k] = f.b[k + 1] * v - f.a[k + 1] * y + z[k + 1];
      z[n - 1] = f.b[n] * v - f.a[n] * y;
    }
    zi = z;
  }
  auto scaled = [&](double s) {
    std::vector<double> z = zi;
    for (double& v : z)
      v *= s;
    return z;
  };
  std::vector<double> forward = slowFilter(f, ext, scaled(ext.front()));
  std::vector<double> reversed(forward.rbegin(), forward.rend());
  std::vector<double> backward = slowFilter(f, reversed, scaled(reversed.front()));
  std::vector<double> expected(backward.rbegin(), backward.rend());

  std::vector<float> in(x.begin(), x.end()), out(x.size());
  filterZeroPhase(f, in.data(), static_cast<int>(in.size()), out.data());
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_NEAR(out[i], expected[i + pad], 1e-3) << i;
}

TEST(Butterworth, ZeroPhaseKeepsAPeakInPlaceWhileTheCausalPassDelaysIt) {
  const IirCoefficients f = designButterworthLowPass(2, 0.01);
  std::vector<float> x(4000, 0.F);
  for (int i = 0; i < 4000; ++i)
    x[static_cast<std::size_t>(i)] = static_cast<float>(std::exp(-std::pow((i - 2000) / 80.0, 2)));
  std::vector<float> zeroPhase(x.size()), causal(x.size());
  filterZeroPhase(f, x.data(), 4000, zeroPhase.data());
  filterCausal(f, x.data(), 4000, causal.data());
  const auto argmax = [](const std::vector<float>& v) {
    return static_cast<int>(std::max_element(v.begin(), v.end()) - v.begin());
  };
  EXPECT_NEAR(argmax(zeroPhase), 2000, 1);
  // The causal pass moves the peak deeper by about its group delay (45 samples at DC).
  EXPECT_GT(argmax(causal) - 2000, 25);
  EXPECT_LT(argmax(causal) - 2000, 60);
}

}  // namespace
}  // namespace echoreg::core
