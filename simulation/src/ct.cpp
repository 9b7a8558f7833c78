#include "echoreg/simulation/ct.hpp"

#include "echoreg/core/random.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

namespace echoreg::simulation {

namespace {

constexpr std::size_t kTissueCount = static_cast<std::size_t>(Tissue::Count);
/// Through-slice check planes of a thick slice lie at most this far apart.
constexpr double kCheckPlaneSpacingMm = 1.0;
/// Gaussian kernels are cut at this many sigmas.
constexpr double kKernelRadiusSigmas = 4.0;

void require(bool ok, const std::string& what, double value) {
  if (!ok)
    throw std::invalid_argument(fmt::format("CtProtocol.{}, got {}", what, value));
}

/// A slice group of `spacing` centred on `centre` covering `length` (whole number of slices).
CtSliceGroup centredGroup(std::string name, double centre, double length, double spacing) {
  const double half = 0.5 * (length - spacing);
  return {std::move(name), centre - half, centre + half, spacing};
}

CtProtocol protocolFromGroups(std::vector<CtSliceGroup> groups, Eigen::Vector2d centreXY) {
  std::sort(groups.begin(), groups.end(),
            [](const CtSliceGroup& a, const CtSliceGroup& b) { return a.firstZMm < b.firstZMm; });
  CtProtocol protocol;
  protocol.centreXYMm = centreXY;
  protocol.groups = std::move(groups);
  return protocol;
}

/// Normalised discrete Gaussian of `sigmaPx` pixels, radius ceil(4 sigma) (at least 1 tap).
std::vector<double> gaussianKernel(double sigmaPx) {
  if (sigmaPx <= 0.0)
    return {1.0};
  const int radius = std::max(1, static_cast<int>(std::ceil(kKernelRadiusSigmas * sigmaPx)));
  std::vector<double> kernel(static_cast<std::size_t>(2 * radius + 1));
  double sum = 0.0;
  for (int d = -radius; d <= radius; ++d) {
    const double w = std::exp(-0.5 * d * d / (sigmaPx * sigmaPx));
    kernel[static_cast<std::size_t>(d + radius)] = w;
    sum += w;
  }
  for (double& w : kernel)
    w /= sum;
  return kernel;
}

/// Separable convolution of a width x height image with `kernel` along x then y, edges replicated.
void blurReplicate(std::vector<double>& image, std::vector<double>& scratch, int width, int height,
                   const std::vector<double>& kernel) {
  if (kernel.size() <= 1)
    return;
  const int radius = static_cast<int>(kernel.size() / 2);
  const auto at = [width](int x, int y) {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(x);
  };
  scratch.resize(image.size());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int d = -radius; d <= radius; ++d) {
        const int xs = std::clamp(x + d, 0, width - 1);
        sum += kernel[static_cast<std::size_t>(d + radius)] * image[at(xs, y)];
      }
      scratch[at(x, y)] = sum;
    }
  }
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int d = -radius; d <= radius; ++d) {
        const int ys = std::clamp(y + d, 0, height - 1);
        sum += kernel[static_cast<std::size_t>(d + radius)] * scratch[at(x, ys)];
      }
      image[at(x, y)] = sum;
    }
  }
}

/// Gaussian-correlated texture of unit variance on a width x height grid: white noise on a grid
/// padded by the kernel radius (so the edges have the same statistics), blurred, rescaled.
void correlatedTexture(core::Rng& rng, int width, int height, const std::vector<double>& kernel,
                       std::vector<double>& out, std::vector<double>& padded,
                       std::vector<double>& scratch) {
  const int radius = static_cast<int>(kernel.size() / 2);
  const int pw = width + 2 * radius;
  const int ph = height + 2 * radius;
  padded.resize(static_cast<std::size_t>(pw) * static_cast<std::size_t>(ph));
  for (double& v : padded)
    v = rng.normal();
  double sumSquares = 0.0;
  for (double w : kernel)
    sumSquares += w * w;
  const double scale = 1.0 / sumSquares;  // 1 / sqrt((sum w^2)^2) for the separable 2-D kernel
  const auto pat = [pw](int x, int y) {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(pw) + static_cast<std::size_t>(x);
  };
  // Along x over all padded rows, then along y for the interior only.
  scratch.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(ph));
  for (int y = 0; y < ph; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int d = -radius; d <= radius; ++d) {
        sum += kernel[static_cast<std::size_t>(d + radius)] * padded[pat(x + radius + d, y)];
      }
      scratch[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
              static_cast<std::size_t>(x)] = sum;
    }
  }
  out.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int d = -radius; d <= radius; ++d) {
        sum += kernel[static_cast<std::size_t>(d + radius)] *
               scratch[static_cast<std::size_t>(y + radius + d) * static_cast<std::size_t>(width) +
                       static_cast<std::size_t>(x)];
      }
      out[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
          static_cast<std::size_t>(x)] = sum * scale;
    }
  }
}

