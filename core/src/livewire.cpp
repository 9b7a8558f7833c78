#include "echoreg/core/livewire.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace echoreg::core {

namespace {

constexpr std::uint16_t kNoLink = std::numeric_limits<std::uint16_t>::max();
constexpr std::uint32_t kUnreached = std::numeric_limits<std::uint32_t>::max();
constexpr double kPi = 3.14159265358979323846;

// The 8 neighbours, as OpenCV numbers them:  0 1 2 / 3 x 4 / 5 6 7.
constexpr int kDx[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
constexpr int kDy[8] = {-1, -1, -1, 0, 0, 1, 1, 1};

// acos to 2.2e-8 rad (Abramowitz & Stegun 4.4.46, Hastings' polynomial): std::acos is several
// times slower, and two of them per link dominated the link precomputation.
double fastAcos(double x) {
  const double a = std::min(std::abs(x), 1.0);
  const double p =
      1.5707963050 +
      a * (-0.2145988016 +
           a * (0.0889789874 +
                a * (-0.0501743046 +
                     a * (0.0308918810 +
                          a * (-0.0170881256 + a * (0.0066700901 + a * -0.0012624911))))));
  const double r = std::sqrt(1.0 - a) * p;
  return x >= 0.0 ? r : kPi - r;
}

// The unit link vector (mm frame) of neighbour n and its length over the pixel diagonal's.
struct LinkGeometry {
  double ux = 0.0;
  double uy = 0.0;
  double lengthRatio = 1.0;
};

std::array<LinkGeometry, 8> linkGeometry(const Eigen::Vector2d& spacing) {
  std::array<LinkGeometry, 8> g;
  for (std::size_t n = 0; n < 8; ++n) {
    const double lx = kDx[n] * spacing.x();
    const double ly = kDy[n] * spacing.y();
    const double length = std::sqrt(lx * lx + ly * ly);
    g[n] = {lx / length, ly / length, length / spacing.norm()};
  }
  return g;
}

// l(p, q) = wZ fZ(q) + wD fD(p, q) + wG fG(q) (length-scaled), Mortensen & Barrett 1995 eq. 1-4:
// D'(p) = (Iy, -Ix) the unit edge direction, L the link oriented so that D'(p) . L >= 0,
// fD = 2 / (3 pi) (acos(D'(p) . L) + acos(L . D'(q))).
double linkCost(const LiveWireFeatures& f, const LiveWireOptions& o, std::size_t p, std::size_t q,
                const LinkGeometry& g) {
  const Eigen::Vector2f& gp = f.gradientDirection[p];
  const Eigen::Vector2f& gq = f.gradientDirection[q];
  double dp = static_cast<double>(gp.y()) * g.ux - static_cast<double>(gp.x()) * g.uy;
  double dq = static_cast<double>(gq.y()) * g.ux - static_cast<double>(gq.x()) * g.uy;
  if (dp < 0.0) {
    dp = -dp;
    dq = -dq;
  }
  // acos(|y|) rounded to float as the link table keeps it; acos(-|y|) = pi - acos(|y|).
  const double ap = static_cast<float>(fastAcos(dp));
  const double aq = static_cast<float>(fastAcos(std::abs(dq)));
  const double fD = ap + (dq >= 0.0 ? aq : kPi - aq);
  return o.weightZeroCrossing * f.zeroCrossing[q] + o.weightDirection * (2.0 / (3.0 * kPi)) * fD +
         o.weightMagnitude * f.magnitudeCost[q] * g.lengthRatio;
}

int neighbourIndex(int dx, int dy) {
  for (int n = 0; n < 8; ++n)
    if (kDx[n] == dx && kDy[n] == dy)
      return n;
  return -1;
}

std::string pixelText(const Eigen::Vector2i& p) {
  return "(" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ")";
}

std::size_t toIndex(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}

// Normalised 1-D Gaussian of standard deviation `sigma` pixels, radius ceil(3 sigma); {1} for
// sigma <= 0.
std::vector<float> gaussianKernel(double sigma) {
  if (!(sigma > 0.0))
    return {1.0f};
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<double> k(static_cast<std::size_t>(2 * radius + 1));
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    const double v = std::exp(-0.5 * (i * i) / (sigma * sigma));
    k[static_cast<std::size_t>(i + radius)] = v;
    sum += v;
  }
  std::vector<float> out(k.size());
  for (std::size_t i = 0; i < k.size(); ++i)
    out[i] = static_cast<float>(k[i] / sum);
  return out;
}

// Separable convolution with edge replication.
std::vector<float> smooth(const std::vector<float>& image, int width, int height, double sigmaX,
                          double sigmaY) {
  const std::vector<float> kx = gaussianKernel(sigmaX);
  const std::vector<float> ky = gaussianKernel(sigmaY);
  const int rx = static_cast<int>(kx.size() / 2);
  const int ry = static_cast<int>(ky.size() / 2);
  std::vector<float> tmp(image.size());
  std::vector<float> out(image.size());
  for (int y = 0; y < height; ++y) {
    const float* row = image.data() + toIndex(0, y, width);
    float* dst = tmp.data() + toIndex(0, y, width);
    const auto clamped = [&](int x) {
      float sum = 0.0f;
      for (int i = -rx; i <= rx; ++i)
        sum += kx[static_cast<std::size_t>(i + rx)] * row[std::clamp(x + i, 0, width - 1)];
      return sum;
    };
    const int interiorEnd = std::max(rx, width - rx);
    for (int x = 0; x < std::min(rx, width); ++x)
      dst[x] = clamped(x);
    for (int x = rx; x < interiorEnd; ++x) {
      float sum = 0.0f;
      const float* src = row + x - rx;
      for (int i = 0; i <= 2 * rx; ++i)
        sum += kx[static_cast<std::size_t>(i)] * src[i];
      dst[x] = sum;
    }
    for (int x = std::max(interiorEnd, std::min(rx, width)); x < width; ++x)
      dst[x] = clamped(x);
  }
  for (int y = 0; y < height; ++y) {
    float* dst = out.data() + toIndex(0, y, width);
    std::fill(dst, dst + width, 0.0f);
    for (int i = -ry; i <= ry; ++i) {
      const int yi = std::clamp(y + i, 0, height - 1);
      const float w = ky[static_cast<std::size_t>(i + ry)];
      const float* src = tmp.data() + toIndex(0, yi, width);
      for (int x = 0; x < width; ++x)
        dst[x] += w * src[x];
    }
  }
  return out;
}

void checkOptions(const LiveWireOptions& o) {
  const double weights[3] = {o.weightZeroCrossing, o.weightDirection, o.weightMagnitude};
  double sum = 0.0;
  for (double w : weights) {
    if (!std::isfinite(w) || w < 0.0)
      throw std::invalid_argument("live-wire: cost weights must be finite and >= 0");
    sum += w;
  }
  if (!(sum > 0.0))
    throw std::invalid_argument("live-wire: the cost weights sum to 0");
  if (o.costResolution < 1)
    throw std::invalid_argument("live-wire: costResolution must be >= 1");
  if (sum * o.costResolution > 65000.0)
    throw std::invalid_argument("live-wire: weights' sum x costResolution exceeds 65000");
  if (!std::isfinite(o.laplacianSigmaMm) || o.laplacianSigmaMm < 0.0)
    throw std::invalid_argument("live-wire: laplacianSigmaMm must be finite and >= 0");
  if (!std::isfinite(o.gradientSigmaMm))
    throw std::invalid_argument("live-wire: gradientSigmaMm must be finite");
  if (!std::isfinite(o.gradientMagnitudeCap) || o.gradientMagnitudeCap < 0.0)
    throw std::invalid_argument("live-wire: gradientMagnitudeCap must be finite and >= 0");
  if (!std::isfinite(o.minEdgeGradientFraction) || o.minEdgeGradientFraction < 0.0 ||
      o.minEdgeGradientFraction >= 1.0)
    throw std::invalid_argument("live-wire: minEdgeGradientFraction must be in [0, 1)");
}

}  // namespace

