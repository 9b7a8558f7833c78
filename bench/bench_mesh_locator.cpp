// Speed of echoreg::core::MeshLocator beside VTK's vtkStaticCellLocator on the real femur
// (../shared/data/meshes/femur.stl, 20,308 triangles; the benchmarks skip when it is absent):
// building the hierarchy, a closest-point query (FindClosestPoint) and a first-hit query
// (IntersectWithLine), on the same queries. Also the build of a 327,680-triangle icosphere, and
// inside() and signedDistance(), which VTK's locator does not offer.
//
// Queries: 4096 points, half uniform in the femur's bounds grown by 20 mm and half within 2 mm
// of a random vertex; 4096 rays from the bounds grown by 30 mm toward a random vertex (+-1 mm),
// as a beam would go. Every timed iteration answers one query, so the time is ns per query.
// The "disagree" counter is the number of queries where the two answers differ by more than
// 1e-6 mm.
//
//   bench_mesh_locator [--benchmark_filter=closest]

#include "mesh_test_support.hpp"
#include "test_support.hpp"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/filters/mesh_io.h"

#include <benchmark/benchmark.h>
#include <vtkGenericCell.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkStaticCellLocator.h>

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace {

using echoreg::core::MeshLocator;
using echoreg::core::Rng;
using echoreg::core::TriangleMesh;

constexpr std::size_t kQueries = 4096;

struct Ray {
  Eigen::Vector3d origin, direction;
};

struct Scene {
  TriangleMesh mesh;
  vtkSmartPointer<vtkPolyData> polyData;
  std::optional<MeshLocator> locator;
  vtkSmartPointer<vtkStaticCellLocator> vtkLocator;
  std::vector<Eigen::Vector3d> points;
  std::vector<Ray> rays;
  double lineLengthMm = 0.0;  // VTK intersects segments: this long covers every ray
};

// The femur scene, built once; nullptr when the file is absent.
const Scene* femur() {
  static const std::optional<Scene> scene = []() -> std::optional<Scene> {
    const std::string path = echoreg::test::sharedDataFile("meshes/femur.stl");
    if (path.empty())
      return std::nullopt;
    Scene s;
    s.mesh = echoreg::filters::readMesh(path);
    s.polyData = echoreg::filters::toPolyData(s.mesh);
    s.locator.emplace(s.mesh);
    s.vtkLocator = vtkSmartPointer<vtkStaticCellLocator>::New();
    s.vtkLocator->SetDataSet(s.polyData);
    s.vtkLocator->BuildLocator();
    const auto box = echoreg::core::bounds(s.mesh);
    s.lineLengthMm = (box[1] - box[0]).norm() + 100.0;
    Rng rng = Rng::derive(2008, "bench-mesh-locator");
    auto inBox = [&](double margin) {
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k)
        p[k] = rng.uniform(box[0][k] - margin, box[1][k] + margin);
      return p;
    };
    auto nearVertex = [&](double spread) {
      return s.mesh.vertices[rng.below(s.mesh.vertices.size())] +
             Eigen::Vector3d(rng.uniform(-spread, spread), rng.uniform(-spread, spread),
                             rng.uniform(-spread, spread));
    };
    for (std::size_t i = 0; i < kQueries; ++i) {
      s.points.push_back(i % 2 == 0 ? inBox(20.0) : nearVertex(2.0));
      const Eigen::Vector3d origin = inBox(30.0);
      s.rays.push_back({origin, (nearVertex(1.0) - origin).normalized()});
    }
    return s;
  }();
  return scene ? &*scene : nullptr;
}

bool skipWithoutFemur(benchmark::State& state) {
  if (femur() != nullptr)
    return false;
  state.SkipWithError("../shared/data/meshes/femur.stl is absent");
  return true;
}

void reportQueries(benchmark::State& state) {
  state.SetItemsProcessed(state.iterations());
}

void BM_BuildFemur_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  for (auto _ : state) {
    MeshLocator locator(femur()->mesh);
    benchmark::DoNotOptimize(&locator);
  }
  state.counters["triangles"] = static_cast<double>(femur()->mesh.triangles.size());
}

void BM_BuildFemur_vtkStaticCellLocator(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  for (auto _ : state) {
    vtkNew<vtkStaticCellLocator> locator;
    locator->SetDataSet(femur()->polyData);
    locator->BuildLocator();
    benchmark::DoNotOptimize(locator.GetPointer());
  }
}

const TriangleMesh& bigSphere() {
  static const TriangleMesh mesh = echoreg::test::icosphere(25.0, 7);  // 327,680 triangles
  return mesh;
}

