// Live-Wire ("intelligent scissors", Mortensen & Barrett 1995) on a plain 2-D image: the local
// cost of every link between 8-neighbours is computed once from the image (Laplacian zero
// crossings, gradient magnitude, gradient direction), then Dijkstra's algorithm from an anchor
// gives the optimal path to every pixel. Used on CT slices (segmentation/livewire_contours.hpp)
// to contour bone between anchors placed by the user; plain arrays, no VTK.
//
// Pixels are Eigen::Vector2i (x = column, y = row); the image is row-major (x fastest). Pixel
// spacing may differ along x and y: derivatives, smoothing and link directions are in mm.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <vector>

namespace echoreg::core {

struct LiveWireOptions {
  /// Weights of the three cost terms (Mortensen & Barrett 1995, and OpenCV's
  /// IntelligentScissorsMB): Laplacian zero crossing, gradient direction, gradient magnitude.
  /// Each >= 0, their sum > 0.
  double weightZeroCrossing = 0.43;
  double weightDirection = 0.43;
  double weightMagnitude = 0.14;
  /// Standard deviation of the Gaussian of the Laplacian-of-Gaussian (zero crossings), mm;
  /// 0 uses one pixel along each axis (sigma = spacing, so anisotropic in mm).
  double laplacianSigmaMm = 0.0;
  /// Standard deviation of the Gaussian smoothing before the gradient (central differences), mm;
  /// 0 uses one pixel along each axis; a negative value takes the gradient of the raw image.
  double gradientSigmaMm = 0.0;
  /// Gradient magnitudes above this (image units per mm) count as this much (fG = 0 at and above
  /// it), so one very strong edge does not flatten all others; 0 uses the image's maximum (the
  /// paper's fG = 1 - G / max G).
  double gradientMagnitudeCap = 0.0;
  /// Zero crossings where the gradient magnitude is below this fraction of the cap (or maximum)
  /// are ignored (fZ = 1): they are noise in flat regions. 0 keeps them all, as the paper.
  double minEdgeGradientFraction = 0.0;
  /// Link costs are quantised to integers: a cost of 1 becomes `costResolution`. The search is
  /// exact for the quantised costs (a bucket queue). weights' sum x costResolution <= 65000.
  int costResolution = 1024;
};

/// The feature maps, per pixel (row-major), kept for diagnostics and sub-pixel refinement.
struct LiveWireFeatures {
  std::vector<float> zeroCrossing;                 ///< fZ: 0 on a zero crossing of the LoG, else 1
  std::vector<float> gradientMagnitude;            ///< G, image units per mm (after smoothing)
  std::vector<float> magnitudeCost;                ///< fG = 1 - min(G, cap) / cap
  std::vector<Eigen::Vector2f> gradientDirection;  ///< unit gradient (mm frame), 0 where G = 0
  double magnitudeCap = 0.0;                       ///< the cap used (max G when not set)
};

/// Integer cost of a path, and the same in cost units (sum of the local costs l(p, q)).
struct LiveWirePathCost {
  std::uint64_t quantised = 0;
  double cost = 0.0;  ///< quantised / costResolution
};

class LiveWire {
 public:
  /// Computes the features and every link cost of `image` (width x height, row-major, any
  /// units, e.g. Hounsfield). Throws std::invalid_argument for an empty image (width or height
  /// < 2), a size that does not match, a pixel that is not finite, a spacing that is not
  /// positive, or bad options.
  LiveWire(const std::vector<float>& image, int width, int height,
           const Eigen::Vector2d& spacingMm = Eigen::Vector2d(1.0, 1.0),
           const LiveWireOptions& options = {});

  int width() const { return width_; }
  int height() const { return height_; }
  const Eigen::Vector2d& spacingMm() const { return spacing_; }
  const LiveWireOptions& options() const { return options_; }
  const LiveWireFeatures& features() const { return features_; }
  bool contains(const Eigen::Vector2i& pixel) const {
    return pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() < width_ && pixel.y() < height_;
  }

  /// Runs Dijkstra from `anchor` over the whole image, or, with `target`, only until the target's
  /// optimal path is known (faster for anchor-to-anchor contours). Throws std::invalid_argument
  /// when the anchor or the target is outside the image.
  void setAnchor(const Eigen::Vector2i& anchor,
                 const std::optional<Eigen::Vector2i>& target = std::nullopt);

  /// The optimal path anchor..pixel (both included; one point when pixel == anchor). Throws
  /// std::logic_error before setAnchor, std::invalid_argument when the pixel is outside the image
  /// or its optimal path is not known (the search stopped at another target).
  std::vector<Eigen::Vector2i> pathTo(const Eigen::Vector2i& pixel) const;

  /// The optimal cost from the anchor to `pixel` (same conditions as pathTo).
  LiveWirePathCost costTo(const Eigen::Vector2i& pixel) const;

  /// The cost of ANY 8-connected path under this image's local costs: the sum of l(p_i, p_i+1)
  /// (directed: from the path's first point to its last). Throws std::invalid_argument when a
  /// point is outside the image or two consecutive points are not 8-neighbours (equal points
  /// are skipped).
  LiveWirePathCost pathCost(const std::vector<Eigen::Vector2i>& path) const;

  /// The local cost l(p, q) of the link from p to its 8-neighbour q, unquantised (for tests and
  /// diagnostics). Throws std::invalid_argument as pathCost.
  double localCost(const Eigen::Vector2i& p, const Eigen::Vector2i& q) const;

  /// The anchor of the last setAnchor, if any.
  const std::optional<Eigen::Vector2i>& anchor() const { return anchor_; }

 private:
  std::size_t linkIndex(const Eigen::Vector2i& p, const Eigen::Vector2i& q) const;

  int width_ = 0;
  int height_ = 0;
  Eigen::Vector2d spacing_{1.0, 1.0};
  LiveWireOptions options_;
  LiveWireFeatures features_;
  /// Quantised cost of the link from pixel p to its neighbour n: links_[8 p + n]; kNoLink off
  /// the image.
  std::vector<std::uint16_t> links_;
  std::uint32_t maxLink_ = 0;
  // Search state of the last anchor.
  std::optional<Eigen::Vector2i> anchor_;
  std::vector<std::uint32_t> distance_;
  std::vector<std::uint8_t> predecessor_;  ///< neighbour index + 1 of the previous pixel, 0 none
  std::vector<std::uint8_t> settled_;
  std::vector<std::vector<std::uint32_t>> buckets_;
};

struct ClosedLiveWire {
  /// The closed path through the anchors in order, each anchor once, the closing link back to
  /// the first point implied (the first point is not repeated).
  std::vector<Eigen::Vector2i> points;
  /// Index in `points` of each anchor.
  std::vector<std::size_t> anchorIndices;
  /// Cost of each segment (anchor i to anchor i+1, the last back to the first) and in total.
  std::vector<double> segmentCosts;
  double cost = 0.0;
};

/// Live-wire from each anchor to the next and from the last back to the first. Consecutive equal
/// anchors are merged. Throws std::invalid_argument for fewer than 3 distinct anchors or an
/// anchor outside the image. Leaves `wire` anchored at the last anchor.
ClosedLiveWire closedLiveWire(LiveWire& wire, const std::vector<Eigen::Vector2i>& anchors);

}  // namespace echoreg::core
