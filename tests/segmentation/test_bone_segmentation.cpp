#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include "simulated_knee.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <iostream>

namespace {

using namespace echoreg;
using segmentation::BoneSurfaceOptions;
using segmentation::GrowOptions;
using simulation::BoneId;

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// A point inside `bone` at height z (the centroid of a ring of inside points).
Eigen::Vector3d insidePoint(const simulation::Bone& bone, double z) {
  const core::MeshLocator locator(bone.mesh);
  const auto b = core::bounds(bone.mesh);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (double y = b[0].y(); y <= b[1].y(); y += 1.0) {
    for (double x = b[0].x(); x <= b[1].x(); x += 1.0) {
      if (locator.signedDistance({x, y, z}) < -3.0) {
        sum += Eigen::Vector3d(x, y, z);
        ++n;
      }
    }
  }
  if (n == 0)
    throw std::runtime_error("no inside point");
  // The inside point nearest the centroid.
  const Eigen::Vector3d c = sum / n;
  Eigen::Vector3d best = c;
  double bestD = 1e30;
  for (double y = b[0].y(); y <= b[1].y(); y += 1.0) {
    for (double x = b[0].x(); x <= b[1].x(); x += 1.0) {
      if (locator.signedDistance({x, y, z}) < -3.0 &&
          (Eigen::Vector3d(x, y, z) - c).norm() < bestD) {
        bestD = (Eigen::Vector3d(x, y, z) - c).norm();
        best = Eigen::Vector3d(x, y, z);
      }
    }
  }
  return best;
}

TEST(BoneSegmentation, AutoFromSeedMatchesTheTruth) {
  const auto& sim = test::simulatedKnee();
  for (BoneId id : {BoneId::Femur, BoneId::Tibia}) {
    const simulation::Bone& bone = sim.knee.bone(id);
    const double z = id == BoneId::Femur ? sim.kneeZMaxMm - 15.0 : sim.kneeZMinMm + 15.0;
    const Eigen::Vector3d seed = insidePoint(bone, z);
    auto t0 = std::chrono::steady_clock::now();
    const auto grown = segmentation::growBone(sim.ct, seed);
    const double tGrow = secondsSince(t0);
    t0 = std::chrono::steady_clock::now();
    const auto surface = segmentation::boneSurface(sim.ct, grown.mask, &grown.others);
    const double tSurf = secondsSince(t0);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    t0 = std::chrono::steady_clock::now();
    const auto c = segmentation::compareSurfaces(surface.mesh, bone.mesh, co);
    std::cout << "[ measured ] " << simulation::boneName(id) << " auto: grow " << tGrow
              << " s, surface " << tSurf << " s, compare " << secondsSince(t0) << " s; iso "
              << surface.isoHu << " (cortex " << surface.cortexHu << ", soft "
              << surface.softTissueHu << "), " << surface.mesh.triangles.size()
              << " triangles, pieces " << surface.components << " dropped "
              << surface.droppedComponents << "; MSD " << c.meanMm << " (est->truth "
              << c.meanEstimateToTruthMm << ", truth->est " << c.meanTruthToEstimateMm << ") p95 "
              << c.p95Mm << " max " << c.maxMm << " Dice " << c.dice << " vol "
              << c.volumeEstimateMm3 << " / " << c.volumeTruthMm3 << "\n";
    EXPECT_LE(c.meanMm, 0.5);
    EXPECT_LE(c.p95Mm, 1.5);
    EXPECT_GE(c.dice, 0.97);
  }
}

}  // namespace

