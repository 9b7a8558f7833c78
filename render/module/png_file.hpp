// PNG encoding, inside the renderer module (png_file.cpp).
#pragma once

#include "echoreg/render/image.hpp"

#include <cstdint>
#include <vector>

namespace echoreg::render {

/// The bytes of `image` as a PNG file. Throws std::runtime_error when VTK cannot encode it.
std::vector<std::uint8_t> encodePng(const RgbImage& image);

}  // namespace echoreg::render
