#include "echoreg/render/image.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkUnsignedCharArray.h>

#include <cstring>

namespace echoreg::render {

void writePng(const std::string& path, const RgbImage& image) {
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
  if (writer->GetErrorCode() != 0 || bytes == nullptr || bytes->GetNumberOfValues() == 0) {
    throw FileError(path, "could not encode the PNG");
  }
  AtomicFile file(path);
  file.stream().write(reinterpret_cast<const char*>(bytes->GetPointer(0)),
                      static_cast<std::streamsize>(bytes->GetNumberOfValues()));
  file.commit();
}

}  // namespace echoreg::render
