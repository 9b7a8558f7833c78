// The scene renderer: a model, points with their distance array (as
// vtkEchoregPointToSurfaceDistance writes it), context models, views, a legend and a title, drawn
// off-screen.
#include "echoreg/render/scene.hpp"

#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSphereSource.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using echoreg::render::RgbImage;
using echoreg::render::Scene;

vtkSmartPointer<vtkPolyData> sphere(double radius, const std::array<double, 3>& centre) {
  vtkNew<vtkSphereSource> source;
  source->SetRadius(radius);
  source->SetCenter(centre.data());
  source->SetThetaResolution(32);
  source->SetPhiResolution(24);
  source->Update();
  return source->GetOutput();
}

// Points as the distance filter outputs them: a vertex per point and a "DistanceMm" array.
vtkSmartPointer<vtkPolyData> pointsWithDistances(const std::vector<std::array<double, 3>>& points,
                                                 const std::vector<double>& distances) {
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  vtkNew<vtkPoints> xyz;
  vtkNew<vtkCellArray> vertices;
  for (const auto& p : points) {
    const vtkIdType id = xyz->InsertNextPoint(p.data());
    vertices->InsertNextCell(1, &id);
  }
  vtkNew<vtkDoubleArray> values;
  values->SetName("DistanceMm");
  for (double d : distances)
    values->InsertNextValue(d);
  poly->SetPoints(xyz);
  poly->SetVerts(vertices);
  poly->GetPointData()->AddArray(values);
  return poly;
}

// Pixels within `tolerance` of a colour in rows [y0, y1).
int count(const RgbImage& image, std::array<int, 3> rgb, int y0, int y1, int tolerance = 30) {
  int n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = 0; x < image.width; ++x) {
      bool near = true;
      for (int c = 0; c < 3; ++c)
        near = near && std::abs(image.at(x, y, c) - rgb[static_cast<std::size_t>(c)]) < tolerance;
      n += near ? 1 : 0;
    }
  }
  return n;
}

// Pixels darker than 80 in every channel (text) in rows [y0, y1), columns [0, x1).
int dark(const RgbImage& image, int y0, int y1, int x1 = -1) {
  int n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = 0; x < (x1 < 0 ? image.width : x1); ++x)
      n += image.at(x, y, 0) < 80 && image.at(x, y, 1) < 80 && image.at(x, y, 2) < 80 ? 1 : 0;
  }
  return n;
}

// A 25 mm bone with three points in front of it (seen from anterior, -y): 1 mm (green) on the
// patient's right, 4 mm (yellow) in the middle, 8 mm (red) on the left.
Scene boneScene() {
  Scene scene;
  echoreg::render::SceneModel bone;
  bone.surface = sphere(25.0, {0, 0, 0});
  scene.models.push_back(bone);
  echoreg::render::ScenePoints points;
  points.points = pointsWithDistances({{-15, -30, 0}, {0, -30, 0}, {15, -30, 0}}, {1.0, -4.0, 8.0});
  points.radiusMm = 4.0;
  scene.pointSets.push_back(points);
  scene.views = {{echoreg::render::View::Coronal, ""}};
  scene.legend = echoreg::render::pointsLegend(points, "distance to surface");
  scene.title.text = "scene";
  scene.title.fontSize = 18;
  return scene;
}

constexpr std::array<int, 3> kGreen{26, 179, 51};
constexpr std::array<int, 3> kYellow{242, 204, 26};
constexpr std::array<int, 3> kRed{217, 26, 26};

TEST(Scene, DrawsTheModelThePointsInTheirColoursAndTheLegend) {
  const Scene scene = boneScene();
  const RgbImage image = echoreg::render::renderScene(scene, {600, 400});
  if (const char* keep = std::getenv("ECHOREG_KEEP_FIGURES"))
    echoreg::render::writePng(std::string(keep) + "/scene_test.png", image);
  ASSERT_EQ(image.width, 600);
  ASSERT_EQ(image.height, 400);
  // Bands: title 0.08 (32 rows), legend clamp(110/400) = 0.25 (100 rows) at the bottom.
  const int panelTop = 32;
  const int panelBottom = 300;
  // Not blank: the bone (lit, so not white) covers a good part of the panel.
  const int panelPixels = 600 * (panelBottom - panelTop);
  const int white = count(image, {255, 255, 255}, panelTop, panelBottom, 3);
  EXPECT_GT(panelPixels - white, 15000);
  // Each point in its band's colour (shaded spheres: a looser tolerance).
  EXPECT_GT(count(image, kGreen, panelTop, panelBottom, 60), 40);
  EXPECT_GT(count(image, kYellow, panelTop, panelBottom, 60), 40);
  EXPECT_GT(count(image, kRed, panelTop, panelBottom, 60), 40);
  // The legend: the three swatches (unlit, their exact colours) and its text.
  EXPECT_GT(count(image, kGreen, panelBottom, 400, 4), 50);
  EXPECT_GT(count(image, kYellow, panelBottom, 400, 4), 50);
  EXPECT_GT(count(image, kRed, panelBottom, 400, 4), 50);
  EXPECT_GT(dark(image, panelBottom, 400), 80);
  // The title, at the top left.
  EXPECT_GT(dark(image, 0, panelTop, 100), 20);
}

