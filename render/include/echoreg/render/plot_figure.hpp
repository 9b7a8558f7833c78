// 2D figures: line plots in panels (an A-line and its envelopes under several filter settings,
// with the threshold, the detected peaks and each setting's verdict: Figs. 5.10-5.29), and box
// plots of errors between groups with the one-way ANOVA p-value (Figs. 6.1, 6.3, 6.7-6.9).
// Both are scene descriptions: chart panels of a Scene (scene.hpp), drawn by renderScene.
#pragma once

#include "echoreg/render/image.hpp"
#include "echoreg/render/scene.hpp"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace echoreg::render {

/// Panels in a grid of `columns` columns, filled row by row, with an optional title over all.
/// Throws std::invalid_argument for no panel, a series whose x and y differ in length or hold a
/// value that is not finite, or columns < 1.
Scene plotScene(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                const FigureSize& size = {1200, 900});
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
Scene boxPlotScene(const std::vector<BoxGroup>& groups, const std::string& title,
                   const std::string& yLabel, const FigureSize& size = {900, 650});
RgbImage renderBoxPlot(const std::vector<BoxGroup>& groups, const std::string& title,
                       const std::string& yLabel, const FigureSize& size = {900, 650});

}  // namespace echoreg::render
