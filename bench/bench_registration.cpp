// Surface registration side by side on the SAME simulated trials of the real femur
// (../shared/data/meshes/femur.stl; tests/support/registration_trials.hpp): VTK's
// vtkIterativeClosestPointTransform in rigid mode, echoreg's plain ICP (the dissertation's), and
// echoreg's robust registration without and with the speed-of-sound scale (and with 4 restarts).
// Printed first: the error at the knee centre over the trials (median, 95th percentile, max,
// failures > 3 mm), the rotation error and the time per registration, for two settings:
//   A: 120 beams, 0.3 mm depth noise (the settings of
//   tests/filters/test_surface_registration_femur) B: 60 beams, 0.4 mm depth noise
// both with 10 % false echoes of 3-15 mm, the true speed of sound 3 % above the assumed, and an
// initial pose 3-6 deg / 3-6 mm off about the knee centre.
// Then Google Benchmark timings of one registration of 50 beams on the femur subdivided to
// 325k triangles (every edge cut in 4), per method.
//
//   bench_registration [--trials N] [--benchmark_filter=robust]

#include "registration_trials.hpp"
#include "test_support.hpp"

#include "echoreg/core/surface_registration.hpp"
#include "echoreg/filters/mesh_io.h"

#include <benchmark/benchmark.h>
#include <vtkCellLocator.h>
#include <vtkIterativeClosestPointTransform.h>
#include <vtkLandmarkTransform.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace {

using echoreg::core::SurfaceMethod;
using echoreg::core::SurfacePoint;
using echoreg::core::SurfaceRegistration;
using echoreg::core::SurfaceRegistrationOptions;
using echoreg::test::RegistrationTrial;

// VTK's ICP, rigid (its default mode estimates a similarity: SetModeToRigidBody), from the
// initial pose: the points mapped by the initial pose are the source, the model the target; the
// estimate is the ICP transform times the initial pose. Closest points on the cells (its
// vtkCellLocator), mean distance as the stopping rule, 100 iterations at most.
class VtkIcp {
 public:
  explicit VtkIcp(const echoreg::core::TriangleMesh& mesh)
      : target_(echoreg::filters::toPolyData(mesh)) {}

  Eigen::Isometry3d run(const std::vector<SurfacePoint>& points,
                        const Eigen::Isometry3d& initial) const {
    vtkNew<vtkPoints> sourcePoints;
    for (const SurfacePoint& p : points) {
      const Eigen::Vector3d q = initial * p.point;
      sourcePoints->InsertNextPoint(q.x(), q.y(), q.z());
    }
    vtkNew<vtkPolyData> source;
    source->SetPoints(sourcePoints);
    vtkNew<vtkIterativeClosestPointTransform> icp;
    icp->SetSource(source);
    icp->SetTarget(target_);
    icp->GetLandmarkTransform()->SetModeToRigidBody();
    icp->SetMaximumNumberOfIterations(100);
    icp->SetMaximumNumberOfLandmarks(static_cast<int>(points.size()));
    icp->CheckMeanDistanceOn();
    icp->SetMeanDistanceModeToRMS();
    icp->SetMaximumMeanDistance(1e-4);
    icp->StartByMatchingCentroidsOff();
    icp->Modified();
    icp->Update();
    vtkMatrix4x4* m = icp->GetMatrix();
    Eigen::Matrix4d matrix;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c)
        matrix(r, c) = m->GetElement(r, c);
    }
    Eigen::Isometry3d t;
    t.matrix() = matrix;
    return t * initial;
  }

 private:
  vtkSmartPointer<vtkPolyData> target_;
};

struct Model {
  std::unique_ptr<SurfaceRegistration> registration;
  std::unique_ptr<VtkIcp> icp;
  std::unique_ptr<echoreg::test::FemurTrials> trials;
};

// The femur (levels = 1) or the femur with every edge cut in `parts`; nullptr without the file.
const Model* femur(int parts) {
  static std::vector<std::unique_ptr<Model>> models(8);
  std::unique_ptr<Model>& slot = models.at(static_cast<std::size_t>(parts));
  if (!slot) {
    const std::string path = echoreg::test::sharedDataFile("meshes/femur.stl");
    if (path.empty())
      return nullptr;
    echoreg::core::TriangleMesh mesh = echoreg::filters::readMesh(path);
    if (parts > 1)
      mesh = echoreg::test::subdivided(mesh, parts);
    slot = std::make_unique<Model>();
    slot->registration = std::make_unique<SurfaceRegistration>(mesh);
    slot->icp = std::make_unique<VtkIcp>(mesh);
    slot->trials = std::make_unique<echoreg::test::FemurTrials>(slot->registration->locator());
  }
  return slot.get();
}

struct Method {
  const char* name;
  std::function<Eigen::Isometry3d(const Model&, const RegistrationTrial&)> run;
};

