// A capture of the blind generator (randomised_alines) as a PLUS sequence: its stored codes in
// their own sample type, its acquisition facts in the header, one frame per record with the
// generator's timestamps (and the probe's pose, where the capture is tracked, as
// "ProbeToTracker").
#pragma once

#include "randomised_alines.hpp"

#include "echoreg/core/sequence.hpp"

namespace echoreg::test {

core::Sequence randomisedSequence(const RandomisedCapture& capture);

}  // namespace echoreg::test
