// vtkEchoregPointToSurfaceDistance: the distances are MeshLocator's (a brute-force oracle over
// every triangle checks both), signed inside a closed surface, the locator built once per
// surface, and errors through the executive.
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/filters/vtkEchoregPointToSurfaceDistance.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkTrivialProducer.h>

#include <cmath>
#include <random>
#include <sstream>

namespace echoreg::test {
namespace {

// Distance from p to triangle (a, b, c) by projecting onto the plane and, outside it, onto the
// three edges: the slow, obvious oracle.
double pointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  const Eigen::Vector3d q = p - n * n.dot(p - a);
  const auto inside = [&](const Eigen::Vector3d& x) {
    return (b - a).cross(x - a).dot(n) >= 0 && (c - b).cross(x - b).dot(n) >= 0 &&
           (a - c).cross(x - c).dot(n) >= 0;
  };
  if (inside(q))
    return (p - q).norm();
  const auto segment = [&](const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
    const double t = std::clamp((p - u).dot(v - u) / (v - u).squaredNorm(), 0.0, 1.0);
    return (p - (u + t * (v - u))).norm();
  };
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

vtkSmartPointer<vtkPolyData> randomPoints(int count, double spreadMm, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-spreadMm, spreadMm);
  vtkNew<vtkPoints> points;
  for (int i = 0; i < count; ++i)
    points->InsertNextPoint(uniform(random), uniform(random), uniform(random));
  auto polyData = vtkSmartPointer<vtkPolyData>::New();
  polyData->SetPoints(points);
  return polyData;
}

TEST(PointToSurfaceDistance, EqualsTheLocatorAndABruteForceOracle) {
  const core::TriangleMesh sphere = core::uvSphere(Eigen::Vector3d(1, 2, 3), 20.0, 12, 24);
  vtkNew<vtkEchoregPointToSurfaceDistance> filter;
  filter->SetInputData(0, randomPoints(300, 35.0, 7));
  filter->SetSurfaceData(filters::toPolyData(sphere));
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");
  vtkPolyData* output = filter->GetOutput();
  ASSERT_EQ(output->GetNumberOfPoints(), 300);
  auto* distances = vtkDoubleArray::SafeDownCast(output->GetPointData()->GetArray("DistanceMm"));
  ASSERT_NE(distances, nullptr);
  const core::MeshLocator locator(sphere);
  double sumSquares = 0.0;
  for (vtkIdType id = 0; id < 300; ++id) {
    double p[3];
    output->GetPoint(id, p);
    const Eigen::Vector3d point(p[0], p[1], p[2]);
    EXPECT_EQ(distances->GetValue(id), locator.closest(point).distance) << id;
    double oracle = 1e30;
    for (const auto& t : sphere.triangles) {
      oracle =
          std::min(oracle, pointTriangleDistance(point, sphere.vertices[t[0]],
                                                 sphere.vertices[t[1]], sphere.vertices[t[2]]));
    }
    EXPECT_NEAR(distances->GetValue(id), oracle, 1e-9) << id;
    sumSquares += oracle * oracle;
  }
  EXPECT_NEAR(filter->GetLastResult().rmsMm, std::sqrt(sumSquares / 300.0), 1e-9);
  auto* rms = vtkDoubleArray::SafeDownCast(output->GetFieldData()->GetArray("DistanceRmsMm"));
  ASSERT_NE(rms, nullptr);
  EXPECT_EQ(rms->GetValue(0), filter->GetLastResult().rmsMm);
}

// The output's points are the input's, bit for bit: double points stay double (a float copy moved
// the registration figure's spheres by a fraction of a pixel), float points stay float.
TEST(PointToSurfaceDistance, OutputPointsKeepTheInputsPrecision) {
  const core::TriangleMesh sphere = core::uvSphere(Eigen::Vector3d(1, 2, 3), 20.0, 12, 24);
  for (const int type : {VTK_DOUBLE, VTK_FLOAT}) {
    SCOPED_TRACE(type == VTK_DOUBLE ? "double" : "float");
    vtkNew<vtkPoints> points;
    points->SetDataType(type);
    for (int i = 0; i < 20; ++i)
      points->InsertNextPoint(0.1 + 1e-9 * i, 25.0 / 3.0 + i, -std::sqrt(2.0) * i);
    vtkNew<vtkPolyData> input;
    input->SetPoints(points);
    vtkNew<vtkEchoregPointToSurfaceDistance> filter;
    filter->SetInputData(0, input);
    filter->SetSurfaceData(filters::toPolyData(sphere));
    filter->Update();
    ASSERT_EQ(filter->GetLastError(), "");
    vtkPoints* out = filter->GetOutput()->GetPoints();
    ASSERT_EQ(out->GetNumberOfPoints(), 20);
    EXPECT_EQ(out->GetDataType(), type);
    for (vtkIdType id = 0; id < 20; ++id) {
      double a[3], b[3];
      points->GetPoint(id, a);
      out->GetPoint(id, b);
      EXPECT_TRUE(a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) << "point " << id;
    }
  }
}

TEST(PointToSurfaceDistance, SignedDistancesAreNegativeInside) {
  const core::TriangleMesh sphere = core::uvSphere(Eigen::Vector3d::Zero(), 10.0);
  vtkNew<vtkPoints> points;
  points->InsertNextPoint(0, 0, 0);
  points->InsertNextPoint(0, 0, 15);
  vtkNew<vtkPolyData> pointData;
  pointData->SetPoints(points);
  vtkNew<vtkEchoregPointToSurfaceDistance> filter;
  filter->SetInputData(0, pointData);
  filter->SetSurfaceData(filters::toPolyData(sphere));
  filter->SignedDistanceOn();
  filter->Update();
  auto* distances =
      vtkDoubleArray::SafeDownCast(filter->GetOutput()->GetPointData()->GetArray("DistanceMm"));
  EXPECT_NEAR(distances->GetValue(0), -10.0, 0.05);
  EXPECT_NEAR(distances->GetValue(1), 5.0, 1e-6);
}

TEST(PointToSurfaceDistance, NewPointsReuseTheLocatorANewSurfaceRebuildsIt) {
  vtkNew<vtkTrivialProducer> pointSource, surfaceSource;
  pointSource->SetOutput(randomPoints(50, 30.0, 1));
  vtkSmartPointer<vtkPolyData> surface =
      filters::toPolyData(core::uvSphere(Eigen::Vector3d::Zero(), 20.0));
  surfaceSource->SetOutput(surface);
  vtkNew<vtkEchoregPointToSurfaceDistance> filter;
  filter->SetInputConnection(0, pointSource->GetOutputPort());
  filter->SetSurfaceConnection(surfaceSource->GetOutputPort());
  filter->Update();
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 1);
  EXPECT_EQ(filter->GetLocatorBuildCount(), 1);

