// Simulated registration trials on a bone model, shared by the surface-registration tests and
// bench/bench_registration.cpp so that every method is compared on the SAME trials: A-mode beams
// aimed at regions of the distal femur from 10-30 mm outside the surface, depths measured with a
// wrong speed of sound, noise, false echoes (outliers), and an initial pose off by a
// landmark-like error.
#pragma once

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/surface_registration.hpp"

#include <cstdint>
#include <vector>

namespace echoreg::test {

struct TrialOptions {
  int points = 60;
  double noiseMm = 0.4;          ///< depth noise, 1 sigma
  double outlierFraction = 0.1;  ///< false echoes: depth off by 3-15 mm (either sign)
  double speedError = 0.03;      ///< true speed = assumed * (1 + speedError)
  double standoffMinMm = 10.0;   ///< beam origin's distance from the surface
  double standoffMaxMm = 30.0;
  double tiltDeg = 15.0;               ///< beam's largest tilt from the surface normal
  double initialRotationMinDeg = 3.0;  ///< initial pose error: rotation about the knee centre
  double initialRotationMaxDeg = 6.0;
  double initialTranslationMinMm = 3.0;
  double initialTranslationMaxMm = 6.0;
  double sigmaMm = 0.5;  ///< sigma given to the registration
};

struct RegistrationTrial {
  std::vector<core::SurfacePoint> points;  ///< bone frame, measured depths (with their beams)
  std::vector<bool> outlier;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();    ///< bone -> model
  Eigen::Isometry3d initial = Eigen::Isometry3d::Identity();  ///< bone -> model, perturbed
};

/// The regions the simulator uses (simulation/src/study.cpp, after the dissertation's Fig. 4.8)
/// on a femur model whose long axis is z with the knee at low z and the condyles towards +y
/// (posterior), as ../shared/data/meshes/femur.stl: the medial and lateral epicondyles (faces
/// whose normal is within 50 deg of -x / +x, 12-45 mm above the knee centre, 30 % of the points
/// each) and the anterior distal femur (normal within 50 deg of -y, 60-130 mm above the knee
/// centre, 40 %). The knee centre lies 20 mm above the distal end.
class FemurTrials {
 public:
  explicit FemurTrials(const core::MeshLocator& model);
  /// Trial `index` of stream `seed`: same arguments, same trial.
  RegistrationTrial make(std::uint64_t seed, int index, const TrialOptions& options = {}) const;
  /// Centre of the distal end (model frame): the centre of the condyles' bounds, 20 mm up.
  const Eigen::Vector3d& kneeCentre() const { return kneeCentre_; }
  std::size_t regionTriangles(int region) const {
    return triangles_[static_cast<std::size_t>(region)].size();
  }

 private:
  const core::MeshLocator& model_;
  std::vector<int> triangles_[3];  // anterior, medial/lateral (-x), (+x)
  Eigen::Vector3d kneeCentre_ = Eigen::Vector3d::Zero();
};

/// Errors of an estimate against the truth: at the knee centre (mm) and the rotation angle (deg).
struct TrialError {
  double kneeMm = 0.0;
  double rotationDeg = 0.0;
};
TrialError trialError(const Eigen::Isometry3d& truth, const Eigen::Isometry3d& estimate,
                      const Eigen::Vector3d& kneeCentreModel);

/// Every edge split into `parts` equal segments and each triangle into parts^2 (edge points
/// shared, so a closed mesh stays closed): the surface is unchanged, the count x parts^2 (a
/// bigger model for the timing benchmarks).
core::TriangleMesh subdivided(const core::TriangleMesh& mesh, int parts);

/// Percentile (0..100) by linear interpolation of the sorted values; 0 for none.
double percentile(std::vector<double> values, double percent);

}  // namespace echoreg::test
