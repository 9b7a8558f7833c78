// Live-Wire side by side with OpenCV's cv::segmentation::IntelligentScissorsMB (when the build
// found OpenCV; `scripts/install-deps --bench` installs it) on a 512 x 512 slice of real CT
// (../shared/data/ct-abdomen/1-124.dcm: the pelvis with both ilia and the sacrum, read with
// gdcm::ImageReader, Hounsfield units windowed -200..1300 HU onto 0..255, the 8-bit image OpenCV
// takes; echoreg gets the same 8-bit values as floats).
//
// Timed (milliseconds per call):
//   echoreg_Features     LiveWire construction: smoothing, gradient, LoG zero crossings and every
//                        quantised link cost (OpenCV computes link costs inside buildMap instead)
//   echoreg_BuildMap     setAnchor: Dijkstra over the whole image from one anchor
//   echoreg_BuildMapToTarget  setAnchor with a target (stops when it is settled), the 40 pairs in
//   turn opencv_ApplyImage    IntelligentScissorsMB::applyImage (features) opencv_BuildMap
//   IntelligentScissorsMB::buildMap from the same anchor
// Agreement, printed before the timings: for 40 anchor/target pairs on the bone boundary
// (pixels >= 300 HU with a neighbour below, drawn with Rng(2008), 15-60 pixels apart), the mean
// distance between echoreg's and OpenCV's paths, each path's cost under echoreg's cost, and the
// share of each path's pixels on the 300 HU boundary.
//
//   bench_livewire [--no-agreement] [--benchmark_filter=BuildMap]

#include "test_support.hpp"

#include "echoreg/core/livewire.hpp"
#include "echoreg/core/random.hpp"

#include <benchmark/benchmark.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>

#ifdef ECHOREG_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc/segmentation.hpp>
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace {

using echoreg::core::LiveWire;
using echoreg::core::LiveWireOptions;
using Pixel = Eigen::Vector2i;

constexpr int kPairs = 40;

struct Slice {
  int width = 0;
  int height = 0;
  Eigen::Vector2d spacingMm{1.0, 1.0};
  std::vector<float> hu;
  std::vector<std::uint8_t> windowed;  // -200..1300 HU -> 0..255
  std::vector<float> windowedFloat;
  std::vector<std::pair<Pixel, Pixel>> pairs;
};

std::optional<Slice> readSlice(const std::string& path) {
  gdcm::ImageReader reader;
  reader.SetFileName(path.c_str());
  if (!reader.Read())
    return std::nullopt;
  const gdcm::Image& image = reader.GetImage();
  const unsigned int* dims = image.GetDimensions();
  const gdcm::PixelFormat format = image.GetPixelFormat();
  if (format.GetBitsAllocated() != 16 || format.GetSamplesPerPixel() != 1)
    return std::nullopt;
  std::vector<char> buffer(image.GetBufferLength());
  if (!image.GetBuffer(buffer.data()))
    return std::nullopt;
  Slice s;
  s.width = static_cast<int>(dims[0]);
  s.height = static_cast<int>(dims[1]);
  s.spacingMm = {image.GetSpacing()[0], image.GetSpacing()[1]};
  const std::size_t n = static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height);
  s.hu.resize(n);
  const bool isSigned = format.GetPixelRepresentation() != 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint16_t raw = 0;
    std::memcpy(&raw, buffer.data() + 2 * i, 2);
    const double v =
        isSigned ? static_cast<double>(static_cast<std::int16_t>(raw)) : static_cast<double>(raw);
    s.hu[i] = static_cast<float>(v * image.GetSlope() + image.GetIntercept());
  }
  s.windowed.resize(n);
  s.windowedFloat.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double v = std::clamp((s.hu[i] + 200.0) / 1500.0 * 255.0, 0.0, 255.0);
    s.windowed[i] = static_cast<std::uint8_t>(std::lround(v));
    s.windowedFloat[i] = s.windowed[i];
  }
  // Anchor/target pairs on the bone boundary.
  std::vector<Pixel> boundary;
  for (int y = 1; y + 1 < s.height; ++y) {
    for (int x = 1; x + 1 < s.width; ++x) {
      const auto at = [&](int xx, int yy) {
        return s.hu[static_cast<std::size_t>(yy * s.width + xx)];
      };
      if (at(x, y) < 300.0f)
        continue;
      if (at(x - 1, y) < 300.0f || at(x + 1, y) < 300.0f || at(x, y - 1) < 300.0f ||
          at(x, y + 1) < 300.0f)
        boundary.emplace_back(x, y);
    }
  }
  if (boundary.size() < 2)
    return std::nullopt;
  echoreg::core::Rng rng(2008);
  while (static_cast<int>(s.pairs.size()) < kPairs) {
    const Pixel a = boundary[rng.below(boundary.size())];
    const Pixel b = boundary[rng.below(boundary.size())];
    const double d = (a - b).cast<double>().norm();
    if (d >= 15.0 && d <= 60.0)
      s.pairs.emplace_back(a, b);
  }
  return s;
}

