#include "echoreg/filters/vtkEchoregSphereFitFilter.h"

#include "echoreg/filters/sequence_field_data.h"

#include <vtkDataObject.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkTable.h>

#include <cmath>
#include <exception>
#include <limits>

vtkStandardNewMacro(vtkEchoregSphereFitFilter);

namespace {

void addValue(vtkFieldData* fieldData, const char* name, double value) {
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->InsertNextValue(value);
  fieldData->AddArray(array);
}

bool sameNumber(double a, double b) {
  return std::isnan(a) ? std::isnan(b) : a == b;
}

}  // namespace

vtkEchoregSphereFitFilter::vtkEchoregSphereFitFilter()
    : BallRadiusMm(std::numeric_limits<double>::quiet_NaN()) {}

vtkEchoregSphereFitFilter::~vtkEchoregSphereFitFilter() = default;

void vtkEchoregSphereFitFilter::SetStylusTransformName(const std::string& name) {
  if (this->StylusTransformName == name)
    return;
  this->StylusTransformName = name;
  this->Modified();
}

void vtkEchoregSphereFitFilter::SetTipInStylusMm(double x, double y, double z) {
  const std::array<double, 3> tip{x, y, z};
  if (this->TipInStylusMm == tip)
    return;
  this->TipInStylusMm = tip;
  this->Modified();
}

void vtkEchoregSphereFitFilter::SetTipRadiusMm(double radius) {
  if (sameNumber(this->TipRadiusMm, radius))
    return;
  this->TipRadiusMm = radius;
  this->Modified();
}

void vtkEchoregSphereFitFilter::SetBallRadiusMm(double radius) {
  if (sameNumber(this->BallRadiusMm, radius))
    return;
  this->BallRadiusMm = radius;
  this->Modified();
}

void vtkEchoregSphereFitFilter::Fail(const std::string& message) {
  this->LastError = message;
  vtkErrorMacro(<< message);
}

int vtkEchoregSphereFitFilter::FillInputPortInformation(int /*port*/, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkDataObject");
  return 1;
}

int vtkEchoregSphereFitFilter::RequestData(vtkInformation* /*request*/,
                                           vtkInformationVector** inputVector,
                                           vtkInformationVector* outputVector) {
  ++this->ExecutionCount;
  vtkDataObject* input = vtkDataObject::GetData(inputVector[0]);
  vtkTable* output = vtkTable::GetData(outputVector);
  if (input == nullptr || output == nullptr) {
    this->Fail("needs an input with stylus poses in its field data and a vtkTable output");
    return 0;
  }
  if (!(this->TipRadiusMm >= 0.0) || !std::isfinite(this->TipRadiusMm)) {
    this->Fail("TipRadiusMm must be >= 0 mm, got " + std::to_string(this->TipRadiusMm));
    return 0;
  }
  if (!std::isnan(this->BallRadiusMm) && !(this->BallRadiusMm > 0.0)) {
    this->Fail("BallRadiusMm must be > 0 mm (or NaN to fit it), got " +
               std::to_string(this->BallRadiusMm));
    return 0;
  }
  const echoreg::filters::SequenceFieldData poses(input->GetFieldData());
  if (!poses.hasTransform(this->StylusTransformName)) {
    std::string known;
    for (const std::string& name : poses.transformNames())
      known += (known.empty() ? "" : ", ") + name;
    this->Fail("the input has no transform \"" + this->StylusTransformName +
               "\" (it has: " + (known.empty() ? "none" : known) + ")");
    return 0;
  }
  const Eigen::Vector3d tipInStylus(this->TipInStylusMm[0], this->TipInStylusMm[1],
                                    this->TipInStylusMm[2]);
  std::vector<Eigen::Vector3d> tips;
  std::vector<int> frames;
  for (vtkIdType frame = 0; frame < poses.frameCount(); ++frame) {
    if (auto matrix = poses.validMatrix(this->StylusTransformName, frame)) {
      Eigen::Isometry3d pose;
      pose.matrix() = *matrix;
      tips.push_back(pose * tipInStylus);
      frames.push_back(static_cast<int>(frame));
    }
  }
  echoreg::core::SphereFitOptions options;
  if (!std::isnan(this->BallRadiusMm))
    options.radiusMm = this->BallRadiusMm + this->TipRadiusMm;
  echoreg::core::SphereFit fit;
  try {
    fit = echoreg::core::fitSphere(tips, options);
  } catch (const std::exception& exception) {
    this->Fail(std::string("the stylus points give no sphere: ") + exception.what());
    return 0;
  }

  vtkNew<vtkIntArray> frameColumn;
  frameColumn->SetName("frame");
  vtkNew<vtkDoubleArray> x, y, z, residual;
  x->SetName("x_mm");
  y->SetName("y_mm");
  z->SetName("z_mm");
  residual->SetName("residual_mm");
  vtkNew<vtkIntArray> inlier;
  inlier->SetName("inlier");
  for (std::size_t i = 0; i < tips.size(); ++i) {
    frameColumn->InsertNextValue(frames[i]);
    x->InsertNextValue(tips[i].x());
    y->InsertNextValue(tips[i].y());
    z->InsertNextValue(tips[i].z());
    residual->InsertNextValue(fit.residualsMm[i]);
    inlier->InsertNextValue(fit.inlier[i] ? 1 : 0);
  }
  output->Initialize();
  for (vtkAbstractArray* column :
       std::initializer_list<vtkAbstractArray*>{frameColumn, x, y, z, residual, inlier}) {
    output->AddColumn(column);
  }
  vtkFieldData* fieldData = output->GetFieldData();
  vtkNew<vtkDoubleArray> centre;
  centre->SetName("SphereCentreMm");
  centre->SetNumberOfComponents(3);
  centre->InsertNextTuple(fit.centre.data());
  fieldData->AddArray(centre);
  addValue(fieldData, "SphereRadiusMm", fit.radiusMm - this->TipRadiusMm);
  addValue(fieldData, "RmsMm", fit.rmsMm);
  addValue(fieldData, "Inliers", fit.inliers);
  addValue(fieldData, "ConditionNumber", fit.conditionNumber);
  this->LastResult = std::move(fit);
  this->LastError.clear();
  return 1;
}

void vtkEchoregSphereFitFilter::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "StylusTransformName: " << this->StylusTransformName << "\n";
  os << indent << "TipInStylusMm: " << this->TipInStylusMm[0] << " " << this->TipInStylusMm[1]
     << " " << this->TipInStylusMm[2] << "\n";
  os << indent << "TipRadiusMm: " << this->TipRadiusMm << "\n";
  os << indent << "BallRadiusMm: " << this->BallRadiusMm << "\n";
  os << indent << "LastResult: centre " << this->LastResult.centre.transpose() << ", radius "
     << this->LastResult.radiusMm << " mm, RMS " << this->LastResult.rmsMm << " mm\n";
  os << indent << "LastError: " << (this->LastError.empty() ? "(none)" : this->LastError) << "\n";
  os << indent << "ExecutionCount: " << this->ExecutionCount << "\n";
}
