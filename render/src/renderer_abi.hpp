// The interface between render::renderScene (in every executable) and the renderer module that
// draws (libechoreg_render_gl, opened with dlopen on the first figure; docs/figures.md). C entry
// points, so that dlsym finds them by name; C++ types cross by pointer, which holds because the
// module is built from the same sources by the same compiler (checked by rendererAbi()).
// Internal to render/.
#pragma once

#include "echoreg/core/loadable_module.hpp"
#include "echoreg/render/image.hpp"
#include "echoreg/render/scene.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <string>
#include <vector>

#ifndef ECHOREG_VERSION
#error "ECHOREG_VERSION must be defined (render/CMakeLists.txt)"
#endif

namespace echoreg::render::detail {

/// What the draw entry point returns: the exception renderScene throws with its message.
enum DrawStatus : int { kDrawn = 0, kInvalidArgument = 1, kFailed = 2 };

/// int echoreg_render_draw_scene(const Scene*, const FigureSize*, RgbImage* out,
/// std::string* error): draws into `out`, or returns the status and sets `error`.
inline constexpr const char* kDrawSceneSymbol = "echoreg_render_draw_scene";
using DrawSceneFunction = int (*)(const Scene*, const FigureSize*, RgbImage*, std::string*);

/// int echoreg_render_encode_png(const RgbImage* image, std::vector<std::uint8_t>* out,
/// std::string* error): the PNG file's bytes of `image` into `out` (VTK's PNG writer, whose
/// image-format libraries the executable does not link), or kFailed and `error`.
inline constexpr const char* kEncodePngSymbol = "echoreg_render_encode_png";
using EncodePngFunction = int (*)(const RgbImage*, std::vector<std::uint8_t>*, std::string*);

/// const char* echoreg_render_abi(): the module's rendererAbi().
inline constexpr const char* kAbiSymbol = "echoreg_render_abi";
using AbiFunction = const char* (*)();

/// The version, the compiler and the layout of the types that cross; the module and the
/// executable must agree on it.
inline std::string rendererAbi() {
  return fmt::format(
      "echoreg {} / {} / Scene {} SceneModel {} ScenePoints {} PlotPanel {} "
      "Series {} LegendEntry {} FigureSize {} RgbImage {}",
      ECHOREG_VERSION, __VERSION__, sizeof(Scene), sizeof(SceneModel), sizeof(ScenePoints),
      sizeof(PlotPanel), sizeof(Series), sizeof(LegendEntry), sizeof(FigureSize), sizeof(RgbImage));
}

/// What core::moduleSymbol checks and names in its messages.
inline core::ModuleIdentity rendererIdentity() {
  return {"renderer module", "echoreg_render_gl", "draws figures", kAbiSymbol, rendererAbi()};
}

}  // namespace echoreg::render::detail
