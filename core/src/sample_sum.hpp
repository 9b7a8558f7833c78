// Sum of float samples with eight independent float partial sums, combined in double: a single
// running sum is bound by the latency of one addition per sample, eight lanes vectorise. The
// order is fixed, so the result is deterministic; integer samples (8/16-bit digitisers) sum
// exactly while a lane stays below 2^24.
#pragma once

namespace echoreg::core::detail {

inline double sumOfSamples(const float* values, int count) {
  float partial[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    for (int lane = 0; lane < 8; ++lane)
      partial[lane] += values[i + lane];
  }
  double sum = 0.0;
  for (float p : partial)
    sum += p;
  for (; i < count; ++i)
    sum += values[i];
  return sum;
}

}  // namespace echoreg::core::detail
