// PNG encoding inside the renderer module (VTK's PNG writer and the image-format libraries it
// brings): render::writePng sends the pixels here and writes the bytes itself.
#include "png_file.hpp"

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkUnsignedCharArray.h>

#include <cstring>
#include <stdexcept>

namespace echoreg::render {

std::vector<std::uint8_t> encodePng(const RgbImage& image) {
  vtkNew<vtkImageData> data;
  data->SetDimensions(image.width, image.height, 1);
  data->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* out = static_cast<std::uint8_t*>(data->GetScalarPointer());
  const std::size_t row = static_cast<std::size_t>(image.width) * 3;
  for (int y = 0; y < image.height; ++y) {
    std::memcpy(out + static_cast<std::size_t>(image.height - 1 - y) * row,
                image.pixels.data() + static_cast<std::size_t>(y) * row, row);
  }
  vtkNew<vtkPNGWriter> writer;
  writer->WriteToMemoryOn();
  writer->SetInputData(data);
  writer->Write();
  vtkUnsignedCharArray* bytes = writer->GetResult();
  if (writer->GetErrorCode() != 0 || bytes == nullptr || bytes->GetNumberOfValues() == 0)
    throw std::runtime_error("could not encode the PNG");
  return {bytes->GetPointer(0), bytes->GetPointer(0) + bytes->GetNumberOfValues()};
}

}  // namespace echoreg::render