void BM_BuildIcosphere327k_echoreg(benchmark::State& state) {
  for (auto _ : state) {
    MeshLocator locator(bigSphere());
    benchmark::DoNotOptimize(&locator);
  }
  state.counters["triangles"] = static_cast<double>(bigSphere().triangles.size());
}

void BM_BuildIcosphere327k_vtkStaticCellLocator(benchmark::State& state) {
  static const vtkSmartPointer<vtkPolyData> polyData = echoreg::filters::toPolyData(bigSphere());
  for (auto _ : state) {
    vtkNew<vtkStaticCellLocator> locator;
    locator->SetDataSet(polyData);
    locator->BuildLocator();
    benchmark::DoNotOptimize(locator.GetPointer());
  }
}

void BM_Closest_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.locator->closest(s.points[i++ % kQueries]));
  }
  reportQueries(state);
}

void BM_Closest_vtkStaticCellLocator(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  vtkNew<vtkGenericCell> cell;
  double closest[3], dist2 = 0.0;
  vtkIdType cellId = -1;
  int subId = 0;
  std::size_t i = 0;
  for (auto _ : state) {
    s.vtkLocator->FindClosestPoint(s.points[i++ % kQueries].data(), closest, cell, cellId, subId,
                                   dist2);
    benchmark::DoNotOptimize(dist2);
  }
  reportQueries(state);
  // Agreement with echoreg on every query (outside the timing).
  int disagree = 0;
  for (const Eigen::Vector3d& p : s.points) {
    s.vtkLocator->FindClosestPoint(p.data(), closest, cell, cellId, subId, dist2);
    disagree += std::abs(std::sqrt(dist2) - s.locator->closest(p).distance) > 1e-6 ? 1 : 0;
  }
  state.counters["disagree"] = disagree;
}

void BM_FirstHit_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  std::size_t i = 0;
  for (auto _ : state) {
    const Ray& ray = s.rays[i++ % kQueries];
    benchmark::DoNotOptimize(s.locator->firstHit(ray.origin, ray.direction));
  }
  reportQueries(state);
}

void BM_FirstHit_vtkStaticCellLocator(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  vtkNew<vtkGenericCell> cell;
  double t = 0.0, x[3], pcoords[3];
  vtkIdType cellId = -1;
  int subId = 0;
  auto intersect = [&](const Ray& ray) {
    const Eigen::Vector3d end = ray.origin + s.lineLengthMm * ray.direction;
    return s.vtkLocator->IntersectWithLine(ray.origin.data(), end.data(), 0.0, t, x, pcoords, subId,
                                           cellId, cell);
  };
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(intersect(s.rays[i++ % kQueries]));
  }
  reportQueries(state);
  int disagree = 0;
  for (const Ray& ray : s.rays) {
    const int found = intersect(ray);
    const auto ours = s.locator->firstHit(ray.origin, ray.direction);
    if ((found != 0) != ours.has_value()) {
      ++disagree;
    } else if (ours && std::abs(t * s.lineLengthMm - ours->t) > 1e-6) {
      ++disagree;
    }
  }
  state.counters["disagree"] = disagree;
}

void BM_AllHits_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  std::size_t i = 0;
  for (auto _ : state) {
    const Ray& ray = s.rays[i++ % kQueries];
    benchmark::DoNotOptimize(s.locator->allHits(ray.origin, ray.direction));
  }
  reportQueries(state);
}

void BM_Inside_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  std::size_t i = 0;
  for (auto _ : state)
    benchmark::DoNotOptimize(s.locator->inside(s.points[i++ % kQueries]));
  reportQueries(state);
}

void BM_SignedDistance_echoreg(benchmark::State& state) {
  if (skipWithoutFemur(state))
    return;
  const Scene& s = *femur();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.locator->signedDistance(s.points[i++ % kQueries]));
  }
  reportQueries(state);
}

}  // namespace

BENCHMARK(BM_BuildFemur_echoreg)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildFemur_vtkStaticCellLocator)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildIcosphere327k_echoreg)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildIcosphere327k_vtkStaticCellLocator)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Closest_echoreg);
BENCHMARK(BM_Closest_vtkStaticCellLocator);
BENCHMARK(BM_FirstHit_echoreg);
BENCHMARK(BM_FirstHit_vtkStaticCellLocator);
BENCHMARK(BM_AllHits_echoreg);
BENCHMARK(BM_Inside_echoreg);
BENCHMARK(BM_SignedDistance_echoreg);

BENCHMARK_MAIN();
