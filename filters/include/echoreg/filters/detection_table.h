// The detection table of the A-line pipeline (reader -> envelope -> peaks -> beam points ->
// inter-signal) read back as the core's SequenceDetection, so that what the pipeline computed is
// reported, written and warned about by the same code as detectSequence's result.
#pragma once

#include "echoreg/core/sequence_detection.hpp"

class vtkTable;

namespace echoreg::filters {

/// The frames of a vtkEchoregInterSignalFilter output: frame, timestamp (absent when NaN),
/// reason, peaks, sample index (when the single-signal chain chose one), depth and point (only
/// when accepted); `accepted`, `rejectedByReason` (reasons that occur) and `echoes` (field data
/// "EchoesBeforeInterSignal"). `params` and `analysis` are left default: they are the caller's.
/// Throws std::invalid_argument naming a missing column or an unknown reason.
core::SequenceDetection sequenceDetectionOf(vtkTable* table);

/// Whether the table's points are tracked (field data "PointFrame" other than "Beam").
bool hasTrackedPoints(vtkTable* table);

}  // namespace echoreg::filters
