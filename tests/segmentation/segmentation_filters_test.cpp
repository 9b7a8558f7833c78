// The CT-side algorithms as pipeline steps: CT -> vtkEchoregBoneGrowthFilter ->
// vtkEchoregBoneSurfaceFilter, and CT -> vtkEchoregLiveWireFilter. Each equals the segmentation
// function it adapts on the same CT; a change re-runs only what is downstream of it; errors go
// through the executive.
#include "echoreg/filters/mesh_io.h"
#include "echoreg/filters/sequence_field_data.h"
#include "echoreg/filters/vtkEchoregBeamPointsFilter.h"
#include "echoreg/filters/vtkEchoregInterSignalFilter.h"
#include "echoreg/filters/vtkEchoregSurfaceRegistrationFilter.h"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "echoreg/segmentation/vtkEchoregBoneGrowthFilter.h"
#include "echoreg/segmentation/vtkEchoregBoneSurfaceFilter.h"
#include "echoreg/segmentation/vtkEchoregCompetingBonesFilter.h"
#include "echoreg/segmentation/vtkEchoregDicomSeriesReader.h"
#include "echoreg/segmentation/vtkEchoregLiveWireFilter.h"

#include <gtest/gtest.h>

#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkStringOutputWindow.h>
#include <vtkTable.h>
#include <vtkTrivialProducer.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <sstream>

namespace {

using namespace echoreg;
using core::CtImage;

// VTK's messages into a string while it lives (the errors these tests provoke).
class QuietVtk {
 public:
  QuietVtk() : previous_(vtkOutputWindow::GetInstance()) {
    vtkOutputWindow::SetInstance(window_);
    vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  }
  ~QuietVtk() { vtkOutputWindow::SetInstance(previous_); }
  std::string text() const { return window_->GetOutput(); }

 private:
  vtkSmartPointer<vtkOutputWindow> previous_;
  vtkSmartPointer<vtkStringOutputWindow> window_ = vtkSmartPointer<vtkStringOutputWindow>::New();
};

// A hollow ellipsoidal "bone" (semi-axes 14, 10, 16 mm; cortex 2.5 mm of 1400 HU, marrow 80 HU)
// in soft tissue of 35 HU, on a grid of 0.8 x 0.8 x 1 mm, with partial volume (3^3 sub-samples).
CtImage ellipsoidCt() {
  const Eigen::Vector3i n(48, 40, 44);
  const Eigen::Vector3d spacing(0.8, 0.8, 1.0);
  CtImage ct;
  ct.dimensions = {n.x(), n.y(), n.z()};
  ct.pixelSpacingMm = spacing.head<2>();
  ct.originMm = Eigen::Vector3d(-20.0, -18.0, -500.0);
  for (int k = 0; k < n.z(); ++k)
    ct.slicePositionsMm.push_back(k * spacing.z());
  ct.groups = {{0, n.z(), spacing.z()}};
  const Eigen::Vector3d centre = ct.originMm + Eigen::Vector3d(19.0, 15.6, 21.5);
  const auto hu = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - centre).cwiseQuotient(Eigen::Vector3d(14, 10, 16));
    const double r = q.norm();
    if (r > 1.0)
      return 35.0;
    return r > 1.0 - 2.5 / 12.0 ? 1400.0 : 80.0;
  };
  ct.hu.resize(ct.voxelCount());
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d c = ct.voxelToLps(Eigen::Vector3d(i, j, k));
        double sum = 0.0;
        for (int a = -1; a <= 1; ++a) {
          for (int b = -1; b <= 1; ++b) {
            for (int d = -1; d <= 1; ++d)
              sum += hu(c + Eigen::Vector3d(a, b, d).cwiseProduct(spacing) / 3.0);
          }
        }
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>(std::lround(sum / 27.0));
      }
    }
  }
  return ct;
}

Eigen::Vector3d centreOf(const CtImage& ct) {
  return ct.originMm + Eigen::Vector3d(19.0, 15.6, 21.5);
}

