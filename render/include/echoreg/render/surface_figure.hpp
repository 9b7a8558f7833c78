// Figures of points on a surface: a bone model with the ultrasound points mapped by a
// registration (the dissertation's Figs. 5.6-5.9, 5.30-5.35), or the calibration sphere with the
// calibration points (Figs. 5.1-5.5). Points are spheres coloured by their distance to the
// surface in bands (green / yellow / red), drawn in views named from the CT's axes, with a legend.
// A SurfaceFigure is a description in plain types; surfaceScene turns it into the Scene that
// renderScene draws (scene.hpp).
#pragma once

#include "echoreg/core/mesh.hpp"
#include "echoreg/render/image.hpp"
#include "echoreg/render/scene.hpp"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace echoreg::render {

struct SurfaceFigure {
  core::TriangleMesh surface;                          ///< CT coordinates (LPS, mm)
  std::array<double, 3> surfaceRgb{0.89, 0.85, 0.79};  ///< bone
  /// Neighbouring surfaces drawn translucent for context (e.g. the patella in front of the femur,
  /// where stray echoes land), cropped like the surface; they do not move the cameras.
  std::vector<core::TriangleMesh> context;
  std::vector<Eigen::Vector3d> points;  ///< CT coordinates
  std::vector<double>
      valuesMm;  ///< per point, the value (distance to surface); its magnitude is coloured
  std::vector<ColourBand> bands = registrationBands();
  double pointRadiusMm = 1.5;
  std::vector<View> views{View::Coronal, View::Sagittal, View::Transverse};
  std::string title;
  std::string valueName = "distance to surface";
  /// Labels of the views (default: viewName of each), e.g. for a figure in the tracker's frame.
  std::vector<std::string> viewLabels;
  /// When > 0 and there are points: show only the surface within this margin of the points'
  /// bounding box (the distal femur around its points rather than the whole bone, which would
  /// also hide the knee behind the hip in the transverse view), and frame the views on it.
  double cropMarginMm = 0.0;
};

/// The legend's entries: per band "LABEL: N points" (the points in it), then "colour: VALUE
/// NAME". A figure without points (a model alone) has its bands' labels only and no colour
/// entry: there is nothing they count or colour.
std::vector<std::string> surfaceFigureLegend(const SurfaceFigure& figure);

/// The figure as a scene: the surface (cropped), the context models, the points with their
/// values in a "DistanceMm" array coloured by the bands, one view per panel side by side, the
/// legend (surfaceFigureLegend with the bands' swatches) and the title. Checks as
/// renderSurfaceFigure does.
Scene surfaceScene(const SurfaceFigure& figure, const FigureSize& size = {});

/// Renders the figure (renderScene(surfaceScene(figure, size), size)): one panel per view side by
/// side, titled, with a legend of the bands (and how many points fall in each). Deterministic:
/// fixed cameras (parallel projection fitted to the surface and points), a headlight, the same
/// pixels for the same input. Throws std::invalid_argument when points and values differ in number,
/// a value is not finite, the bands are empty, or there is nothing to draw.
RgbImage renderSurfaceFigure(const SurfaceFigure& figure, const FigureSize& size = {});

}  // namespace echoreg::render