TEST(Scene, TheLegendCountsThePointsPerBand) {
  const Scene scene = boneScene();
  std::vector<std::string> texts;
  for (const auto& entry : scene.legend)
    texts.push_back(entry.text);
  EXPECT_EQ(texts, (std::vector<std::string>{"< 3 mm: 1 point", "3-5 mm: 1 point",
                                             "> 5 mm: 1 point", "colour: distance to surface"}));
  EXPECT_TRUE(scene.legend[0].swatch.has_value());
  EXPECT_FALSE(scene.legend[3].swatch.has_value());
}

// Without a legend and a title the panel takes the whole image: the footer rows hold the bone.
TEST(Scene, WithoutLegendOrTitleThePanelFillsTheImage) {
  Scene scene = boneScene();
  scene.legend.clear();
  scene.title.text.clear();
  const RgbImage image = echoreg::render::renderScene(scene, {600, 400});
  EXPECT_EQ(count(image, kGreen, 300, 400, 4), 0);
  EXPECT_EQ(dark(image, 0, 32, 100), 0);
  const int white = count(image, {255, 255, 255}, 0, 400, 3);
  EXPECT_GT(600 * 400 - white, 20000);
}

// A context model is drawn translucent and does not move the cameras: the same scene with a far
// context model frames the bone the same way.
TEST(Scene, ContextModelsDoNotMoveTheCameras) {
  Scene scene = boneScene();
  scene.legend.clear();
  const RgbImage alone = echoreg::render::renderScene(scene, {400, 300});
  scene.models.push_back(echoreg::render::contextModel(sphere(10.0, {300, 0, 0})));
  const RgbImage withFarContext = echoreg::render::renderScene(scene, {400, 300});
  EXPECT_EQ(alone.pixels, withFarContext.pixels);
  scene.models.back() = echoreg::render::contextModel(sphere(10.0, {0, -60, 20}));
  const RgbImage withNearContext = echoreg::render::renderScene(scene, {400, 300});
  EXPECT_NE(alone.pixels, withNearContext.pixels);
}

TEST(Scene, BadScenesAreRefused) {
  Scene noPanel = boneScene();
  noPanel.views.clear();
  EXPECT_THROW(echoreg::render::renderScene(noPanel, {400, 300}), std::invalid_argument);

  Scene noArray = boneScene();
  noArray.pointSets[0].scalarName = "ResidualMm";
  EXPECT_THROW(echoreg::render::renderScene(noArray, {400, 300}), std::invalid_argument);
  EXPECT_THROW(echoreg::render::pointsLegend(noArray.pointSets[0], ""), std::invalid_argument);

  Scene shortArray = boneScene();
  shortArray.pointSets[0].points->GetPointData()->GetArray("DistanceMm")->SetNumberOfTuples(2);
  EXPECT_THROW(echoreg::render::renderScene(shortArray, {400, 300}), std::invalid_argument);

  Scene notFinite = boneScene();
  notFinite.pointSets[0].points->GetPointData()->GetArray("DistanceMm")->SetComponent(1, 0, NAN);
  EXPECT_THROW(echoreg::render::renderScene(notFinite, {400, 300}), std::invalid_argument);

  Scene noColours = boneScene();
  noColours.pointSets[0].colourMap.clear();
  EXPECT_THROW(echoreg::render::renderScene(noColours, {400, 300}), std::invalid_argument);

  Scene contextOnly;
  contextOnly.models.push_back(echoreg::render::contextModel(sphere(10.0, {0, 0, 0})));
  contextOnly.views = {{echoreg::render::View::Sagittal, ""}};
  EXPECT_THROW(echoreg::render::renderScene(contextOnly, {400, 300}), std::invalid_argument);

  Scene nothing;
  nothing.views = {{echoreg::render::View::Sagittal, ""}};
  EXPECT_THROW(echoreg::render::renderScene(nothing, {400, 300}), std::invalid_argument);
}

}  // namespace
