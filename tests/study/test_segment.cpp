// echoreg segment on the fixture's simulated study (a real DICOM series written by the simulator,
// with the true bone surfaces beside it): femur and tibia from a seed (--auto) and from anchors
// a simulated user placed (--anchors), against the truth inside the knee group. Targets (issue 5):
// mean symmetric surface distance <= 0.5 mm, 95th percentile <= 1.5 mm, Dice >= 0.97.
#include "cli_test_support.hpp"
#include "mesh_test_support.hpp"
#include "study_checks.hpp"
#include "test_support.hpp"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "echoreg/segmentation/surface_metrics.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <iostream>

namespace echoreg::simulation {
namespace {

using test::runEchoreg;

// The inside point of `mesh` nearest the centroid of its section at height z (3 mm or more deep).
Eigen::Vector3d insidePoint(const core::TriangleMesh& mesh, double z) {
  const std::optional<Eigen::Vector3d> p = test::insidePointNearCentroid(mesh, z);
  EXPECT_TRUE(p.has_value()) << "no point 3 mm inside at z " << z;
  return p.value_or(Eigen::Vector3d::Zero());
}

class Segment : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fixtureStudy();
    if (root_.empty())
      GTEST_SKIP() << "needs the ctest fixture's study (simulate_fixture_study)";
  }

  // Runs segment, checks the model, returns the comparison inside the knee group (2 mm in from
  // its end slices, where the model is capped).
  segmentation::SurfaceComparison run(const std::string& bone, std::vector<std::string> mode,
                                      double* seconds) {
    const std::string model = dir_.file(bone + ".vtp");
    std::vector<std::string> args{
        "segment", "--dicom", root_ + "/ct/series", "--bone", bone, "--out", model, "--json"};
    args.insert(args.end(), mode.begin(), mode.end());
    const auto start = std::chrono::steady_clock::now();
    const auto r = runEchoreg(args);
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(r.exitCode, 0) << r.err;
    const auto json = nlohmann::json::parse(r.out);
    EXPECT_TRUE(json["surface"]["closed"].get<bool>());
    zFirst_ = json["group"]["z_first_mm"];
    zLast_ = json["group"]["z_last_mm"];
    segmentation::SurfaceComparisonOptions co;
    co.zMinMm = std::min(zFirst_, zLast_) + 2.0;
    co.zMaxMm = std::max(zFirst_, zLast_) - 2.0;
    return segmentation::compareSurfaces(filters::readMesh(model),
                                         filters::readMesh(root_ + "/truth/" + bone + ".vtp"), co);
  }

  std::string root_;
  test::TempDir dir_;
  double zFirst_ = 0.0, zLast_ = 0.0;
};

void expectTargets(const std::string& what, const segmentation::SurfaceComparison& c,
                   double seconds) {
  std::cout << "[ measured ] " << what << ": MSD " << c.meanMm << " mm, p95 " << c.p95Mm
            << " mm, max " << c.maxMm << " mm, Dice " << c.dice << ", " << seconds << " s\n";
  EXPECT_LE(c.meanMm, 0.5) << what;
  EXPECT_LE(c.p95Mm, 1.5) << what;
  EXPECT_GE(c.dice, 0.97) << what;
}

TEST_F(Segment, FemurAndTibiaFromASeedAndFromAnchors) {
  for (const std::string bone : {"femur", "tibia"}) {
    const core::TriangleMesh truth = filters::readMesh(root_ + "/truth/" + bone + ".vtp");
    // The knee group: z of the fixture's small protocol is the knee centre +-39.5 mm; the seed 15
    // mm inside its far end for this bone (found from the truth, as a user would click in the
    // bone).
    double seconds = 0.0;
    // A first run finds the group's extent (and is the femur's / tibia's auto result).
    const double kneeZ = 0.5 * (core::bounds(filters::readMesh(root_ + "/truth/femur.vtp"))[0].z() +
                                core::bounds(filters::readMesh(root_ + "/truth/tibia.vtp"))[1].z());
    const Eigen::Vector3d seed = insidePoint(truth, bone == "femur" ? kneeZ + 25.0 : kneeZ - 25.0);
    const auto automatic = run(bone,
                               {"--auto", "--seed", std::to_string(seed.x()),
                                std::to_string(seed.y()), std::to_string(seed.z())},
                               &seconds);
    expectTargets(bone + " --auto", automatic, seconds);

    // A simulated user: anchors on the truth's sagittal sections in the scanned group (40 slices,
    // ~12 mm apart and at corners), each off by noise of sigma 0.3 mm in the slice.
    segmentation::AnchorProposalOptions proposal;
    proposal.zMinMm = std::min(zFirst_, zLast_);
    proposal.zMaxMm = std::max(zFirst_, zLast_);
    auto sets =
        segmentation::proposeAnchors(truth, segmentation::SlicePlane::Sagittal, 40, proposal);
    core::Rng rng(bone == "femur" ? 21 : 22);
    for (auto& s : sets) {
      for (auto& a : s.anchorsLps) {
        const bool onEnd =
            std::abs(a.z() - proposal.zMinMm) < 1e-9 || std::abs(a.z() - proposal.zMaxMm) < 1e-9;
        a.y() += rng.normal(0.0, 0.3);
        if (!onEnd)
          a.z() = std::clamp(a.z() + rng.normal(0.0, 0.3), proposal.zMinMm, proposal.zMaxMm);
      }
    }
    const std::string anchors = dir_.file(bone + "_anchors.mrk.json");
    segmentation::writeAnchors(anchors, sets);
    const auto fromAnchors = run(bone, {"--anchors", anchors}, &seconds);
    expectTargets(bone + " --anchors (" + std::to_string(sets.size()) + " contours)", fromAnchors,
                  seconds);
  }
}

}  // namespace
}  // namespace echoreg::simulation