LiveWire::LiveWire(const std::vector<float>& image, int width, int height,
                   const Eigen::Vector2d& spacingMm, const LiveWireOptions& options)
    : width_(width), height_(height), spacing_(spacingMm), options_(options) {
  if (width < 2 || height < 2)
    throw std::invalid_argument("live-wire: the image is empty (needs at least 2 x 2 pixels, got " +
                                std::to_string(width) + " x " + std::to_string(height) + ")");
  const std::size_t count = toIndex(0, height, width);
  if (image.size() != count)
    throw std::invalid_argument("live-wire: the image has " + std::to_string(image.size()) +
                                " pixels, " + std::to_string(width) + " x " +
                                std::to_string(height) + " expected");
  if (!std::isfinite(spacingMm.x()) || !std::isfinite(spacingMm.y()) || spacingMm.x() <= 0.0 ||
      spacingMm.y() <= 0.0)
    throw std::invalid_argument("live-wire: the pixel spacing must be positive");
  checkOptions(options);
  for (std::size_t i = 0; i < count; ++i) {
    if (!std::isfinite(image[i]))
      throw std::invalid_argument(
          "live-wire: pixel (" + std::to_string(i % static_cast<std::size_t>(width)) + ", " +
          std::to_string(i / static_cast<std::size_t>(width)) + ") is not finite");
  }

  const double sx = spacingMm.x();
  const double sy = spacingMm.y();
  // Smoothing: a Gaussian of sigma mm along both axes, or of one pixel along each axis (0).
  const auto sigmaPixels = [&](double sigmaMm) -> Eigen::Vector2d {
    if (sigmaMm == 0.0)
      return Eigen::Vector2d(1.0, 1.0);
    return Eigen::Vector2d(sigmaMm / sx, sigmaMm / sy);
  };

  // Gradient: Gaussian smoothing, then central differences (one-sided at the border), per mm.
  const Eigen::Vector2d gradientSigma = sigmaPixels(options.gradientSigmaMm);
  const std::vector<float> g =
      options.gradientSigmaMm >= 0.0
          ? smooth(image, width, height, gradientSigma.x(), gradientSigma.y())
          : image;
  features_.gradientMagnitude.assign(count, 0.0f);
  features_.gradientDirection.assign(count, Eigen::Vector2f::Zero());
  double maxG = 0.0;
  for (int y = 0; y < height; ++y) {
    const int y0 = std::max(0, y - 1);
    const int y1 = std::min(height - 1, y + 1);
    const float invY = static_cast<float>(1.0 / ((y1 - y0) * sy));
    const float* above = g.data() + toIndex(0, y0, width);
    const float* row = g.data() + toIndex(0, y, width);
    const float* below = g.data() + toIndex(0, y1, width);
    float* magnitude = features_.gradientMagnitude.data() + toIndex(0, y, width);
    Eigen::Vector2f* direction = features_.gradientDirection.data() + toIndex(0, y, width);
    const float invInterior = static_cast<float>(1.0 / (2.0 * sx));
    const float invBorder = static_cast<float>(1.0 / sx);
    for (int x = 0; x < width; ++x) {
      const int x0 = std::max(0, x - 1);
      const int x1 = std::min(width - 1, x + 1);
      const float gx = (row[x1] - row[x0]) * (x1 - x0 == 2 ? invInterior : invBorder);
      const float gy = (below[x] - above[x]) * invY;
      const float m = std::sqrt(gx * gx + gy * gy);
      magnitude[x] = m;
      if (m > 0.0f) {
        const float inv = 1.0f / m;
        direction[x] = Eigen::Vector2f(gx * inv, gy * inv);
      }
      maxG = std::max(maxG, static_cast<double>(m));
    }
  }
  const double cap = options.gradientMagnitudeCap > 0.0 ? options.gradientMagnitudeCap : maxG;
  features_.magnitudeCap = cap;
  features_.magnitudeCost.assign(count, 1.0f);
  if (cap > 0.0) {
    for (std::size_t i = 0; i < count; ++i)
      features_.magnitudeCost[i] = static_cast<float>(
          1.0 - std::min(static_cast<double>(features_.gradientMagnitude[i]), cap) / cap);
  }

  // Laplacian of Gaussian and its zero crossings: of two neighbours whose Laplacians have
  // opposite signs, the one closer to zero is the edge (fZ = 0). Values within a tiny fraction of
  // the largest count as +0, so rounding noise in flat regions makes no crossings.
  const Eigen::Vector2d laplacianSigma = sigmaPixels(options.laplacianSigmaMm);
  const std::vector<float> s = smooth(image, width, height, laplacianSigma.x(), laplacianSigma.y());
  std::vector<float> lap(count);
  float maxLap = 0.0f;
  for (int y = 0; y < height; ++y) {
    const int y0 = std::max(0, y - 1);
    const int y1 = std::min(height - 1, y + 1);
    for (int x = 0; x < width; ++x) {
      const int x0 = std::max(0, x - 1);
      const int x1 = std::min(width - 1, x + 1);
      const double c = s[toIndex(x, y, width)];
      const double v = (s[toIndex(x1, y, width)] - 2.0 * c + s[toIndex(x0, y, width)]) / (sx * sx) +
                       (s[toIndex(x, y1, width)] - 2.0 * c + s[toIndex(x, y0, width)]) / (sy * sy);
      lap[toIndex(x, y, width)] = static_cast<float>(v);
      maxLap = std::max(maxLap, static_cast<float>(std::abs(v)));
    }
  }
  const float tolerance = 1e-5f * maxLap;
  for (float& v : lap)
    if (std::abs(v) <= tolerance)
      v = 0.0f;
  features_.zeroCrossing.assign(count, 1.0f);
  const auto mark = [&](std::size_t a, std::size_t b) {
    const float va = lap[a];
    const float vb = lap[b];
    if ((va < 0.0f) != (vb < 0.0f))
      features_.zeroCrossing[std::abs(va) <= std::abs(vb) ? a : b] = 0.0f;
  };
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::size_t i = toIndex(x, y, width);
      if (x + 1 < width)
        mark(i, i + 1);
      if (y + 1 < height) {
        const std::size_t below = toIndex(x, y + 1, width);
        mark(i, below);
        if (x + 1 < width)
          mark(i, below + 1);
        if (x > 0)
          mark(i, below - 1);
      }
    }
  }
  if (options.minEdgeGradientFraction > 0.0) {
    const double floor = options.minEdgeGradientFraction * cap;
    for (std::size_t i = 0; i < count; ++i)
      if (features_.gradientMagnitude[i] < floor)
        features_.zeroCrossing[i] = 1.0f;
  }

  // Every directed link, quantised (rounded to the nearest integer). The same values as
  // linkCost(), bit for bit, with a quarter of the acos evaluations: per pixel and undirected
  // direction d (neighbours 4, 6, 7, 5), y = D'(p) . u_d, A = acos(|y|) and the sign of y; a link
  // n = sigma_n d has acos(dp) = A(p) and acos(dq) = A(q) or pi - A(q), as the sign of dq.
  links_.assign(8 * count, kNoLink);
  const double resolution = options.costResolution;
  const std::array<LinkGeometry, 8> geometry = linkGeometry(spacingMm);
  constexpr std::size_t kUndirected[4] = {4, 6, 7, 5};
  constexpr int kDirectionOf[8] = {2, 1, 3, 0, 0, 3, 1, 2};
  constexpr int kSigmaOf[8] = {-1, -1, -1, -1, 1, 1, 1, 1};
  // acos(|y|) and the sign of y for three rows at a time (a ring: row r in slot r % 3).
  const std::size_t w = static_cast<std::size_t>(width);
  std::vector<float> acosAbs(3 * 4 * w);
  std::vector<signed char> sign(3 * 4 * w);
  const auto prepareRow = [&](int row) {
    const std::size_t base = static_cast<std::size_t>(row % 3) * 4 * w;
    const Eigen::Vector2f* gradient = features_.gradientDirection.data() + toIndex(0, row, width);
    for (std::size_t x = 0; x < w; ++x) {
      for (std::size_t d = 0; d < 4; ++d) {
        const LinkGeometry& u = geometry[kUndirected[d]];
        const double y = static_cast<double>(gradient[x].y()) * u.ux -
                         static_cast<double>(gradient[x].x()) * u.uy;
        acosAbs[base + 4 * x + d] = static_cast<float>(fastAcos(std::abs(y)));
        sign[base + 4 * x + d] = static_cast<signed char>(y > 0.0 ? 1 : y < 0.0 ? -1 : 0);
      }
    }
  };
  const double wZ = options.weightZeroCrossing;
  const double wD = options.weightDirection * (2.0 / (3.0 * kPi));
  const double wG = options.weightMagnitude;
  std::uint32_t maxLink = 1;
  prepareRow(0);
  for (int y = 0; y < height; ++y) {
    if (y + 1 < height)
      prepareRow(y + 1);
    for (int x = 0; x < width; ++x) {
      const std::size_t p = toIndex(x, y, width);
      const std::size_t pr =
          static_cast<std::size_t>(y % 3) * 4 * w + 4 * static_cast<std::size_t>(x);
      std::uint16_t* out = links_.data() + 8 * p;
      const bool interior = x > 0 && y > 0 && x + 1 < width && y + 1 < height;
      for (std::size_t n = 0; n < 8; ++n) {
        const int qx = x + kDx[n];
        const int qy = y + kDy[n];
        if (!interior && (qx < 0 || qy < 0 || qx >= width || qy >= height))
          continue;
        const std::size_t q = toIndex(qx, qy, width);
        const std::size_t qr =
            static_cast<std::size_t>(qy % 3) * 4 * w + 4 * static_cast<std::size_t>(qx);
        const std::size_t d = static_cast<std::size_t>(kDirectionOf[n]);
        const int sp = sign[pr + d];
        const int orientation = (sp != 0 ? sp : kSigmaOf[n]) * sign[qr + d];
        const double aq = acosAbs[qr + d];
        const double fD = static_cast<double>(acosAbs[pr + d]) + (orientation >= 0 ? aq : kPi - aq);
        const double c = wZ * features_.zeroCrossing[q] + wD * fD +
                         wG * features_.magnitudeCost[q] * geometry[n].lengthRatio;
        const auto quantised = static_cast<std::uint32_t>(c * resolution + 0.5);
        out[n] = static_cast<std::uint16_t>(quantised);
        maxLink = std::max(maxLink, quantised);
      }
    }
  }
  maxLink_ = maxLink;
}

