#include "echoreg/render/plot_figure.hpp"

#include "echoreg/core/statistics.hpp"

#include <fmt/format.h>

#include <vtkAxis.h>
#include <vtkBrush.h>
#include <vtkChartLegend.h>
#include <vtkChartXY.h>
#include <vtkContextActor.h>
#include <vtkContextScene.h>
#include <vtkCoordinate.h>
#include <vtkDoubleArray.h>
#include <vtkPen.h>
#include <vtkPlot.h>
#include <vtkPlotLine.h>
#include <vtkPlotPoints.h>
#include <vtkRenderer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace echoreg::render {

namespace {

unsigned char byte(double v) {
  return static_cast<unsigned char>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
}

void checkSeries(const Series& s, const std::string& where) {
  if (s.x.size() != s.y.size()) {
    throw std::invalid_argument(fmt::format("{}: series \"{}\" has {} x but {} y values", where,
                                            s.name, s.x.size(), s.y.size()));
  }
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
      throw std::invalid_argument(
          fmt::format("{}: series \"{}\" value {} is not finite", where, s.name, i));
    }
  }
}

vtkPlot* addSeries(vtkChartXY* chart, const Series& s, int fontSize) {
  vtkNew<vtkTable> table;
  vtkNew<vtkDoubleArray> xs;
  xs->SetName("x");
  vtkNew<vtkDoubleArray> ys;
  ys->SetName(s.name.empty() ? " " : s.name.c_str());
  xs->SetNumberOfValues(static_cast<vtkIdType>(s.x.size()));
  ys->SetNumberOfValues(static_cast<vtkIdType>(s.y.size()));
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    xs->SetValue(static_cast<vtkIdType>(i), s.x[i]);
    ys->SetValue(static_cast<vtkIdType>(i), s.y[i]);
  }
  table->AddColumn(xs);
  table->AddColumn(ys);
  vtkPlot* plot = chart->AddPlot(s.markersOnly ? vtkChart::POINTS : vtkChart::LINE);
  plot->SetInputData(table, 0, 1);
  plot->SetColor(byte(s.rgb[0]), byte(s.rgb[1]), byte(s.rgb[2]), 255);
  plot->SetWidth(static_cast<float>(s.lineWidth));
  plot->SetLabel(s.name);
  plot->SetLegendVisibility(!s.name.empty());
  if (auto* points = vtkPlotPoints::SafeDownCast(plot)) {
    points->SetMarkerStyle(s.markersOnly ? vtkPlotPoints::CIRCLE : vtkPlotPoints::NONE);
    points->SetMarkerSize(static_cast<float>(s.markerSize));
  }
  (void)fontSize;
  return plot;
}

void styleAxis(vtkAxis* axis, const std::string& title, int fontSize) {
  axis->SetTitle(title);
  axis->GetTitleProperties()->SetFontSize(fontSize);
  axis->GetTitleProperties()->SetFontFamilyToArial();
  axis->GetTitleProperties()->SetColor(0.1, 0.1, 0.1);
  axis->GetLabelProperties()->SetFontSize(fontSize - 2);
  axis->GetLabelProperties()->SetFontFamilyToArial();
  axis->GetLabelProperties()->SetColor(0.1, 0.1, 0.1);
  axis->GetGridPen()->SetColor(225, 225, 225, 255);
}

// A chart in a renderer covering `viewport`.
vtkChartXY* addChart(OffscreenWindow& window, const double viewport[4], const std::string& title,
                     int fontSize, vtkRenderer** rendererOut = nullptr) {
  vtkRenderer* renderer = window.addRenderer(viewport[0], viewport[1], viewport[2], viewport[3]);
  renderer->SetBackground(1, 1, 1);
  vtkNew<vtkContextActor> actor;
  vtkNew<vtkChartXY> chart;
  chart->SetTitle(title);
  chart->GetTitleProperties()->SetFontSize(fontSize + 1);
  chart->GetTitleProperties()->SetFontFamilyToArial();
  chart->GetTitleProperties()->SetBold(true);
  chart->GetTitleProperties()->SetColor(0.05, 0.05, 0.05);
  actor->GetScene()->AddItem(chart);
  renderer->AddActor(actor);
  if (rendererOut != nullptr)
    *rendererOut = renderer;
  return chart;  // owned by the scene, which the actor (owned by the renderer) holds
}

void addTitle(OffscreenWindow& window, const std::string& title, double height, int fontSize) {
  if (title.empty())
    return;
  vtkRenderer* header = window.addRenderer(0.0, 1.0 - height, 1.0, 1.0);
  header->SetBackground(1, 1, 1);
  vtkNew<vtkTextActor> text;
  text->SetInput(title.c_str());
  text->GetTextProperty()->SetFontSize(fontSize);
  text->GetTextProperty()->SetBold(true);
  text->GetTextProperty()->SetFontFamilyToArial();
  text->GetTextProperty()->SetColor(0.05, 0.05, 0.05);
  text->SetPosition(20, 0.25 * height * window.height());
  header->AddViewProp(text);
}

}  // namespace