const Slice* slice() {
  static const std::optional<Slice> s = []() -> std::optional<Slice> {
    const std::string path = echoreg::test::sharedDataFile("ct-abdomen/1-124.dcm");
    if (path.empty())
      return std::nullopt;
    return readSlice(path);
  }();
  return s ? &*s : nullptr;
}

// The options that mimic OpenCV's features: no smoothing before the gradient (OpenCV: 3 x 3
// Sobel), an almost-zero Gaussian before the Laplacian (OpenCV: 3 x 3 Laplacian).
LiveWireOptions openCvLike() {
  LiveWireOptions o;
  o.gradientSigmaMm = -1.0;
  o.laplacianSigmaMm = 1e-3;
  return o;
}

// Mean over the points of each path of the distance to the nearest point of the other, both ways.
double meanDistance(const std::vector<Pixel>& a, const std::vector<Pixel>& b) {
  const auto oneWay = [](const std::vector<Pixel>& from, const std::vector<Pixel>& to) {
    double sum = 0.0;
    for (const auto& p : from) {
      double best = std::numeric_limits<double>::infinity();
      for (const auto& q : to)
        best = std::min(best, (p - q).cast<double>().norm());
      sum += best;
    }
    return sum / static_cast<double>(from.size());
  };
  return 0.5 * (oneWay(a, b) + oneWay(b, a));
}

// Share of a path's pixels whose 3 x 3 neighbourhood holds pixels on both sides of 300 HU (the
// bone boundary the anchors were drawn on).
double shareOnBoundary(const Slice& s, const std::vector<Pixel>& path) {
  int on = 0;
  for (const auto& p : path) {
    bool above = false;
    bool below = false;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = std::clamp(p.x() + dx, 0, s.width - 1);
        const int y = std::clamp(p.y() + dy, 0, s.height - 1);
        (s.hu[static_cast<std::size_t>(y * s.width + x)] >= 300.0f ? above : below) = true;
      }
    if (above && below)
      ++on;
  }
  return static_cast<double>(on) / static_cast<double>(path.size());
}

#ifdef ECHOREG_HAVE_OPENCV
cv::Mat openCvImage(const Slice& s) {
  return cv::Mat(s.height, s.width, CV_8UC1, const_cast<std::uint8_t*>(s.windowed.data())).clone();
}

std::vector<Pixel> openCvPath(const cv::segmentation::IntelligentScissorsMB& scissors,
                              const Pixel& target) {
  std::vector<cv::Point> contour;
  scissors.getContour(cv::Point(target.x(), target.y()), contour, false);
  std::vector<Pixel> path;
  for (const auto& p : contour)
    path.emplace_back(p.x, p.y);
  return path;
}
#endif

void printAgreement() {
  const Slice* s = slice();
  if (!s) {
    std::printf("agreement: ../shared/data/ct-abdomen/1-124.dcm is absent; skipped\n\n");
    return;
  }
#ifndef ECHOREG_HAVE_OPENCV
  std::printf("agreement: built without OpenCV (scripts/install-deps --bench); skipped\n\n");
#else
  cv::segmentation::IntelligentScissorsMB own;
  own.applyImage(openCvImage(*s));
  struct Variant {
    const char* name;
    LiveWireOptions options;
    bool sameFeatures;  // OpenCV given echoreg's feature maps, its fD weight matched
  };
  const Variant variants[] = {{"echoreg default (Gaussian sigma 1 px)", LiveWireOptions{}, false},
                              {"echoreg OpenCV-like (no smoothing)", openCvLike(), false},
                              {"OpenCV given echoreg's features", LiveWireOptions{}, true}};
  std::printf("agreement on %d anchor/target pairs, slice 1-124.dcm (%d x %d, %.3f mm pixels)\n",
              kPairs, s->width, s->height, s->spacingMm.x());
  std::printf("%-40s %8s %8s %12s %12s %10s %9s %8s %8s\n", "variant", "dist px", "dist mm",
              "cost echoreg", "cost OpenCV", "OpenCV/ech", "identical", "edge ech", "edge OCV");
  for (const Variant& v : variants) {
    LiveWire wire(s->windowedFloat, s->width, s->height, s->spacingMm, v.options);
    cv::segmentation::IntelligentScissorsMB fed;
    if (v.sameFeatures) {
      // echoreg's fD is 2/(3 pi) (acos + acos), OpenCV's (acos + acos) / pi: weight 2/3 of it.
      fed.setWeights(static_cast<float>(v.options.weightZeroCrossing),
                     static_cast<float>(v.options.weightDirection * 2.0 / 3.0),
                     static_cast<float>(v.options.weightMagnitude));
      const auto& f = wire.features();
      cv::Mat nonEdge(s->height, s->width, CV_8UC1);
      cv::Mat direction(s->height, s->width, CV_32FC2);
      cv::Mat magnitude(s->height, s->width, CV_32FC1);
      for (int y = 0; y < s->height; ++y) {
        for (int x = 0; x < s->width; ++x) {
          const std::size_t i = static_cast<std::size_t>(y * s->width + x);
          nonEdge.at<std::uint8_t>(y, x) = f.zeroCrossing[i] > 0.5f ? 1 : 0;
          direction.at<cv::Point2f>(y, x) =
              cv::Point2f(f.gradientDirection[i].x(), f.gradientDirection[i].y());
          magnitude.at<float>(y, x) = f.magnitudeCost[i];
        }
      }
      fed.applyImageFeatures(nonEdge, direction, magnitude);
    }
    cv::segmentation::IntelligentScissorsMB& scissors = v.sameFeatures ? fed : own;
    double distance = 0.0;
    double ours = 0.0;
    double theirs = 0.0;
    double ratio = 0.0;
    int identical = 0;
    double edgeOurs = 0.0;
    double edgeTheirs = 0.0;
    for (const auto& [anchor, target] : s->pairs) {
      scissors.buildMap(cv::Point(anchor.x(), anchor.y()));
      const std::vector<Pixel> cvPath = openCvPath(scissors, target);
      wire.setAnchor(anchor, target);
      const std::vector<Pixel> path = wire.pathTo(target);
      distance += meanDistance(path, cvPath);
      const double a = wire.pathCost(path).cost;
      const double b = wire.pathCost(cvPath).cost;
      ours += a;
      theirs += b;
      ratio += b / a;
      if (path == cvPath)
        ++identical;
      edgeOurs += shareOnBoundary(*s, path);
      edgeTheirs += shareOnBoundary(*s, cvPath);
    }
    std::printf("%-40s %8.3f %8.3f %12.3f %12.3f %10.4f %6d/%d %8.3f %8.3f\n", v.name,
                distance / kPairs, distance / kPairs * s->spacingMm.x(), ours / kPairs,
                theirs / kPairs, ratio / kPairs, identical, kPairs, edgeOurs / kPairs,
                edgeTheirs / kPairs);
  }
  std::printf(
      "(dist: mean of the two paths' mean nearest-point distances; costs: mean per path under\n"
      " echoreg's cost of the variant; OpenCV/ech: mean ratio of the two, >= 1 as echoreg's is "
      "optimal;\n"
      " edge: mean share of path pixels whose 3 x 3 neighbourhood straddles 300 HU)\n\n");
#endif
}