std::vector<std::uint8_t> maskVoxels(vtkImageData* image) {
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  std::vector<std::uint8_t> voxels(static_cast<std::size_t>(scalars->GetNumberOfTuples()));
  for (std::size_t v = 0; v < voxels.size(); ++v)
    voxels[v] = static_cast<std::uint8_t>(scalars->GetComponent(static_cast<vtkIdType>(v), 0));
  return voxels;
}

struct SegmentationPipeline {
  CtImage ct = ellipsoidCt();
  vtkNew<vtkTrivialProducer> source;
  vtkNew<vtkEchoregBoneGrowthFilter> growth;
  vtkNew<vtkEchoregBoneSurfaceFilter> surface;
  vtkNew<vtkEchoregLiveWireFilter> liveWire;
  SegmentationPipeline() {
    source->SetOutput(segmentation::toImageData(ct));
    growth->SetInputConnection(source->GetOutputPort());
    const Eigen::Vector3d seed = centreOf(ct);
    growth->SetSeedLps(seed.x(), seed.y(), seed.z());
    surface->SetInputConnection(0, source->GetOutputPort());
    surface->SetRegionConnection(growth->GetOutputPort(0));
    surface->SetExcludeConnection(growth->GetOutputPort(1));
    liveWire->SetInputConnection(source->GetOutputPort());
  }
};

TEST(BoneGrowthFilter, EqualsGrowBone) {
  SegmentationPipeline pipeline;
  pipeline.growth->Update();
  ASSERT_EQ(pipeline.growth->GetLastError(), "");
  const segmentation::GrowResult expected =
      segmentation::growBone(pipeline.ct, centreOf(pipeline.ct));
  vtkImageData* mask = pipeline.growth->GetOutput(0);
  EXPECT_EQ(maskVoxels(mask), expected.mask.voxels);
  EXPECT_EQ(maskVoxels(pipeline.growth->GetOutput(1)), expected.others.voxels);
  EXPECT_EQ(pipeline.growth->GetLastResult().volumeMm3, expected.volumeMm3);
  EXPECT_EQ(pipeline.growth->GetLastResult().seedHu, 80) << "the seed lies in the marrow";
  const double ellipsoid = 4.0 / 3.0 * M_PI * 14 * 10 * 16;
  EXPECT_GT(expected.volumeMm3, 0.9 * ellipsoid);
  EXPECT_LT(expected.volumeMm3, 1.2 * ellipsoid);
  double origin[3];
  mask->GetOrigin(origin);
  EXPECT_EQ(origin[2], pipeline.ct.originMm.z()) << "the mask lies on the CT's grid";
  ASSERT_NE(mask->GetFieldData()->GetArray("VolumeMm3"), nullptr);
}

TEST(BoneSurfaceFilter, EqualsBoneSurfaceOnTheGrownRegion) {
  SegmentationPipeline pipeline;
  pipeline.surface->Update();
  ASSERT_EQ(pipeline.surface->GetLastError(), "") << pipeline.growth->GetLastError();
  const segmentation::GrowResult grown = segmentation::growBone(pipeline.ct, centreOf(pipeline.ct));
  const segmentation::BoneSurfaceResult expected =
      segmentation::boneSurface(pipeline.ct, grown.mask, &grown.others);
  vtkPolyData* output = pipeline.surface->GetOutput();
  ASSERT_EQ(output->GetNumberOfPoints(), static_cast<vtkIdType>(expected.mesh.vertices.size()));
  EXPECT_EQ(output->GetNumberOfPolys(), static_cast<vtkIdType>(expected.mesh.triangles.size()));
  for (vtkIdType id = 0; id < output->GetNumberOfPoints(); id += 97) {
    double p[3];
    output->GetPoint(id, p);
    const Eigen::Vector3d& v = expected.mesh.vertices[static_cast<std::size_t>(id)];
    EXPECT_NEAR(p[0], v.x(), 1e-5);  // vtkPoints of toPolyData: float
    EXPECT_NEAR(p[1], v.y(), 1e-5);
    EXPECT_NEAR(p[2], v.z(), 1e-4);
  }
  EXPECT_EQ(pipeline.surface->GetLastResult().isoHu, expected.isoHu);
  EXPECT_EQ(pipeline.surface->GetLastResult().components, 1);
}

