// The per-frame metadata of a PLUS sequence, kept in a vtkFieldData so that it travels down a
// pipeline beside the A-lines: the reader writes it, the envelope and peak filters pass it through
// and the inter-signal filter reads the poses from it.
//
// Layout, for a sequence of F frames (names are the constants of SequenceFieldData):
//   "Timestamp"          vtkDoubleArray, F tuples: seconds, NaN in frames without a timestamp.
//   "<Name>"             vtkDoubleArray, F tuples of 16 components: the 4x4 matrix of the
//                        transform <Name> (e.g. "ProbeToTracker", p_To = M * p_From), row-major;
//                        NaN in frames that do not carry that transform.
//   "<Name>_Valid"       vtkUnsignedCharArray, F tuples: 1 when the status is "OK", else 0.
//   "<Name>_Status"      vtkStringArray, F values: PLUS's status word verbatim ("OK", "INVALID",
//                        ...), "" in frames that do not carry that transform.
//   "SamplingFrequencyHz", "DelayS", "SpeedOfSoundMps"
//                        vtkDoubleArray, 1 tuple each, only when the file states the value.
//   "Transducer"         vtkStringArray, 1 value, only when the file names the transducer.
// A transform is recognised by its three arrays together (16-component doubles plus _Valid and
// _Status of matching lengths), so other arrays in the same field data are left alone.
#pragma once

#include "echoreg/core/sequence.hpp"

#include <vtkSmartPointer.h>
#include <vtkType.h>

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

class vtkFieldData;

namespace echoreg::filters {

/// Writes and reads the layout above. A reader object keeps a reference to its vtkFieldData;
/// it reads the arrays on every call, so it sees arrays added after it was made.
class SequenceFieldData {
 public:
  static constexpr const char* kTimestamp = "Timestamp";
  static constexpr const char* kValidSuffix = "_Valid";
  static constexpr const char* kStatusSuffix = "_Status";
  static constexpr const char* kSamplingFrequencyHz = "SamplingFrequencyHz";
  static constexpr const char* kDelayS = "DelayS";
  static constexpr const char* kSpeedOfSoundMps = "SpeedOfSoundMps";
  static constexpr const char* kTransducer = "Transducer";

  /// Adds (or replaces) the timestamps, transforms and acquisition settings of `sequence` in
  /// `fieldData`. Arrays of acquisition settings the sequence does not state are removed.
  static void write(const core::Sequence& sequence, vtkFieldData* fieldData);

  /// Reads `fieldData`, which may be null (then it holds nothing).
  explicit SequenceFieldData(vtkFieldData* fieldData);

  /// Frames described: tuples of "Timestamp", else of the first transform, else 0.
  vtkIdType frameCount() const;
  /// Timestamp of `frame` in seconds; NaN when absent or out of range.
  double timestampS(vtkIdType frame) const;

  /// Names of the transforms present, sorted.
  std::vector<std::string> transformNames() const;
  bool hasTransform(const std::string& name) const;
  /// Transform `name` of `frame` with its status word verbatim; nullopt when the field data has
  /// no such transform, `frame` is out of range, or that frame does not carry it.
  std::optional<core::TrackedTransform> transform(const std::string& name, vtkIdType frame) const;
  /// The matrix of transform `name` in `frame` when it is present and its status is OK.
  std::optional<Eigen::Matrix4d> validMatrix(const std::string& name, vtkIdType frame) const;

  /// The acquisition settings stored (absent ones stay unset).
  core::AcquisitionSettings acquisition() const;
  /// Timestamps and transforms of every frame, as a Sequence holds them (other per-frame fields
  /// are not carried in field data).
  std::vector<core::SequenceFrame> frames() const;

 private:
  vtkSmartPointer<vtkFieldData> fieldData_;
};

}  // namespace echoreg::filters
