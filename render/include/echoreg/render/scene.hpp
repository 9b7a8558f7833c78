// A scene and its renderer: what a figure shows, described as data (surfaces, point sets with a
// scalar array and a colour map, camera views along the CT's axes, chart panels, a legend and a
// title), and one function that draws any scene off-screen (OffscreenWindow, OSMesa, inside the
// renderer module that renderScene opens on its first call: renderer_module.hpp). The
// figures (surface_figure.hpp, plot_figure.hpp) are scene descriptions; pipeline outputs go in
// as they come: a model as vtkPolyData, points as the vtkPolyData of
// vtkEchoregPointToSurfaceDistance with its "DistanceMm" array.
#pragma once

#include "echoreg/render/image.hpp"

#include <vtkSmartPointer.h>

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

class vtkPolyData;

namespace echoreg::render {

struct FigureSize {
  int width = 1500;
  int height = 620;
};

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

/// A surface in the scene. The subject (a bone model, the calibration sphere) is shaded with
/// smoothed normals and frames the cameras; context (e.g. the patella beside the femur) is drawn
/// translucent as it is and does not move the cameras.
struct SceneModel {
  vtkSmartPointer<vtkPolyData> surface;  ///< polygons, mm; may be null or empty
  std::array<double, 3> rgb{0.89, 0.85, 0.79};
  double opacity = 1.0;
  double specular = 0.15;
  bool smoothNormals = true;  ///< vtkPolyDataNormals (feature angle 60, no splitting)
  bool framesViews = true;    ///< its (cropped) extent fits the cameras
};
/// A context model: translucent blue-grey, unshaded normals, not framing the views.
SceneModel contextModel(vtkSmartPointer<vtkPolyData> surface);

/// Points drawn as spheres coloured through a colour map by one of their point-data arrays.
struct ScenePoints {
  vtkSmartPointer<vtkPolyData> points;  ///< its points; cells are ignored
  std::string scalarName = "DistanceMm";
  std::vector<ColourBand> colourMap = registrationBands();
  double radiusMm = 1.5;
};

/// One entry of the legend under the views: an optional colour swatch and its text.
struct LegendEntry {
  std::optional<std::array<double, 3>> swatch;
  std::string text;
  std::array<double, 3> textRgb{0.1, 0.1, 0.1};
};
/// The legend of a point set: per colour band "LABEL: N points", then "colour: VALUE NAME"
/// (left out when `valueName` is empty). Throws std::invalid_argument as renderScene does for
/// a missing or non-finite array.
std::vector<LegendEntry> pointsLegend(const ScenePoints& points, const std::string& valueName);

/// A 3D panel: the scene's models and points seen along `view`, parallel projection.
struct SceneView {
  View view = View::Coronal;
  std::string label;  ///< shown in the panel's corner; empty: viewName(view)
};

struct Series {
  std::string name;  ///< shown in the panel's legend when not empty
  std::vector<double> x;
  std::vector<double> y;
  std::array<double, 3> rgb{0.1, 0.1, 0.1};
  double lineWidth = 1.5;
  bool markersOnly = false;  ///< points (e.g. detected peaks) instead of a line
  double markerSize = 8.0;
};

/// A 2D panel: a chart of series (VTK's charts).
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
  /// Labelled ticks on the x axis instead of numbers (e.g. box plots' groups); no x grid then.
  std::vector<std::pair<double, std::string>> xTicks;
  bool showLegend = true;  ///< the chart's legend of named series
};

/// The band over the panels.
struct SceneTitle {
  std::string text;              ///< empty: no band
  double heightFraction = 0.08;  ///< of the image's height
  int fontSize = 20;
  double baselinePx = 10.0;  ///< the text's bottom over the band's, pixels
};

struct Scene {
  SceneTitle title;
  std::vector<SceneModel> models;
  std::vector<ScenePoints> pointSets;
  /// When > 0 and there are points: draw only the polygons within this margin of the points'
  /// bounding box (radius included) and frame the views on them.
  double cropMarginMm = 0.0;
  /// The panels, in a grid of `columns` filled row by row: the 3D views first, then the charts.
  std::vector<SceneView> views;
  std::vector<PlotPanel> charts;
  int columns = 0;  ///< 0: every panel side by side
  int chartFontSize = 12;
  /// Under the panels, in one row when it fits, else one entry per row.
  std::vector<LegendEntry> legend;
};

/// Draws the scene, through the renderer module (renderer_module.hpp: opened on the first call;
/// throws FileError naming its path when it is missing). Deterministic: fixed cameras (parallel
/// projection fitted to the framing models and the points), a headlight, the same pixels for the
/// same scene. Throws std::invalid_argument for a scene without panels, views without anything to
/// draw, a point set without its scalar array (or one of another length, or a value or point that
/// is not finite), an empty colour map, or a chart series whose x and y differ in length or hold a
/// value that is not finite.
RgbImage renderScene(const Scene& scene, const FigureSize& size);

}  // namespace echoreg::render
