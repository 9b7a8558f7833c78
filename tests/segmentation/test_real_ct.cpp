// Bone growth on a real CT (../shared/data/ct-abdomen: 512 x 512 pixels of 1.07 mm, 3 mm slices,
// Philips, from the sacroiliac joints up to the thorax; the series holds no femoral heads). The
// pelvis is grown from one seed in each ilium in the lowest 40 slices (z 86 to 203 mm), cropped
// in-plane around it to keep the test short.
#include "echoreg/core/mesh.hpp"
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/dicom_series.hpp"

#include "test_support.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

namespace {

using namespace echoreg;

// Columns i0.., rows j0.. (ni x nj) of the lowest `count` slices.
core::CtImage crop(const core::CtImage& ct, int i0, int j0, int ni, int nj, int count) {
  core::CtImage out = ct;
  out.dimensions = {ni, nj, count};
  out.originMm = ct.voxelToLps(Eigen::Vector3d(i0, j0, 0));
  out.slicePositionsMm.resize(static_cast<std::size_t>(count));
  out.groups = {{0, count, ct.groups.front().spacingMm}};
  out.hu.resize(out.voxelCount());
  for (int k = 0; k < count; ++k) {
    for (int j = 0; j < nj; ++j) {
      for (int i = 0; i < ni; ++i)
        out.hu[out.index(i, j, k)] = ct.at(i0 + i, j0 + j, k);
    }
  }
  return out;
}

// `thin` (one slice group) averaged into slabs `widthMm` thick, the first starting `phaseMm` above
// the first slice's lower face, each the overlap-weighted mean of the slices it covers (a
// scanner's thick reconstruction, without its own blur along z); only whole slabs.
struct Slabs {
  core::CtImage image;
  std::vector<std::vector<std::pair<int, double>>> weights;  // per slab: (thin slice, weight)
};

Slabs slabAverage(const core::CtImage& thin, double widthMm, double phaseMm) {
  const double h = thin.spacingMm().z();
  const int nz = thin.dimensions[2];
  const double lo = thin.slicePositionsMm.front() - 0.5 * h + phaseMm;
  const double top = thin.slicePositionsMm.back() + 0.5 * h;
  const int count = static_cast<int>(std::floor((top - lo) / widthMm + 1e-9));
  Slabs out;
  core::CtImage& g = out.image;
  g = thin;
  g.dimensions[2] = count;
  g.originMm = thin.originMm + thin.direction.col(2) * (lo + 0.5 * widthMm);
  g.slicePositionsMm.resize(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k)
    g.slicePositionsMm[static_cast<std::size_t>(k)] = widthMm * k;
  g.groups = {{0, count, widthMm}};
  g.sliceLocationsMm.clear();
  g.sliceThicknessMm.clear();
  g.hu.assign(g.voxelCount(), 0);
  for (int k = 0; k < count; ++k) {
    const double a = lo + widthMm * k, b = a + widthMm;
    std::vector<std::pair<int, double>> w;
    for (int s = 0; s < nz; ++s) {
      const double sa = thin.slicePositionsMm[static_cast<std::size_t>(s)] - 0.5 * h;
      const double overlap = std::min(b, sa + h) - std::max(a, sa);
      if (overlap > 1e-9)
        w.push_back({s, overlap / widthMm});
    }
    for (int j = 0; j < g.dimensions[1]; ++j) {
      for (int i = 0; i < g.dimensions[0]; ++i) {
        double v = 0.0;
        for (const auto& [s, f] : w)
          v += f * thin.at(i, j, s);
        g.hu[g.index(i, j, k)] = static_cast<std::int16_t>(std::lround(v));
      }
    }
    out.weights.push_back(std::move(w));
  }
  return out;
}

// In the sacrum's body (S1), on the midline.
const Eigen::Vector3d kSacrumSeed(0.0, 158.0, 100.0);

bool inMask(const segmentation::VoxelMask& mask, const Eigen::Vector3d& lps) {
  const Eigen::Vector3d v = mask.geometry.lpsToVoxel(lps);
  return mask.at(static_cast<int>(std::lround(v.x())), static_cast<int>(std::lround(v.y())),
                 static_cast<int>(std::lround(v.z())));
}

TEST(RealCt, PelvisFromTwoSeedsByErosion) {
  ECHOREG_REQUIRE_SHARED_FILE(first, "ct-abdomen/1-001.dcm");
  const auto start = std::chrono::steady_clock::now();
  // The pelvis' part of the slices (x -168 to 169 mm, y -17 to 253 mm): the body's outline stays
  // outside the crop, as the whole image's border does.
  const core::CtImage ct = crop(
      segmentation::readDicomSeries(test::sharedDataDir() + "/ct-abdomen"), 100, 150, 314, 252, 40);
  ASSERT_TRUE(ct.uniform());
  // Seeds in the right and the left iliac wing (found on the axial slice z = 91.9 mm).
  const Eigen::Vector3d right(-65.5, 133.4, 91.91), left(66.6, 144.2, 91.91);
  // The defaults: at 3 mm slices the erosion is 2 slices, 6 mm (2.4 mm would leave the
  // lumbosacral facets and the left sacroiliac joint bridged); it cuts the spine off at L5 / S1
  // (the thin iliac fossa comes back through the reassignment).
  segmentation::GrowOptions options;
  const auto a = segmentation::growBone(ct, right, options);
  const auto b = segmentation::growBone(ct, left, options);
  const auto pelvis = segmentation::unite(a.mask, b.mask);
  const double volumeCm3 = static_cast<double>(pelvis.count()) * ct.spacingMm().prod() / 1000.0;
  segmentation::VoxelMask others = segmentation::unite(a.others, b.others);
  for (std::size_t i = 0; i < others.voxels.size(); ++i)
    others.voxels[i] &= static_cast<std::uint8_t>(!pelvis.voxels[i]);
  const auto surface = segmentation::boneSurface(ct, pelvis, &others);
  const auto check = core::checkMesh(surface.mesh);
  std::cout << "[ measured ] pelvis: " << volumeCm3 << " cm^3 (right " << a.volumeMm3 / 1000.0
            << ", left " << b.volumeMm3 / 1000.0 << "), surface " << check.triangles
            << " triangles " << check.volumeMm3 / 1000.0 << " cm^3, iso " << surface.isoHu
            << " HU (cortex " << surface.cortexHu << ", soft " << surface.softTissueHu << "); "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " s\n";
  // A pelvis (both ilia and the sacrum over 12 cm): a few hundred cm^3, not a whole skeleton.
  EXPECT_GT(volumeCm3, 150.0);
  EXPECT_LT(volumeCm3, 600.0);
  EXPECT_TRUE(check.closed()) << check.describe();
  // The local level (docs/segmentation.md, section 4) against one level for the whole pelvis:
  // its thin cortex at 3 mm reads less than the median nearly everywhere, so the two stay
  // within a few per cent (no reference: the two are compared, not judged).
  segmentation::BoneSurfaceOptions oneLevel;
  oneLevel.localLevel = false;
  const auto before =
      core::checkMesh(segmentation::boneSurface(ct, pelvis, &others, oneLevel).mesh);
  std::cout << "[ measured ] pelvis with one level: " << before.triangles << " triangles "
            << before.volumeMm3 / 1000.0 << " cm^3\n";
  EXPECT_TRUE(before.closed());
  EXPECT_NEAR(check.volumeMm3, before.volumeMm3, 0.05 * before.volumeMm3);
  EXPECT_LE(check.volumeMm3, 1.001 * before.volumeMm3);  // the level only rises
  // Inside: both wings near the seeds and higher up, the sacrum's midline.
  EXPECT_TRUE(inMask(pelvis, right));
  EXPECT_TRUE(inMask(pelvis, left));
  // Not inside: gluteal muscle beside the right wing, the bowel in front of the sacrum, the
  // psoas, and the L5 vertebral body (a separate bone).
  EXPECT_FALSE(inMask(pelvis, {-124.6, 144.2, 91.91}));
  EXPECT_FALSE(inMask(pelvis, {0.0, 60.0, 91.91}));
  EXPECT_FALSE(inMask(pelvis, {-44.0, 90.0, 127.91}));
  EXPECT_FALSE(inMask(pelvis, {0.0, 106.5, 145.91}));
  // Nothing above the iliac crests (z 175 mm and up holds only vertebrae and soft tissue).
  const Eigen::Vector3d crest = ct.lpsToVoxel({0, 0, 175.0});
  std::size_t above = 0;
  for (int k = static_cast<int>(std::ceil(crest.z())); k < ct.dimensions[2]; ++k) {
    for (int j = 0; j < ct.dimensions[1]; ++j) {
      for (int i = 0; i < ct.dimensions[0]; ++i)
        above += pelvis.at(i, j, k) ? 1u : 0u;
    }
  }
  EXPECT_EQ(above, 0u);
}

}  // namespace

