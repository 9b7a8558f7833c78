// Latency and throughput of a live session on loopback: `echoreg serve` streams a tracked A-line
// sweep (tests/support's demo sweep: 4096 uint8 samples per A-line, ProbeToTracker and
// FemurToTracker per frame) into `echoreg live`, both in this process. Reported per run, from the
// session's own measurements (--session-json): the latency from an A-line's arrival (its last byte
// read) to its point's POINT message sent (median, 99th percentile; frames that waited for the
// chain's adaptation excluded), the time from arrival to every frame's verdict, and the frames per
// second the session took in while the stream lasted (the final write and registration after it
// are not counted).
//
//   bench_live [--benchmark_filter=Recorded]
//
// Recorded/3000: 3000 A-lines a second for 5 s at their timestamps (the sustained rate,
// 30 elements x 100 Hz as single A-lines); Max: as fast as live reads. The model is a cube the
// sweep is not of, so the registration runs (on the second core) but does not converge; its cost
// is part of the measurement, its result is not.

#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/cli/cli.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/live/connection.hpp"

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <future>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace echoreg;

void writeInputs(const test::TempDir& dir, int frames, double rateHz) {
  test::DemoSweepOptions options;
  options.frames = frames;
  options.frameRateHz = rateHz;
  Sequence sweep = test::makeDemoSweep(options);
  for (SequenceFrame& frame : sweep.frames)
    frame.transforms["FemurToTracker"] = TrackedTransform{};
  writeSequence(sweep, dir.file("sweep.igs.mha"));
  std::ofstream cube(dir.file("cube.obj"));
  for (int i = 0; i < 8; ++i)
    cube << "v " << ((i & 1) ? 50 : -50) << " " << ((i & 2) ? 50 : -50) << " "
         << ((i & 4) ? 50 : -50) << "\n";
  cube << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  writeTransformFile(dir.file("BeamToProbe.json"),
                     {"Beam", "Probe", Eigen::Matrix4d::Identity(), {}}, false);
  writeTransformFile(dir.file("initial.json"), {"Femur", "CT", Eigen::Matrix4d::Identity(), {}},
                     false);
}

int run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  return cli::run(args, out, err);
}

void session(benchmark::State& state, const std::string& rate) {
  const double rateHz = static_cast<double>(state.range(0));
  const int frames = static_cast<int>(rateHz * 5.0);
  test::TempDir dir;
  writeInputs(dir, frames, rateHz);
  for (auto _ : state) {
    int port = 0;
    {
      live::Listener probe("127.0.0.1", 0);
      port = probe.port();
    }
    auto server = std::async(std::launch::async, [&] {
      return run({"serve", dir.file("sweep.igs.mha"), "--port", std::to_string(port), "--rate",
                  rate, "--wait", "20"});
    });
    run({"live", "--connect", "127.0.0.1:" + std::to_string(port), "--record",
         dir.file("rec.igs.mha"), "--model", dir.file("cube.obj"), "--calibration",
         dir.file("BeamToProbe.json"), "--initial", dir.file("initial.json"), "--out",
         dir.file("out.json"), "--session-json", dir.file("session.json"), "--idle-timeout", "10"});
    server.get();
    std::ifstream in(dir.file("session.json"));
    const nlohmann::json s = nlohmann::json::parse(in);
    const double seconds = s.at("stream_seconds").get<double>();
    state.SetIterationTime(seconds);
    state.counters["frames"] = s.at("frames").get<double>();
    state.counters["frames_per_s"] = s.at("frames").get<double>() / seconds;
    state.counters["points"] = s.at("latency_ms").at("count").get<double>();
    state.counters["latency_median_ms"] = s.at("latency_ms").at("median").get<double>();
    state.counters["latency_p99_ms"] = s.at("latency_ms").at("p99").get<double>();
    state.counters["latency_max_ms"] = s.at("latency_ms").at("max").get<double>();
    state.counters["decision_median_ms"] = s.at("decision_latency_ms").at("median").get<double>();
    state.counters["decision_p99_ms"] = s.at("decision_latency_ms").at("p99").get<double>();
    state.counters["registration_updates"] = s.at("registration_updates").get<double>();
  }
}

void Recorded(benchmark::State& state) {
  session(state, "recorded");
}
void Max(benchmark::State& state) {
  session(state, "max");
}

BENCHMARK(Recorded)->Arg(3000)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);
BENCHMARK(Max)->Arg(3000)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
