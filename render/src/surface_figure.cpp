#include "echoreg/render/surface_figure.hpp"

#include <fmt/format.h>

#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace echoreg::render {

namespace {

vtkSmartPointer<vtkPolyData> toPolyData(const core::TriangleMesh& mesh) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    points->SetPoint(static_cast<vtkIdType>(i), mesh.vertices[i].data());
  }
  vtkNew<vtkCellArray> cells;
  for (const auto& t : mesh.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    cells->InsertNextCell(3, ids);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(cells);
  return poly;
}

// The figure's points with their values as a "DistanceMm" point-data array.
ScenePoints scenePoints(const SurfaceFigure& figure) {
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkDoubleArray> values;
  values->SetName("DistanceMm");
  for (std::size_t i = 0; i < figure.points.size(); ++i) {
    points->InsertNextPoint(figure.points[i].data());
    values->InsertNextValue(figure.valuesMm[i]);
  }
  poly->SetPoints(points);
  poly->GetPointData()->AddArray(values);
  ScenePoints set;
  set.points = poly;
  set.scalarName = "DistanceMm";
  set.colourMap = figure.bands;
  set.radiusMm = figure.pointRadiusMm;
  return set;
}

void checkFigure(const SurfaceFigure& figure) {
  if (figure.points.size() != figure.valuesMm.size()) {
    throw std::invalid_argument(fmt::format("surface figure: {} points but {} values",
                                            figure.points.size(), figure.valuesMm.size()));
  }
  if (figure.bands.empty())
    throw std::invalid_argument("surface figure: no colour bands");
  if (figure.surface.triangles.empty() && figure.points.empty()) {
    throw std::invalid_argument("surface figure: nothing to draw (no surface, no points)");
  }
  if (figure.views.empty())
    throw std::invalid_argument("surface figure: no view");
  for (std::size_t i = 0; i < figure.valuesMm.size(); ++i) {
    if (!std::isfinite(figure.valuesMm[i]) || !figure.points[i].allFinite()) {
      throw std::invalid_argument(fmt::format("surface figure: point {} is not finite", i));
    }
  }
}

}  // namespace

std::vector<std::string> surfaceFigureLegend(const SurfaceFigure& figure) {
  if (figure.points.size() != figure.valuesMm.size()) {
    throw std::invalid_argument(fmt::format("surface figure: {} points but {} values",
                                            figure.points.size(), figure.valuesMm.size()));
  }
  std::vector<std::string> entries;
  for (const LegendEntry& entry : pointsLegend(scenePoints(figure), figure.valueName))
    entries.push_back(entry.text);
  return entries;
}

Scene surfaceScene(const SurfaceFigure& figure, const FigureSize& size) {
  checkFigure(figure);
  Scene scene;
  SceneModel subject;
  subject.surface = toPolyData(figure.surface);
  subject.rgb = figure.surfaceRgb;
  scene.models.push_back(subject);
  for (const core::TriangleMesh& mesh : figure.context)
    scene.models.push_back(contextModel(toPolyData(mesh)));
  scene.pointSets.push_back(scenePoints(figure));
  scene.cropMarginMm = figure.cropMarginMm;
  for (std::size_t v = 0; v < figure.views.size(); ++v) {
    scene.views.push_back(
        {figure.views[v], v < figure.viewLabels.size() ? figure.viewLabels[v] : std::string()});
  }
  scene.legend = pointsLegend(scene.pointSets.front(), figure.valueName);
  if (!figure.title.empty()) {
    scene.title.text = figure.title;
    scene.title.heightFraction = 0.08;
    scene.title.fontSize = std::max(14, size.height / 24);
    scene.title.baselinePx = 0.2 * size.height * scene.title.heightFraction;
  }
  return scene;
}

RgbImage renderSurfaceFigure(const SurfaceFigure& figure, const FigureSize& size) {
  return renderScene(surfaceScene(figure, size), size);
}

}  // namespace echoreg::render
