#include "echoreg/render/plot_figure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

namespace {

void keep(const echoreg::render::RgbImage& image, const std::string& name) {
  if (const char* dir = std::getenv("ECHOREG_KEEP_FIGURES")) {
    echoreg::render::writePng(std::string(dir) + "/" + name, image);
  }
}

// Counts pixels close to a colour.
int count(const echoreg::render::RgbImage& image, int r, int g, int b, int tolerance = 40) {
  int n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (std::abs(image.at(x, y, 0) - r) < tolerance &&
          std::abs(image.at(x, y, 1) - g) < tolerance &&
          std::abs(image.at(x, y, 2) - b) < tolerance) {
        ++n;
      }
    }
  }
  return n;
}

TEST(PlotFigure, PanelsDrawTheirSeries) {
  echoreg::render::PlotPanel panel;
  panel.title = "raw A-line";
  panel.xLabel = "depth (mm)";
  panel.yLabel = "amplitude";
  echoreg::render::Series line;
  line.name = "envelope";
  line.rgb = {0.0, 0.3, 0.9};
  for (int i = 0; i < 400; ++i) {
    line.x.push_back(i * 0.1);
    line.y.push_back(std::exp(-0.5 * std::pow((i - 200) / 20.0, 2)));
  }
  panel.series.push_back(line);
  echoreg::render::Series peak;
  peak.name = "peak";
  peak.markersOnly = true;
  peak.rgb = {0.9, 0.1, 0.1};
  peak.x = {20.0};
  peak.y = {1.0};
  panel.series.push_back(peak);
  panel.horizontalLines.push_back({"threshold", 0.5});
  panel.note = "accepted: 20.0 mm";
  const auto image = echoreg::render::renderPlots({panel, panel}, 2, "two panels", {800, 400});
  keep(image, "plot_test.png");
  EXPECT_GT(count(image, 0, 77, 230), 100);  // the blue envelope
  EXPECT_GT(count(image, 230, 26, 26), 10);  // the red peak marker
  line.y.pop_back();
  panel.series = {line};
  EXPECT_THROW(echoreg::render::renderPlots({panel}, 1, ""), std::invalid_argument);
  EXPECT_THROW(echoreg::render::renderPlots({}, 1, ""), std::invalid_argument);
}

TEST(PlotFigure, BoxPlotShowsTheGroupsAndTheAnova) {
  const auto image = echoreg::render::renderBoxPlot(
      {{"glove", {0.24, 0.31, 0.18, 0.45, 0.29, 0.33}},
       {"gel", {0.52, 0.61, 0.47, 0.70, 0.39, 0.58, 0.66, 1.9}},
       {"none", {0.30, 0.28, 0.41, 0.36, 0.25}}},
      "knee error by standoff", "error at the knee (mm)", {700, 500});
  keep(image, "boxplot_test.png");
  EXPECT_GT(count(image, 38, 64, 140), 200);  // box outlines
  EXPECT_GT(count(image, 204, 77, 26), 30);   // medians
  EXPECT_THROW(echoreg::render::renderBoxPlot({{"a", {}}}, "", ""), std::invalid_argument);
}

}  // namespace
