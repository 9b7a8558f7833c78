#include "draw_scene.hpp"

#include "echoreg/render/offscreen.hpp"
#include "scene_checks.hpp"

#include <fmt/format.h>

#include <vtkActor.h>
#include <vtkAxis.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkChartLegend.h>
#include <vtkChartXY.h>
#include <vtkContextActor.h>
#include <vtkContextScene.h>
#include <vtkCoordinate.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkGlyph3DMapper.h>
#include <vtkIdList.h>
#include <vtkPen.h>
#include <vtkPlot.h>
#include <vtkPlotPoints.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace echoreg::render {

namespace {

std::array<unsigned char, 3> toBytes(const std::array<double, 3>& rgb) {
  std::array<unsigned char, 3> out{};
  for (int i = 0; i < 3; ++i) {
    out[static_cast<std::size_t>(i)] = static_cast<unsigned char>(
        std::lround(255.0 * std::clamp(rgb[static_cast<std::size_t>(i)], 0.0, 1.0)));
  }
  return out;
}

unsigned char byte(double v) {
  return static_cast<unsigned char>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
}

// Camera position direction (from the focal point towards the camera) and view-up, LPS.
void viewAxes(View view, Eigen::Vector3d& towardsCamera, Eigen::Vector3d& up) {
  switch (view) {
    case View::Coronal:
      towardsCamera = {0, -1, 0};
      up = {0, 0, 1};
      return;
    case View::Sagittal:
      towardsCamera = {-1, 0, 0};
      up = {0, 0, 1};
      return;
    case View::Transverse:
      towardsCamera = {0, 0, 1};
      up = {0, -1, 0};
      return;
  }
}

// The polygons of `surface` whose points all lie in [lo, hi] (all of them when `crop` is off),
// sharing the surface's points.
vtkSmartPointer<vtkPolyData> croppedPolygons(vtkPolyData* surface, bool crop,
                                             const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  auto out = vtkSmartPointer<vtkPolyData>::New();
  out->SetPoints(surface->GetPoints());
  vtkNew<vtkCellArray> cells;
  vtkCellArray* polys = surface->GetPolys();
  vtkNew<vtkIdList> ids;
  for (polys->InitTraversal(); polys->GetNextCell(ids) != 0;) {
    bool inside = true;
    for (vtkIdType c = 0; c < ids->GetNumberOfIds() && crop && inside; ++c) {
      Eigen::Vector3d v;
      surface->GetPoint(ids->GetId(c), v.data());
      inside = (v.array() >= lo.array()).all() && (v.array() <= hi.array()).all();
    }
    if (inside)
      cells->InsertNextCell(ids);
  }
  out->SetPolys(cells);
  return out;
}

vtkPlot* addSeries(vtkChartXY* chart, const Series& s) {
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

// A chart panel in `renderer`.
void drawChart(vtkRenderer* renderer, const PlotPanel& panel, int fontSize) {
  vtkNew<vtkContextActor> actor;
  vtkNew<vtkChartXY> chart;
  chart->SetTitle(panel.title);
  chart->GetTitleProperties()->SetFontSize(fontSize + 1);
  chart->GetTitleProperties()->SetFontFamilyToArial();
  chart->GetTitleProperties()->SetBold(true);
  chart->GetTitleProperties()->SetColor(0.05, 0.05, 0.05);
  actor->GetScene()->AddItem(chart);
  renderer->AddActor(actor);
  double xmin = std::numeric_limits<double>::infinity();
  double xmax = -xmin;
  for (const Series& s : panel.series) {
    addSeries(chart, s);
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
    vtkPlot* plot = addSeries(chart, line);
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
  if (!panel.xTicks.empty()) {
    vtkNew<vtkDoubleArray> ticks;
    vtkNew<vtkStringArray> labels;
    for (const auto& [at, label] : panel.xTicks) {
      ticks->InsertNextValue(at);
      labels->InsertNextValue(label);
    }
    chart->GetAxis(vtkAxis::BOTTOM)->SetCustomTickPositions(ticks, labels);
    chart->GetAxis(vtkAxis::BOTTOM)->SetGridVisible(false);
  }
  chart->SetShowLegend(panel.showLegend);
  if (panel.showLegend) {
    chart->GetLegend()->GetLabelProperties()->SetFontSize(fontSize - 2);
    chart->GetLegend()->GetLabelProperties()->SetFontFamilyToArial();
    chart->GetLegend()->SetHorizontalAlignment(vtkChartLegend::RIGHT);
    chart->GetLegend()->SetVerticalAlignment(vtkChartLegend::TOP);
  }
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

// The 3D content of the scene, built once and shared by every view panel.
struct Content {
  struct Model {
    const SceneModel* model = nullptr;
    vtkSmartPointer<vtkPolyData> data;  // cropped
    vtkSmartPointer<vtkPolyDataNormals> normals;
  };
  std::vector<Model> models;
  std::vector<vtkSmartPointer<vtkPolyData>> glyphPoints;
  std::vector<vtkSmartPointer<vtkSphereSource>> spheres;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent = Eigen::Vector3d::Ones();
};

Content buildContent(const Scene& scene) {
  Content content;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  std::vector<detail::CheckedPoints> sets;
  bool anyPoint = false;
  for (const ScenePoints& set : scene.pointSets) {
    sets.push_back(detail::checkedPoints(set));
    for (const auto& p : sets.back().points) {
      lo = lo.cwiseMin(p - Eigen::Vector3d::Constant(set.radiusMm));
      hi = hi.cwiseMax(p + Eigen::Vector3d::Constant(set.radiusMm));
      anyPoint = true;
    }
  }
  const bool crop = scene.cropMarginMm > 0.0 && anyPoint;
  const Eigen::Vector3d boxLo = lo - Eigen::Vector3d::Constant(scene.cropMarginMm);
  const Eigen::Vector3d boxHi = hi + Eigen::Vector3d::Constant(scene.cropMarginMm);
  bool anySurface = false;
  for (const SceneModel& model : scene.models) {
    if (!model.surface || model.surface->GetNumberOfPolys() == 0)
      continue;
    Content::Model shown;
    shown.model = &model;
    shown.data = croppedPolygons(model.surface, crop, boxLo, boxHi);
    if (shown.data->GetNumberOfPolys() == 0)
      continue;
    anySurface = true;
    if (model.framesViews) {
      vtkCellArray* polys = shown.data->GetPolys();
      vtkNew<vtkIdList> ids;
      for (polys->InitTraversal(); polys->GetNextCell(ids) != 0;) {
        for (vtkIdType c = 0; c < ids->GetNumberOfIds(); ++c) {
          Eigen::Vector3d v;
          shown.data->GetPoint(ids->GetId(c), v.data());
          lo = lo.cwiseMin(v);
          hi = hi.cwiseMax(v);
        }
      }
    }
    if (model.smoothNormals) {
      shown.normals = vtkSmartPointer<vtkPolyDataNormals>::New();
      shown.normals->SetInputData(shown.data);
      shown.normals->SetFeatureAngle(60.0);
      shown.normals->SplittingOff();
      shown.normals->ConsistencyOff();
      shown.normals->Update();
    }
    content.models.push_back(shown);
  }
  if (!anySurface && !anyPoint)
    throw std::invalid_argument("scene: nothing to draw in its views (no surface, no points)");
  if (!std::isfinite(lo.x()))
    throw std::invalid_argument("scene: nothing frames its views (context models only)");
  content.centre = 0.5 * (lo + hi);
  content.extent = (hi - lo).cwiseMax(1.0);

  for (std::size_t s = 0; s < sets.size(); ++s) {
    const ScenePoints& set = scene.pointSets[s];
    auto glyphPoints = vtkSmartPointer<vtkPolyData>::New();
    vtkNew<vtkPoints> pts;
    pts->SetDataTypeToDouble();
    vtkNew<vtkUnsignedCharArray> colours;
    colours->SetNumberOfComponents(3);
    colours->SetName("colour");
    for (std::size_t i = 0; i < sets[s].points.size(); ++i) {
      pts->InsertNextPoint(sets[s].points[i].data());
      const int band = bandOf(set.colourMap, sets[s].values[i]);
      const auto c = toBytes(set.colourMap[static_cast<std::size_t>(band)].rgb);
      colours->InsertNextTypedTuple(c.data());
    }
    glyphPoints->SetPoints(pts);
    glyphPoints->GetPointData()->SetScalars(colours);
    auto sphere = vtkSmartPointer<vtkSphereSource>::New();
    sphere->SetRadius(set.radiusMm);
    sphere->SetThetaResolution(16);
    sphere->SetPhiResolution(12);
    content.glyphPoints.push_back(glyphPoints);
    content.spheres.push_back(sphere);
  }
  return content;
}

void drawView(vtkRenderer* renderer, const Content& content, const SceneView& view,
              double panelAspect, int labelFontSize) {
  for (const Content::Model& shown : content.models) {
    vtkNew<vtkPolyDataMapper> mapper;
    if (shown.normals)
      mapper->SetInputConnection(shown.normals->GetOutputPort());
    else
      mapper->SetInputData(shown.data);
    mapper->ScalarVisibilityOff();
    vtkNew<vtkActor> actor;
    actor->SetMapper(mapper);
    const SceneModel& model = *shown.model;
    actor->GetProperty()->SetColor(model.rgb[0], model.rgb[1], model.rgb[2]);
    if (model.specular > 0.0)
      actor->GetProperty()->SetSpecular(model.specular);
    if (model.opacity < 1.0)
      actor->GetProperty()->SetOpacity(model.opacity);
    renderer->AddActor(actor);
  }
  for (std::size_t s = 0; s < content.glyphPoints.size(); ++s) {
    if (content.glyphPoints[s]->GetNumberOfPoints() == 0)
      continue;
    vtkNew<vtkGlyph3DMapper> mapper;
    mapper->SetInputData(content.glyphPoints[s]);
    mapper->SetSourceConnection(content.spheres[s]->GetOutputPort());
    mapper->ScalingOff();
    mapper->OrientOff();
    mapper->SetColorModeToDirectScalars();
    mapper->SetScalarModeToUsePointData();
    vtkNew<vtkActor> actor;
    actor->SetMapper(mapper);
    renderer->AddActor(actor);
  }
  Eigen::Vector3d towards(0, -1, 0);
  Eigen::Vector3d up(0, 0, 1);
  viewAxes(view.view, towards, up);
  vtkCamera* camera = renderer->GetActiveCamera();
  camera->ParallelProjectionOn();
  const Eigen::Vector3d position = content.centre + towards * (2.0 * content.extent.norm() + 100.0);
  camera->SetFocalPoint(content.centre.data());
  camera->SetPosition(position.data());
  camera->SetViewUp(up.data());
  // Fit: half the visible height is the larger of the vertical extent and the horizontal one
  // scaled by the panel's aspect.
  const Eigen::Vector3d right = up.cross(towards);
  const double w = content.extent.cwiseProduct(right.cwiseAbs()).sum();
  const double h = (content.extent.cwiseProduct(up.cwiseAbs())).sum();
  camera->SetParallelScale(0.55 * std::max(h, w / panelAspect));
  renderer->ResetCameraClippingRange();

  vtkNew<vtkTextActor> label;
  label->SetInput(view.label.empty() ? viewName(view.view) : view.label.c_str());
  label->GetTextProperty()->SetFontSize(labelFontSize);
  label->GetTextProperty()->SetColor(0.1, 0.1, 0.1);
  label->GetTextProperty()->SetFontFamilyToArial();
  label->SetPosition(8, 8);
  renderer->AddViewProp(label);
}

void drawLegend(vtkRenderer* footer, const std::vector<LegendEntry>& legend, const FigureSize& size,
                double legendHeight) {
  const int fontSize = std::max(11, std::min(size.height / 30, size.width / 60));
  const double footerPx = size.height * legendHeight;
  // One row when the entries fit side by side, else one row per entry.
  const std::size_t entries = legend.size();
  const bool oneRow = size.width / static_cast<double>(entries) >= 13.0 * fontSize;
  const double step =
      oneRow ? std::min(15.0 * fontSize, (size.width - 40.0) / static_cast<double>(entries)) : 0.0;
  const double rowHeight = oneRow ? 0.0 : (footerPx - 8.0) / static_cast<double>(entries);
  auto place = [&](std::size_t entry, double dx) {
    const double px = 20.0 + (oneRow ? step * static_cast<double>(entry) : 0.0) + dx;
    const double py =
        oneRow ? 0.35 * footerPx : footerPx - 4.0 - rowHeight * static_cast<double>(entry + 1);
    return std::array<double, 2>{px, py};
  };
  for (std::size_t e = 0; e < legend.size(); ++e) {
    const LegendEntry& entry = legend[e];
    double dx = 0.0;
    if (entry.swatch) {
      vtkNew<vtkTextActor> swatch;
      swatch->SetInput("  ");
      swatch->GetTextProperty()->SetBackgroundColor((*entry.swatch)[0], (*entry.swatch)[1],
                                                    (*entry.swatch)[2]);
      swatch->GetTextProperty()->SetBackgroundOpacity(1.0);
      swatch->GetTextProperty()->SetFontSize(fontSize);
      const auto at = place(e, 0.0);
      swatch->SetPosition(at[0], at[1]);
      footer->AddViewProp(swatch);
      dx = 2.2 * fontSize;
    }
    vtkNew<vtkTextActor> text;
    text->SetInput(entry.text.c_str());
    text->GetTextProperty()->SetFontSize(fontSize);
    text->GetTextProperty()->SetColor(entry.textRgb[0], entry.textRgb[1], entry.textRgb[2]);
    text->GetTextProperty()->SetFontFamilyToArial();
    const auto textAt = place(e, dx);
    text->SetPosition(textAt[0], textAt[1]);
    footer->AddViewProp(text);
  }
}

}  // namespace

RgbImage drawScene(const Scene& scene, const FigureSize& size) {
  const std::size_t panelCount = scene.views.size() + scene.charts.size();
  if (panelCount == 0)
    throw std::invalid_argument("scene: no panel (no view, no chart)");
  if (scene.columns < 0)
    throw std::invalid_argument("scene: columns < 0");
  for (std::size_t p = 0; p < scene.charts.size(); ++p) {
    for (const Series& s : scene.charts[p].series)
      detail::checkSeries(s, fmt::format("panel {}", p + 1));
  }
  Content content;
  if (!scene.views.empty())
    content = buildContent(scene);

  OffscreenWindow window(size.width, size.height);
  const double legendHeight =
      scene.legend.empty() ? 0.0 : std::clamp(110.0 / size.height, 0.08, 0.25);
  const double titleHeight = scene.title.text.empty() ? 0.0 : scene.title.heightFraction;
  const int columns = scene.columns > 0 ? scene.columns : static_cast<int>(panelCount);
  const int rows = (static_cast<int>(panelCount) + columns - 1) / columns;
  const double rowHeight = (1.0 - titleHeight - legendHeight) / rows;
  const double panelAspect = (static_cast<double>(size.width) / columns) /
                             (size.height * (1.0 - legendHeight - titleHeight) / rows);
  const int labelFontSize = std::max(12, size.height / 32);
  for (std::size_t p = 0; p < panelCount; ++p) {
    const int row = static_cast<int>(p) / columns;
    const int col = static_cast<int>(p) % columns;
    // The bottom row ends on the legend's band exactly (no rounding of the sum).
    const double ymin = row + 1 == rows && legendHeight > 0.0
                            ? legendHeight
                            : 1.0 - titleHeight - (row + 1) * rowHeight;
    vtkRenderer* renderer = window.addRenderer(static_cast<double>(col) / columns, ymin,
                                               static_cast<double>(col + 1) / columns,
                                               1.0 - titleHeight - row * rowHeight);
    renderer->SetBackground(1, 1, 1);
    if (p < scene.views.size())
      drawView(renderer, content, scene.views[p], panelAspect, labelFontSize);
    else
      drawChart(renderer, scene.charts[p - scene.views.size()], scene.chartFontSize);
  }
  if (!scene.legend.empty()) {
    vtkRenderer* footer = window.addRenderer(0.0, 0.0, 1.0, legendHeight);
    footer->SetBackground(1, 1, 1);
    drawLegend(footer, scene.legend, size, legendHeight);
  }
  if (!scene.title.text.empty()) {
    vtkRenderer* header = window.addRenderer(0.0, 1.0 - titleHeight, 1.0, 1.0);
    header->SetBackground(1, 1, 1);
    vtkNew<vtkTextActor> title;
    title->SetInput(scene.title.text.c_str());
    title->GetTextProperty()->SetFontSize(scene.title.fontSize);
    title->GetTextProperty()->SetBold(true);
    title->GetTextProperty()->SetColor(0.05, 0.05, 0.05);
    title->GetTextProperty()->SetFontFamilyToArial();
    title->SetPosition(20, scene.title.baselinePx);
    header->AddViewProp(title);
  }
  return window.capture();
}

}  // namespace echoreg::render
