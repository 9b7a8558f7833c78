// vtkEchoregSurfaceRegistrationFilter: the core's registerPoints on points from a detection table
// or a point set, with optional landmarks; the model prepared once per model; points or model
// changed upstream re-run it; bad input through the executive.
#include "echoreg/core/surface_registration.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/filters/vtkEchoregSurfaceRegistrationFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTrivialProducer.h>

#include <Eigen/Geometry>

#include <random>
#include <sstream>

namespace echoreg::test {
namespace {

// An ellipsoid (semi-axes 40, 25, 15 mm): no symmetry a rigid motion could slide along.
core::TriangleMesh ellipsoid() {
  core::TriangleMesh mesh = core::uvSphere(Eigen::Vector3d::Zero(), 1.0, 24, 48);
  for (Eigen::Vector3d& v : mesh.vertices)
    v = Eigen::Vector3d(40.0 * v.x(), 25.0 * v.y(), 15.0 * v.z());
  return mesh;
}

Eigen::Isometry3d truthBoneToCt() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.rotate(Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 2, 3).normalized()));
  t.pretranslate(Eigen::Vector3d(2.0, -1.5, 1.0));
  return t;
}

// Points on the model's upper half (a probe reaches one side), in the bone frame.
std::vector<Eigen::Vector3d> bonePoints(int count, unsigned seed) {
  const core::TriangleMesh model = ellipsoid();
  std::mt19937 random(seed);
  std::uniform_int_distribution<std::size_t> pick(0, model.vertices.size() - 1);
  std::vector<Eigen::Vector3d> points;
  const Eigen::Isometry3d ctToBone = truthBoneToCt().inverse();
  while (static_cast<int>(points.size()) < count) {
    const Eigen::Vector3d v = model.vertices[pick(random)];
    if (v.z() > -5.0)
      points.push_back(ctToBone * v);
  }
  return points;
}

vtkSmartPointer<vtkTable> detectionTable(const std::vector<Eigen::Vector3d>& points) {
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkStringArray> status;
  status->SetName("status");
  vtkNew<vtkDoubleArray> x, y, z;
  x->SetName("x_mm");
  y->SetName("y_mm");
  z->SetName("z_mm");
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Every fifth row rejected upstream, at a point far off the surface: it must not be used.
    const bool rejected = i % 5 == 4;
    status->InsertNextValue(rejected ? "rejected" : "accepted");
    const Eigen::Vector3d p = rejected ? Eigen::Vector3d(500, 500, 500) : points[i];
    x->InsertNextValue(p.x());
    y->InsertNextValue(p.y());
    z->InsertNextValue(p.z());
  }
  table->AddColumn(status);
  table->AddColumn(x);
  table->AddColumn(y);
  table->AddColumn(z);
  return table;
}

TEST(SurfaceRegistrationFilter, EqualsRegisterPointsAndFindsTheTruth) {
  const std::vector<Eigen::Vector3d> points = bonePoints(150, 3);
  vtkNew<vtkEchoregSurfaceRegistrationFilter> filter;
  filter->SetInputData(0, detectionTable(points));
  filter->SetModelData(filters::toPolyData(ellipsoid()));
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");
  const core::SurfaceRegistrationResult& result = filter->GetLastResult();
  EXPECT_TRUE(result.converged) << result.message;

  std::vector<core::SurfacePoint> used;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i % 5 == 4)
      continue;
    core::SurfacePoint point;
    point.point = points[i];
    used.push_back(point);
  }
  const core::SurfaceRegistration model(ellipsoid());
  const core::SurfaceRegistrationResult expected =
      model.registerPoints(used, {}, core::SurfaceRegistrationOptions{});
  EXPECT_TRUE(result.transform.matrix() == expected.transform.matrix());
  EXPECT_EQ(result.rmsMm, expected.rmsMm);
  EXPECT_EQ(result.pointsUsed, expected.pointsUsed);
  const Eigen::Isometry3d error = truthBoneToCt().inverse() * result.transform;
  EXPECT_LT(error.translation().norm(), 0.05);
  EXPECT_LT(Eigen::AngleAxisd(error.rotation()).angle(), 1e-3);

  vtkPolyData* output = filter->GetOutput();
  EXPECT_EQ(output->GetNumberOfPoints(), static_cast<vtkIdType>(used.size()));
  auto* boneToCt = vtkDoubleArray::SafeDownCast(output->GetFieldData()->GetArray("BoneToCT"));
  ASSERT_NE(boneToCt, nullptr);
  EXPECT_EQ(boneToCt->GetComponent(0, 3), result.transform.translation().x()) << "row-major";
  EXPECT_NE(output->GetPointData()->GetArray("ResidualMm"), nullptr);
}

