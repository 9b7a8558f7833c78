// A synthetic CT of a human hip joint with known truth, for judging bone segmentation: the
// proximal femur (a real surface mesh) seated in the acetabulum of an implicit hip bone
// (innominate), voxelised with partial volume, a Gaussian point spread and Gaussian noise.
// Independent of the simulator and the segmentation: written from anatomy and CT physics only.
#pragma once

#include "echoreg/core/ct_image.hpp"
#include "echoreg/core/mesh.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace echoreg::test {

struct HipPhantomOptions {
  std::string femurMesh;    ///< path of a real femur surface (STL, or what filters::readMesh reads)
  double sliceMm = 3.0;     ///< slice thickness = slice spacing, [1, 6]
  double pixelMm = 0.8;     ///< square in-plane pixels, [0.3, 2]
  double jointGapMm = 2.0;  ///< radial bone-to-bone space between femoral head and cup, [0, 4]
  double cancellousHu =
      250.0;  ///< trabecular bone of head, neck, trochanters and hip bone, [50, 1000]
  double cortexHu = 1300.0;  ///< cortical bone, [300, 3000], above cancellousHu
  double noiseHu = 18.0;     ///< CT noise standard deviation, [0, 200]
  double zPhaseMm = 0.0;     ///< shifts the slab boundaries relative to the anatomy, [0, sliceMm]
  std::uint64_t seed = 1;    ///< all randomness from this (same options, same bytes)
  /// Correlate the noise in plane (Gaussian kernel of this sigma, mm; 0 = white noise). The
  /// standard deviation stays noiseHu. [0, 2]
  double noiseCorrelationMm = 0.35;
  /// Sigma of the in-plane Gaussian point spread function, mm. [0, 2]
  double psfSigmaMm = 0.4;
};

/// Tissue classes of the phantom (the sample labels behind HipPhantom::tissue).
enum class HipTissue : std::uint8_t {
  kAir = 0,
  kFat,               ///< subcutaneous fat, -100 HU
  kMuscle,            ///< 50 HU
  kJoint,             ///< cartilage, synovial fluid, labrum: 80 HU
  kMarrow,            ///< fatty marrow of the femoral canal: -20 HU
  kFemurCancellous,   ///< cancellousHu
  kFemurCortex,       ///< cortexHu
  kFemurSubchondral,  ///< dense layer under the head's cortex: halfway cancellous-cortex
  kHipCancellous,
  kHipCortex,
  kHipSubchondral,
  kCount
};
const char* hipTissueName(HipTissue tissue);
/// HU given to every sample of `tissue` (before partial volume, blur and noise).
double hipTissueHu(HipTissue tissue, const HipPhantomOptions& options);

struct HipPhantom {
  core::CtImage ct;                          ///< axial, direction identity, LPS mm, one group
  core::TriangleMesh femur, hip;             ///< truth: closed outward-wound surfaces, LPS
  Eigen::Vector3d femurSeedLps, hipSeedLps;  ///< deep in each bone's cancellous bone (>= 6 mm)
  Eigen::Vector3d headCentreLps;             ///< the femoral head's fitted sphere centre
  double headRadiusMm = 0.0;                 ///< the fitted sphere's radius

  // Added: what the generator knows beyond the interface.
  double headFitRmsMm = 0.0;     ///< rms radial residual of the head points about the sphere
  double cupRadiusMm = 0.0;      ///< acetabulum's articular bone surface: a sphere about the centre
  Eigen::Vector3d cupAxisLps;    ///< unit, out of the cup (lateral, inferior, anterior)
  Eigen::Vector3d neckAxisLps;   ///< unit, from the head centre along the femoral neck
  Eigen::Vector3d shaftAxisLps;  ///< unit, femoral long axis pointing proximal
  int lateralSign = 1;           ///< +1: lateral is +x (a left hip), -1: a right hip
  /// Smallest hip-bone implicit value (~ signed distance) over the femur's vertices: the joint
  /// gap as the generator sees it (the truth meshes can be checked independently).
  double minFemurToHipMm = 0.0;
  /// Per voxel (indexed like ct.hu): the HipTissue holding the largest share of the voxel's
  /// samples, and that share in percent (100 = a pure voxel).
  std::vector<std::uint8_t> tissue;
  std::vector<std::uint8_t> purity;
};

/// Throws std::invalid_argument on bad options (out-of-range values, unreadable or open femur
/// mesh, no femoral head found), naming the option or file.
HipPhantom makeHipPhantom(const HipPhantomOptions& options);

}  // namespace echoreg::test
