// Latency and throughput of a live session on loopback: `echoreg serve` streams a tracked A-line
// sweep (tests/support's demo sweep: 4096 uint8 samples per A-line, ProbeToTracker and
// FemurToTracker per frame) into `echoreg live`, both in this process. Reported per run, from the
// session's own measurements (--session-json): the latency from an A-line's arrival (its last byte
// read) to its point's POINT message sent (median, 99th percentile; frames that waited for the
// chain's adaptation excluded), the time from arrival to every frame's verdict, and the frames per
// second the session took in while the stream lasted (the final write and registration after it
// are not counted), and the registration's rate: the worker's runs, timed from the first run's
// start to the last's (registration_hz; --update-hz caps it).
//
//   bench_live [--benchmark_filter=Recorded]
//   bench_live --soak-seconds=600 [--soak-rate=3000] [--soak-report-every=10]
//
// Recorded/3000: 3000 A-lines a second for 5 s at their timestamps (the sustained rate,
// 30 elements x 100 Hz as single A-lines); Max: as fast as live reads. The model is a cube the
// sweep is not of, so the registration runs (on the second core) but does not converge; its cost
// is part of the measurement, its result is not.
//
// --soak-seconds: instead of the benchmarks, one long session for memory: a server in this process
// streams the 600-frame demo sweep over and over (timestamps going on, ProbeToTracker and
// FemurToTracker per frame, the sweep's INVALID probe poses not sent) at --soak-rate A-lines a
// second into `echoreg live`, and every --soak-report-every seconds a line gives the frames sent,
// the process's resident memory (VmRSS) and its peak so far (VmHWM), and the size of the partial
// recording on disk. After the stream: live's own counts, and the time the final write and
// registration took.

#include "demo_capture.hpp"
#include "test_support.hpp"

#include "echoreg/cli/cli.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/live/connection.hpp"

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "echoreg/live/igtl_messages.hpp"

namespace {

using namespace echoreg;

void writeInputs(const test::TempDir& dir, int frames, double rateHz) {
  test::DemoSweepOptions options;
  options.frames = frames;
  options.frameRateHz = rateHz;
  core::Sequence sweep = test::makeDemoSweep(options);
  for (core::SequenceFrame& frame : sweep.frames)
    frame.transforms["FemurToTracker"] = core::TrackedTransform{};
  core::writeSequence(sweep, dir.file("sweep.igs.mha"));
  std::ofstream cube(dir.file("cube.obj"));
  for (int i = 0; i < 8; ++i)
    cube << "v " << ((i & 1) ? 50 : -50) << " " << ((i & 2) ? 50 : -50) << " "
         << ((i & 4) ? 50 : -50) << "\n";
  cube << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  core::writeTransformFile(dir.file("BeamToProbe.json"),
                           {"Beam", "Probe", Eigen::Matrix4d::Identity(), {}}, false);
  core::writeTransformFile(dir.file("initial.json"),
                           {"Femur", "CT", Eigen::Matrix4d::Identity(), {}}, false);
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
    // The worker's runs while points came and their rate, from the first run's start to the
    // last's (not diluted by the time before --min-points points had come).
    state.counters["registration_runs"] = s.at("registration_runs").get<double>();
    state.counters["registration_hz"] = s.at("registration_rate_hz").get<double>();
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

// VmRSS and VmHWM of this process, MB.
std::pair<double, double> residentMb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  double rss = 0.0, hwm = 0.0;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0)
      rss = std::stod(line.substr(6)) / 1024.0;
    else if (line.rfind("VmHWM:", 0) == 0)
      hwm = std::stod(line.substr(6)) / 1024.0;
  }
  return {rss, hwm};
}

double fileMb(const std::string& path) {
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  return ec ? 0.0 : static_cast<double>(bytes) / (1024.0 * 1024.0);
}

