// Loading a long CT series (dissertation section 6.3.3: the long scan made the software crawl):
// 1000 slices of 512 x 512 (a 524 MB int16 volume) written once by the simulator's DICOM writer
// (a cheap synthetic volume, not the physics), then
//   - BM_CatFiles: reading every file's bytes (the floor: what `cat` costs, page cache warm),
//   - BM_AllocateVolume: a fresh zero-filled volume of that size (the page-fault floor),
//   - BM_ScanHeaders: readDicomSeriesGeometry (headers only),
//   - BM_ReadDicomSeries/threads:N: readDicomSeries,
//   - BM_VtkGdcmImageReader: Debian's vtkGDCMImageReader on the same files (sorted for it),
//   - BM_PeakMemory/<reader>: the peak resident memory (VmHWM) of a fresh process (this program
//     run again with --peak) that loads the series with that reader; reported with the process's
//     resident memory before loading (libraries), so peak - before is what the load costs.
// The series lives in ECHOREG_BENCH_DATA_DIR (the build folder) and is reused by later runs.
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/segmentation/vtkEchoregDicomSeriesReader.h"
#include "echoreg/simulation/ct.hpp"

#include <benchmark/benchmark.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkStringArray.h>
#ifdef ECHOREG_HAVE_VTKGDCM
#include <vtkGDCMImageReader.h>
#endif

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
constexpr int kSlices = 1000;
constexpr int kSize = 512;

std::string seriesFolder() {
  return std::string(ECHOREG_BENCH_DATA_DIR) + "/ct-1000x512";
}

double volumeMegabytes() {
  return static_cast<double>(kSlices) * kSize * kSize * 2.0 / 1e6;
}

// Writes the series once: a cylinder of "bone" in "soft tissue" in air, 1 mm slices.
void ensureSeries() {
  const std::string folder = seriesFolder();
  if (fs::exists(folder + "/IM001000.dcm"))
    return;
  fs::remove_all(folder);
  fs::create_directories(ECHOREG_BENCH_DATA_DIR);
  std::cerr << "writing the 1000-slice benchmark series into " << folder << " (once)\n";
  std::vector<double> z;
  for (int k = 0; k < kSlices; ++k)
    z.push_back(-500.0 + k);
  echoreg::core::CtImage v =
      echoreg::core::axialCtImage(kSize, kSize, 0.48, {-122.64, -122.64}, {{"leg", z, 1.0}});
  v.hu.resize(static_cast<std::size_t>(kSlices) * kSize * kSize);
  for (int k = 0; k < kSlices; ++k) {
    for (int j = 0; j < kSize; ++j) {
      for (int i = 0; i < kSize; ++i) {
        const int dx = i - 256, dy = j - 256 + (k % 50);
        const int r2 = dx * dx + dy * dy;
        v.hu[v.index(i, j, k)] = static_cast<std::int16_t>(r2 < 900     ? 1200
                                                           : r2 < 40000 ? 40 + (i + j + k) % 30
                                                                        : -1000);
      }
    }
  }
  echoreg::simulation::DicomSeriesInfo info;
  info.uidSeed = 1000;
  echoreg::simulation::writeDicomSeries(folder, v, info);
}

std::vector<std::string> seriesFiles() {
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(seriesFolder()))
    files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

void BM_CatFiles(benchmark::State& state) {
  const std::vector<std::string> files = seriesFiles();
  std::vector<char> buffer(1 << 20);
  std::size_t bytes = 0;
  for (auto _ : state) {
    bytes = 0;
    for (const std::string& file : files) {
      std::ifstream in(file, std::ios::binary);
      while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) ||
             in.gcount() > 0) {
        bytes += static_cast<std::size_t>(in.gcount());
      }
    }
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["MB"] = static_cast<double>(bytes) / 1e6;
}
BENCHMARK(BM_CatFiles)->Unit(benchmark::kMillisecond)->Iterations(3);

