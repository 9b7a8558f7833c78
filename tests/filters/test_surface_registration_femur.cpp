// Surface registration on the real femur (../shared/data/meshes/femur.stl): a known transform
// recovered from noise-free beams, and 150 seeded trials with noise, 10 % false echoes, a 3 %
// speed-of-sound error and a landmark-like initial error (tests/support/registration_trials.hpp;
// bench/bench_registration.cpp runs VTK's ICP and every method on the same trials).
#include "echoreg/core/surface_registration.hpp"
#include "echoreg/filters/mesh_io.h"
#include "registration_trials.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>

namespace echoreg::core {
namespace {

const SurfaceRegistration& femurModel(const std::string& path) {
  static std::unique_ptr<SurfaceRegistration> model;
  if (!model)
    model = std::make_unique<SurfaceRegistration>(filters::readMesh(path));
  return *model;
}

TEST(SurfaceRegistrationFemur, NoiseFreeBeamsRecoverTheTransformExactly) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  const SurfaceRegistration& model = femurModel(path);
  const test::FemurTrials trials(model.locator());
  test::TrialOptions exact;
  exact.noiseMm = 0.0;
  exact.outlierFraction = 0.0;
  exact.speedError = 0.0;
  for (int index = 0; index < 3; ++index) {
    const test::RegistrationTrial trial = trials.make(5, index, exact);
    SurfaceRegistrationOptions options;
    options.initial = trial.initial;
    options.toleranceMm = 1e-9;
    const SurfaceRegistrationResult r = model.registerPoints(trial.points, {}, options);
    ASSERT_TRUE(r.converged) << r.message;
    const test::TrialError e = test::trialError(trial.truth, r.transform, trials.kneeCentre());
    EXPECT_LT(e.kneeMm, 1e-6) << index;
    EXPECT_LT(r.rmsAllMm, 1e-6);
    EXPECT_EQ(r.pointsRejected, 0);
  }
  // With a 3 % speed-of-sound error and the scale fitted: the scale and the pose, exactly.
  exact.speedError = 0.03;
  const test::RegistrationTrial trial = trials.make(5, 7, exact);
  SurfaceRegistrationOptions options;
  options.initial = trial.initial;
  options.fitSpeedOfSound = true;
  options.toleranceMm = 1e-9;
  const SurfaceRegistrationResult r = model.registerPoints(trial.points, {}, options);
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_NEAR(r.speedOfSoundScale, 1.03, 1e-9);
  EXPECT_LT(test::trialError(trial.truth, r.transform, trials.kneeCentre()).kneeMm, 1e-6);
}

// 120 beams per trial over the simulator's femur regions, 0.3 mm depth noise, 10 % false echoes
// of 3-15 mm, true speed 3 % above the assumed, initial pose 3-6 deg and 3-6 mm off. Measured:
// knee median 0.215 mm (95th 0.447, max 0.556), rotation median 0.236 deg, scale median 1.0286,
// all converged. With 60 beams at 0.4 mm: 0.43 mm and 0.53 deg (the noise, not the method, sets
// these: noise-free trials come back exact), and one start of 150 fell into a local minimum
// (5.6 mm) that restarts = 4 removes.
TEST(SurfaceRegistrationFemur, RobustWithSpeedOfSoundOver150NoisyTrials) {
  ECHOREG_REQUIRE_SHARED_FILE(path, "meshes/femur.stl");
  const SurfaceRegistration& model = femurModel(path);
  const test::FemurTrials trials(model.locator());
  test::TrialOptions trialOptions;
  trialOptions.points = 120;
  trialOptions.noiseMm = 0.3;
  std::vector<double> knee, rotation, scale;
  int notConverged = 0, outliers = 0, outliersKept = 0;
  for (int index = 0; index < 150; ++index) {
    const test::RegistrationTrial trial = trials.make(2008, index, trialOptions);
    SurfaceRegistrationOptions options;
    options.initial = trial.initial;
    options.fitSpeedOfSound = true;
    const SurfaceRegistrationResult r = model.registerPoints(trial.points, {}, options);
    if (!r.converged)
      ++notConverged;
    for (std::size_t i = 0; i < trial.points.size(); ++i) {
      if (!trial.outlier[i])
        continue;
      ++outliers;
      if (r.inlier[i])
        ++outliersKept;
    }
    const test::TrialError e = test::trialError(trial.truth, r.transform, trials.kneeCentre());
    knee.push_back(e.kneeMm);
    rotation.push_back(e.rotationDeg);
    scale.push_back(r.speedOfSoundScale);
  }
  const double medianKnee = test::percentile(knee, 50);
  const double medianRotation = test::percentile(rotation, 50);
  const double worst = *std::max_element(knee.begin(), knee.end());
  std::printf(
      "robust + speed: knee median %.3f mm, 95th %.3f, max %.3f; rotation median %.3f deg; "
      "scale median %.4f; not converged %d; outliers kept %d of %d\n",
      medianKnee, test::percentile(knee, 95), worst, medianRotation, test::percentile(scale, 50),
      notConverged, outliersKept, outliers);
  EXPECT_LE(medianKnee, 0.3);
  EXPECT_LE(medianRotation, 0.3);
  EXPECT_LT(worst, 3.0);
  EXPECT_NEAR(test::percentile(scale, 50), 1.03, 0.005);
  EXPECT_EQ(notConverged, 0);
  // False echoes of 3 mm or more leave the fit (a few of the 3 mm ones may hide in the noise).
  EXPECT_LT(outliersKept, outliers / 20);
}

}  // namespace
}  // namespace echoreg::core