  pointSource->SetOutput(randomPoints(60, 30.0, 2));
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 2);
  EXPECT_EQ(filter->GetLocatorBuildCount(), 1) << "the same surface";
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPoints(), 60);

  surfaceSource->SetOutput(filters::toPolyData(core::uvSphere(Eigen::Vector3d::Zero(), 25.0)));
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 3);
  EXPECT_EQ(filter->GetLocatorBuildCount(), 2) << "a new surface";
}

TEST(PointToSurfaceDistance, BadSurfaceFailsThroughTheExecutiveAndNoPointsWarns) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregPointToSurfaceDistance> filter;
  filter->SetInputData(0, randomPoints(5, 10.0, 3));
  vtkNew<vtkPolyData> empty;
  filter->SetSurfaceData(empty);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("no triangles"), std::string::npos)
      << filter->GetLastError();

  filter->SetSurfaceData(filters::toPolyData(core::uvSphere(Eigen::Vector3d::Zero(), 5.0)));
  vtkNew<vtkPolyData> none;
  filter->SetInputData(0, none);
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPoints(), 0);
  EXPECT_NE(messages.text().find("no points"), std::string::npos);
}

TEST(PointToSurfaceDistance, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregPointToSurfaceDistance> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"SignedDistance", "LastResult", "ExecutionCount", "LocatorBuildCount"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
