#include "echoreg/filters/sequence_field_data.h"

#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace echoreg::filters {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kMatrixComponents = 16;

void writeSetting(vtkFieldData* fieldData, const char* name, const std::optional<double>& value) {
  if (!value) {
    fieldData->RemoveArray(name);
    return;
  }
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(*value);
  fieldData->AddArray(array);
}

std::optional<double> readSetting(vtkFieldData* fieldData, const char* name) {
  auto* array = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray(name));
  if (array == nullptr || array->GetNumberOfTuples() < 1)
    return std::nullopt;
  return array->GetValue(0);
}

// The three arrays of one transform, or nulls when they are not all there and consistent.
struct TransformArrays {
  vtkDoubleArray* matrices = nullptr;
  vtkUnsignedCharArray* valid = nullptr;
  vtkStringArray* status = nullptr;
  explicit operator bool() const { return matrices != nullptr; }
};

TransformArrays transformArrays(vtkFieldData* fieldData, const std::string& name) {
  if (fieldData == nullptr)
    return {};
  auto* matrices = vtkDoubleArray::SafeDownCast(fieldData->GetAbstractArray(name.c_str()));
  auto* valid = vtkUnsignedCharArray::SafeDownCast(
      fieldData->GetAbstractArray((name + SequenceFieldData::kValidSuffix).c_str()));
  auto* status = vtkStringArray::SafeDownCast(
      fieldData->GetAbstractArray((name + SequenceFieldData::kStatusSuffix).c_str()));
  if (matrices == nullptr || valid == nullptr || status == nullptr ||
      matrices->GetNumberOfComponents() != kMatrixComponents ||
      valid->GetNumberOfTuples() != matrices->GetNumberOfTuples() ||
      status->GetNumberOfValues() != matrices->GetNumberOfTuples()) {
    return {};
  }
  return {matrices, valid, status};
}

}  // namespace

void SequenceFieldData::write(const core::Sequence& sequence, vtkFieldData* fieldData) {
  const auto frameCount = static_cast<vtkIdType>(sequence.frameCount());

  vtkNew<vtkDoubleArray> timestamps;
  timestamps->SetName(kTimestamp);
  timestamps->SetNumberOfValues(frameCount);
  for (vtkIdType frame = 0; frame < frameCount; ++frame) {
    const auto& timestamp = sequence.frames[static_cast<std::size_t>(frame)].timestampS;
    timestamps->SetValue(frame, timestamp.value_or(kNaN));
  }
  fieldData->AddArray(timestamps);

  for (const std::string& name : sequence.transformNames()) {
    vtkNew<vtkDoubleArray> matrices;
    matrices->SetName(name.c_str());
    matrices->SetNumberOfComponents(kMatrixComponents);
    matrices->SetNumberOfTuples(frameCount);
    vtkNew<vtkUnsignedCharArray> valid;
    valid->SetName((name + kValidSuffix).c_str());
    valid->SetNumberOfValues(frameCount);
    vtkNew<vtkStringArray> status;
    status->SetName((name + kStatusSuffix).c_str());
    status->SetNumberOfValues(frameCount);

    double rowMajor[kMatrixComponents];
    for (vtkIdType frame = 0; frame < frameCount; ++frame) {
      const auto& transforms = sequence.frames[static_cast<std::size_t>(frame)].transforms;
      const auto found = transforms.find(name);
      if (found == transforms.end()) {
        std::fill(std::begin(rowMajor), std::end(rowMajor), kNaN);
        valid->SetValue(frame, 0);
        status->SetValue(frame, "");
      } else {
        for (int row = 0; row < 4; ++row) {
          for (int col = 0; col < 4; ++col)
            rowMajor[row * 4 + col] = found->second.matrix(row, col);
        }
        valid->SetValue(frame, found->second.valid() ? 1 : 0);
        status->SetValue(frame, found->second.status);
      }
      matrices->SetTypedTuple(frame, rowMajor);
    }
    fieldData->AddArray(matrices);
    fieldData->AddArray(valid);
    fieldData->AddArray(status);
  }

  writeSetting(fieldData, kSamplingFrequencyHz, sequence.acquisition.samplingFrequencyHz);
  writeSetting(fieldData, kDelayS, sequence.acquisition.delayS);
  writeSetting(fieldData, kSpeedOfSoundMps, sequence.acquisition.speedOfSoundMps);
  if (sequence.acquisition.transducer.empty()) {
    fieldData->RemoveArray(kTransducer);
  } else {
    vtkNew<vtkStringArray> transducer;
    transducer->SetName(kTransducer);
    transducer->InsertNextValue(sequence.acquisition.transducer);
    fieldData->AddArray(transducer);
  }
}

