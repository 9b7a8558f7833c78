#include "echoreg/render/surface_figure.hpp"

#include <fmt/format.h>

#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkGlyph3DMapper.h>
#include <vtkLegendBoxActor.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkProperty2D.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace echoreg::render {

std::vector<ColourBand> registrationBands(double greenBelowMm, double redAboveMm) {
  if (!(greenBelowMm > 0.0) || !(redAboveMm > greenBelowMm)) {
    throw std::invalid_argument("colour bands: need 0 < green limit < red limit");
  }
  return {{greenBelowMm, {0.10, 0.70, 0.20}, fmt::format("< {:g} mm", greenBelowMm)},
          {redAboveMm, {0.95, 0.80, 0.10}, fmt::format("{:g}-{:g} mm", greenBelowMm, redAboveMm)},
          {std::numeric_limits<double>::infinity(),
           {0.85, 0.10, 0.10},
           fmt::format("> {:g} mm", redAboveMm)}};
}

std::vector<ColourBand> calibrationBands(double greenBelowMm, double redAboveMm) {
  return registrationBands(greenBelowMm, redAboveMm);
}

int bandOf(const std::vector<ColourBand>& bands, double valueMm) {
  const double v = std::abs(valueMm);
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (v < bands[i].upToMm || i + 1 == bands.size())
      return static_cast<int>(i);
  }
  return static_cast<int>(bands.size()) - 1;
}

const char* viewName(View view) {
  switch (view) {
    case View::Coronal:
      return "coronal (from anterior)";
    case View::Sagittal:
      return "sagittal (from the right)";
    case View::Transverse:
      return "transverse (from superior)";
  }
  return "";
}

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

std::array<unsigned char, 3> toBytes(const std::array<double, 3>& rgb) {
  std::array<unsigned char, 3> out{};
  for (int i = 0; i < 3; ++i) {
    out[static_cast<std::size_t>(i)] = static_cast<unsigned char>(
        std::lround(255.0 * std::clamp(rgb[static_cast<std::size_t>(i)], 0.0, 1.0)));
  }
  return out;
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

}  // namespace

std::vector<std::string> surfaceFigureLegend(const SurfaceFigure& figure) {
  std::vector<std::string> entries;
  if (figure.points.empty()) {
    for (const ColourBand& band : figure.bands)
      entries.push_back(band.label);
    return entries;
  }
  std::vector<int> perBand(figure.bands.size(), 0);
  for (double value : figure.valuesMm)
    ++perBand[static_cast<std::size_t>(bandOf(figure.bands, value))];
  for (std::size_t b = 0; b < figure.bands.size(); ++b) {
    entries.push_back(fmt::format("{}: {} point{}", figure.bands[b].label, perBand[b],
                                  perBand[b] == 1 ? "" : "s"));
  }
  if (!figure.valueName.empty())
    entries.push_back(fmt::format("colour: {}", figure.valueName));
  return entries;
}