TEST(LiveWireFilter, EqualsLiveWireContourAndContoursToMask) {
  SegmentationPipeline pipeline;
  const segmentation::GrowResult grown = segmentation::growBone(pipeline.ct, centreOf(pipeline.ct));
  const core::TriangleMesh mesh =
      segmentation::boneSurface(pipeline.ct, grown.mask, &grown.others).mesh;
  const std::vector<segmentation::AnchorSet> anchors =
      segmentation::proposeAnchors(mesh, segmentation::SlicePlane::Sagittal, 6);
  ASSERT_EQ(anchors.size(), 6U);
  pipeline.liveWire->SetAnchors(anchors);
  pipeline.liveWire->Update();
  ASSERT_EQ(pipeline.liveWire->GetLastError(), "");

  std::vector<segmentation::SliceContour> expected;
  for (const auto& set : anchors)
    expected.push_back(segmentation::liveWireContour(pipeline.ct, set));
  ASSERT_EQ(pipeline.liveWire->GetLastContours().size(), expected.size());
  for (std::size_t c = 0; c < expected.size(); ++c) {
    EXPECT_EQ(pipeline.liveWire->GetLastContours()[c].pointsLps, expected[c].pointsLps) << c;
  }
  vtkPolyData* contours = pipeline.liveWire->GetOutput(0);
  EXPECT_EQ(contours->GetNumberOfLines(), 6);
  const segmentation::VoxelMask mask = segmentation::contoursToMask(expected, pipeline.ct);
  EXPECT_EQ(maskVoxels(vtkImageData::SafeDownCast(pipeline.liveWire->GetOutputDataObject(1))),
            mask.voxels);
  EXPECT_GT(mask.count(), 1000U);
}

TEST(SegmentationPipeline, AChangeReRunsOnlyWhatIsDownstream) {
  SegmentationPipeline pipeline;
  const segmentation::GrowResult grown = segmentation::growBone(pipeline.ct, centreOf(pipeline.ct));
  pipeline.liveWire->SetAnchors(segmentation::proposeAnchors(
      segmentation::boneSurface(pipeline.ct, grown.mask, &grown.others).mesh,
      segmentation::SlicePlane::Sagittal, 4));
  pipeline.surface->Update();
  pipeline.liveWire->Update();
  const auto counts = [&] {
    return std::array<int, 3>{pipeline.growth->GetExecutionCount(),
                              pipeline.surface->GetExecutionCount(),
                              pipeline.liveWire->GetExecutionCount()};
  };
  EXPECT_EQ(counts(), (std::array<int, 3>{1, 1, 1}));

  pipeline.surface->SetSmoothingIterations(5);
  pipeline.surface->Update();
  pipeline.liveWire->Update();
  EXPECT_EQ(counts(), (std::array<int, 3>{1, 2, 1})) << "a surface setting: growth stays";

  const Eigen::Vector3d seed = centreOf(pipeline.ct) + Eigen::Vector3d(2.0, 0.0, 0.0);
  pipeline.growth->SetSeedLps(seed.x(), seed.y(), seed.z());
  pipeline.surface->Update();
  pipeline.liveWire->Update();
  EXPECT_EQ(counts(), (std::array<int, 3>{2, 3, 1})) << "a new seed: live-wire stays";

  pipeline.liveWire->SetSubpixelRefine(false);
  pipeline.surface->Update();
  pipeline.liveWire->Update();
  EXPECT_EQ(counts(), (std::array<int, 3>{2, 3, 2})) << "a live-wire setting only";
}