std::size_t LiveWire::linkIndex(const Eigen::Vector2i& p, const Eigen::Vector2i& q) const {
  if (!contains(p) || !contains(q))
    throw std::invalid_argument("live-wire: link " + pixelText(p) + " -> " + pixelText(q) +
                                " leaves the image");
  const int n = neighbourIndex(q.x() - p.x(), q.y() - p.y());
  if (n < 0)
    throw std::invalid_argument("live-wire: " + pixelText(p) + " and " + pixelText(q) +
                                " are not 8-neighbours");
  return 8 * toIndex(p.x(), p.y(), width_) + static_cast<std::size_t>(n);
}

double LiveWire::localCost(const Eigen::Vector2i& p, const Eigen::Vector2i& q) const {
  const std::size_t link = linkIndex(p, q);  // validates
  return linkCost(features_, options_, link / 8, toIndex(q.x(), q.y(), width_),
                  linkGeometry(spacing_)[link % 8]);
}

void LiveWire::setAnchor(const Eigen::Vector2i& anchor,
                         const std::optional<Eigen::Vector2i>& target) {
  if (!contains(anchor))
    throw std::invalid_argument("live-wire: anchor " + pixelText(anchor) + " is outside the " +
                                std::to_string(width_) + " x " + std::to_string(height_) +
                                " image");
  if (target && !contains(*target))
    throw std::invalid_argument("live-wire: target " + pixelText(*target) + " is outside the " +
                                std::to_string(width_) + " x " + std::to_string(height_) +
                                " image");
  const std::size_t count = toIndex(0, height_, width_);
  distance_.assign(count, kUnreached);
  predecessor_.assign(count, 0);
  settled_.assign(count, 0);
  // Dial's algorithm: a circular array of maxLink + 1 buckets holds every tentative distance
  // between the current one and current + maxLink. Stale entries are skipped when popped.
  const std::size_t bucketCount = static_cast<std::size_t>(maxLink_) + 1;
  if (buckets_.size() != bucketCount)
    buckets_.assign(bucketCount, {});
  for (auto& b : buckets_)
    b.clear();

  const std::ptrdiff_t w = width_;
  std::ptrdiff_t offset[8];
  for (int n = 0; n < 8; ++n)
    offset[n] = kDy[n] * w + kDx[n];

  const auto start = static_cast<std::uint32_t>(toIndex(anchor.x(), anchor.y(), width_));
  const std::uint32_t stop =
      target ? static_cast<std::uint32_t>(toIndex(target->x(), target->y(), width_)) : kUnreached;
  distance_[start] = 0;
  buckets_[0].push_back(start);
  std::size_t pending = 1;
  std::uint32_t current = 0;
  std::size_t slot = 0;
  std::uint32_t* dist = distance_.data();
  std::uint8_t* pred = predecessor_.data();
  std::uint8_t* done = settled_.data();
  const std::uint16_t* links = links_.data();
  bool finished = false;
  while (pending > 0 && !finished) {
    std::vector<std::uint32_t>& bucket = buckets_[slot];
    while (!bucket.empty()) {
      const std::uint32_t p = bucket.back();
      bucket.pop_back();
      --pending;
      if (dist[p] != current || done[p])
        continue;
      done[p] = 1;
      if (p == stop) {
        finished = true;
        break;
      }
      const std::uint16_t* pl = links + 8 * static_cast<std::size_t>(p);
      for (int n = 0; n < 8; ++n) {
        const std::uint16_t c = pl[n];
        if (c == kNoLink)
          continue;
        const auto q = static_cast<std::uint32_t>(static_cast<std::ptrdiff_t>(p) + offset[n]);
        const std::uint32_t d = current + c;
        if (d < dist[q]) {
          dist[q] = d;
          pred[q] = static_cast<std::uint8_t>(n + 1);
          std::size_t s = slot + c;
          if (s >= bucketCount)
            s -= bucketCount;
          buckets_[s].push_back(q);
          ++pending;
        }
      }
    }
    ++current;
    if (++slot == bucketCount)
      slot = 0;
  }
  anchor_ = anchor;
}

