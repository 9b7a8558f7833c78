// Off-screen rendering without any X server: an OSMesa core-profile context made current on our
// own buffer, and VTK told to render through a vtkGenericOpenGLRenderWindow whose context is
// current and owned by us (Debian's VTK 9.1 is built for X only; see DEVELOPERS.md). Fixed size,
// camera and lighting give the same pixels for the same scene.
#pragma once

#include <vtkSmartPointer.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

class vtkRenderWindow;
class vtkRenderer;

namespace echoreg::render {

/// An RGB image, rows from the top, 3 bytes per pixel.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;
  std::uint8_t at(int x, int y, int channel) const {
    return pixels[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                   static_cast<std::size_t>(x)) *
                      3 +
                  static_cast<std::size_t>(channel)];
  }
};

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
  /// Renders and writes a PNG atomically. Throws FileError.
  void writePng(const std::string& path);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes an RGB image as PNG, atomically. Throws FileError.
void writePng(const std::string& path, const RgbImage& image);

}  // namespace echoreg::render
