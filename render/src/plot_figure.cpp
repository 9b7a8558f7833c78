#include "echoreg/render/plot_figure.hpp"

#include "echoreg/core/statistics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace echoreg::render {

namespace {

// The title band of the 2D figures: at most `maxFraction` of the image, 50 pixels.
SceneTitle plotTitle(const std::string& text, double maxFraction, int fontSize,
                     const FigureSize& size) {
  SceneTitle title;
  if (text.empty())
    return title;
  title.text = text;
  title.heightFraction = std::min(maxFraction, 50.0 / size.height);
  title.fontSize = fontSize;
  title.baselinePx = 0.25 * title.heightFraction * size.height;
  return title;
}

}  // namespace

Scene plotScene(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                const FigureSize& size) {
  if (panels.empty())
    throw std::invalid_argument("plot figure: no panel");
  if (columns < 1)
    throw std::invalid_argument("plot figure: columns < 1");
  Scene scene;
  scene.charts = panels;
  scene.columns = columns;
  scene.chartFontSize = std::max(10, std::min(size.height, size.width) / 55);
  scene.title = plotTitle(title, 0.08, scene.chartFontSize + 3, size);
  return scene;
}

RgbImage renderPlots(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                     const FigureSize& size) {
  return renderScene(plotScene(panels, columns, title, size), size);
}

Scene boxPlotScene(const std::vector<BoxGroup>& groups, const std::string& title,
                   const std::string& yLabel, const FigureSize& size) {
  if (groups.empty())
    throw std::invalid_argument("box plot: no group");
  std::vector<core::BoxSummary> boxes;
  std::vector<std::vector<double>> values;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].values.empty()) {
      throw std::invalid_argument(fmt::format("box plot: group \"{}\" is empty", groups[g].label));
    }
    boxes.push_back(core::boxSummary(groups[g].values));
    values.push_back(groups[g].values);
  }
  std::string anova;
  if (groups.size() >= 2) {
    try {
      const core::AnovaResult r = core::oneWayAnova(values);
      anova = fmt::format(
          "one-way ANOVA: F({}, {}) = {:.3g}, p = {}", r.dfBetween, r.dfWithin, r.f,
          r.pValue < 1e-4 ? fmt::format("{:.1e}", r.pValue) : fmt::format("{:.4f}", r.pValue));
    } catch (const std::invalid_argument& e) {
      anova = std::string("ANOVA undefined: ") + e.what();
    }
  }
  PlotPanel panel;
  panel.title = anova;
  panel.yLabel = yLabel;
  panel.xLabel = "";
  panel.showLegend = false;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  const std::array<double, 3> ink{0.15, 0.25, 0.55};
  for (std::size_t g = 0; g < boxes.size(); ++g) {
    const core::BoxSummary& b = boxes[g];
    const double x = static_cast<double>(g + 1);
    const double w = 0.25;
    auto line = [&](std::vector<double> xs, std::vector<double> ys, std::array<double, 3> rgb,
                    double width) {
      Series s;
      s.x = std::move(xs);
      s.y = std::move(ys);
      s.rgb = rgb;
      s.lineWidth = width;
      panel.series.push_back(std::move(s));
    };
    line({x - w, x + w, x + w, x - w, x - w}, {b.q1, b.q1, b.q3, b.q3, b.q1}, ink, 2.0);
    line({x - w, x + w}, {b.median, b.median}, {0.8, 0.3, 0.1}, 3.0);
    line({x, x}, {b.q3, b.whiskerHigh}, ink, 1.5);
    line({x, x}, {b.q1, b.whiskerLow}, ink, 1.5);
    line({x - 0.5 * w, x + 0.5 * w}, {b.whiskerHigh, b.whiskerHigh}, ink, 1.5);
    line({x - 0.5 * w, x + 0.5 * w}, {b.whiskerLow, b.whiskerLow}, ink, 1.5);
    if (!b.outliers.empty()) {
      Series outliers;
      outliers.markersOnly = true;
      outliers.rgb = {0.6, 0.1, 0.1};
      outliers.markerSize = 7.0;
      outliers.y = b.outliers;
      outliers.x.assign(b.outliers.size(), x);
      panel.series.push_back(outliers);
    }
    Series mean;
    mean.markersOnly = true;
    mean.rgb = {0.1, 0.1, 0.1};
    mean.markerSize = 9.0;
    mean.x = {x};
    mean.y = {b.mean};
    panel.series.push_back(mean);
    lo = std::min(lo, b.minimum);
    hi = std::max(hi, b.maximum);
    panel.xTicks.emplace_back(x,
                              fmt::format("{} (n={})", groups[g].label, groups[g].values.size()));
  }
  const double pad = std::max(1e-6, 0.08 * (hi - lo));
  panel.yRange = std::array<double, 2>{lo - pad, hi + pad};
  panel.xRange = std::array<double, 2>{0.4, static_cast<double>(groups.size()) + 0.6};
  Scene scene;
  scene.charts = {panel};
  scene.columns = 1;
  scene.chartFontSize = std::max(10, std::min(size.height, size.width) / 50);
  scene.title = plotTitle(title, 0.1, scene.chartFontSize + 3, size);
  return scene;
}

RgbImage renderBoxPlot(const std::vector<BoxGroup>& groups, const std::string& title,
                       const std::string& yLabel, const FigureSize& size) {
  return renderScene(boxPlotScene(groups, title, yLabel, size), size);
}

}  // namespace echoreg::render