// Two hollow balls (radius 9 mm, cortex 2 mm) 24 mm apart, as two bones.
CtImage twoBallsCt() {
  CtImage ct;
  const Eigen::Vector3i n(60, 36, 36);
  ct.dimensions = {n.x(), n.y(), n.z()};
  ct.pixelSpacingMm = Eigen::Vector2d(0.8, 0.8);
  ct.originMm = Eigen::Vector3d(0, 0, -100);
  for (int k = 0; k < n.z(); ++k)
    ct.slicePositionsMm.push_back(0.8 * k);
  ct.groups = {{0, n.z(), 0.8}};
  ct.hu.resize(ct.voxelCount());
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d p = ct.voxelToLps(Eigen::Vector3d(i, j, k));
        double hu = 35.0;
        for (const double x : {12.0, 36.0}) {
          const double r = (p - Eigen::Vector3d(x, 14.0, -86.0)).norm();
          if (r <= 9.0)
            hu = r > 7.0 ? 1400.0 : 80.0;
        }
        ct.hu[ct.index(i, j, k)] = static_cast<std::int16_t>(hu);
      }
    }
  }
  return ct;
}

TEST(CompetingBonesFilter, EqualsSegmentCompetingBones) {
  const CtImage ct = twoBallsCt();
  vtkNew<vtkTrivialProducer> source;
  source->SetOutput(segmentation::toImageData(ct));
  vtkNew<vtkEchoregCompetingBonesFilter> bones;
  bones->SetInputConnection(source->GetOutputPort());
  bones->SetCheckPlausible(false);
  bones->AddSeed("left", 12.0, 14.0, -86.0);
  bones->AddSeed("right", 36.0, 14.0, -86.0);
  bones->SetSelectedBone("right");
  bones->Update();
  ASSERT_EQ(bones->GetLastError(), "");

  segmentation::CompetingOptions options;
  options.checkPlausible = false;
  const segmentation::CompetingResult expected = segmentation::segmentCompetingBones(
      ct, {{"left", Eigen::Vector3d(12, 14, -86)}, {"right", Eigen::Vector3d(36, 14, -86)}},
      options);
  ASSERT_EQ(expected.bones.size(), 2U);
  EXPECT_EQ(maskVoxels(bones->GetOutput(0)), expected.bones[1].mask.voxels) << "the selected";
  const std::vector<std::uint8_t> exclude = maskVoxels(bones->GetOutput(1));
  const std::vector<std::uint8_t> labels = maskVoxels(bones->GetOutput(2));
  for (std::size_t v = 0; v < exclude.size(); ++v) {
    if (expected.bones[0].mask.voxels[v] != 0) {
      ASSERT_EQ(exclude[v], 1) << "the other bone is excluded";
      ASSERT_EQ(labels[v], 1);
    }
    if (expected.bones[1].mask.voxels[v] != 0) {
      ASSERT_EQ(labels[v], 2);
    }
  }
  EXPECT_EQ(bones->GetLastResult().bones, (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(bones->GetLastResult().volumesMm3[1], expected.bones[1].volumeMm3);

  // The surface of the selected ball, excluding the other: a closed surface near radius 9.
  vtkNew<vtkEchoregBoneSurfaceFilter> surface;
  surface->SetInputConnection(0, source->GetOutputPort());
  surface->SetRegionConnection(bones->GetOutputPort(0));
  surface->SetExcludeConnection(bones->GetOutputPort(1));
  surface->Update();
  ASSERT_EQ(surface->GetLastError(), "");
  double bounds[6];
  surface->GetOutput()->GetBounds(bounds);
  EXPECT_NEAR(0.5 * (bounds[0] + bounds[1]), 36.0, 0.5) << "the right ball's surface";

  bones->SetSelectedBone("left");
  surface->Update();
  EXPECT_EQ(bones->GetExecutionCount(), 2);
  surface->GetOutput()->GetBounds(bounds);
  EXPECT_NEAR(0.5 * (bounds[0] + bounds[1]), 12.0, 0.5);
}

TEST(SegmentationFilters, BadInputFailsThroughTheExecutive) {
  QuietVtk quiet;
  SegmentationPipeline pipeline;
  pipeline.growth->SetSeedLps(0.0, 0.0, 0.0);  // far outside the CT
  EXPECT_EQ(pipeline.surface->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.growth->GetLastError().find("bone growth failed"), std::string::npos)
      << pipeline.growth->GetLastError();
  EXPECT_EQ(pipeline.surface->GetExecutionCount(), 0) << "nothing runs below a failure";

  EXPECT_EQ(pipeline.liveWire->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.liveWire->GetLastError().find("no anchors"), std::string::npos);
  pipeline.liveWire->SetAnchorsFileName("/nonexistent/anchors.mrk.json");
  EXPECT_EQ(pipeline.liveWire->GetExecutive()->Update(), 0);
  EXPECT_NE(pipeline.liveWire->GetLastError().find("/nonexistent/anchors.mrk.json"),
            std::string::npos)
      << pipeline.liveWire->GetLastError();
  EXPECT_NE(quiet.text().find("live-wire failed"), std::string::npos);

  vtkNew<vtkEchoregCompetingBonesFilter> bones;
  bones->SetInputConnection(pipeline.source->GetOutputPort());
  EXPECT_EQ(bones->GetExecutive()->Update(), 0);
  EXPECT_NE(bones->GetLastError().find("no seeds"), std::string::npos);
  bones->AddSeed("femur", 0.0, 0.0, 0.0);  // outside the CT
  EXPECT_EQ(bones->GetExecutive()->Update(), 0);
  EXPECT_NE(bones->GetLastError().find("bone segmentation failed"), std::string::npos)
      << bones->GetLastError();
}

TEST(SegmentationFilters, PrintSelfListsEveryParameter) {
  vtkNew<vtkEchoregBoneGrowthFilter> growth;
  vtkNew<vtkEchoregBoneSurfaceFilter> surface;
  vtkNew<vtkEchoregLiveWireFilter> liveWire;
  std::ostringstream text;
  growth->Print(text);
  surface->Print(text);
  liveWire->Print(text);
  for (const char* name :
       {"SeedLps", "StrongHu", "WeakHu", "SeparationRadiusMm", "MinVolumeMm3", "IsoHu", "BandMm",
        "SmoothingIterations", "TargetTriangles", "AnchorsFileName", "SubpixelRefine", "RasterMm"})
    EXPECT_NE(text.str().find(name), std::string::npos) << name;
}

// The study's shape in one process: CT -> bone growth -> bone surface = the model (input 1 of
// the registration); a sweep's peak table -> beam points (its calibration on input 1) ->
// inter-signal -> the points (input 0). A new calibration re-runs the points, the filter and the
// registration, and not the segmentation.
vtkSmartPointer<vtkTable> sweepPeakTable(const core::TriangleMesh& surface,
                                         const Eigen::Vector3d& centre, double beamOffsetMm) {
  core::Sequence sequence;
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkIntArray> frames;
  frames->SetName("frame");
  vtkNew<vtkDoubleArray> depths;
  depths->SetName("depth_mm");
  vtkNew<vtkStringArray> reasons;
  reasons->SetName("reason");
  constexpr double kDepthMm = 20.0;
  int frame = 0;
  for (std::size_t v = 0; v < surface.vertices.size(); v += 23) {
    const Eigen::Vector3d hit = surface.vertices[v];
    const Eigen::Vector3d beam = (centre - hit).normalized();
    const Eigen::Matrix3d rotation =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), beam).toRotationMatrix();
    core::SequenceFrame poses;
    core::TrackedTransform probe;
    probe.matrix.block<3, 3>(0, 0) = rotation;
    probe.matrix.block<3, 1>(0, 3) =
        hit - kDepthMm * beam - rotation * Eigen::Vector3d(0, 0, beamOffsetMm);
    poses.transforms["ProbeToTracker"] = probe;
    poses.transforms["FemurToTracker"] = core::TrackedTransform();  // Femur = Tracker = CT here
    poses.timestampS = 0.02 * frame;
    sequence.frames.push_back(poses);
    frames->InsertNextValue(frame++);
    depths->InsertNextValue(kDepthMm);
    reasons->InsertNextValue("");
  }
  table->AddColumn(frames);
  table->AddColumn(depths);
  table->AddColumn(reasons);
  filters::SequenceFieldData::write(sequence, table->GetFieldData());
  return table;
}

