// The zlib compression of a capture's pixels, as the end of a live session and writeSequence do
// it: one zlib stream at level 1 on one thread (the way before 2026-12-04) against
// core::deflateParallel's blocks on 1, 2 and every hardware thread. The input is the demo sweep's
// A-lines (4096 uint8 samples each, tests/support) repeated to 256 MB, in memory, so the disk is
// not measured. Reported: wall time (UseRealTime), bytes per second of input, and the compressed
// size as a fraction of the input.
//
//   bench_deflate [--benchmark_filter=Parallel]

#include "demo_capture.hpp"

#include "echoreg/core/parallel_deflate.hpp"
#include "echoreg/core/sequence.hpp"

#include <benchmark/benchmark.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using namespace echoreg;

const std::vector<std::uint8_t>& input() {
  static const std::vector<std::uint8_t> bytes = [] {
    test::DemoSweepOptions options;
    options.frames = 600;
    const core::Sequence sweep = test::makeDemoSweep(options);
    std::vector<std::uint8_t> out;
    const std::size_t total = std::size_t{256} << 20;
    out.reserve(total);
    while (out.size() < total) {
      const std::size_t n = std::min(sweep.pixels.size(), total - out.size());
      out.insert(out.end(), sweep.pixels.begin(),
                 sweep.pixels.begin() + static_cast<std::ptrdiff_t>(n));
    }
    return out;
  }();
  return bytes;
}

void OneStream(benchmark::State& state) {
  const std::vector<std::uint8_t>& in = input();
  std::vector<std::uint8_t> out(std::size_t{1} << 20);
  std::uint64_t produced = 0;
  for (auto _ : state) {
    z_stream zs{};
    if (deflateInit2(&zs, Z_BEST_SPEED, Z_DEFLATED, 15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
      throw std::runtime_error("deflateInit2");
    zs.next_in = const_cast<std::uint8_t*>(in.data());
    zs.avail_in = static_cast<uInt>(in.size());
    produced = 0;
    for (int status = Z_OK; status != Z_STREAM_END;) {
      zs.next_out = out.data();
      zs.avail_out = static_cast<uInt>(out.size());
      status = deflate(&zs, Z_FINISH);
      produced += out.size() - zs.avail_out;
    }
    deflateEnd(&zs);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * in.size()));
  state.counters["ratio"] = static_cast<double>(produced) / static_cast<double>(in.size());
}

void Parallel(benchmark::State& state) {
  const std::vector<std::uint8_t>& in = input();
  core::ParallelDeflateOptions options;
  options.level = Z_BEST_SPEED;
  options.threads = static_cast<int>(state.range(0));
  std::uint64_t produced = 0;
  for (auto _ : state) {
    produced = core::deflateParallel(
        in.size(),
        [&](std::uint64_t offset, std::uint8_t* to, std::size_t bytes) {
          std::memcpy(to, in.data() + offset, bytes);
        },
        [](const std::uint8_t*, std::size_t) {}, options);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * in.size()));
  state.counters["ratio"] = static_cast<double>(produced) / static_cast<double>(in.size());
  state.counters["threads"] = options.threads;
}

BENCHMARK(OneStream)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(2);
BENCHMARK(Parallel)
    ->Arg(1)
    ->Arg(2)
    ->Arg(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())))
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
