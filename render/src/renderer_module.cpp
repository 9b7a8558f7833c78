#include "echoreg/render/renderer_module.hpp"

#include "echoreg/core/loadable_module.hpp"
#include "renderer_abi.hpp"

#include <stdexcept>
#include <string>

#ifndef ECHOREG_RENDER_MODULE_FILE_NAME
#error "ECHOREG_RENDER_MODULE_FILE_NAME must be defined (render/CMakeLists.txt)"
#endif

namespace echoreg::render {

std::filesystem::path rendererModulePath() {
  return core::moduleBesideExecutable(ECHOREG_RENDER_MODULE_FILE_NAME);
}

RgbImage renderSceneWith(const std::filesystem::path& modulePath, const Scene& scene,
                         const FigureSize& size) {
  // Opened once per process and kept open: VTK keeps factories and objects of its libraries until
  // exit. RTLD_LOCAL: the module's libraries, libOSMesa first, form its own lookup scope, with the
  // module's glXGetProcAddress ahead of libGLX's.
  const auto draw = reinterpret_cast<detail::DrawSceneFunction>(
      core::moduleSymbol(modulePath, detail::rendererIdentity(), detail::kDrawSceneSymbol));
  RgbImage image;
  std::string error;
  switch (draw(&scene, &size, &image, &error)) {
    case detail::kDrawn:
      return image;
    case detail::kInvalidArgument:
      throw std::invalid_argument(error);
    default:
      throw std::runtime_error(error);
  }
}

RgbImage renderScene(const Scene& scene, const FigureSize& size) {
  return renderSceneWith(rendererModulePath(), scene, size);
}

}  // namespace echoreg::render
