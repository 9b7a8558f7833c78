#include "echoreg/render/image.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/loadable_module.hpp"
#include "echoreg/render/renderer_module.hpp"
#include "renderer_abi.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::render {

void writePng(const std::string& path, const RgbImage& image) {
  // The encoder is in the renderer module (VTK's image-format libraries stay out of every
  // process that draws nothing), which drew the image in the first place.
  const auto encode = reinterpret_cast<detail::EncodePngFunction>(core::moduleSymbol(
      rendererModulePath(), detail::rendererIdentity(), detail::kEncodePngSymbol));
  std::vector<std::uint8_t> bytes;
  std::string error;
  if (encode(&image, &bytes, &error) != detail::kDrawn)
    throw core::FileError(path, error);
  core::AtomicFile file(path);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()),
                      static_cast<std::streamsize>(bytes.size()));
  file.commit();
}

}  // namespace echoreg::render