TEST(SurfaceRegistrationFilter, LandmarksAndPointSetsAreTheCoresInputsToo) {
  const std::vector<Eigen::Vector3d> points = bonePoints(120, 4);
  vtkNew<vtkPoints> vtkPointsIn;
  vtkPointsIn->SetDataTypeToDouble();  // float points would not be the core's inputs
  for (const Eigen::Vector3d& p : points)
    vtkPointsIn->InsertNextPoint(p.data());
  vtkNew<vtkPolyData> pointSet;
  pointSet->SetPoints(vtkPointsIn);
  vtkNew<vtkDoubleArray> sigmas;
  sigmas->SetName("SigmaMm");
  for (std::size_t i = 0; i < points.size(); ++i)
    sigmas->InsertNextValue(i % 2 == 0 ? 0.5 : 1.0);
  pointSet->GetPointData()->AddArray(sigmas);

  // Two landmarks: the ends of the long axis.
  vtkNew<vtkTable> landmarks;
  vtkNew<vtkStringArray> names;
  names->SetName("name");
  const char* keys[6] = {"bone_x_mm",  "bone_y_mm",  "bone_z_mm",
                         "model_x_mm", "model_y_mm", "model_z_mm"};
  vtkNew<vtkDoubleArray> columns[6];
  for (int k = 0; k < 6; ++k)
    columns[k]->SetName(keys[k]);
  std::vector<core::LandmarkPair> pairs;
  for (const double x : {40.0, -40.0}) {
    core::LandmarkPair pair;
    pair.name = x > 0 ? "front" : "back";
    pair.model = Eigen::Vector3d(x, 0, 0);
    pair.bone = truthBoneToCt().inverse() * pair.model;
    pairs.push_back(pair);
    names->InsertNextValue(pair.name);
    for (int axis = 0; axis < 3; ++axis) {
      columns[axis]->InsertNextValue(pair.bone[axis]);
      columns[axis + 3]->InsertNextValue(pair.model[axis]);
    }
  }
  landmarks->AddColumn(names);
  for (auto& column : columns)
    landmarks->AddColumn(column);

  vtkNew<vtkEchoregSurfaceRegistrationFilter> filter;
  filter->SetInputData(0, pointSet);
  filter->SetModelData(filters::toPolyData(ellipsoid()));
  filter->SetLandmarksData(landmarks);
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");

  std::vector<core::SurfacePoint> corePoints;
  for (std::size_t i = 0; i < points.size(); ++i) {
    core::SurfacePoint point;
    point.point = points[i];
    point.sigmaMm = i % 2 == 0 ? 0.5 : 1.0;
    corePoints.push_back(point);
  }
  const core::SurfaceRegistration model(ellipsoid());
  const core::SurfaceRegistrationResult expected =
      model.registerPoints(corePoints, pairs, core::SurfaceRegistrationOptions{});
  EXPECT_TRUE(filter->GetLastResult().transform.matrix() == expected.transform.matrix());
  ASSERT_EQ(filter->GetLastResult().landmarkResidualsMm.size(), 2U);
  EXPECT_LT(filter->GetLastResult().landmarkResidualsMm[0], 0.05);
}

TEST(SurfaceRegistrationFilter, NewPointsReRunItWithoutPreparingTheModelAgain) {
  vtkNew<vtkTrivialProducer> pointSource, modelSource;
  pointSource->SetOutput(detectionTable(bonePoints(100, 5)));
  modelSource->SetOutput(filters::toPolyData(ellipsoid()));
  vtkNew<vtkEchoregSurfaceRegistrationFilter> filter;
  filter->SetInputConnection(0, pointSource->GetOutputPort());
  filter->SetModelConnection(modelSource->GetOutputPort());
  filter->Update();
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 1);
  EXPECT_EQ(filter->GetModelPreparationCount(), 1);

  pointSource->SetOutput(detectionTable(bonePoints(90, 6)));
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 2);
  EXPECT_EQ(filter->GetModelPreparationCount(), 1) << "the same model";

  filter->SetMethod(core::SurfaceMethod::Plain);
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 3);
  EXPECT_EQ(filter->GetModelPreparationCount(), 1);

  modelSource->SetOutput(filters::toPolyData(ellipsoid()));
  filter->Update();
  EXPECT_EQ(filter->GetExecutionCount(), 4);
  EXPECT_EQ(filter->GetModelPreparationCount(), 2) << "a new model";
}

TEST(SurfaceRegistrationFilter, BadInputFailsThroughTheExecutive) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregSurfaceRegistrationFilter> filter;
  filter->SetInputData(0, detectionTable(bonePoints(2, 7)));
  filter->SetModelData(filters::toPolyData(ellipsoid()));
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("surface registration failed"), std::string::npos)
      << filter->GetLastError();

  // An open model (half the triangles) is refused by the core.
  core::TriangleMesh open = ellipsoid();
  open.triangles.resize(open.triangles.size() / 2);
  filter->SetInputData(0, detectionTable(bonePoints(50, 7)));
  filter->SetModelData(filters::toPolyData(open));
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("bad model"), std::string::npos) << filter->GetLastError();

  filter->SetModelData(filters::toPolyData(ellipsoid()));
  filter->SetPointSigmaMm(0.0);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("PointSigmaMm"), std::string::npos);
  filter->SetPointSigmaMm(0.5);
  EXPECT_EQ(filter->GetExecutive()->Update(), 1);
  EXPECT_EQ(filter->GetLastError(), "");
}

TEST(SurfaceRegistrationFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregSurfaceRegistrationFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name : {"Method", "Loss", "FitSpeedOfSound", "UseLandmarks", "Restarts",
                           "MaxIterations", "PointSigmaMm", "ModelPreparationCount"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
