// A tracked A-line sweep made by the project's own code, for `make demo` and the CLI tests until
// the simulator exists: the probe slides along the thigh at 100 Hz over soft tissue of varying
// thickness, mostly normal to the bone, with a stretch held too obliquely and a stretch where the
// camera loses the probe's markers.
#pragma once

#include "echoreg/core/sequence.hpp"

#include <cstdint>

namespace echoreg::test {

struct DemoSweepOptions {
  int frames = 600;
  std::uint64_t seed = 42;
  double frameRateHz = 100.0;
  double speedMmPerS = 20.0;
};

/// The sweep as a PLUS sequence: uint8 A-lines of 4096 samples at 50 MHz, ProbeToTracker poses
/// (frames 300-319 INVALID), timestamps, and echoreg's acquisition keys (50 MHz, 0 s, 1540 m/s).
/// `boneDepthMm`, when given, receives each frame's true bone depth (or -1 when the echo is lost).
core::Sequence makeDemoSweep(const DemoSweepOptions& options,
                             std::vector<double>* boneDepthMm = nullptr);

}  // namespace echoreg::test