std::vector<Method> methods() {
  return {
      {"VTK ICP (rigid)",
       [](const Model& m, const RegistrationTrial& t) { return m.icp->run(t.points, t.initial); }},
      {"echoreg plain",
       [](const Model& m, const RegistrationTrial& t) {
         SurfaceRegistrationOptions o;
         o.method = SurfaceMethod::Plain;
         o.initial = t.initial;
         return m.registration->registerPoints(t.points, {}, o).transform;
       }},
      {"echoreg robust",
       [](const Model& m, const RegistrationTrial& t) {
         SurfaceRegistrationOptions o;
         o.initial = t.initial;
         return m.registration->registerPoints(t.points, {}, o).transform;
       }},
      {"echoreg robust + speed",
       [](const Model& m, const RegistrationTrial& t) {
         SurfaceRegistrationOptions o;
         o.initial = t.initial;
         o.fitSpeedOfSound = true;
         return m.registration->registerPoints(t.points, {}, o).transform;
       }},
      {"robust + speed, 4 rest.",
       [](const Model& m, const RegistrationTrial& t) {
         SurfaceRegistrationOptions o;
         o.initial = t.initial;
         o.fitSpeedOfSound = true;
         o.restarts = 4;
         return m.registration->registerPoints(t.points, {}, o).transform;
       }},
  };
}

void compare(int trialCount) {
  const Model* model = femur(1);
  if (model == nullptr) {
    std::printf("../shared/data/meshes/femur.stl is absent: no comparison\n");
    return;
  }
  struct Setting {
    const char* name;
    int points;
    double noise;
  };
  for (const Setting& setting : {Setting{"A: 120 beams, 0.3 mm noise", 120, 0.3},
                                 Setting{"B: 60 beams, 0.4 mm noise", 60, 0.4}}) {
    echoreg::test::TrialOptions options;
    options.points = setting.points;
    options.noiseMm = setting.noise;
    std::vector<RegistrationTrial> trials;
    for (int i = 0; i < trialCount; ++i)
      trials.push_back(model->trials->make(2008, i, options));
    std::printf(
        "\n%s, 10 %% false echoes, speed +3 %%, start 3-6 deg / 3-6 mm off; %d trials, femur %zu "
        "triangles\n",
        setting.name, trialCount, model->registration->locator().mesh().triangles.size());
    std::printf("%-24s %9s %9s %9s %9s %11s %10s\n", "method", "median", "95th", "max", "> 3 mm",
                "rot median", "ms median");
    for (const Method& method : methods()) {
      std::vector<double> knee, rotation, ms;
      int failures = 0;
      for (const RegistrationTrial& trial : trials) {
        const auto start = std::chrono::steady_clock::now();
        const Eigen::Isometry3d estimate = method.run(*model, trial);
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count());
        const echoreg::test::TrialError e =
            echoreg::test::trialError(trial.truth, estimate, model->trials->kneeCentre());
        knee.push_back(e.kneeMm);
        rotation.push_back(e.rotationDeg);
        failures += e.kneeMm > 3.0 ? 1 : 0;
      }
      std::printf("%-24s %7.3f mm %7.3f mm %7.2f mm %5d (%2.0f%%) %7.3f deg %8.2f\n", method.name,
                  echoreg::test::percentile(knee, 50), echoreg::test::percentile(knee, 95),
                  echoreg::test::percentile(knee, 100), failures, 100.0 * failures / trialCount,
                  echoreg::test::percentile(rotation, 50), echoreg::test::percentile(ms, 50));
    }
  }
  std::printf("\n");
}

// One registration of 50 beams on the femur cut to 325k triangles (trials cycle over 16).
void timed(benchmark::State& state, int methodIndex) {
  const Model* model = femur(4);
  if (model == nullptr) {
    state.SkipWithError("../shared/data/meshes/femur.stl is absent");
    return;
  }
  echoreg::test::TrialOptions options;
  options.points = 50;
  std::vector<RegistrationTrial> trials;
  for (int i = 0; i < 16; ++i)
    trials.push_back(model->trials->make(7, i, options));
  const Method method = methods().at(static_cast<std::size_t>(methodIndex));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(method.run(*model, trials[i++ % trials.size()]));
  }
  state.counters["triangles"] =
      static_cast<double>(model->registration->locator().mesh().triangles.size());
}

void BM_Register50_325k_VtkIcp(benchmark::State& state) {
  timed(state, 0);
}
void BM_Register50_325k_Plain(benchmark::State& state) {
  timed(state, 1);
}
void BM_Register50_325k_Robust(benchmark::State& state) {
  timed(state, 2);
}
void BM_Register50_325k_RobustSpeed(benchmark::State& state) {
  timed(state, 3);
}
void BM_Register50_325k_RobustSpeedRestarts4(benchmark::State& state) {
  timed(state, 4);
}

void BM_PrepareModel_325k(benchmark::State& state) {
  const std::string path = echoreg::test::sharedDataFile("meshes/femur.stl");
  if (path.empty()) {
    state.SkipWithError("../shared/data/meshes/femur.stl is absent");
    return;
  }
  const echoreg::core::TriangleMesh mesh =
      echoreg::test::subdivided(echoreg::filters::readMesh(path), 4);
  for (auto _ : state) {
    SurfaceRegistration model(mesh);
    benchmark::DoNotOptimize(&model);
  }
}

BENCHMARK(BM_Register50_325k_VtkIcp)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Register50_325k_Plain)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Register50_325k_Robust)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Register50_325k_RobustSpeed)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Register50_325k_RobustSpeedRestarts4)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PrepareModel_325k)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  int trials = 150;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--trials") == 0 && i + 1 < argc) {
      trials = std::atoi(argv[++i]);
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (trials > 0)
    compare(trials);
  int count = static_cast<int>(rest.size());
  benchmark::Initialize(&count, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