LiveWirePathCost LiveWire::costTo(const Eigen::Vector2i& pixel) const {
  if (!anchor_)
    throw std::logic_error("live-wire: costTo before setAnchor");
  if (!contains(pixel))
    throw std::invalid_argument("live-wire: pixel " + pixelText(pixel) + " is outside the image");
  const std::size_t i = toIndex(pixel.x(), pixel.y(), width_);
  if (!settled_[i])
    throw std::invalid_argument("live-wire: the optimal path to " + pixelText(pixel) +
                                " is not known (the search stopped at another target)");
  LiveWirePathCost result;
  result.quantised = distance_[i];
  result.cost = static_cast<double>(distance_[i]) / options_.costResolution;
  return result;
}

std::vector<Eigen::Vector2i> LiveWire::pathTo(const Eigen::Vector2i& pixel) const {
  costTo(pixel);  // validates
  std::vector<Eigen::Vector2i> path;
  Eigen::Vector2i p = pixel;
  const std::size_t limit = toIndex(0, height_, width_);
  for (std::size_t steps = 0;; ++steps) {
    path.push_back(p);
    const std::uint8_t n = predecessor_[toIndex(p.x(), p.y(), width_)];
    if (n == 0)
      break;
    if (steps > limit)
      throw std::logic_error("live-wire: the predecessor map has a loop");
    p -= Eigen::Vector2i(kDx[n - 1], kDy[n - 1]);
  }
  std::reverse(path.begin(), path.end());
  return path;
}

