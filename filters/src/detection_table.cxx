#include "echoreg/filters/detection_table.h"

#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace echoreg::filters {

namespace {

constexpr core::RejectReason kAllReasons[] = {
    core::RejectReason::None,          core::RejectReason::NoPeak,
    core::RejectReason::TooManyPeaks,  core::RejectReason::TooFewPeaks,
    core::RejectReason::OutsideWindow, core::RejectReason::NotBone,
    core::RejectReason::Inconsistent,  core::RejectReason::TooClose,
    core::RejectReason::InvalidPose,   core::RejectReason::InRingDown,
};

core::RejectReason reasonNamed(const std::string& name) {
  for (core::RejectReason reason : kAllReasons) {
    if (core::rejectReasonName(reason) == name)
      return reason;
  }
  throw std::invalid_argument("the detection table holds an unknown reason \"" + name + "\"");
}

template <typename Array>
Array* requiredColumn(vtkTable* table, const char* name) {
  auto* column = Array::SafeDownCast(table->GetColumnByName(name));
  if (column == nullptr) {
    throw std::invalid_argument(std::string("the detection table has no column \"") + name + "\"");
  }
  return column;
}

}  // namespace

bool hasTrackedPoints(vtkTable* table) {
  auto* frame = vtkStringArray::SafeDownCast(table->GetFieldData()->GetAbstractArray("PointFrame"));
  return frame != nullptr && frame->GetNumberOfValues() == 1 && frame->GetValue(0) != "Beam";
}

core::SequenceDetection sequenceDetectionOf(vtkTable* table) {
  if (table == nullptr)
    throw std::invalid_argument("no detection table");
  auto* frames = requiredColumn<vtkDataArray>(table, "frame");
  auto* timestamps = requiredColumn<vtkDataArray>(table, "timestamp_s");
  auto* peaks = requiredColumn<vtkDataArray>(table, "peaks");
  auto* samples = requiredColumn<vtkDataArray>(table, "sample_index");
  auto* depths = requiredColumn<vtkDataArray>(table, "depth_mm");
  auto* reasons = requiredColumn<vtkStringArray>(table, "reason");
  auto* xs = requiredColumn<vtkDataArray>(table, "x_mm");
  auto* ys = requiredColumn<vtkDataArray>(table, "y_mm");
  auto* zs = requiredColumn<vtkDataArray>(table, "z_mm");

  core::SequenceDetection detection;
  const vtkIdType rows = table->GetNumberOfRows();
  detection.frames.reserve(static_cast<std::size_t>(rows));
  for (vtkIdType row = 0; row < rows; ++row) {
    core::FrameDetection frame;
    frame.frame = static_cast<int>(frames->GetComponent(row, 0));
    const double timestamp = timestamps->GetComponent(row, 0);
    if (!std::isnan(timestamp))
      frame.timestampS = timestamp;
    frame.reason = reasonNamed(reasons->GetValue(row));
    frame.peakCount = static_cast<int>(peaks->GetComponent(row, 0));
    const double sample = samples->GetComponent(row, 0);
    if (!std::isnan(sample))
      frame.sampleIndex = sample;
    if (frame.accepted()) {
      frame.depthMm = depths->GetComponent(row, 0);
      frame.pointMm = Eigen::Vector3d(xs->GetComponent(row, 0), ys->GetComponent(row, 0),
                                      zs->GetComponent(row, 0));
      ++detection.accepted;
    } else {
      ++detection.rejectedByReason[std::string(core::rejectReasonName(frame.reason))];
    }
    detection.frames.push_back(frame);
  }
  if (auto* echoes = vtkDataArray::SafeDownCast(
          table->GetFieldData()->GetAbstractArray("EchoesBeforeInterSignal"))) {
    detection.echoes = static_cast<int>(echoes->GetComponent(0, 0));
  }
  if (auto* fromContext = vtkDataArray::SafeDownCast(
          table->GetFieldData()->GetAbstractArray("EchoesFromContext"))) {
    detection.fromContext = static_cast<int>(fromContext->GetComponent(0, 0));
  }
  return detection;
}

}  // namespace echoreg::filters