namespace {

TEST(BoneSegmentation, TruthContoursToSurface) {
  using namespace echoreg;
  const auto& sim = test::simulatedKnee();
  for (simulation::BoneId id : {simulation::BoneId::Femur, simulation::BoneId::Tibia}) {
    const simulation::Bone& bone = sim.knee.bone(id);
    auto t0 = std::chrono::steady_clock::now();
    std::vector<segmentation::SliceContour> contours;
    for (double x :
         segmentation::evenSlicePositions(bone.mesh, segmentation::SlicePlane::Sagittal, 40)) {
      for (auto& loop :
           segmentation::planeSections(bone.mesh, segmentation::SlicePlane::Sagittal, x)) {
        segmentation::SliceContour c;
        c.positionMm = x;
        c.pointsLps = loop;
        contours.push_back(c);
      }
    }
    const auto mask = segmentation::contoursToMask(contours, sim.ct);
    const double tMask = secondsSince(t0);
    const auto threshold = segmentation::thresholdBone(sim.ct);
    const auto others = segmentation::otherBones(threshold, mask, 2.0);
    const auto surface = segmentation::boneSurface(sim.ct, mask, &others);
    const auto plain = segmentation::maskSurface(mask);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    const auto c = segmentation::compareSurfaces(surface.mesh, bone.mesh, co);
    const auto cp = segmentation::compareSurfaces(plain.mesh, bone.mesh, co);
    std::cout << "[ measured ] " << simulation::boneName(id)
              << " truth contours: " << contours.size() << " contours, mask " << tMask
              << " s, total " << secondsSince(t0) << " s; refined MSD " << c.meanMm << " p95 "
              << c.p95Mm << " Dice " << c.dice << "; mask only MSD " << cp.meanMm << " p95 "
              << cp.p95Mm << " Dice " << cp.dice << "\n";
    EXPECT_LE(c.meanMm, 0.5);
    EXPECT_LE(c.p95Mm, 1.5);
    EXPECT_GE(c.dice, 0.97);
  }
}

}  // namespace

namespace {

// A simulated user: the truth's sagittal sections (clipped to the scanned slab), anchors every
// ~12 mm and at the corners, each moved by noise of sigma 0.3 mm within the slice (along the
// scan's end only: a click on the image's edge row stays on it).
std::vector<echoreg::segmentation::AnchorSet> simulatedUserAnchors(
    const echoreg::core::TriangleMesh& truth, double zMin, double zMax, std::uint64_t seed) {
  using namespace echoreg;
  segmentation::AnchorProposalOptions proposal;
  proposal.zMinMm = zMin;
  proposal.zMaxMm = zMax;
  auto sets = segmentation::proposeAnchors(truth, segmentation::SlicePlane::Sagittal, 40, proposal);
  core::Rng rng(seed);
  for (auto& s : sets) {
    for (auto& a : s.anchorsLps) {
      const bool onEnd = std::abs(a.z() - zMin) < 1e-9 || std::abs(a.z() - zMax) < 1e-9;
      a.y() += rng.normal(0.0, 0.3);
      if (!onEnd)
        a.z() = std::clamp(a.z() + rng.normal(0.0, 0.3), zMin, zMax);
    }
  }
  return sets;
}

TEST(BoneSegmentation, FromAnchorsMatchesTheTruth) {
  using namespace echoreg;
  const auto& sim = test::simulatedKnee();
  for (simulation::BoneId id : {simulation::BoneId::Femur, simulation::BoneId::Tibia}) {
    const simulation::Bone& bone = sim.knee.bone(id);
    auto t0 = std::chrono::steady_clock::now();
    const auto sets = simulatedUserAnchors(bone.mesh, sim.kneeZMinMm, sim.kneeZMaxMm, 11);
    const core::MeshLocator truth(bone.mesh);
    std::vector<segmentation::SliceContour> contours;
    double worstContour = 0.0;  // farthest live-wire point from the truth, inside the slab
    for (const auto& s : sets) {
      contours.push_back(segmentation::liveWireContour(sim.ct, s));
      segmentation::straightenAtScanEnds(contours.back(), s, sim.kneeZMinMm, sim.kneeZMaxMm, 0.51);
      double worst = 0.0;
      for (const auto& p : contours.back().pointsLps) {
        if (p.z() > sim.kneeZMinMm + 0.5 && p.z() < sim.kneeZMaxMm - 0.5)
          worst = std::max(worst, truth.closest(p).distance);
      }
      worstContour = std::max(worstContour, worst);
    }
    const double tWire = secondsSince(t0);
    const auto mask = segmentation::contoursToMask(contours, sim.ct);
    const auto others = segmentation::otherBones(segmentation::thresholdBone(sim.ct), mask, 2.0);
    const auto surface = segmentation::boneSurface(sim.ct, mask, &others);
    const auto plain = segmentation::maskSurface(mask);
    const double total = secondsSince(t0);
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = sim.kneeZMinMm + 2.0;
    co.zMaxMm = sim.kneeZMaxMm - 2.0;
    const auto c = segmentation::compareSurfaces(surface.mesh, bone.mesh, co);
    const auto cp = segmentation::compareSurfaces(plain.mesh, bone.mesh, co);
    std::cout << "[ measured ] " << simulation::boneName(id) << " anchors: " << sets.size()
              << " contours (worst path point " << worstContour << " mm), live-wire " << tWire
              << " s, total " << total << " s; refined MSD " << c.meanMm << " p95 " << c.p95Mm
              << " max " << c.maxMm << " Dice " << c.dice << "; contours only MSD " << cp.meanMm
              << " p95 " << cp.p95Mm << " max " << cp.maxMm << " Dice " << cp.dice << "\n";
    EXPECT_LE(c.meanMm, 0.5);
    EXPECT_LE(c.p95Mm, 1.5);
    EXPECT_GE(c.dice, 0.97);
    EXPECT_LT(worstContour, 3.0) << "a live-wire path left the bone's edge";
  }
}

}  // namespace