/// Per-thread buffers, reused from slice to slice.
struct SliceBuffers {
  std::vector<std::uint8_t> labels;  // one plane of rows * columns per check plane
  std::vector<double> value;
  std::vector<double> sigma;
  std::vector<double> texture;
  std::vector<double> padded;
  std::vector<double> scratch;
};

class Synthesizer {
 public:
  Synthesizer(const TissueField& field, const CtProtocol& protocol, std::uint64_t seed,
              core::CtImage& volume)
      : field_(field), protocol_(protocol), seed_(seed), volume_(volume) {
    for (std::size_t t = 0; t < kTissueCount; ++t) {
      const TissueProperties& p = properties(static_cast<Tissue>(t));
      hu_[t] = p.hounsfield;
      sigma_[t] = p.hounsfieldSigma * protocol.textureScale;
    }
    if (std::isfinite(protocol.cancellousHu))
      hu_[static_cast<std::size_t>(Tissue::CancellousBone)] = protocol.cancellousHu;
    psfKernel_ = gaussianKernel(protocol.psfSigmaMm / protocol.pixelSpacingMm);
    // Autocorrelation exp(-d^2 / L^2) of blurred white noise needs a kernel sigma of L / 2.
    textureKernel_ = gaussianKernel(0.5 * protocol.textureCorrelationMm / protocol.pixelSpacingMm);
  }

  void slice(int k, SliceBuffers& buffers) const {
    const int columns = volume_.dimensions[0];
    const int rows = volume_.dimensions[1];
    const std::size_t plane = static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows);
    const double z = volume_.sliceLocationsMm[static_cast<std::size_t>(k)];
    const double thickness = volume_.sliceThicknessMm[static_cast<std::size_t>(k)];
    const double ps = volume_.pixelSpacingMm.x();
    const double x0 = volume_.originMm.x();
    const double y0 = volume_.originMm.y();

    // Through-slice sub-planes and the check planes among them.
    const int nz =
        std::max(1, static_cast<int>(std::ceil(thickness / protocol_.zSubsampleMm - 1e-9)));
    const double subStep = thickness / nz;
    std::vector<double> subZ(static_cast<std::size_t>(nz));
    for (int s = 0; s < nz; ++s) {
      subZ[static_cast<std::size_t>(s)] = z - 0.5 * thickness + (s + 0.5) * subStep;
    }
    const int stride =
        std::max(1, static_cast<int>(std::floor(kCheckPlaneSpacingMm / subStep + 1e-9)));
    std::vector<double> checkZ;
    for (int s = 0; s < nz; s += stride)
      checkZ.push_back(subZ[static_cast<std::size_t>(s)]);
    if ((nz - 1) % stride != 0)
      checkZ.push_back(subZ.back());