RgbImage renderPlots(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                     const FigureSize& size) {
  if (panels.empty())
    throw std::invalid_argument("plot figure: no panel");
  if (columns < 1)
    throw std::invalid_argument("plot figure: columns < 1");
  for (std::size_t p = 0; p < panels.size(); ++p) {
    for (const Series& s : panels[p].series)
      checkSeries(s, fmt::format("panel {}", p + 1));
  }
  OffscreenWindow window(size.width, size.height);
  const int fontSize = std::max(10, std::min(size.height, size.width) / 55);
  const double titleHeight = title.empty() ? 0.0 : std::min(0.08, 50.0 / size.height);
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    const int row = static_cast<int>(p) / columns;
    const int col = static_cast<int>(p) % columns;
    const double h = (1.0 - titleHeight) / rows;
    const double viewport[4] = {
        static_cast<double>(col) / columns, 1.0 - titleHeight - (row + 1) * h,
        static_cast<double>(col + 1) / columns, 1.0 - titleHeight - row * h};
    const PlotPanel& panel = panels[p];
    vtkRenderer* renderer = nullptr;
    vtkChartXY* chart = addChart(window, viewport, panel.title, fontSize, &renderer);
    double xmin = std::numeric_limits<double>::infinity();
    double xmax = -xmin;
    for (const Series& s : panel.series) {
      addSeries(chart, s, fontSize);
      for (double x : s.x) {
        xmin = std::min(xmin, x);
        xmax = std::max(xmax, x);
      }
    }
    if (panel.xRange) {
      xmin = (*panel.xRange)[0];
      xmax = (*panel.xRange)[1];
    }
    for (const auto& [name, value] : panel.horizontalLines) {
      if (!std::isfinite(xmin))
        break;
      Series line;
      line.name = name;
      line.x = {xmin, xmax};
      line.y = {value, value};
      line.rgb = {0.45, 0.45, 0.45};
      line.lineWidth = 1.0;
      vtkPlot* plot = addSeries(chart, line, fontSize);
      plot->GetPen()->SetLineType(vtkPen::DASH_LINE);
    }
    styleAxis(chart->GetAxis(vtkAxis::BOTTOM), panel.xLabel, fontSize);
    styleAxis(chart->GetAxis(vtkAxis::LEFT), panel.yLabel, fontSize);
    if (panel.xRange) {
      chart->GetAxis(vtkAxis::BOTTOM)->SetBehavior(vtkAxis::FIXED);
      chart->GetAxis(vtkAxis::BOTTOM)->SetRange((*panel.xRange)[0], (*panel.xRange)[1]);
    }
    if (panel.yRange) {
      chart->GetAxis(vtkAxis::LEFT)->SetBehavior(vtkAxis::FIXED);
      chart->GetAxis(vtkAxis::LEFT)->SetRange((*panel.yRange)[0], (*panel.yRange)[1]);
    }
    chart->SetShowLegend(true);
    chart->GetLegend()->GetLabelProperties()->SetFontSize(fontSize - 2);
    chart->GetLegend()->GetLabelProperties()->SetFontFamilyToArial();
    chart->GetLegend()->SetHorizontalAlignment(vtkChartLegend::RIGHT);
    chart->GetLegend()->SetVerticalAlignment(vtkChartLegend::TOP);
    if (!panel.note.empty()) {
      vtkNew<vtkTextActor> note;
      note->SetInput(panel.note.c_str());
      note->GetTextProperty()->SetFontSize(fontSize);
      note->GetTextProperty()->SetBold(true);
      note->GetTextProperty()->SetFontFamilyToArial();
      note->GetTextProperty()->SetColor(panel.noteRgb[0], panel.noteRgb[1], panel.noteRgb[2]);
      note->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
      note->SetPosition(0.12, 0.80);
      renderer->AddViewProp(note);
    }
  }
  addTitle(window, title, titleHeight, fontSize + 3);
  return window.capture();
}

RgbImage renderBoxPlot(const std::vector<BoxGroup>& groups, const std::string& title,
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
  }
  const double pad = std::max(1e-6, 0.08 * (hi - lo));
  panel.yRange = std::array<double, 2>{lo - pad, hi + pad};
  panel.xRange = std::array<double, 2>{0.4, static_cast<double>(groups.size()) + 0.6};
  // The chart is built here (not by renderPlots) to label the groups under their boxes.
  OffscreenWindow window(size.width, size.height);
  const int fontSize = std::max(10, std::min(size.height, size.width) / 50);
  const double titleHeight = title.empty() ? 0.0 : std::min(0.1, 50.0 / size.height);
  const double viewport[4] = {0.0, 0.0, 1.0, 1.0 - titleHeight};
  vtkChartXY* chart = addChart(window, viewport, panel.title, fontSize);
  for (const Series& s : panel.series) {
    vtkPlot* plot = addSeries(chart, s, fontSize);
    plot->SetLegendVisibility(false);
  }
  styleAxis(chart->GetAxis(vtkAxis::LEFT), yLabel, fontSize);
  styleAxis(chart->GetAxis(vtkAxis::BOTTOM), "", fontSize);
  chart->GetAxis(vtkAxis::LEFT)->SetBehavior(vtkAxis::FIXED);
  chart->GetAxis(vtkAxis::LEFT)->SetRange((*panel.yRange)[0], (*panel.yRange)[1]);
  vtkAxis* bottom = chart->GetAxis(vtkAxis::BOTTOM);
  bottom->SetBehavior(vtkAxis::FIXED);
  bottom->SetRange((*panel.xRange)[0], (*panel.xRange)[1]);
  vtkNew<vtkDoubleArray> ticks;
  vtkNew<vtkStringArray> labels;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    ticks->InsertNextValue(static_cast<double>(g + 1));
    labels->InsertNextValue(fmt::format("{} (n={})", groups[g].label, groups[g].values.size()));
  }
  bottom->SetCustomTickPositions(ticks, labels);
  bottom->SetGridVisible(false);
  chart->SetShowLegend(false);
  addTitle(window, title, titleHeight, fontSize + 3);
  return window.capture();
}

}  // namespace echoreg::render