vtkSmartPointer<vtkTable> calibrationTable(double beamOffsetMm) {
  auto table = vtkSmartPointer<vtkTable>::New();
  vtkNew<vtkDoubleArray> beamToProbe;
  beamToProbe->SetName("BeamToProbe");
  beamToProbe->SetNumberOfComponents(16);
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> matrix = Eigen::Matrix4d::Identity();
  matrix(2, 3) = beamOffsetMm;
  beamToProbe->InsertNextTuple(matrix.data());
  table->GetFieldData()->AddArray(beamToProbe);
  return table;
}

TEST(StudyShapedPipeline, ACalibrationChangeDoesNotReRunTheSegmentation) {
  SegmentationPipeline segmentation;
  segmentation.surface->Update();
  ASSERT_EQ(segmentation.surface->GetLastError(), "");
  const core::TriangleMesh model = filters::toTriangleMesh(segmentation.surface->GetOutput());

  vtkNew<vtkTrivialProducer> sweep, calibration;
  sweep->SetOutput(sweepPeakTable(model, centreOf(segmentation.ct), 5.0));
  calibration->SetOutput(calibrationTable(5.0));
  vtkNew<vtkEchoregBeamPointsFilter> beamPoints;
  beamPoints->SetInputConnection(sweep->GetOutputPort());
  beamPoints->SetCalibrationConnection(calibration->GetOutputPort());
  beamPoints->SetPoseTransformName("ProbeToTracker");
  beamPoints->SetReferenceTransformName("FemurToTracker");
  vtkNew<vtkEchoregInterSignalFilter> interSignal;
  interSignal->SetInputConnection(beamPoints->GetOutputPort());
  interSignal->SetHistory(1);
  interSignal->SetMinSpreadMm(0.0);
  vtkNew<vtkEchoregSurfaceRegistrationFilter> registration;
  registration->SetInputConnection(0, interSignal->GetOutputPort());
  registration->SetModelConnection(segmentation.surface->GetOutputPort());
  registration->Update();
  ASSERT_EQ(registration->GetLastError(), "") << beamPoints->GetLastError();
  EXPECT_TRUE(registration->GetLastResult().converged) << registration->GetLastResult().message;
  EXPECT_LT(registration->GetLastResult().transform.translation().norm(), 0.05)
      << "the points lie on the model: FemurToCT is the identity";
  EXPECT_LT(registration->GetLastResult().rmsMm, 0.01);

  const auto counts = [&] {
    return std::array<int, 5>{segmentation.growth->GetExecutionCount(),
                              segmentation.surface->GetExecutionCount(),
                              beamPoints->GetExecutionCount(), interSignal->GetExecutionCount(),
                              registration->GetExecutionCount()};
  };
  EXPECT_EQ(counts(), (std::array<int, 5>{1, 1, 1, 1, 1}));

  // A calibration 1.5 mm off along the beam: every point moves 1.5 mm into the bone.
  calibration->SetOutput(calibrationTable(6.5));
  registration->Update();
  EXPECT_EQ(counts(), (std::array<int, 5>{1, 1, 2, 2, 2}))
      << "the calibration re-runs the points and the registration, not the segmentation";
  EXPECT_EQ(registration->GetModelPreparationCount(), 1);
  EXPECT_GT(registration->GetLastResult().rmsAllMm, 0.3) << "the wrong calibration is seen";

  // A new seed re-runs the segmentation and the registration, not the points.
  const Eigen::Vector3d seed = centreOf(segmentation.ct) + Eigen::Vector3d(1.0, 0.0, 0.0);
  segmentation.growth->SetSeedLps(seed.x(), seed.y(), seed.z());
  registration->Update();
  EXPECT_EQ(counts(), (std::array<int, 5>{2, 2, 2, 2, 3}));
  EXPECT_EQ(registration->GetModelPreparationCount(), 2);
}

}  // namespace