LiveWirePathCost LiveWire::pathCost(const std::vector<Eigen::Vector2i>& path) const {
  LiveWirePathCost result;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (!contains(path[i]))
      throw std::invalid_argument("live-wire: path point " + std::to_string(i) + " " +
                                  pixelText(path[i]) + " is outside the image");
    if (i == 0 || path[i] == path[i - 1])
      continue;
    result.quantised += links_[linkIndex(path[i - 1], path[i])];
  }
  result.cost = static_cast<double>(result.quantised) / options_.costResolution;
  return result;
}

ClosedLiveWire closedLiveWire(LiveWire& wire, const std::vector<Eigen::Vector2i>& anchors) {
  std::vector<Eigen::Vector2i> distinct;
  for (const auto& a : anchors) {
    if (!wire.contains(a))
      throw std::invalid_argument("live-wire: anchor " + pixelText(a) + " is outside the " +
                                  std::to_string(wire.width()) + " x " +
                                  std::to_string(wire.height()) + " image");
    if (distinct.empty() || distinct.back() != a)
      distinct.push_back(a);
  }
  while (distinct.size() > 1 && distinct.back() == distinct.front())
    distinct.pop_back();
  if (distinct.size() < 3)
    throw std::invalid_argument(
        "live-wire: a closed contour needs at least 3 distinct anchors, got " +
        std::to_string(distinct.size()));
  ClosedLiveWire result;
  for (std::size_t i = 0; i < distinct.size(); ++i) {
    const Eigen::Vector2i& from = distinct[i];
    const Eigen::Vector2i& to = distinct[(i + 1) % distinct.size()];
    wire.setAnchor(from, to);
    const std::vector<Eigen::Vector2i> path = wire.pathTo(to);
    const double cost = wire.costTo(to).cost;
    result.anchorIndices.push_back(result.points.size());
    result.points.insert(result.points.end(), path.begin(), path.end() - 1);
    result.segmentCosts.push_back(cost);
    result.cost += cost;
  }
  return result;
}

}  // namespace echoreg::core
