#include "echoreg/segmentation/vtkEchoregDicomSeriesReader.h"

#include "echoreg/core/error.hpp"
#include "echoreg/segmentation/dicom_series.hpp"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

vtkStandardNewMacro(vtkEchoregDicomSeriesReader);

namespace echoreg::segmentation {

namespace {

// Voxel buffers handed to VTK arrays without a copy: VTK calls releaseVoxels(pointer) when the
// array lets go of its memory, and the vector owning that pointer is destroyed.
std::mutex& handedOverMutex() {
  static std::mutex mutex;
  return mutex;
}
std::map<void*, std::unique_ptr<std::vector<std::int16_t>>>& handedOver() {
  static std::map<void*, std::unique_ptr<std::vector<std::int16_t>>> buffers;
  return buffers;
}
void releaseVoxels(void* pointer) {
  std::unique_ptr<std::vector<std::int16_t>> owner;
  {
    const std::lock_guard<std::mutex> lock(handedOverMutex());
    auto it = handedOver().find(pointer);
    if (it == handedOver().end())
      return;
    owner = std::move(it->second);
    handedOver().erase(it);
  }
}

void checkImage(const core::CtImage& image) {
  if (!image.uniform()) {
    throw std::invalid_argument(
        "toImageData: the CT has several slice spacings (groups); resample it (resampleUniform) or "
        "extract one group first");
  }
  if (image.hu.size() != image.voxelCount() || image.voxelCount() == 0) {
    throw std::invalid_argument("toImageData: the CT's voxels do not match its dimensions");
  }
}

vtkSmartPointer<vtkImageData> emptyImage(const core::CtImage& image) {
  auto data = vtkSmartPointer<vtkImageData>::New();
  data->SetDimensions(image.dimensions[0], image.dimensions[1], image.dimensions[2]);
  const Eigen::Vector3d spacing = image.spacingMm();
  data->SetSpacing(spacing.x(), spacing.y(), spacing.z());
  data->SetOrigin(image.originMm.x(), image.originMm.y(), image.originMm.z());
  double direction[9];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      direction[3 * r + c] = image.direction(r, c);
  }
  data->SetDirectionMatrix(direction);
  return data;
}

// A copy of everything but the voxels (copying the CtImage and clearing `hu` would hold a second
// full volume for a moment).
core::CtImage geometryOnly(const core::CtImage& image) {
  core::CtImage out;
  out.dimensions = image.dimensions;
  out.originMm = image.originMm;
  out.direction = image.direction;
  out.pixelSpacingMm = image.pixelSpacingMm;
  out.slicePositionsMm = image.slicePositionsMm;
  out.groups = image.groups;
  out.seriesInstanceUid = image.seriesInstanceUid;
  out.folder = image.folder;
  return out;
}

// Geometry of resampleUniform(image, spacing) without voxels (same slice count rule).
core::CtImage resampledGeometry(const core::CtImage& image, double spacingMm) {
  if (spacingMm <= 0.0) {
    spacingMm = 0.0;
    for (std::size_t k = 1; k < image.slicePositionsMm.size(); ++k) {
      const double step = image.slicePositionsMm[k] - image.slicePositionsMm[k - 1];
      if (spacingMm == 0.0 || step < spacingMm)
        spacingMm = step;
    }
    if (spacingMm <= 0.0)
      spacingMm = 1.0;
  }
  core::CtImage out = geometryOnly(image);
  const double length = image.slicePositionsMm.empty() ? 0.0 : image.slicePositionsMm.back();
  const int slices = static_cast<int>(std::floor(length / spacingMm + 1e-6)) + 1;
  out.dimensions[2] = slices;
  out.slicePositionsMm.resize(static_cast<std::size_t>(slices));
  for (int k = 0; k < slices; ++k)
    out.slicePositionsMm[static_cast<std::size_t>(k)] = k * spacingMm;
  out.groups = {core::CtSliceGroup{0, slices, slices > 1 ? spacingMm : 0.0}};
  return out;
}

}  // namespace