    // Tissue at every voxel centre on every check plane.
    buffers.labels.resize(plane * checkZ.size());
    for (std::size_t c = 0; c < checkZ.size(); ++c) {
      std::uint8_t* labels = buffers.labels.data() + c * plane;
      for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < columns; ++i) {
          labels[static_cast<std::size_t>(j) * static_cast<std::size_t>(columns) +
                 static_cast<std::size_t>(i)] =
              label(Eigen::Vector3d(x0 + i * ps, y0 + j * ps, checkZ[c]));
        }
      }
    }

    // Mean HU and texture amplitude per voxel: uniform neighbourhoods from the labels, the rest
    // averaged over the sub-grid.
    const int ss = protocol_.inPlaneSupersample;
    std::vector<double> subOffset(static_cast<std::size_t>(ss));
    for (int a = 0; a < ss; ++a)
      subOffset[static_cast<std::size_t>(a)] = ((a + 0.5) / ss - 0.5) * ps;
    const double subCount = static_cast<double>(ss) * ss * nz;
    buffers.value.resize(plane);
    buffers.sigma.resize(plane);
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < columns; ++i) {
        const std::size_t idx = static_cast<std::size_t>(j) * static_cast<std::size_t>(columns) +
                                static_cast<std::size_t>(i);
        const std::uint8_t centre = buffers.labels[idx];
        bool uniform = true;
        for (std::size_t c = 0; c < checkZ.size() && uniform; ++c) {
          const std::uint8_t* labels = buffers.labels.data() + c * plane;
          for (int dj = -1; dj <= 1 && uniform; ++dj) {
            const int jj = j + dj;
            if (jj < 0 || jj >= rows)
              continue;
            for (int di = -1; di <= 1; ++di) {
              const int ii = i + di;
              if (ii < 0 || ii >= columns)
                continue;
              if (labels[static_cast<std::size_t>(jj) * static_cast<std::size_t>(columns) +
                         static_cast<std::size_t>(ii)] != centre) {
                uniform = false;
                break;
              }
            }
          }
        }
        if (uniform) {
          buffers.value[idx] = hu_[centre];
          buffers.sigma[idx] = sigma_[centre];
          continue;
        }
        double sumHu = 0.0;
        double sumSigma = 0.0;
        for (int s = 0; s < nz; ++s) {
          for (int b = 0; b < ss; ++b) {
            for (int a = 0; a < ss; ++a) {
              const std::uint8_t t =
                  label(Eigen::Vector3d(x0 + i * ps + subOffset[static_cast<std::size_t>(a)],
                                        y0 + j * ps + subOffset[static_cast<std::size_t>(b)],
                                        subZ[static_cast<std::size_t>(s)]));
              sumHu += hu_[t];
              sumSigma += sigma_[t];
            }
          }
        }
        buffers.value[idx] = sumHu / subCount;
        buffers.sigma[idx] = sumSigma / subCount;
      }
    }

    // Texture: correlated in-plane, averaged down through thick slices.
    if (protocol_.textureScale > 0.0) {
      core::Rng rng = core::Rng::derive(seed_, "ct-texture", static_cast<std::uint64_t>(k));
      correlatedTexture(rng, columns, rows, textureKernel_, buffers.texture, buffers.padded,
                        buffers.scratch);
      constexpr double kSqrtPi = 1.7724538509055160273;
      const double throughSlice =
          std::sqrt(std::min(1.0, kSqrtPi * protocol_.textureCorrelationMm / thickness));
      for (std::size_t idx = 0; idx < plane; ++idx) {
        buffers.value[idx] += buffers.texture[idx] * buffers.sigma[idx] * throughSlice;
      }
    }

    blurReplicate(buffers.value, buffers.scratch, columns, rows, psfKernel_);

    core::Rng noise = core::Rng::derive(seed_, "ct-noise", static_cast<std::uint64_t>(k));
    const double noiseSigma = protocol_.noiseSigmaHu;
    std::int16_t* out = volume_.hu.data() + static_cast<std::size_t>(k) * plane;
    for (std::size_t idx = 0; idx < plane; ++idx) {
      double v = buffers.value[idx];
      if (noiseSigma > 0.0)
        v += noiseSigma * noise.normal();
      const double rounded = std::clamp(std::floor(v + 0.5), static_cast<double>(kCtMinHu),
                                        static_cast<double>(kCtMaxHu));
      out[idx] = static_cast<std::int16_t>(rounded);
    }
  }

 private:
  std::uint8_t label(const Eigen::Vector3d& point) const {
    const Tissue tissue = field_.tissueAt(point);
    const auto value = static_cast<std::size_t>(tissue);
    if (value >= kTissueCount) {
      throw std::invalid_argument(
          fmt::format("TissueField returned {} at ({}, {}, {}), which is not a Tissue", value,
                      point.x(), point.y(), point.z()));
    }
    return static_cast<std::uint8_t>(value);
  }

  const TissueField& field_;
  const CtProtocol& protocol_;
  std::uint64_t seed_;
  core::CtImage& volume_;
  std::array<double, kTissueCount> hu_{};
  std::array<double, kTissueCount> sigma_{};
  std::vector<double> psfKernel_;
  std::vector<double> textureKernel_;
};

}  // namespace

CtProtocol dissertationProtocol(double hipZ, double kneeZ, double ankleZ,
                                Eigen::Vector2d centreXY) {
  CtProtocol protocol = protocolFromGroups(
      {centredGroup("hip", hipZ, 100.0, 5.0), centredGroup("knee", kneeZ, 200.0, 1.0),
       centredGroup("ankle", ankleZ, 100.0, 5.0)},
      centreXY);
  ctGeometry(protocol);  // overlapping groups fail here, with the offending value
  return protocol;
}

CtProtocol smallProtocol(double hipZ, double kneeZ, double ankleZ, Eigen::Vector2d centreXY) {
  CtProtocol protocol = protocolFromGroups(
      {centredGroup("hip", hipZ, 15.0, 5.0), centredGroup("knee", kneeZ, 160.0, 1.0),
       centredGroup("ankle", ankleZ, 15.0, 5.0)},
      centreXY);
  protocol.columns = 256;
  protocol.rows = 256;
  protocol.pixelSpacingMm = 0.8;
  ctGeometry(protocol);
  return protocol;
}

