// The renderer module's entry points (render/src/renderer_abi.hpp): no exception crosses the
// dlopen boundary; each becomes a status and its message.
#include "draw_scene.hpp"
#include "png_file.hpp"
#include "renderer_abi.hpp"

#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

extern "C" {

__attribute__((visibility("default"))) const char* echoreg_render_abi() {
  static const std::string abi = echoreg::render::detail::rendererAbi();
  return abi.c_str();
}

__attribute__((visibility("default"))) int echoreg_render_draw_scene(
    const echoreg::render::Scene* scene, const echoreg::render::FigureSize* size,
    echoreg::render::RgbImage* out, std::string* error) {
  using namespace echoreg::render::detail;
  try {
    *out = echoreg::render::drawScene(*scene, *size);
    return kDrawn;
  } catch (const std::invalid_argument& e) {
    *error = e.what();
    return kInvalidArgument;
  } catch (const std::exception& e) {
    *error = e.what();
    return kFailed;
  } catch (...) {
    *error = "unknown error";
    return kFailed;
  }
}

__attribute__((visibility("default"))) int echoreg_render_encode_png(
    const echoreg::render::RgbImage* image, std::vector<std::uint8_t>* out, std::string* error) {
  using namespace echoreg::render::detail;
  try {
    *out = echoreg::render::encodePng(*image);
    return kDrawn;
  } catch (const std::exception& e) {
    *error = e.what();
    return kFailed;
  } catch (...) {
    *error = "unknown error";
    return kFailed;
  }
}

}  // extern "C"