core::CtImage extractSliceGroup(const core::CtImage& image, int group) {
  if (group < 0 || static_cast<std::size_t>(group) >= image.groups.size()) {
    throw std::invalid_argument("slice group " + std::to_string(group) +
                                " does not exist (the CT has " +
                                std::to_string(image.groups.size()) + ")");
  }
  const core::CtSliceGroup& g = image.groups[static_cast<std::size_t>(group)];
  core::CtImage out;
  out.dimensions = {image.dimensions[0], image.dimensions[1], g.count};
  const double first = image.slicePositionsMm[static_cast<std::size_t>(g.firstSlice)];
  out.originMm = image.originMm + first * image.direction.col(2);
  out.direction = image.direction;
  out.pixelSpacingMm = image.pixelSpacingMm;
  for (int k = 0; k < g.count; ++k) {
    out.slicePositionsMm.push_back(
        image.slicePositionsMm[static_cast<std::size_t>(g.firstSlice + k)] - first);
  }
  out.groups = {core::CtSliceGroup{0, g.count, g.spacingMm}};
  out.seriesInstanceUid = image.seriesInstanceUid;
  out.folder = image.folder;
  if (!image.hu.empty()) {
    const std::size_t plane = static_cast<std::size_t>(image.dimensions[0]) *
                              static_cast<std::size_t>(image.dimensions[1]);
    const auto begin = image.hu.begin() +
                       static_cast<std::ptrdiff_t>(plane * static_cast<std::size_t>(g.firstSlice));
    out.hu.assign(begin,
                  begin + static_cast<std::ptrdiff_t>(plane * static_cast<std::size_t>(g.count)));
  }
  return out;
}

vtkSmartPointer<vtkImageData> toImageData(const core::CtImage& image) {
  checkImage(image);
  vtkSmartPointer<vtkImageData> data = emptyImage(image);
  auto scalars = vtkSmartPointer<vtkShortArray>::New();
  scalars->SetName("HU");
  scalars->SetNumberOfValues(static_cast<vtkIdType>(image.hu.size()));
  std::memcpy(scalars->GetPointer(0), image.hu.data(), image.hu.size() * sizeof(std::int16_t));
  data->GetPointData()->SetScalars(scalars);
  return data;
}

vtkSmartPointer<vtkImageData> toImageData(core::CtImage&& image) {
  checkImage(image);
  vtkSmartPointer<vtkImageData> data = emptyImage(image);
  auto owner = std::make_unique<std::vector<std::int16_t>>(std::move(image.hu));
  image.hu.clear();
  std::int16_t* pointer = owner->data();
  const auto count = static_cast<vtkIdType>(owner->size());
  {
    const std::lock_guard<std::mutex> lock(handedOverMutex());
    handedOver()[pointer] = std::move(owner);
  }
  auto scalars = vtkSmartPointer<vtkShortArray>::New();
  scalars->SetName("HU");
  scalars->SetArray(pointer, count, 0, vtkShortArray::VTK_DATA_ARRAY_USER_DEFINED);
  scalars->SetArrayFreeFunction(releaseVoxels);
  data->GetPointData()->SetScalars(scalars);
  return data;
}

}  // namespace echoreg::segmentation

vtkEchoregDicomSeriesReader::vtkEchoregDicomSeriesReader() {
  this->SetNumberOfInputPorts(0);
}

vtkEchoregDicomSeriesReader::~vtkEchoregDicomSeriesReader() = default;

void vtkEchoregDicomSeriesReader::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "DirectoryName: " << this->DirectoryName << "\n";
  os << indent << "SeriesUid: " << this->SeriesUid << "\n";
  os << indent << "ResampleToUniform: " << this->ResampleToUniform << "\n";
  os << indent << "ResampleSpacing: " << this->ResampleSpacing << "\n";
  os << indent << "Group: " << this->Group << "\n";
}

void vtkEchoregDicomSeriesReader::SetDirectoryName(const std::string& folder) {
  if (this->DirectoryName == folder)
    return;
  this->DirectoryName = folder;
  this->Modified();
}

void vtkEchoregDicomSeriesReader::SetSeriesUid(const std::string& uid) {
  if (this->SeriesUid == uid)
    return;
  this->SeriesUid = uid;
  this->Modified();
}

void vtkEchoregDicomSeriesReader::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