core::CtImage ctGeometry(const CtProtocol& p) {
  require(p.columns >= 1 && p.columns <= 65535, "columns must be 1..65535", p.columns);
  require(p.rows >= 1 && p.rows <= 65535, "rows must be 1..65535", p.rows);
  require(std::isfinite(p.pixelSpacingMm) && p.pixelSpacingMm > 0.0,
          "pixelSpacingMm must be positive", p.pixelSpacingMm);
  require(std::isfinite(p.centreXYMm.x()), "centreXYMm.x must be finite", p.centreXYMm.x());
  require(std::isfinite(p.centreXYMm.y()), "centreXYMm.y must be finite", p.centreXYMm.y());
  require(std::isfinite(p.noiseSigmaHu) && p.noiseSigmaHu >= 0.0,
          "noiseSigmaHu must be zero or positive", p.noiseSigmaHu);
  require(std::isfinite(p.psfSigmaMm) && p.psfSigmaMm >= 0.0, "psfSigmaMm must be zero or positive",
          p.psfSigmaMm);
  require(p.inPlaneSupersample >= 1 && p.inPlaneSupersample <= 16,
          "inPlaneSupersample must be 1..16", p.inPlaneSupersample);
  require(std::isfinite(p.zSubsampleMm) && p.zSubsampleMm > 0.0, "zSubsampleMm must be positive",
          p.zSubsampleMm);
  require(std::isfinite(p.textureScale) && p.textureScale >= 0.0,
          "textureScale must be zero or positive", p.textureScale);
  require(std::isfinite(p.textureCorrelationMm) && p.textureCorrelationMm > 0.0,
          "textureCorrelationMm must be positive", p.textureCorrelationMm);
  if (p.groups.empty())
    throw std::invalid_argument("CtProtocol.groups is empty: no slices");

  std::vector<core::AxialSliceGroup> slices;
  for (std::size_t g = 0; g < p.groups.size(); ++g) {
    const CtSliceGroup& group = p.groups[g];
    const std::string name = fmt::format("groups[{}] ({})", g, group.name);
    require(std::isfinite(group.spacingMm) && group.spacingMm > 0.0,
            name + ".spacingMm must be positive", group.spacingMm);
    require(std::isfinite(group.firstZMm), name + ".firstZMm must be finite", group.firstZMm);
    require(std::isfinite(group.lastZMm) && group.lastZMm >= group.firstZMm,
            name + ".lastZMm must be finite and >= firstZMm", group.lastZMm);
    const double steps = (group.lastZMm - group.firstZMm) / group.spacingMm;
    const double whole = std::round(steps);
    require(std::abs(steps - whole) <= 1e-6 * std::max(1.0, steps),
            name + ": lastZMm - firstZMm must be a whole number of spacingMm", steps);
    require(whole < 100000.0, name + ": too many slices", whole + 1.0);
    if (g > 0) {
      const CtSliceGroup& previous = p.groups[g - 1];
      const double previousTop = previous.lastZMm + 0.5 * previous.spacingMm;
      const double bottom = group.firstZMm - 0.5 * group.spacingMm;
      require(bottom >= previousTop - 1e-9,
              fmt::format("{}: the slab starting at z = {} mm overlaps the group below, which "
                          "ends at z",
                          name, bottom),
              previousTop);
    }
    core::AxialSliceGroup& run = slices.emplace_back();
    run.name = group.name;
    run.thicknessMm = group.spacingMm;
    const int count = static_cast<int>(whole) + 1;
    for (int s = 0; s < count; ++s)
      run.zMm.push_back(group.firstZMm + s * group.spacingMm);
  }
  const Eigen::Vector2d firstPixel =
      p.centreXYMm - 0.5 * p.pixelSpacingMm * Eigen::Vector2d(p.columns - 1, p.rows - 1);
  return core::axialCtImage(p.columns, p.rows, p.pixelSpacingMm, firstPixel, slices);
}

core::CtImage synthesizeCt(const TissueField& field, const CtProtocol& protocol, std::uint64_t seed,
                           const std::function<void(double fraction)>& progress) {
  core::CtImage volume = ctGeometry(protocol);
  const int slices = volume.dimensions[2];
  volume.hu.assign(volume.voxelCount(), 0);
  const Synthesizer synthesizer(field, protocol, seed, volume);

  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  std::exception_ptr error;
  int done = 0;
  const auto worker = [&]() {
    SliceBuffers buffers;
    while (!failed.load()) {
      const int k = next.fetch_add(1);
      if (k >= slices)
        break;
      try {
        synthesizer.slice(k, buffers);
        const std::lock_guard<std::mutex> lock(mutex);
        ++done;
        if (progress)
          progress(static_cast<double>(done) / slices);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!error)
          error = std::current_exception();
        failed.store(true);
      }
    }
  };
  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const unsigned threadCount = std::min(hardware, static_cast<unsigned>(slices));
  std::vector<std::thread> threads;
  try {
    for (unsigned t = 1; t < threadCount; ++t)
      threads.emplace_back(worker);
  } catch (...) {
    // No more threads: the ones started and this one share the work.
  }
  worker();
  for (std::thread& thread : threads)
    thread.join();
  if (error)
    std::rethrow_exception(error);
  return volume;
}

}  // namespace echoreg::simulation
