// Figures of points on a surface: a bone model with the ultrasound points mapped by a
// registration (the dissertation's Figs. 5.6-5.9, 5.30-5.35), or the calibration sphere with the
// calibration points (Figs. 5.1-5.5). Points are spheres coloured by their distance to the
// surface in bands (green / yellow / red), drawn in views named from the CT's axes, with a legend.
#pragma once

#include "echoreg/core/mesh.hpp"
#include "echoreg/render/offscreen.hpp"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace echoreg::render {

/// Values up to `upToMm` (and above the previous band) take this colour.
struct ColourBand {
  double upToMm = 0.0;                 ///< use +infinity for the last band
  std::array<double, 3> rgb{0, 0, 0};  ///< 0..1
  std::string label;                   ///< e.g. "< 3 mm"
};

/// The dissertation's registration bands: green < 3 mm, yellow 3-5 mm, red > 5 mm.
std::vector<ColourBand> registrationBands(double greenBelowMm = 3.0, double redAboveMm = 5.0);
/// The dissertation's calibration bands: < 0.5, 0.5-1.0, > 1.0 mm.
std::vector<ColourBand> calibrationBands(double greenBelowMm = 0.5, double redAboveMm = 1.0);
/// Index of the band a value falls in (|value| is used).
int bandOf(const std::vector<ColourBand>& bands, double valueMm);

/// A view along one of the CT's patient axes (LPS).
enum class View {
  Coronal,     ///< seen from the front (anterior, -y), superior up
  Sagittal,    ///< seen from the patient's right (-x), superior up, anterior to the left
  Transverse,  ///< seen from above (superior, +z), anterior up
};
const char* viewName(View view);

struct SurfaceFigure {
  core::TriangleMesh surface;                          ///< CT coordinates (LPS, mm)
  std::array<double, 3> surfaceRgb{0.89, 0.85, 0.79};  ///< bone
  /// Neighbouring surfaces drawn translucent for context (e.g. the patella in front of the femur,
  /// where stray echoes land), cropped like the surface; they do not move the cameras.
  std::vector<core::TriangleMesh> context;
  std::vector<Eigen::Vector3d> points;  ///< CT coordinates
  std::vector<double> valuesMm;         ///< per point, the value coloured (distance to surface)
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

struct FigureSize {
  int width = 1500;
  int height = 620;
};

/// The legend's entries: per band "LABEL: N points" (the points in it), then "colour: VALUE
/// NAME". A figure without points (a model alone) has its bands' labels only and no colour
/// entry: there is nothing they count or colour.
std::vector<std::string> surfaceFigureLegend(const SurfaceFigure& figure);

/// Renders the figure: one panel per view side by side, titled, with a legend of the bands (and
/// how many points fall in each). Deterministic: fixed cameras (parallel projection fitted to
/// the surface and points), a headlight, the same pixels for the same input. Throws
/// std::invalid_argument when points and values differ in number, a value is not finite, the
/// bands are empty, or there is nothing to draw.
RgbImage renderSurfaceFigure(const SurfaceFigure& figure, const FigureSize& size = {});

}  // namespace echoreg::render