SequenceFieldData::SequenceFieldData(vtkFieldData* fieldData) : fieldData_(fieldData) {}

vtkIdType SequenceFieldData::frameCount() const {
  if (fieldData_ == nullptr)
    return 0;
  if (auto* timestamps = vtkDoubleArray::SafeDownCast(fieldData_->GetAbstractArray(kTimestamp))) {
    return timestamps->GetNumberOfTuples();
  }
  const std::vector<std::string> names = transformNames();
  if (names.empty())
    return 0;
  return transformArrays(fieldData_, names.front()).matrices->GetNumberOfTuples();
}

double SequenceFieldData::timestampS(vtkIdType frame) const {
  if (fieldData_ == nullptr)
    return kNaN;
  auto* timestamps = vtkDoubleArray::SafeDownCast(fieldData_->GetAbstractArray(kTimestamp));
  if (timestamps == nullptr || frame < 0 || frame >= timestamps->GetNumberOfTuples())
    return kNaN;
  return timestamps->GetValue(frame);
}

std::vector<std::string> SequenceFieldData::transformNames() const {
  std::set<std::string> names;
  if (fieldData_ == nullptr)
    return {};
  for (int i = 0; i < fieldData_->GetNumberOfArrays(); ++i) {
    const char* name = fieldData_->GetAbstractArray(i)->GetName();
    if (name != nullptr && transformArrays(fieldData_, name))
      names.insert(name);
  }
  return {names.begin(), names.end()};
}

bool SequenceFieldData::hasTransform(const std::string& name) const {
  return static_cast<bool>(transformArrays(fieldData_, name));
}

std::optional<core::TrackedTransform> SequenceFieldData::transform(const std::string& name,
                                                                   vtkIdType frame) const {
  const TransformArrays arrays = transformArrays(fieldData_, name);
  if (!arrays || frame < 0 || frame >= arrays.matrices->GetNumberOfTuples())
    return std::nullopt;
  core::TrackedTransform result;
  result.status = arrays.status->GetValue(frame);
  if (result.status.empty())
    return std::nullopt;
  double rowMajor[kMatrixComponents];
  arrays.matrices->GetTypedTuple(frame, rowMajor);
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col)
      result.matrix(row, col) = rowMajor[row * 4 + col];
  }
  return result;
}

std::optional<Eigen::Matrix4d> SequenceFieldData::validMatrix(const std::string& name,
                                                              vtkIdType frame) const {
  const TransformArrays arrays = transformArrays(fieldData_, name);
  if (!arrays || frame < 0 || frame >= arrays.matrices->GetNumberOfTuples() ||
      arrays.valid->GetValue(frame) != 1) {
    return std::nullopt;
  }
  std::optional<core::TrackedTransform> tracked = transform(name, frame);
  if (!tracked || !tracked->matrix.allFinite())
    return std::nullopt;
  return tracked->matrix;
}

core::AcquisitionSettings SequenceFieldData::acquisition() const {
  core::AcquisitionSettings settings;
  if (fieldData_ == nullptr)
    return settings;
  settings.samplingFrequencyHz = readSetting(fieldData_, kSamplingFrequencyHz);
  settings.delayS = readSetting(fieldData_, kDelayS);
  settings.speedOfSoundMps = readSetting(fieldData_, kSpeedOfSoundMps);
  auto* transducer = vtkStringArray::SafeDownCast(fieldData_->GetAbstractArray(kTransducer));
  if (transducer != nullptr && transducer->GetNumberOfValues() > 0) {
    settings.transducer = transducer->GetValue(0);
  }
  return settings;
}

std::vector<core::SequenceFrame> SequenceFieldData::frames() const {
  std::vector<core::SequenceFrame> result(static_cast<std::size_t>(frameCount()));
  const std::vector<std::string> names = transformNames();
  for (std::size_t frame = 0; frame < result.size(); ++frame) {
    const auto frameId = static_cast<vtkIdType>(frame);
    const double timestamp = timestampS(frameId);
    if (!std::isnan(timestamp))
      result[frame].timestampS = timestamp;
    for (const std::string& name : names) {
      if (auto tracked = transform(name, frameId))
        result[frame].transforms[name] = *tracked;
    }
  }
  return result;
}

}  // namespace echoreg::filters
