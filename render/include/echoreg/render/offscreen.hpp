// Off-screen rendering without any X server (inside the renderer module, libechoreg_render_gl;
// docs/figures.md): an OSMesa core-profile context made current on our
// own buffer, and VTK told to render through a vtkGenericOpenGLRenderWindow whose context is
// current and owned by us (Debian's VTK 9.1 is built for X only; see DEVELOPERS.md). Fixed size,
// camera and lighting give the same pixels for the same scene.
#pragma once

#include "echoreg/render/image.hpp"

#include <memory>
#include <string>

class vtkRenderWindow;
class vtkRenderer;

namespace echoreg::render {

/// One OSMesa context and one VTK render window of a fixed size. Not thread-safe; one window per
/// thread at a time. Throws std::runtime_error when OSMesa cannot create a 3.2 core context.
class OffscreenWindow {
 public:
  OffscreenWindow(int width, int height);
  ~OffscreenWindow();
  OffscreenWindow(const OffscreenWindow&) = delete;
  OffscreenWindow& operator=(const OffscreenWindow&) = delete;

  int width() const;
  int height() const;
  vtkRenderWindow* window();
  /// Adds a renderer covering `viewport` (xmin, ymin, xmax, ymax in 0..1).
  vtkRenderer* addRenderer(double xmin = 0, double ymin = 0, double xmax = 1, double ymax = 1);

  /// Renders and reads the pixels back.
  RgbImage capture();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace echoreg::render
