// The pixels a figure is drawn into, and their PNG file. Plain data: no OpenGL here (the drawing
// is in the renderer module, docs/figures.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

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

/// Writes an RGB image as PNG, atomically. Throws FileError.
void writePng(const std::string& path, const RgbImage& image);

}  // namespace echoreg::render