namespace {

TEST(BoneSegmentation, TibiaWithFibulaAsOneModel) {
  using namespace echoreg;
  const auto& sim = test::simulatedKnee();
  const auto& tibia = sim.knee.bone(simulation::BoneId::Tibia);
  const auto& fibula = sim.knee.bone(simulation::BoneId::Fibula);
  const double z = sim.kneeZMinMm + 15.0;
  const auto a = segmentation::growBone(sim.ct, insidePoint(tibia, z));
  const auto b = segmentation::growBone(sim.ct, insidePoint(fibula, z));
  const auto both = segmentation::unite(a.mask, b.mask);
  auto others = segmentation::unite(a.others, b.others);
  for (std::size_t i = 0; i < others.voxels.size(); ++i)
    others.voxels[i] &= static_cast<std::uint8_t>(!both.voxels[i]);
  const auto surface = segmentation::boneSurface(sim.ct, both, &others);
  EXPECT_TRUE(core::checkMesh(surface.mesh).closed());
  // Where the fibula's head nearly touches the tibia the two may join into one piece.
  const core::MeshLocator model(surface.mesh);
  EXPECT_TRUE(model.inside(insidePoint(fibula, z)));
  EXPECT_TRUE(model.inside(insidePoint(tibia, z)));
  core::TriangleMesh truth = tibia.mesh;
  const int offset = static_cast<int>(truth.vertices.size());
  truth.vertices.insert(truth.vertices.end(), fibula.mesh.vertices.begin(),
                        fibula.mesh.vertices.end());
  for (const auto& t : fibula.mesh.triangles)
    truth.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  segmentation::SurfaceComparisonOptions co;
  co.zMinMm = sim.kneeZMinMm + 2.0;
  co.zMaxMm = sim.kneeZMaxMm - 2.0;
  const auto c = segmentation::compareSurfaces(surface.mesh, truth, co);
  std::cout << "[ measured ] tibia+fibula auto: MSD " << c.meanMm << " p95 " << c.p95Mm << " Dice "
            << c.dice << "\n";
  EXPECT_LE(c.meanMm, 0.5);
  EXPECT_LE(c.p95Mm, 1.5);
  EXPECT_GE(c.dice, 0.97);
  // The fibula alone is a small part of the volume: it must be there (the model is not the tibia).
  const auto tibiaOnly = segmentation::compareSurfaces(surface.mesh, tibia.mesh, co);
  EXPECT_GT(tibiaOnly.meanEstimateToTruthMm, 1.0);
}

}  // namespace
