// The drawing of a scene, inside the renderer module: what render::renderScene does once the
// module is open (render/src/renderer_module.cpp).
#pragma once

#include "echoreg/render/image.hpp"
#include "echoreg/render/scene.hpp"

namespace echoreg::render {

/// Draws the scene in an OffscreenWindow; the checks and exceptions of renderScene (scene.hpp).
RgbImage drawScene(const Scene& scene, const FigureSize& size);

}  // namespace echoreg::render
