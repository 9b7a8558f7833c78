#include "echoreg/render/surface_figure.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

using echoreg::render::ColourBand;
using echoreg::render::SurfaceFigure;

TEST(SurfaceFigure, BandsFollowTheDissertation) {
  const auto bands = echoreg::render::registrationBands();
  ASSERT_EQ(bands.size(), 3u);
  EXPECT_EQ(echoreg::render::bandOf(bands, 2.99), 0);
  EXPECT_EQ(echoreg::render::bandOf(bands, -3.5), 1);
  EXPECT_EQ(echoreg::render::bandOf(bands, 5.01), 2);
  EXPECT_EQ(bands[1].label, "3-5 mm");
  EXPECT_THROW(echoreg::render::registrationBands(3, 2), std::invalid_argument);
}

// The legend counts points per band and names the colour only when there are points: a model
// alone (the segmentation's figures) shows its bands' labels, not "0 points" and "colour:".
TEST(SurfaceFigure, TheLegendCountsPointsOnlyWhenThereAreSome) {
  SurfaceFigure figure;
  figure.surface = echoreg::core::uvSphere(Eigen::Vector3d::Zero(), 25.0, 12, 24);
  figure.bands = {{1e9, {0.9, 0.85, 0.8}, "femur"}};
  EXPECT_EQ(echoreg::render::surfaceFigureLegend(figure), std::vector<std::string>{"femur"});
  figure.bands = echoreg::render::registrationBands();
  figure.points = {{0, -33, 0}, {0, 33, 0}, {33, 0, 0}};
  figure.valuesMm = {8.0, 1.0, -0.5};
  EXPECT_EQ(echoreg::render::surfaceFigureLegend(figure),
            (std::vector<std::string>{"< 3 mm: 2 points", "3-5 mm: 0 points", "> 5 mm: 1 point",
                                      "colour: distance to surface"}));
  figure.valueName.clear();
  EXPECT_EQ(echoreg::render::surfaceFigureLegend(figure).size(), 3u);
}

TEST(SurfaceFigure, PointsAreDrawnInTheirBandColours) {
  SurfaceFigure figure;
  figure.surface = echoreg::core::uvSphere(Eigen::Vector3d::Zero(), 25.0, 24, 48);
  // One point in front of the sphere (towards anterior, -y), coloured red (8 mm off).
  figure.points = {{0, -33, 0}};
  figure.valuesMm = {8.0};
  figure.pointRadiusMm = 3.0;
  figure.views = {echoreg::render::View::Coronal};
  figure.title = "test";
  const echoreg::render::RgbImage image = echoreg::render::renderSurfaceFigure(figure, {400, 400});
  if (const char* keep = std::getenv("ECHOREG_KEEP_FIGURES")) {
    echoreg::render::writePng(std::string(keep) + "/surface_figure_test.png", image);
  }
  // The panel's centre (the point seen from the front, over the sphere) is red.
  const int cx = 200;
  int redPixels = 0;
  for (int y = 100; y < 300; ++y) {
    for (int x = 100; x < 300; ++x) {
      if (image.at(x, y, 0) > 150 && image.at(x, y, 1) < 60 && image.at(x, y, 2) < 60)
        ++redPixels;
    }
  }
  EXPECT_GT(redPixels, 50);
  (void)cx;
  figure.valuesMm = {1.0};
  const auto green = echoreg::render::renderSurfaceFigure(figure, {400, 400});
  int greenPixels = 0;
  for (int y = 100; y < 300; ++y) {
    for (int x = 100; x < 300; ++x) {
      if (green.at(x, y, 1) > 120 && green.at(x, y, 0) < 80 && green.at(x, y, 2) < 80)
        ++greenPixels;
    }
  }
  EXPECT_GT(greenPixels, 50);
}

TEST(SurfaceFigure, BadInputIsRefused) {
  SurfaceFigure figure;
  figure.points = {{0, 0, 0}};
  EXPECT_THROW(echoreg::render::renderSurfaceFigure(figure), std::invalid_argument);  // no value
  figure.valuesMm = {NAN};
  EXPECT_THROW(echoreg::render::renderSurfaceFigure(figure), std::invalid_argument);
  figure.valuesMm = {1.0};
  figure.bands.clear();
  EXPECT_THROW(echoreg::render::renderSurfaceFigure(figure), std::invalid_argument);
  EXPECT_THROW(echoreg::render::renderSurfaceFigure(SurfaceFigure{}), std::invalid_argument);
}

}  // namespace
