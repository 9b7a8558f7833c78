#include "echoreg/render/scene.hpp"

#include "scene_checks.hpp"

#include <fmt/format.h>

#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>

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

SceneModel contextModel(vtkSmartPointer<vtkPolyData> surface) {
  SceneModel model;
  model.surface = std::move(surface);
  model.rgb = {0.62, 0.70, 0.85};
  model.opacity = 0.35;
  model.specular = 0.0;
  model.smoothNormals = false;
  model.framesViews = false;
  return model;
}

namespace detail {

CheckedPoints checkedPoints(const ScenePoints& set) {
  CheckedPoints out;
  if (set.colourMap.empty())
    throw std::invalid_argument("scene: a point set has no colour map");
  if (!set.points || set.points->GetNumberOfPoints() == 0)
    return out;
  vtkDataArray* array = set.points->GetPointData()->GetArray(set.scalarName.c_str());
  if (array == nullptr || array->GetNumberOfComponents() != 1) {
    throw std::invalid_argument(
        fmt::format("scene: the points have no one-component array \"{}\"", set.scalarName));
  }
  const vtkIdType n = set.points->GetNumberOfPoints();
  if (array->GetNumberOfTuples() != n) {
    throw std::invalid_argument(fmt::format("scene: {} points but {} values in \"{}\"", n,
                                            array->GetNumberOfTuples(), set.scalarName));
  }
  for (vtkIdType i = 0; i < n; ++i) {
    Eigen::Vector3d p;
    set.points->GetPoint(i, p.data());
    const double value = array->GetComponent(i, 0);
    if (!std::isfinite(value) || !p.allFinite())
      throw std::invalid_argument(fmt::format("scene: point {} is not finite", i));
    out.points.push_back(p);
    out.values.push_back(value);
  }
  return out;
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

}  // namespace detail

std::vector<LegendEntry> pointsLegend(const ScenePoints& points, const std::string& valueName) {
  const detail::CheckedPoints checked = detail::checkedPoints(points);
  std::vector<LegendEntry> entries;
  if (checked.points.empty()) {
    for (const ColourBand& band : points.colourMap)
      entries.push_back({band.rgb, band.label, {0.1, 0.1, 0.1}});
    return entries;
  }
  std::vector<int> perBand(points.colourMap.size(), 0);
  for (double value : checked.values)
    ++perBand[static_cast<std::size_t>(bandOf(points.colourMap, value))];
  for (std::size_t b = 0; b < points.colourMap.size(); ++b) {
    entries.push_back({points.colourMap[b].rgb,
                       fmt::format("{}: {} point{}", points.colourMap[b].label, perBand[b],
                                   perBand[b] == 1 ? "" : "s"),
                       {0.1, 0.1, 0.1}});
  }
  if (!valueName.empty())
    entries.push_back({std::nullopt, fmt::format("colour: {}", valueName), {0.3, 0.3, 0.3}});
  return entries;
}

}  // namespace echoreg::render