int soak(double seconds, double rateHz, double reportEveryS) {
  using Clock = std::chrono::steady_clock;
  test::TempDir dir;
  writeInputs(dir, 600, 100.0);
  const core::Sequence sweep = core::readSequence(dir.file("sweep.igs.mha"));
  const std::size_t frameBytes = sweep.samplesPerFrame() * core::elementSize(sweep.elementType);
  live::Listener listener("127.0.0.1", 0);
  const int port = listener.port();
  const auto total = static_cast<long>(seconds * rateHz);
  std::atomic<long> sent{0};
  std::atomic<bool> done{false};
  const Clock::time_point start = Clock::now();
  auto server = std::async(std::launch::async, [&] {
    std::optional<live::Connection> client = listener.accept(20.0);
    if (!client)
      return;
    // What live sends back is read and dropped, as serve and a PLUS server do.
    live::IncomingDiscarder discard(*client);
    try {
      for (long i = 0; i < total; ++i) {
        const double t = static_cast<double>(i) / rateHz;
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t)));
        const auto f = static_cast<std::size_t>(i % 600);
        for (const auto& [name, transform] : sweep.frames[f].transforms) {
          if (transform.valid())
            client->send(live::encodeTransform(name, transform.matrix, 1.0 + t));
        }
        client->send(live::encodeImage("Image", sweep.elementType,
                                       sweep.pixels.data() + f * frameBytes, sweep.frameSize[0], 1,
                                       1.0 + t));
        sent = i + 1;
      }
    } catch (const std::exception& e) {
      std::cerr << "soak server: " << e.what() << "\n";
    }
    discard.stop();
    client->closeGracefully(30.0);
  });
  auto reporter = std::async(std::launch::async, [&] {
    std::printf("%8s %10s %10s %10s %12s\n", "t_s", "frames", "rss_mb", "peak_mb", "partial_mb");
    Clock::time_point next = start;
    while (!done) {
      next +=
          std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(reportEveryS));
      while (!done && Clock::now() < next)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      const auto [rss, hwm] = residentMb();
      std::printf(
          "%8.1f %10ld %10.1f %10.1f %12.1f\n",
          std::chrono::duration<double>(Clock::now() - start).count(), sent.load(), rss, hwm,
          fileMb(dir.file("rec.igs.partial.raw")) + fileMb(dir.file("rec.igs.partial.mhd")));
      std::fflush(stdout);
    }
  });
  std::ostringstream out, err;
  const int code =
      cli::run({"live", "--connect", "127.0.0.1:" + std::to_string(port), "--record",
                dir.file("rec.igs.mha"), "--model", dir.file("cube.obj"), "--calibration",
                dir.file("BeamToProbe.json"), "--initial", dir.file("initial.json"), "--out",
                dir.file("out.json"), "--session-json", dir.file("session.json"), "--idle-timeout",
                "30", "--sampling-frequency", "50e6"},
               out, err);
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  server.get();
  done = true;
  reporter.get();
  std::ifstream in(dir.file("session.json"));
  const nlohmann::json s = nlohmann::json::parse(in);
  const auto [rss, hwm] = residentMb();
  std::printf(
      "live exit %d; %ld frames sent, %d taken in over %.1f s (%.0f/s), %d recorded (%.1f MB), "
      "latency median %.3f ms p99 %.2f ms over %d points, %d registration updates; final write "
      "and registration %.1f s; rss %.1f MB, peak %.1f MB\n",
      code, sent.load(), s.at("frames").get<int>(), s.at("stream_seconds").get<double>(),
      s.at("frames").get<double>() / s.at("stream_seconds").get<double>(),
      s.at("recorded_frames").get<int>(), fileMb(dir.file("rec.igs.mha")),
      s.at("latency_ms").at("median").get<double>(), s.at("latency_ms").at("p99").get<double>(),
      s.at("latency_ms").at("count").get<int>(), s.at("registration_updates").get<int>(),
      wall - s.at("stream_seconds").get<double>(), rss, hwm);
  if (code != 0) {  // e.g. the final registration on the cube the sweep is not of
    const std::string text = err.str();
    std::printf("live's stderr (end):\n%s\n",
                text.substr(text.size() > 1500 ? text.size() - 1500 : 0).c_str());
  }
  return s.at("recorded_frames").get<long>() == sent.load() ? 0 : 1;
}

// The value of --name=VALUE, removed from argv; `fallback` when absent.
double takeFlag(int& argc, char** argv, const std::string& name, double fallback) {
  const std::string prefix = "--" + name + "=";
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], prefix.c_str(), prefix.size()) == 0) {
      const double value = std::stod(argv[i] + prefix.size());
      for (int j = i; j + 1 < argc; ++j)
        argv[j] = argv[j + 1];
      --argc;
      return value;
    }
  }
  return fallback;
}

}  // namespace

int main(int argc, char** argv) {
  const double soakSeconds = takeFlag(argc, argv, "soak-seconds", 0.0);
  const double soakRate = takeFlag(argc, argv, "soak-rate", 3000.0);
  const double reportEvery = takeFlag(argc, argv, "soak-report-every", 10.0);
  if (soakSeconds > 0.0)
    return soak(soakSeconds, soakRate, reportEvery);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv))
    return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
