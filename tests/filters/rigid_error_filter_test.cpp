// vtkEchoregRigidErrorFilter: per-axis errors of estimates against a reference, equal to the
// core's rigidError and meanAbsoluteError; a new reference re-runs only the decomposition, not
// the registration upstream; bad input through the executive.
#include "echoreg/core/rigid_error.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/filters/vtkEchoregRigidErrorFilter.h"
#include "echoreg/filters/vtkEchoregSurfaceRegistrationFilter.h"
#include "filter_test_helpers.hpp"

#include <gtest/gtest.h>

#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTrivialProducer.h>

#include <Eigen/Geometry>

#include <sstream>

namespace echoreg::test {
namespace {

Eigen::Isometry3d pose(double angleRad, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.rotate(Eigen::AngleAxisd(angleRad, axis.normalized()));
  transform.pretranslate(t);
  return transform;
}

vtkSmartPointer<vtkTable> withTransforms(const std::vector<Eigen::Isometry3d>& transforms) {
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkDoubleArray> array;
  array->SetName("BoneToCT");
  array->SetNumberOfComponents(16);
  for (const Eigen::Isometry3d& transform : transforms) {
    const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> rowMajor = transform.matrix();
    array->InsertNextTuple(rowMajor.data());
  }
  table->GetFieldData()->AddArray(array);
  return table;
}

TEST(RigidErrorFilter, EqualsTheCoresDecompositionAndMeanOfAbsoluteValues) {
  const Eigen::Isometry3d reference = pose(0.3, {0, 0, 1}, {10, 20, -800});
  const std::vector<Eigen::Isometry3d> estimates = {
      reference * pose(0.02, {1, 0, 0}, {0.5, -0.2, 0.1}),
      reference * pose(-0.01, {0, 1, 1}, {-0.3, 0.4, 0.9})};
  vtkNew<vtkEchoregRigidErrorFilter> filter;
  filter->SetInputData(0, withTransforms(estimates));
  filter->SetInputData(1, withTransforms({reference}));
  filter->SetCentreCtMm(5, 15, -790);
  filter->AddTarget("hip_centre", 0, 0, -400);
  filter->Update();
  ASSERT_EQ(filter->GetLastError(), "");

  vtkTable* table = filter->GetOutput();
  ASSERT_EQ(table->GetNumberOfRows(), 3);
  std::vector<core::RigidError> expected;
  for (const Eigen::Isometry3d& estimate : estimates) {
    expected.push_back(core::rigidError(reference, estimate, {Eigen::Vector3d(0, 0, -400)},
                                        Eigen::Vector3d(5, 15, -790)));
  }
  const core::RigidError mean = core::meanAbsoluteError(expected);
  const char* columns[6] = {"tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg"};
  for (vtkIdType row = 0; row < 3; ++row) {
    const core::RigidError& e = row < 2 ? expected[static_cast<std::size_t>(row)] : mean;
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_EQ(table->GetValueByName(row, columns[axis]).ToDouble(), e.translationMm[axis]);
      EXPECT_EQ(table->GetValueByName(row, columns[axis + 3]).ToDouble(), e.rotationDeg[axis]);
    }
    EXPECT_EQ(table->GetValueByName(row, "target_hip_centre_mm").ToDouble(), e.targetErrorsMm[0]);
  }
  EXPECT_EQ(table->GetValueByName(2, "estimate").ToString(), "mean_abs");
  EXPECT_GT(expected[0].rotationDeg.x(), 1.0) << "the 0.02 rad about x is seen";
}

TEST(RigidErrorFilter, ANewReferenceDoesNotReRunTheRegistration) {
  // Points on an ellipsoid's upper half, moved by a known pose: a registration upstream.
  core::TriangleMesh model = core::uvSphere(Eigen::Vector3d::Zero(), 1.0, 24, 48);
  for (Eigen::Vector3d& v : model.vertices)
    v = Eigen::Vector3d(40.0 * v.x(), 25.0 * v.y(), 15.0 * v.z());
  const Eigen::Isometry3d truth = pose(0.04, {1, 2, 3}, {1.0, -1.0, 2.0});
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  for (std::size_t i = 0; i < model.vertices.size(); i += 7) {
    if (model.vertices[i].z() > -5.0)
      points->InsertNextPoint((truth.inverse() * model.vertices[i]).eval().data());
  }
  vtkNew<vtkPolyData> pointSet;
  pointSet->SetPoints(points);
  vtkNew<vtkEchoregSurfaceRegistrationFilter> registration;
  registration->SetInputData(0, pointSet);
  registration->SetModelData(filters::toPolyData(model));

  vtkNew<vtkTrivialProducer> reference;
  reference->SetOutput(withTransforms({truth}));
  vtkNew<vtkEchoregRigidErrorFilter> errors;
  errors->SetInputConnection(0, registration->GetOutputPort());
  errors->SetReferenceConnection(reference->GetOutputPort());
  errors->Update();
  ASSERT_EQ(errors->GetLastError(), "") << registration->GetLastError();
  EXPECT_LT(errors->GetLastResult().rows[0].translationMm.norm(), 0.05);

  reference->SetOutput(withTransforms({pose(0.0, {0, 0, 1}, {1.0, -1.0, 2.0})}));
  errors->Update();
  EXPECT_EQ(registration->GetExecutionCount(), 1) << "the registration is not run again";
  EXPECT_EQ(errors->GetExecutionCount(), 2);
  EXPECT_GT(errors->GetLastResult().rows[0].rotationDeg.norm(), 1.0);
}

TEST(RigidErrorFilter, BadInputFailsThroughTheExecutive) {
  CapturedVtkOutput messages;
  vtkNew<vtkEchoregRigidErrorFilter> filter;
  vtkNew<vtkTable> empty;
  filter->SetInputData(0, withTransforms({Eigen::Isometry3d::Identity()}));
  filter->SetInputData(1, empty);
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("reference input has no 16-component \"BoneToCT\""),
            std::string::npos)
      << filter->GetLastError();

  Eigen::Isometry3d sheared = Eigen::Isometry3d::Identity();
  sheared.matrix()(0, 1) = 0.3;
  filter->SetInputData(1, withTransforms({sheared}));
  EXPECT_EQ(filter->GetExecutive()->Update(), 0);
  EXPECT_NE(filter->GetLastError().find("error decomposition failed"), std::string::npos);
}

TEST(RigidErrorFilter, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregRigidErrorFilter> filter;
  std::ostringstream text;
  filter->Print(text);
  for (const char* name :
       {"EstimateArrayName", "ReferenceArrayName", "CentreCtMm", "Targets", "ExecutionCount"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

}  // namespace
}  // namespace echoreg::test
