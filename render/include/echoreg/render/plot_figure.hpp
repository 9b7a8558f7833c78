// 2D figures: line plots in panels (an A-line and its envelopes under several filter settings,
// with the threshold, the detected peaks and each setting's verdict: Figs. 5.10-5.29), and box
// plots of errors between groups with the one-way ANOVA p-value (Figs. 6.1, 6.3, 6.7-6.9).
// Drawn with VTK's charts in the off-screen window.
#pragma once

#include "echoreg/render/offscreen.hpp"
#include "echoreg/render/surface_figure.hpp"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::render {

struct Series {
  std::string name;  ///< shown in the panel's legend when not empty
  std::vector<double> x;
  std::vector<double> y;
  std::array<double, 3> rgb{0.1, 0.1, 0.1};
  double lineWidth = 1.5;
  bool markersOnly = false;  ///< points (e.g. detected peaks) instead of a line
  double markerSize = 8.0;
};

struct PlotPanel {
  std::string title;
  std::string xLabel;
  std::string yLabel;
  std::vector<Series> series;
  /// Horizontal dashed lines (e.g. the detection threshold), with their legend names.
  std::vector<std::pair<std::string, double>> horizontalLines;
  std::optional<std::array<double, 2>> xRange;  ///< fixed axis range, else fitted
  std::optional<std::array<double, 2>> yRange;
  std::string note;  ///< a line of text inside the panel (e.g. "accepted: 21.4 mm")
  std::array<double, 3> noteRgb{0.1, 0.1, 0.1};
};

/// Panels in a grid of `columns` columns, filled row by row, with an optional title over all.
/// Throws std::invalid_argument for no panel, a series whose x and y differ in length or hold a
/// value that is not finite, or columns < 1.
RgbImage renderPlots(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                     const FigureSize& size = {1200, 900});

struct BoxGroup {
  std::string label;
  std::vector<double> values;
};

/// Box plots of the groups side by side (Tukey whiskers, outliers as points, the mean as a
/// cross), with the one-way ANOVA over the groups in the title line ("one-way ANOVA: F(2, 27) =
/// 3.41, p = 0.048"). Throws std::invalid_argument for fewer than one group or an empty group;
/// the ANOVA line is left out (and says why) when it is undefined.
RgbImage renderBoxPlot(const std::vector<BoxGroup>& groups, const std::string& title,
                       const std::string& yLabel, const FigureSize& size = {900, 650});

}  // namespace echoreg::render
