// Peak tables as vtkEchoregPeakFilter makes them, and tracked poses, for the tests of the filters
// downstream of it (beam points, inter-signal).
#pragma once

#include "echoreg/core/sequence.hpp"
#include "echoreg/filters/sequence_field_data.h"

#include <vtkDoubleArray.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

namespace echoreg::test {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A peak table as vtkEchoregPeakFilter makes it: one row per frame; a non-empty reason means the
// single-signal detection rejected the frame (its depth is then NaN).
inline vtkSmartPointer<vtkTable> peakTable(const std::vector<double>& depthsMm,
                                           const std::vector<std::string>& reasons,
                                           const core::Sequence& poses = core::Sequence()) {
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkIntArray> frames;
  frames->SetName("frame");
  vtkNew<vtkDoubleArray> depths;
  depths->SetName("depth_mm");
  vtkNew<vtkStringArray> reasonColumn;
  reasonColumn->SetName("reason");
  vtkNew<vtkDoubleArray> thresholds;
  thresholds->SetName("threshold");
  for (std::size_t row = 0; row < depthsMm.size(); ++row) {
    frames->InsertNextValue(static_cast<int>(row));
    depths->InsertNextValue(reasons[row].empty() ? depthsMm[row] : kNaN);
    reasonColumn->InsertNextValue(reasons[row]);
    thresholds->InsertNextValue(7.0);
  }
  table->AddColumn(frames);
  table->AddColumn(depths);
  table->AddColumn(reasonColumn);
  table->AddColumn(thresholds);
  filters::SequenceFieldData::write(poses, table->GetFieldData());
  return table;
}

inline core::Sequence probePoses(int frames, const std::vector<int>& invalidFrames = {}) {
  core::Sequence sequence;
  sequence.frames.resize(static_cast<std::size_t>(frames));
  for (int frame = 0; frame < frames; ++frame) {
    core::TrackedTransform probe;
    probe.matrix = Eigen::Matrix4d::Identity();
    probe.matrix(0, 3) = 10.0 * frame;
    probe.matrix(2, 3) = 100.0;
    if (std::find(invalidFrames.begin(), invalidFrames.end(), frame) != invalidFrames.end()) {
      probe.status = "INVALID";
    }
    sequence.frames[static_cast<std::size_t>(frame)].transforms["ProbeToTracker"] = probe;
    core::TrackedTransform femur;
    femur.matrix = Eigen::Matrix4d::Identity();
    femur.matrix.block<3, 3>(0, 0) =
        Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    femur.matrix.block<3, 1>(0, 3) = Eigen::Vector3d(1.0, 2.0, 3.0);
    sequence.frames[static_cast<std::size_t>(frame)].transforms["FemurToTracker"] = femur;
  }
  return sequence;
}

inline std::string reasonAt(vtkTable* table, vtkIdType row) {
  return vtkStringArray::SafeDownCast(table->GetColumnByName("reason"))->GetValue(row);
}
inline std::string statusAt(vtkTable* table, vtkIdType row) {
  return vtkStringArray::SafeDownCast(table->GetColumnByName("status"))->GetValue(row);
}
inline Eigen::Vector3d pointAt(vtkTable* table, vtkIdType row) {
  return {table->GetValueByName(row, "x_mm").ToDouble(),
          table->GetValueByName(row, "y_mm").ToDouble(),
          table->GetValueByName(row, "z_mm").ToDouble()};
}

}  // namespace echoreg::test