echoreg::core::CtImage vtkEchoregDicomSeriesReader::OutputGeometry(
    const echoreg::core::CtImage& series) const {
  using namespace echoreg::segmentation;
  if (this->ResampleToUniform)
    return resampledGeometry(series, this->ResampleSpacing);
  if (this->Group >= 0) {
    if (static_cast<std::size_t>(this->Group) >= series.groups.size()) {
      throw echoreg::core::FileError(
          series.folder, "has " + std::to_string(series.groups.size()) + " slice group(s); group " +
                             std::to_string(this->Group) + " does not exist");
    }
    return extractSliceGroup(geometryOnly(series), this->Group);
  }
  if (!series.uniform()) {
    std::string groups;
    for (const echoreg::core::CtSliceGroup& g : series.groups) {
      groups += (groups.empty() ? "" : ", ") + std::to_string(g.count) + " at " +
                std::to_string(g.spacingMm) + " mm";
    }
    throw echoreg::core::FileError(series.folder,
                                   "has slices of several spacings (" + groups +
                                       "): turn ResampleToUniform on or choose one Group");
  }
  return geometryOnly(series);
}

int vtkEchoregDicomSeriesReader::RequestInformation(vtkInformation* /*request*/,
                                                    vtkInformationVector** /*inputVector*/,
                                                    vtkInformationVector* outputVector) {
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  try {
    if (this->DirectoryName.empty())
      throw std::invalid_argument("no directory name set");
    echoreg::segmentation::DicomReadOptions options;
    options.seriesUid = this->SeriesUid;
    echoreg::segmentation::DicomSeriesRead read =
        echoreg::segmentation::readDicomSeriesGeometry(this->DirectoryName, options);
    this->SeriesGeometry = std::move(read.image);
    this->Warnings = std::move(read.warnings);
    const echoreg::core::CtImage geometry = this->OutputGeometry(this->SeriesGeometry);
    const int extent[6] = {0, geometry.dimensions[0] - 1, 0, geometry.dimensions[1] - 1,
                           0, geometry.dimensions[2] - 1};
    const Eigen::Vector3d spacing = geometry.spacingMm();
    const double spacingArray[3] = {spacing.x(), spacing.y(), spacing.z()};
    const double origin[3] = {geometry.originMm.x(), geometry.originMm.y(), geometry.originMm.z()};
    double direction[9];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        direction[3 * r + c] = geometry.direction(r, c);
    }
    outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
    outInfo->Set(vtkDataObject::SPACING(), spacingArray, 3);
    outInfo->Set(vtkDataObject::ORIGIN(), origin, 3);
    outInfo->Set(vtkDataObject::DIRECTION(), direction, 9);
    vtkDataObject::SetPointDataActiveScalarInfo(outInfo, VTK_SHORT, 1);
  } catch (const std::exception& e) {
    this->Fail(e.what());
    if (vtkDataObject* output = outInfo->Get(vtkDataObject::DATA_OBJECT()))
      output->Initialize();
    return 0;
  }
  return 1;
}

int vtkEchoregDicomSeriesReader::RequestData(vtkInformation* /*request*/,
                                             vtkInformationVector** /*inputVector*/,
                                             vtkInformationVector* outputVector) {
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkImageData* output = vtkImageData::GetData(outInfo);
  if (output == nullptr) {
    this->Fail("the output is not a vtkImageData");
    return 0;
  }
  try {
    using namespace echoreg::segmentation;
    DicomReadOptions options;
    options.seriesUid = this->SeriesUid;
    DicomSeriesRead read = readDicomSeriesWithWarnings(this->DirectoryName, options);
    this->Warnings = std::move(read.warnings);
    echoreg::core::CtImage image = std::move(read.image);
    this->OutputGeometry(image);  // throws for a non-uniform series without resampling or group
    if (this->ResampleToUniform) {
      image = echoreg::core::resampleUniform(image, this->ResampleSpacing);
    } else if (this->Group >= 0) {
      image = extractSliceGroup(image, this->Group);
    }
    vtkSmartPointer<vtkImageData> data = toImageData(std::move(image));
    output->ShallowCopy(data);
    this->LastError.clear();
  } catch (const std::exception& e) {
    this->Fail(e.what());
    output->Initialize();
    return 0;
  }
  return 1;
}
