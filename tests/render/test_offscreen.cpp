#include "echoreg/render/offscreen.hpp"

#include "echoreg/core/error.hpp"
#include "test_support.hpp"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkSphereSource.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

namespace {

void addSphere(echoreg::render::OffscreenWindow& window, double red, double green) {
  vtkRenderer* renderer = window.addRenderer();
  renderer->SetBackground(1, 1, 1);
  vtkNew<vtkSphereSource> sphere;
  sphere->SetThetaResolution(48);
  sphere->SetPhiResolution(48);
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputConnection(sphere->GetOutputPort());
  vtkNew<vtkActor> actor;
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(red, green, 0.1);
  renderer->AddActor(actor);
  renderer->ResetCamera();
}

echoreg::render::RgbImage renderSphere() {
  echoreg::render::OffscreenWindow window(160, 120);
  addSphere(window, 0.9, 0.1);
  return window.capture();
}

// Rendering must work with no X server at all: DISPLAY unset, no Xvfb.
TEST(Offscreen, RendersWithoutAnXServer) {
  ::unsetenv("DISPLAY");
  const echoreg::render::RgbImage image = renderSphere();
  ASSERT_EQ(image.width, 160);
  ASSERT_EQ(image.height, 120);
  // The corner is the white background; the centre is the lit red sphere.
  EXPECT_EQ(image.at(2, 2, 0), 255);
  EXPECT_EQ(image.at(2, 2, 1), 255);
  EXPECT_GT(image.at(80, 60, 0), 120);
  EXPECT_LT(image.at(80, 60, 1), 60);
  EXPECT_LT(image.at(80, 60, 2), 60);
  // The sphere is round and centred: the red region is symmetric left/right.
  int left = 0;
  int right = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 80; ++x)
      left += image.at(x, y, 1) < 128 ? 1 : 0;
    for (int x = 80; x < 160; ++x)
      right += image.at(x, y, 1) < 128 ? 1 : 0;
  }
  EXPECT_GT(left, 1000);
  EXPECT_NEAR(left, right, 0.03 * left);
}

TEST(Offscreen, SameSceneSamePixels) {
  const echoreg::render::RgbImage a = renderSphere();
  const echoreg::render::RgbImage b = renderSphere();
  EXPECT_EQ(a.pixels, b.pixels);
}

// Two windows alive at once (each its own OSMesa context): closing one releases its OpenGL objects
// in its own context, not in the other's, which renders the same pixels afterwards.
TEST(Offscreen, ClosingOneWindowLeavesAnotherIntact) {
  echoreg::render::OffscreenWindow green(160, 120);
  addSphere(green, 0.1, 0.9);
  const echoreg::render::RgbImage before = green.capture();
  EXPECT_GT(before.at(80, 60, 1), 120);
  {
    echoreg::render::OffscreenWindow red(160, 120);
    addSphere(red, 0.9, 0.1);
    EXPECT_GT(red.capture().at(80, 60, 0), 120);
    const echoreg::render::RgbImage between = green.capture();
    EXPECT_EQ(between.pixels, before.pixels);
  }  // closed while the green window's context is the current one
  const echoreg::render::RgbImage after = green.capture();
  EXPECT_EQ(after.pixels, before.pixels);
  EXPECT_EQ(renderSphere().pixels, renderSphere().pixels);
}

TEST(Offscreen, WritesAPngThatReadsBack) {
  echoreg::test::TempDir dir;
  const echoreg::render::RgbImage image = renderSphere();
  echoreg::render::writePng(dir.file("sphere.png"), image);
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(dir.file("sphere.png").c_str());
  reader->Update();
  int dims[3];
  reader->GetOutput()->GetDimensions(dims);
  EXPECT_EQ(dims[0], 160);
  EXPECT_EQ(dims[1], 120);
  // VTK's rows start at the bottom: the top-left pixel of the image is row 119 there.
  const auto* top = static_cast<unsigned char*>(reader->GetOutput()->GetScalarPointer(0, 119, 0));
  EXPECT_EQ(top[0], image.at(0, 0, 0));
  EXPECT_THROW(echoreg::render::writePng(dir.file("missing/sphere.png"), image),
               echoreg::core::FileError);
  EXPECT_FALSE(std::filesystem::exists(dir.file("missing")));
  EXPECT_THROW(echoreg::render::OffscreenWindow(4, 4), std::invalid_argument);
}

}  // namespace
