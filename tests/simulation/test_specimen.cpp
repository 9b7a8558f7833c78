#include "echoreg/simulation/specimen.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace echoreg::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;

const Specimen& cadaver() {
  static const std::unique_ptr<Specimen> specimen = [] {
    KneeOptions options;
    options.meshResolutionMm = 2.0;
    options.seed = 0;
    return std::make_unique<Specimen>(buildKnee(options), SpecimenKind::Cadaver,
                                      SoftTissueOptions{});
  }();
  return *specimen;
}

TEST(Specimen, ThinOverSubcutaneousBoneThickOverMuscle) {
  const Specimen& s = cadaver();
  auto thickness = [&](Segment segment, double h, double thetaDeg) {
    const auto surface = s.surfacePoint(segment, h, thetaDeg * kPi / 180.0);
    EXPECT_TRUE(surface.has_value());
    return surface ? s.boneSignedDistance(surface->point) : -1.0;
  };
  // Skin-to-bone distances measured on the geometry (not read from the table).
  const double anteromedialTibia = thickness(Segment::Shank, 90.0, -45.0);
  const double posteriorThigh = thickness(Segment::Thigh, 200.0, 180.0);
  const double medialEpicondyle = thickness(Segment::Thigh, 30.0, -90.0);
  const double calf = thickness(Segment::Shank, 150.0, 180.0);
  std::cout << "skin to bone: anteromedial tibia " << anteromedialTibia << " mm, medial epicondyle "
            << medialEpicondyle << " mm, posterior thigh " << posteriorThigh << " mm, calf " << calf
            << " mm\n";
  EXPECT_GT(anteromedialTibia, 2.0);
  EXPECT_LT(anteromedialTibia, 7.0);
  EXPECT_LT(medialEpicondyle, 12.0);
  EXPECT_GT(posteriorThigh, 40.0);
  EXPECT_GT(calf, 35.0);
}

TEST(Specimen, LayersFromTheSkinInward) {
  const Specimen& s = cadaver();
  const auto surface = s.surfacePoint(Segment::Thigh, 150.0, 0.0);  // anterior thigh
  ASSERT_TRUE(surface);
  // Outward normal: outside is air, inside the leg.
  EXPECT_EQ(s.tissueAt(surface->point + 1.0 * surface->normal), Tissue::Air);
  EXPECT_EQ(s.tissueAt(surface->point - 0.5 * surface->normal), Tissue::Skin);
  std::vector<Tissue> order;
  for (double d = 0.1; d < 60.0; d += 0.1) {
    const Tissue t = s.tissueAt(surface->point - d * surface->normal);
    if (order.empty() || order.back() != t)
      order.push_back(t);
  }
  ASSERT_GE(order.size(), 4u);
  EXPECT_EQ(order[0], Tissue::Skin);
  EXPECT_EQ(order[1], Tissue::Fat);
  EXPECT_EQ(order[2], Tissue::Muscle);
  EXPECT_EQ(order[3], Tissue::CorticalBone);
}

TEST(Specimen, BeamTraceMatchesTheBoneHitAndTheSkin) {
  const Specimen& s = cadaver();
  const auto surface = s.surfacePoint(Segment::Shank, 90.0, -45.0 * kPi / 180.0);
  ASSERT_TRUE(surface);
  const Eigen::Vector3d origin = surface->point + 10.0 * surface->normal;
  const BeamTrace trace = s.traceBeam(origin, -surface->normal, Tissue::Water, 70.0);
  ASSERT_GE(trace.boneIndex, 0);
  EXPECT_EQ(s.knee().bones[static_cast<std::size_t>(trace.boneIndex)].id, BoneId::Tibia);
  EXPECT_NEAR(trace.skinDepthMm, 10.0, 0.05);
  // The layers add up to the bone depth, start with the standoff and end in cortical bone.
  double sum = 0.0;
  for (std::size_t i = 0; i + 1 < trace.path.layers.size(); ++i)
    sum += trace.path.layers[i].lengthMm;
  EXPECT_NEAR(sum, trace.boneDepthMm, 1e-6);
  EXPECT_EQ(trace.path.layers.front().tissue, Tissue::Water);
  EXPECT_EQ(trace.path.layers.back().tissue, Tissue::CorticalBone);
  // The hit is on the tibia's mesh, exactly.
  EXPECT_LT(s.locator(static_cast<std::size_t>(trace.boneIndex)).closest(trace.hitPoint).distance,
            1e-9);
  // Harmonic mean speed between water's and the soft tissues'.
  EXPECT_GT(trace.meanSpeedMps, 1470.0);
  EXPECT_LT(trace.meanSpeedMps, 1600.0);
}

TEST(Specimen, PhantomIsBonesInWater) {
  KneeOptions options;
  options.meshResolutionMm = 2.0;
  options.seed = 0;
  const Specimen phantom(buildKnee(options), SpecimenKind::Phantom, SoftTissueOptions{});
  const auto surface = phantom.surfacePoint(Segment::Shank, 90.0, -0.8);
  ASSERT_TRUE(surface);
  EXPECT_LT(std::abs(phantom.boneSignedDistance(surface->point)), 0.01);  // the bone itself
  EXPECT_EQ(phantom.tissueAt(surface->point + 2.0 * surface->normal), Tissue::Air);  // CT: air
  EXPECT_EQ(phantom.tissueAt(surface->point - 0.5 * surface->normal), Tissue::SawbonesShell);
  const BeamTrace trace = phantom.traceBeam(surface->point + 20.0 * surface->normal,
                                            -surface->normal, Tissue::GelPad, 70.0);
  ASSERT_EQ(trace.path.layers.size(), 2u);  // water, then the shell: a single echo
  EXPECT_EQ(trace.path.layers[0].tissue, Tissue::Water);
  EXPECT_EQ(trace.path.layers[1].tissue, Tissue::SawbonesShell);
  EXPECT_NEAR(trace.boneDepthMm, 20.0, 0.05);
}

}  // namespace
}  // namespace echoreg::simulation