// The other floor: a fresh zero-filled int16 volume of that size (the kernel zeroes and maps every
// page on first touch), which any loader returning a new volume pays.
void BM_AllocateVolume(benchmark::State& state) {
  for (auto _ : state) {
    std::vector<std::int16_t> volume(static_cast<std::size_t>(kSlices) * kSize * kSize);
    benchmark::DoNotOptimize(volume.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_AllocateVolume)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ScanHeaders(benchmark::State& state) {
  for (auto _ : state) {
    const auto read = echoreg::segmentation::readDicomSeriesGeometry(seriesFolder());
    benchmark::DoNotOptimize(read.image.dimensions[2]);
  }
}
BENCHMARK(BM_ScanHeaders)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ReadDicomSeries(benchmark::State& state) {
  echoreg::segmentation::DicomReadOptions options;
  options.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const echoreg::core::CtImage image =
        echoreg::segmentation::readDicomSeries(seriesFolder(), options);
    benchmark::DoNotOptimize(image.hu.data());
  }
}
BENCHMARK(BM_ReadDicomSeries)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

#ifdef ECHOREG_HAVE_VTKGDCM
// vtkGDCMImageReader stacks files in the order given (and reports z spacing 1): give it the
// slice order our reader found, as an application would have to.
vtkSmartPointer<vtkStringArray> sortedNames() {
  const auto read = echoreg::segmentation::readDicomSeriesGeometry(seriesFolder());
  auto names = vtkSmartPointer<vtkStringArray>::New();
  for (const std::string& f : read.files)
    names->InsertNextValue(seriesFolder() + "/" + f);
  return names;
}

void BM_VtkGdcmImageReader(benchmark::State& state) {
  const auto names = sortedNames();
  for (auto _ : state) {
    vtkNew<vtkGDCMImageReader> reader;
    reader->SetFileNames(names);
    reader->FileLowerLeftOn();
    reader->Update();
    benchmark::DoNotOptimize(reader->GetOutput()->GetScalarPointer());
  }
}
BENCHMARK(BM_VtkGdcmImageReader)->Unit(benchmark::kMillisecond)->Iterations(3);
#endif

// ---- peak memory in a fresh process ---------------------------------------------------------

long statusKb(const char* key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  const std::size_t length = std::strlen(key);
  while (std::getline(status, line)) {
    if (line.compare(0, length, key) == 0)
      return std::stol(line.substr(length + 1));
  }
  return -1;
}

// Child mode: load with `reader`, print "before_kb peak_kb seconds".
int peakMode(const std::string& reader) {
  const long before = statusKb("VmRSS");
  const auto start = std::chrono::steady_clock::now();
  std::size_t voxels = 0;
  if (reader == "readDicomSeries") {
    voxels = echoreg::segmentation::readDicomSeries(seriesFolder()).hu.size();
  } else if (reader == "vtkEchoregDicomSeriesReader") {
    vtkNew<vtkEchoregDicomSeriesReader> r;
    r->SetDirectoryName(seriesFolder());
    r->Update();
    voxels = static_cast<std::size_t>(r->GetOutput()->GetNumberOfPoints());
#ifdef ECHOREG_HAVE_VTKGDCM
  } else if (reader == "vtkGDCMImageReader") {
    const auto names = sortedNames();
    vtkNew<vtkGDCMImageReader> r;
    r->SetFileNames(names);
    r->FileLowerLeftOn();
    r->Update();
    voxels = static_cast<std::size_t>(r->GetOutput()->GetNumberOfPoints());
#endif
  } else {
    std::cerr << "unknown reader " << reader << "\n";
    return 2;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << before << " " << statusKb("VmHWM") << " " << seconds << " " << voxels << "\n";
  return 0;
}

void BM_PeakMemory(benchmark::State& state, const std::string& reader) {
  double before = 0, peak = 0, seconds = 0, voxels = 0;
  for (auto _ : state) {
    const std::string command = "/proc/" + std::to_string(::getpid()) + "/exe --peak " + reader;
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
    char line[256] = {};
    if (!pipe || std::fgets(line, sizeof line, pipe.get()) == nullptr) {
      state.SkipWithError("the child process failed");
      return;
    }
    std::istringstream(line) >> before >> peak >> seconds >> voxels;
  }
  state.counters["before_MB"] = before * 1.024 / 1000.0;
  state.counters["peak_MB"] = peak * 1.024 / 1000.0;
  state.counters["load_MB"] = (peak - before) * 1.024 / 1000.0;
  state.counters["volume_MB"] = volumeMegabytes();
  state.counters["load_per_volume"] = (peak - before) * 1024.0 / 1e6 / volumeMegabytes();
  state.counters["child_s"] = seconds;
  state.counters["voxels_M"] = voxels / 1e6;
}
BENCHMARK_CAPTURE(BM_PeakMemory, readDicomSeries, std::string("readDicomSeries"))
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(BM_PeakMemory, vtkEchoregDicomSeriesReader,
                  std::string("vtkEchoregDicomSeriesReader"))
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
#ifdef ECHOREG_HAVE_VTKGDCM
BENCHMARK_CAPTURE(BM_PeakMemory, vtkGDCMImageReader, std::string("vtkGDCMImageReader"))
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
#endif

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--peak")
    return peakMode(argv[2]);
  ensureSeries();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv))
    return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