namespace {

// The watershed with the defaults: each hip bone and the sacrum from one seed each, against each
// other and against the spine (found automatically).
TEST(RealCt, HipBonesAndSacrumFromOneSeedEach) {
  ECHOREG_REQUIRE_SHARED_FILE(first, "ct-abdomen/1-001.dcm");
  const auto start = std::chrono::steady_clock::now();
  const core::CtImage ct = crop(
      segmentation::readDicomSeries(test::sharedDataDir() + "/ct-abdomen"), 100, 150, 314, 252, 40);
  const std::vector<segmentation::BoneSeed> seeds = {{"right hip", {-65.5, 133.4, 91.91}},
                                                     {"left hip", {66.6, 144.2, 91.91}},
                                                     {"sacrum", kSacrumSeed}};
  const auto result = segmentation::segmentCompetingBones(ct, seeds);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(result.bones.size(), 3u);
  std::cout << "[ measured ] threshold " << result.thresholdUsed.strongHu << " / "
            << result.thresholdUsed.weakHu << " HU from the histogram (soft tissue "
            << result.estimate.softTissueHu << ", noise " << result.estimate.noiseHu << ", cortex "
            << result.estimate.cortexHu << ")\n";
  for (const auto& b : result.bones) {
    std::cout << "[ measured ] " << b.bone << ": " << b.volumeMm3 / 1000.0 << " cm^3, extent "
              << b.extentMm.transpose() << " mm\n";
  }
  std::cout << "[ measured ] " << result.automaticNeighbours << " neighbours found automatically; "
            << seconds << " s\n";
  const auto& right = result.bones[0];
  const auto& left = result.bones[1];
  const auto& sacrum = result.bones[2];
  // Each hip bone on its own side of the midline, the sacrum between them.
  for (const auto* b : {&right, &left, &sacrum}) {
    EXPECT_GT(b->volumeMm3, 40e3) << b->bone;
    EXPECT_LT(b->volumeMm3, 300e3) << b->bone;
  }
  EXPECT_TRUE(inMask(right.mask, {-65.5, 133.4, 91.91}));
  EXPECT_TRUE(inMask(left.mask, {66.6, 144.2, 91.91}));
  EXPECT_TRUE(inMask(sacrum.mask, kSacrumSeed));
  EXPECT_FALSE(inMask(right.mask, {66.6, 144.2, 91.91}));
  EXPECT_FALSE(inMask(left.mask, {-65.5, 133.4, 91.91}));
  // Not inside any: gluteal muscle, bowel, psoas, L5.
  for (const auto* b : {&right, &left, &sacrum}) {
    EXPECT_FALSE(inMask(b->mask, {-124.6, 144.2, 91.91})) << b->bone;
    EXPECT_FALSE(inMask(b->mask, {0.0, 60.0, 91.91})) << b->bone;
    EXPECT_FALSE(inMask(b->mask, {-44.0, 90.0, 127.91})) << b->bone;
    EXPECT_FALSE(inMask(b->mask, {0.0, 106.5, 145.91})) << b->bone;
  }
  // The two hip bones alike (a wing split off would show here), and nothing of the pelvis above
  // the iliac crests (z 175 mm and up: vertebrae only).
  EXPECT_NEAR(left.volumeMm3, right.volumeMm3, 0.15 * right.volumeMm3);
  const Eigen::Vector3d crest = ct.lpsToVoxel({0, 0, 175.0});
  for (const auto* b : {&right, &left, &sacrum}) {
    std::size_t above = 0;
    for (int k = static_cast<int>(std::ceil(crest.z())); k < ct.dimensions[2]; ++k) {
      for (int j = 0; j < ct.dimensions[1]; ++j) {
        for (int i = 0; i < ct.dimensions[0]; ++i)
          above += b->mask.at(i, j, k) ? 1u : 0u;
      }
    }
    EXPECT_EQ(above, 0u) << b->bone;
  }
  // The hip bones stay lateral: none of their voxels within 25 mm of the midline (the sacrum's).
  for (const auto* b : {&right, &left}) {
    std::size_t medial = 0;
    for (int k = 0; k < ct.dimensions[2]; ++k) {
      for (int j = 0; j < ct.dimensions[1]; ++j) {
        for (int i = 0; i < ct.dimensions[0]; ++i) {
          if (b->mask.at(i, j, k) && std::abs(ct.voxelToLps(Eigen::Vector3d(i, j, k)).x()) < 25.0)
            ++medial;
        }
      }
    }
    EXPECT_EQ(medial, 0u) << b->bone;
  }
}

// The same pelvis averaged into 4, 5 and 6 mm slabs at every 1 mm phase (15 scans; the
// dissertation scans the hip at 5 mm): each run either gives the three bones as the 3 mm series
// gives them (the reference: its models, checked above) or refuses with its reason; never a bone
// that took a piece of its neighbour. Before the thick-slice rules (the marker's dynamic at one
// voxel, each piece of a seeded boundary a joint) 2 of the 15 runs wrote such bones without a
// word: the sacrum with L5 (4 mm, 266 cm^3) and the right hip with the back of the sacrum (5 mm,
// 204 cm^3); 6 gave the bones, 7 refused. Now 9 give them and 6 refuse.
TEST(RealCt, PelvisOnThickSlicesIsRightOrRefused) {
  ECHOREG_REQUIRE_SHARED_FILE(first, "ct-abdomen/1-001.dcm");
  const core::CtImage ct = crop(
      segmentation::readDicomSeries(test::sharedDataDir() + "/ct-abdomen"), 100, 150, 314, 252, 40);
  const std::vector<segmentation::BoneSeed> seeds = {{"right hip", {-65.5, 133.4, 91.91}},
                                                     {"left hip", {66.6, 144.2, 91.91}},
                                                     {"sacrum", kSacrumSeed}};
  const auto thin = segmentation::segmentCompetingBones(ct, seeds);
  ASSERT_EQ(thin.bones.size(), 3u);
  int models = 0;
  for (const double width : {4.0, 5.0, 6.0}) {
    for (int phase = 0; phase < static_cast<int>(width); ++phase) {
      const Slabs slabs = slabAverage(ct, width, phase);
      const core::CtImage& g = slabs.image;
      const std::string run = fmt::format("{:.0f} mm slices, phase {} mm", width, phase);
      segmentation::CompetingResult r;
      try {
        r = segmentation::segmentCompetingBones(g, seeds);
      } catch (const std::invalid_argument& e) {
        std::cout << "[ measured ] " << run << ": refused: " << e.what() << "\n";
        EXPECT_GT(std::string(e.what()).size(), 40u) << run;
        continue;
      }
      ++models;
      ASSERT_EQ(r.bones.size(), 3u) << run;
      std::string line;
      for (std::size_t b = 0; b < 3; ++b) {
        // The 3 mm model on the slabs: a voxel is the bone's when half its slab is.
        std::size_t both = 0, mine = 0, theirs = 0;
        for (int k = 0; k < g.dimensions[2]; ++k) {
          for (int j = 0; j < g.dimensions[1]; ++j) {
            for (int i = 0; i < g.dimensions[0]; ++i) {
              double share = 0.0;
              for (const auto& [s, f] : slabs.weights[static_cast<std::size_t>(k)])
                share += thin.bones[b].mask.at(i, j, s) ? f : 0.0;
              const bool ref = share >= 0.5, got = r.bones[b].mask.at(i, j, k) != 0;
              both += ref && got ? 1u : 0u;
              mine += got ? 1u : 0u;
              theirs += ref ? 1u : 0u;
            }
          }
        }
        const double dice = 2.0 * static_cast<double>(both) / static_cast<double>(mine + theirs);
        const double volume = r.bones[b].volumeMm3 / thin.bones[b].volumeMm3;
        line += fmt::format(" {} {:.1f} cm^3 ({:.2f} of 3 mm), Dice {:.3f};", r.bones[b].bone,
                            r.bones[b].volumeMm3 / 1000.0, volume, dice);
        EXPECT_NEAR(volume, 1.0, 0.12) << run << ", " << r.bones[b].bone;
        EXPECT_GE(dice, 0.85) << run << ", " << r.bones[b].bone;
      }
      std::cout << "[ measured ] " << run << ":" << line << "\n";
    }
  }
  EXPECT_GE(models, 9);
}

}  // namespace
