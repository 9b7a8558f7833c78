#include "echoreg/render/renderer_module.hpp"

#include "echoreg/core/error.hpp"
#include "renderer_abi.hpp"

#include <dlfcn.h>

#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>

#ifndef ECHOREG_RENDER_MODULE_RELATIVE_PATH
#error "ECHOREG_RENDER_MODULE_RELATIVE_PATH must be defined (render/CMakeLists.txt)"
#endif

namespace echoreg::render {

namespace {

std::string lastDlError() {
  const char* message = dlerror();
  return message != nullptr ? message : "unknown error";
}

// Opens the module (RTLD_LOCAL: its libraries, libOSMesa first, form its own lookup scope, with
// the module's glXGetProcAddress ahead of libGLX's) and checks that it was built with this
// executable. Never closed: VTK keeps factories and objects of its libraries until exit.
detail::DrawSceneFunction openModule(const std::filesystem::path& path) {
  static std::mutex mutex;
  static std::map<std::string, detail::DrawSceneFunction> opened;
  const std::lock_guard<std::mutex> lock(mutex);
  if (const auto it = opened.find(path.string()); it != opened.end())
    return it->second;
  const std::string hint =
      "; echoreg draws figures through this module, built with it (CMake target "
      "echoreg_render_gl) into lib/echoreg beside the folder of the executable";
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr)
    throw FileError(path.string(),
                    "cannot open the renderer module (" + lastDlError() + ")" + hint);
  auto abi = reinterpret_cast<detail::AbiFunction>(dlsym(handle, detail::kAbiSymbol));
  auto draw = reinterpret_cast<detail::DrawSceneFunction>(dlsym(handle, detail::kDrawSceneSymbol));
  if (abi == nullptr || draw == nullptr)
    throw FileError(path.string(), "is not echoreg's renderer module (no " +
                                       std::string(abi == nullptr ? detail::kAbiSymbol
                                                                  : detail::kDrawSceneSymbol) +
                                       ")" + hint);
  const std::string theirs = abi();
  const std::string ours = detail::rendererAbi();
  if (theirs != ours)
    throw FileError(path.string(), "is the renderer module of another build (" + theirs +
                                       ", this echoreg: " + ours + ")" + hint);
  opened.emplace(path.string(), draw);
  return draw;
}

}  // namespace

std::filesystem::path rendererModulePath() {
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) {
    throw std::runtime_error("cannot find the renderer module: /proc/self/exe unreadable (" +
                             error.message() + ")");
  }
  return (executable.parent_path() / ECHOREG_RENDER_MODULE_RELATIVE_PATH).lexically_normal();
}

RgbImage renderSceneWith(const std::filesystem::path& modulePath, const Scene& scene,
                         const FigureSize& size) {
  const detail::DrawSceneFunction draw = openModule(modulePath);
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
