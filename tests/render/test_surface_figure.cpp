#include "echoreg/render/surface_figure.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

namespace {

using echoreg::render::ColourBand;
using echoreg::render::SurfaceFigure;

// A closed octahedron-like bone stand-in: a UV sphere of radius 25 mm.
echoreg::core::TriangleMesh sphereMesh(double radius) {
  echoreg::core::TriangleMesh mesh;
  const int rings = 24;
  const int segments = 48;
  mesh.vertices.push_back({0, 0, radius});
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      mesh.vertices.push_back({radius * std::sin(theta) * std::cos(phi),
                               radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta)});
    }
  }
  mesh.vertices.push_back({0, 0, -radius});
  const int south = static_cast<int>(mesh.vertices.size()) - 1;
  auto at = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) mesh.triangles.push_back({0, at(1, s), at(1, s + 1)});
  for (int r = 1; r < rings - 1; ++r) {
    for (int s = 0; s < segments; ++s) {
      mesh.triangles.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      mesh.triangles.push_back({at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s) mesh.triangles.push_back({south, at(rings - 1, s + 1), at(rings - 1, s)});
  return mesh;
}

TEST(SurfaceFigure, BandsFollowTheDissertation) {
  const auto bands = echoreg::render::registrationBands();
  ASSERT_EQ(bands.size(), 3u);
  EXPECT_EQ(echoreg::render::bandOf(bands, 2.99), 0);
  EXPECT_EQ(echoreg::render::bandOf(bands, -3.5), 1);
  EXPECT_EQ(echoreg::render::bandOf(bands, 5.01), 2);
  EXPECT_EQ(bands[1].label, "3-5 mm");
  EXPECT_THROW(echoreg::render::registrationBands(3, 2), std::invalid_argument);
}

TEST(SurfaceFigure, PointsAreDrawnInTheirBandColours) {
  SurfaceFigure figure;
  figure.surface = sphereMesh(25.0);
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
      if (image.at(x, y, 0) > 150 && image.at(x, y, 1) < 60 && image.at(x, y, 2) < 60) ++redPixels;
    }
  }
  EXPECT_GT(redPixels, 50);
  (void)cx;
  figure.valuesMm = {1.0};
  const auto green = echoreg::render::renderSurfaceFigure(figure, {400, 400});
  int greenPixels = 0;
  for (int y = 100; y < 300; ++y) {
    for (int x = 100; x < 300; ++x) {
      if (green.at(x, y, 1) > 120 && green.at(x, y, 0) < 80 && green.at(x, y, 2) < 80) ++greenPixels;
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
