// Captures whose tracked poses are used as rigid transforms: read with the one rule of
// core/rigid_pose.hpp applied to the poses a command uses (issue 15, item 2).
#pragma once

#include "echoreg/core/rigid_pose.hpp"
#include "echoreg/core/sequence.hpp"

#include <ostream>
#include <string>
#include <vector>

namespace echoreg::cli {

/// What the rule did to the poses a command read: how many were re-orthonormalised, one line per
/// capture and transform where any was.
struct PoseNotes {
  int reorthonormalised = 0;
  std::vector<std::string> lines;

  /// The lines on `err` as "echoreg COMMAND: note: ...".
  void print(std::ostream& err, const std::string& command) const {
    for (const std::string& line : lines)
      err << "echoreg " << command << ": note: " << line << "\n";
  }
};

/// readSequence(path), then enforceRigidPoses() for each of `transforms` (empty names skipped).
/// Throws FileError naming the capture, the frame and the transform of a pose refused.
inline core::Sequence readTrackedSequence(const std::string& path,
                                          const std::vector<std::string>& transforms,
                                          PoseNotes& notes) {
  core::Sequence sequence = core::readSequence(path);
  for (const std::string& transform : transforms) {
    const core::RigidPoseReport report = core::enforceRigidPoses(sequence, path, transform);
    notes.reorthonormalised += report.reorthonormalised;
    if (auto line = core::rigidPoseNote(report, path, transform))
      notes.lines.push_back(*line);
  }
  return sequence;
}

}  // namespace echoreg::cli
