#include "echoreg/core/butterworth.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Coefficients of prod(z - root) in descending powers, real part only (roots come in conjugate
// pairs, so the imaginary parts cancel up to rounding).
std::vector<double> polynomialFromRoots(const std::vector<std::complex<double>>& roots) {
  std::vector<std::complex<double>> coefficients{1.0};
  for (const auto& root : roots) {
    std::vector<std::complex<double>> next(coefficients.size() + 1, 0.0);
    for (std::size_t i = 0; i < coefficients.size(); ++i) {
      next[i] += coefficients[i];
      next[i + 1] -= coefficients[i] * root;
    }
    coefficients = std::move(next);
  }
  std::vector<double> real(coefficients.size());
  std::transform(coefficients.begin(), coefficients.end(), real.begin(),
                 [](const std::complex<double>& c) { return c.real(); });
  return real;
}

// Direct form II transposed over [in, in + count) with state z (len(a) - 1 values), in place
// allowed. The state is double: with a cutoff of 0.01 the poles sit within 0.02 of z = 1 and a
// float state would lose the low-frequency gain.
template <typename Read, typename Write>
void runDf2t(const IirCoefficients& filter, std::vector<double>& z, int count, Read read,
             Write write) {
  const std::size_t order = z.size();
  const double b0 = filter.b[0];
  if (order == 2) {
    const double b1 = filter.b[1], b2 = filter.b[2], a1 = filter.a[1], a2 = filter.a[2];
    double z0 = z[0], z1 = z[1];
    for (int i = 0; i < count; ++i) {
      const double x = read(i);
      const double y = b0 * x + z0;
      z0 = b1 * x - a1 * y + z1;
      z1 = b2 * x - a2 * y;
      write(i, y);
    }
    z[0] = z0;
    z[1] = z1;
    return;
  }
  for (int i = 0; i < count; ++i) {
    const double x = read(i);
    const double y = b0 * x + (order > 0 ? z[0] : 0.0);
    for (std::size_t k = 0; k + 1 < order; ++k) {
      z[k] = filter.b[k + 1] * x - filter.a[k + 1] * y + z[k + 1];
    }
    if (order > 0)
      z[order - 1] = filter.b[order] * x - filter.a[order] * y;
    write(i, y);
  }
}

// scipy.signal.lfilter_zi: the state of a filter that has seen a constant 1 forever.
std::vector<double> steadyStateForUnitStep(const IirCoefficients& filter) {
  const int order = static_cast<int>(filter.a.size()) - 1;
  if (order <= 0)
    return {};
  Eigen::MatrixXd iMinusA = Eigen::MatrixXd::Identity(order, order);
  // companion(a).T: first column -a[1:], superdiagonal... (transpose of scipy's companion).
  for (int r = 0; r < order; ++r)
    iMinusA(r, 0) += filter.a[static_cast<std::size_t>(r + 1)];
  for (int r = 0; r + 1 < order; ++r)
    iMinusA(r, r + 1) -= 1.0;
  Eigen::VectorXd rhs(order);
  for (int r = 0; r < order; ++r) {
    const auto k = static_cast<std::size_t>(r + 1);
    rhs(r) = filter.b[k] - filter.a[k] * filter.b[0];
  }
  const Eigen::VectorXd zi = iMinusA.partialPivLu().solve(rhs);
  return {zi.data(), zi.data() + order};
}

void checkFilter(const IirCoefficients& filter) {
  if (filter.a.empty() || filter.a.size() != filter.b.size() || filter.a[0] != 1.0) {
    throw std::invalid_argument("IIR filter needs b and a of equal length with a[0] == 1");
  }
}

}  // namespace