void BM_echoreg_Features(benchmark::State& state) {
  const Slice* s = slice();
  if (!s) {
    state.SkipWithError("../shared/data/ct-abdomen/1-124.dcm is absent");
    return;
  }
  for (auto _ : state) {
    LiveWire wire(s->windowedFloat, s->width, s->height, s->spacingMm);
    benchmark::DoNotOptimize(wire.features().zeroCrossing.data());
  }
}

void BM_echoreg_BuildMap(benchmark::State& state) {
  const Slice* s = slice();
  if (!s) {
    state.SkipWithError("../shared/data/ct-abdomen/1-124.dcm is absent");
    return;
  }
  LiveWire wire(s->windowedFloat, s->width, s->height, s->spacingMm);
  for (auto _ : state) {
    wire.setAnchor(s->pairs.front().first);
    benchmark::DoNotOptimize(wire.costTo(s->pairs.front().second).quantised);
  }
}

void BM_echoreg_BuildMapToTarget(benchmark::State& state) {
  const Slice* s = slice();
  if (!s) {
    state.SkipWithError("../shared/data/ct-abdomen/1-124.dcm is absent");
    return;
  }
  LiveWire wire(s->windowedFloat, s->width, s->height, s->spacingMm);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& [anchor, target] = s->pairs[i++ % s->pairs.size()];
    wire.setAnchor(anchor, target);
    benchmark::DoNotOptimize(wire.costTo(target).quantised);
  }
}

BENCHMARK(BM_echoreg_Features)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_echoreg_BuildMap)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_echoreg_BuildMapToTarget)->Unit(benchmark::kMillisecond);

#ifdef ECHOREG_HAVE_OPENCV
void BM_opencv_ApplyImage(benchmark::State& state) {
  const Slice* s = slice();
  if (!s) {
    state.SkipWithError("../shared/data/ct-abdomen/1-124.dcm is absent");
    return;
  }
  const cv::Mat image = openCvImage(*s);
  for (auto _ : state) {
    cv::segmentation::IntelligentScissorsMB scissors;
    scissors.applyImage(image);
    benchmark::DoNotOptimize(&scissors);
  }
}

void BM_opencv_BuildMap(benchmark::State& state) {
  const Slice* s = slice();
  if (!s) {
    state.SkipWithError("../shared/data/ct-abdomen/1-124.dcm is absent");
    return;
  }
  cv::segmentation::IntelligentScissorsMB scissors;
  scissors.applyImage(openCvImage(*s));
  const cv::Point anchor(s->pairs.front().first.x(), s->pairs.front().first.y());
  for (auto _ : state) {
    scissors.buildMap(anchor);
    benchmark::ClobberMemory();
  }
}

BENCHMARK(BM_opencv_ApplyImage)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_opencv_BuildMap)->Unit(benchmark::kMillisecond);
#endif

}  // namespace

int main(int argc, char** argv) {
  // --no-agreement: timings only.
  bool agreement = true;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--no-agreement") {
      agreement = false;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv))
    return 1;
  if (agreement)
    printAgreement();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