RgbImage renderSurfaceFigure(const SurfaceFigure& figure, const FigureSize& size) {
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

  // The surface drawn: all of it, or the part near the points.
  core::TriangleMesh shown = figure.surface;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : figure.points) {
    lo = lo.cwiseMin(p - Eigen::Vector3d::Constant(figure.pointRadiusMm));
    hi = hi.cwiseMax(p + Eigen::Vector3d::Constant(figure.pointRadiusMm));
  }
  const bool crop = figure.cropMarginMm > 0.0 && !figure.points.empty();
  const Eigen::Vector3d boxLo = lo - Eigen::Vector3d::Constant(figure.cropMarginMm);
  const Eigen::Vector3d boxHi = hi + Eigen::Vector3d::Constant(figure.cropMarginMm);
  // The triangles of `mesh` inside the crop box (all of them without cropping).
  const auto cropped = [&](const core::TriangleMesh& mesh) {
    core::TriangleMesh out = mesh;
    if (!crop)
      return out;
    out.triangles.clear();
    for (const auto& t : mesh.triangles) {
      bool inside = true;
      for (int c = 0; c < 3 && inside; ++c) {
        const Eigen::Vector3d& v =
            mesh.vertices[static_cast<std::size_t>(t[static_cast<std::size_t>(c)])];
        inside = (v.array() >= boxLo.array()).all() && (v.array() <= boxHi.array()).all();
      }
      if (inside)
        out.triangles.push_back(t);
    }
    return out;
  };
  shown = cropped(figure.surface);
  std::vector<vtkSmartPointer<vtkPolyData>> contextData;
  for (const core::TriangleMesh& mesh : figure.context) {
    const core::TriangleMesh part = cropped(mesh);
    if (!part.triangles.empty())
      contextData.push_back(toPolyData(part));
  }
  for (const auto& t : shown.triangles) {
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d& v =
          shown.vertices[static_cast<std::size_t>(t[static_cast<std::size_t>(c)])];
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1.0);

  vtkSmartPointer<vtkPolyData> surface;
  vtkNew<vtkPolyDataNormals> normals;
  if (!shown.triangles.empty()) {
    surface = toPolyData(shown);
    normals->SetInputData(surface);
    normals->SetFeatureAngle(60.0);
    normals->SplittingOff();
    normals->ConsistencyOff();
    normals->Update();
  }

  vtkNew<vtkPolyData> glyphPoints;
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToDouble();
  vtkNew<vtkUnsignedCharArray> colours;
  colours->SetNumberOfComponents(3);
  colours->SetName("colour");
  for (std::size_t i = 0; i < figure.points.size(); ++i) {
    pts->InsertNextPoint(figure.points[i].data());
    const int band = bandOf(figure.bands, figure.valuesMm[i]);
    const auto c = toBytes(figure.bands[static_cast<std::size_t>(band)].rgb);
    colours->InsertNextTypedTuple(c.data());
  }
  glyphPoints->SetPoints(pts);
  glyphPoints->GetPointData()->SetScalars(colours);
  vtkNew<vtkSphereSource> sphere;
  sphere->SetRadius(figure.pointRadiusMm);
  sphere->SetThetaResolution(16);
  sphere->SetPhiResolution(12);

  OffscreenWindow window(size.width, size.height);
  const double legendHeight = std::clamp(110.0 / size.height, 0.08, 0.25);
  const double titleHeight = figure.title.empty() ? 0.0 : 0.08;
  const int panels = static_cast<int>(figure.views.size());
  for (int v = 0; v < panels; ++v) {
    vtkRenderer* renderer =
        window.addRenderer(static_cast<double>(v) / panels, legendHeight,
                           static_cast<double>(v + 1) / panels, 1.0 - titleHeight);
    renderer->SetBackground(1, 1, 1);
    if (surface) {
      vtkNew<vtkPolyDataMapper> mapper;
      mapper->SetInputConnection(normals->GetOutputPort());
      mapper->ScalarVisibilityOff();
      vtkNew<vtkActor> actor;
      actor->SetMapper(mapper);
      actor->GetProperty()->SetColor(figure.surfaceRgb[0], figure.surfaceRgb[1],
                                     figure.surfaceRgb[2]);
      actor->GetProperty()->SetSpecular(0.15);
      renderer->AddActor(actor);
    }
    for (const auto& data : contextData) {
      vtkNew<vtkPolyDataMapper> mapper;
      mapper->SetInputData(data);
      mapper->ScalarVisibilityOff();
      vtkNew<vtkActor> actor;
      actor->SetMapper(mapper);
      actor->GetProperty()->SetColor(0.62, 0.70, 0.85);
      actor->GetProperty()->SetOpacity(0.35);
      renderer->AddActor(actor);
    }
    if (!figure.points.empty()) {
      vtkNew<vtkGlyph3DMapper> mapper;
      mapper->SetInputData(glyphPoints);
      mapper->SetSourceConnection(sphere->GetOutputPort());
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
    viewAxes(figure.views[static_cast<std::size_t>(v)], towards, up);
    vtkCamera* camera = renderer->GetActiveCamera();
    camera->ParallelProjectionOn();
    const Eigen::Vector3d position = centre + towards * (2.0 * extent.norm() + 100.0);
    camera->SetFocalPoint(centre.data());
    camera->SetPosition(position.data());
    camera->SetViewUp(up.data());
    // Fit: half the visible height is the larger of the vertical extent and the horizontal one
    // scaled by the panel's aspect.
    const Eigen::Vector3d right = up.cross(towards);
    const double w = extent.cwiseProduct(right.cwiseAbs()).sum();
    const double h = (extent.cwiseProduct(up.cwiseAbs())).sum();
    const double aspect = (static_cast<double>(size.width) / panels) /
                          (size.height * (1.0 - legendHeight - titleHeight));
    camera->SetParallelScale(0.55 * std::max(h, w / aspect));
    renderer->ResetCameraClippingRange();

    vtkNew<vtkTextActor> label;
    label->SetInput(static_cast<std::size_t>(v) < figure.viewLabels.size()
                        ? figure.viewLabels[static_cast<std::size_t>(v)].c_str()
                        : viewName(figure.views[static_cast<std::size_t>(v)]));
    label->GetTextProperty()->SetFontSize(std::max(12, size.height / 32));
    label->GetTextProperty()->SetColor(0.1, 0.1, 0.1);
    label->GetTextProperty()->SetFontFamilyToArial();
    label->SetPosition(8, 8);
    renderer->AddViewProp(label);
  }

  // Title and legend.
  const std::vector<std::string> legend = surfaceFigureLegend(figure);
  vtkRenderer* footer = window.addRenderer(0.0, 0.0, 1.0, legendHeight);
  footer->SetBackground(1, 1, 1);
  const int fontSize = std::max(11, std::min(size.height / 30, size.width / 60));
  const double footerPx = size.height * legendHeight;
  // One row when the bands fit side by side, else one row per band.
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
  for (std::size_t b = 0; b < figure.bands.size(); ++b) {
    vtkNew<vtkTextActor> swatch;
    swatch->SetInput("  ");
    swatch->GetTextProperty()->SetBackgroundColor(figure.bands[b].rgb[0], figure.bands[b].rgb[1],
                                                  figure.bands[b].rgb[2]);
    swatch->GetTextProperty()->SetBackgroundOpacity(1.0);
    swatch->GetTextProperty()->SetFontSize(fontSize);
    const auto at = place(b, 0.0);
    swatch->SetPosition(at[0], at[1]);
    footer->AddViewProp(swatch);
    vtkNew<vtkTextActor> text;
    text->SetInput(legend[b].c_str());
    text->GetTextProperty()->SetFontSize(fontSize);
    text->GetTextProperty()->SetColor(0.1, 0.1, 0.1);
    text->GetTextProperty()->SetFontFamilyToArial();
    const auto textAt = place(b, 2.2 * fontSize);
    text->SetPosition(textAt[0], textAt[1]);
    footer->AddViewProp(text);
  }
  if (legend.size() > figure.bands.size()) {
    vtkNew<vtkTextActor> valueName;
    valueName->SetInput(legend.back().c_str());
    valueName->GetTextProperty()->SetFontSize(fontSize);
    valueName->GetTextProperty()->SetColor(0.3, 0.3, 0.3);
    valueName->GetTextProperty()->SetFontFamilyToArial();
    const auto nameAt = place(figure.bands.size(), 0.0);
    valueName->SetPosition(nameAt[0], nameAt[1]);
    footer->AddViewProp(valueName);
  }
  if (!figure.title.empty()) {
    vtkRenderer* header = window.addRenderer(0.0, 1.0 - titleHeight, 1.0, 1.0);
    header->SetBackground(1, 1, 1);
    vtkNew<vtkTextActor> title;
    title->SetInput(figure.title.c_str());
    title->GetTextProperty()->SetFontSize(std::max(14, size.height / 24));
    title->GetTextProperty()->SetBold(true);
    title->GetTextProperty()->SetColor(0.05, 0.05, 0.05);
    title->GetTextProperty()->SetFontFamilyToArial();
    title->SetPosition(20, 0.2 * size.height * titleHeight);
    header->AddViewProp(title);
  }
  return window.capture();
}

}  // namespace echoreg::render