IirCoefficients designButterworthLowPass(int order, double cutoffNormalized) {
  if (order < 1 || order > 12) {
    throw std::invalid_argument("Butterworth order must be 1..12, got " + std::to_string(order));
  }
  if (!(cutoffNormalized > 0.0 && cutoffNormalized < 1.0)) {
    throw std::invalid_argument("Butterworth cutoff must be in (0, 1) of Nyquist, got " +
                                std::to_string(cutoffNormalized));
  }
  // Analog prototype poles on the left half of the unit circle, scaled to the pre-warped
  // cutoff, mapped by the bilinear transform with a sampling rate of 2 (as MATLAB and scipy).
  const double warped = 4.0 * std::tan(kPi * cutoffNormalized / 2.0);
  std::vector<std::complex<double>> digitalPoles;
  for (int k = 0; k < order; ++k) {
    const double theta = kPi * (2.0 * k + 1.0) / (2.0 * order) + kPi / 2.0;
    const std::complex<double> analogPole = warped * std::polar(1.0, theta);
    digitalPoles.push_back((4.0 + analogPole) / (4.0 - analogPole));
  }
  IirCoefficients filter;
  filter.a = polynomialFromRoots(digitalPoles);
  filter.a[0] = 1.0;
  // All zeros at z = -1; the gain makes the DC response exactly 1.
  filter.b = polynomialFromRoots(
      std::vector<std::complex<double>>(static_cast<std::size_t>(order), {-1.0, 0.0}));
  double sumA = 0.0, sumB = 0.0;
  for (double v : filter.a)
    sumA += v;
  for (double v : filter.b)
    sumB += v;
  for (double& v : filter.b)
    v *= sumA / sumB;
  return filter;
}

double groupDelaySamples(const IirCoefficients& filter, double radiansPerSample) {
  checkFilter(filter);
  // tau = Re( sum(k c_k e^{-jwk}) / sum(c_k e^{-jwk}) ) for b minus the same for a.
  auto delayOf = [radiansPerSample](const std::vector<double>& c) {
    std::complex<double> num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < c.size(); ++k) {
      const std::complex<double> e = std::polar(1.0, -radiansPerSample * static_cast<double>(k));
      num += static_cast<double>(k) * c[k] * e;
      den += c[k] * e;
    }
    return (num / den).real();
  };
  return delayOf(filter.b) - delayOf(filter.a);
}

void filterCausal(const IirCoefficients& filter, const float* in, int count, float* out) {
  checkFilter(filter);
  std::vector<double> z(filter.a.size() - 1, 0.0);
  runDf2t(
      filter, z, count, [in](int i) { return static_cast<double>(in[i]); },
      [out](int i, double y) { out[i] = static_cast<float>(y); });
}

void filterZeroPhase(const IirCoefficients& filter, const float* in, int count, float* out) {
  checkFilter(filter);
  if (count <= 0)
    return;
  const int padding = 3 * static_cast<int>(filter.a.size());
  const int pad = count > padding ? padding : 0;
  const int total = count + 2 * pad;
  // Odd extension: reflect the record about its end values, so the filter starts settled.
  std::vector<double> work(static_cast<std::size_t>(total));
  const double first = in[0], last = in[count - 1];
  for (int i = 0; i < pad; ++i)
    work[static_cast<std::size_t>(i)] = 2.0 * first - in[pad - i];
  for (int i = 0; i < count; ++i)
    work[static_cast<std::size_t>(pad + i)] = in[i];
  for (int i = 0; i < pad; ++i) {
    work[static_cast<std::size_t>(pad + count + i)] = 2.0 * last - in[count - 2 - i];
  }
  const std::vector<double> unitState = steadyStateForUnitStep(filter);
  std::vector<double> z(unitState.size());

  const double forwardStart = work.front();
  for (std::size_t k = 0; k < z.size(); ++k)
    z[k] = unitState[k] * forwardStart;
  runDf2t(
      filter, z, total, [&work](int i) { return work[static_cast<std::size_t>(i)]; },
      [&work](int i, double y) { work[static_cast<std::size_t>(i)] = y; });

  const double backwardStart = work.back();
  for (std::size_t k = 0; k < z.size(); ++k)
    z[k] = unitState[k] * backwardStart;
  const auto mirrored = [total](int i) { return static_cast<std::size_t>(total - 1 - i); };
  runDf2t(
      filter, z, total, [&work, &mirrored](int i) { return work[mirrored(i)]; },
      [&work, &mirrored](int i, double y) { work[mirrored(i)] = y; });

  for (int i = 0; i < count; ++i)
    out[i] = static_cast<float>(work[static_cast<std::size_t>(pad + i)]);
}

}  // namespace echoreg::core
