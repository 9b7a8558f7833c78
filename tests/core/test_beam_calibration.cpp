// Calibration of the tracked transducer on a sphere (core/beam_calibration.hpp), on shots
// simulated from the geometry (tests/support/beam_shots.hpp): recovery without and with the
// dissertation's noise, the speed of sound, a tilted beam, outliers, refusals, and the solver's
// Jacobian against central differences of a residual written here with Eigen's transforms.

#include "beam_shots.hpp"

#include "echoreg/core/beam_calibration.hpp"
#include "echoreg/core/random.hpp"

#include <gtest/gtest.h>
#include <Eigen/SVD>

#include <cmath>
#include <cstddef>
#include <cstring>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using echoreg::core::BeamCalibrationMode;
using echoreg::core::BeamCalibrationOptions;
using echoreg::core::BeamCalibrationResult;
using echoreg::core::BeamShot;
using echoreg::core::calibrateBeam;
using echoreg::test::beamOptionsFor;
using echoreg::test::BeamShotsSpec;
using echoreg::test::makeBeamShots;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// The dissertation's calibration 1 (Table 5.1): the beam origin 201 mm along the probe's axis.
Eigen::Isometry3d trueBeamToProbe() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(28.10, 1.72, 201.47);
  return t;
}

// A CMM-like guess, a few mm off.
Eigen::Isometry3d initialGuess() {
  Eigen::Isometry3d t = trueBeamToProbe();
  t.translation() += Eigen::Vector3d(-2.0, 1.5, -3.0);
  return t;
}

// Tracking noise of ~0.25 mm RMS at the beam point (0.04 deg per axis at a ~240 mm lever, and
// 0.05 mm per axis) and 0.1 mm of depth noise (measured in DissertationNoiseLevel below).
BeamShotsSpec noisySpec(std::size_t shots, std::uint64_t seed) {
  BeamShotsSpec spec;
  spec.shots = shots;
  spec.beamToProbe = trueBeamToProbe();
  spec.trackingRotationSigmaDeg = 0.04;
  spec.trackingTranslationSigmaMm = 0.05;
  spec.depthSigmaMm = 0.1;
  spec.seed = seed;
  return spec;
}

BeamShotsSpec cleanSpec(std::size_t shots, std::uint64_t seed) {
  BeamShotsSpec spec;
  spec.shots = shots;
  spec.beamToProbe = trueBeamToProbe();
  spec.seed = seed;
  return spec;
}

double offsetError(const BeamCalibrationResult& result, const Eigen::Isometry3d& truth) {
  return (result.beamToProbe.translation() - truth.translation()).norm();
}

// r - |p - c| written from Eq. 4.2 with Eigen's transforms, the beam rotation built as
// initial * AngleAxis(tilt_x, x) * AngleAxis(tilt_y, y): not the library's code.
double referenceResidual(const BeamShot& shot, const BeamCalibrationOptions& options,
                         const Eigen::VectorXd& x) {
  const bool tilt = options.mode == BeamCalibrationMode::Beam;
  Eigen::Isometry3d beamToProbe = options.initialBeamToProbe;
  if (tilt) {
    beamToProbe.linear() = options.initialBeamToProbe.linear() *
                           Eigen::Matrix3d(Eigen::AngleAxisd(x[3], Eigen::Vector3d::UnitX())) *
                           Eigen::Matrix3d(Eigen::AngleAxisd(x[4], Eigen::Vector3d::UnitY()));
  }
  beamToProbe.translation() = x.head<3>();
  const double scale =
      options.fitSpeedOfSound ? x[x.size() - 1] / options.assumedSpeedOfSoundMps : 1.0;
  const Eigen::Vector3d p =
      shot.probeToTracker * beamToProbe * Eigen::Vector3d(0.0, 0.0, scale * shot.depthMm);
  return options.sphereRadiusMm - (p - options.sphereCentreTracker).norm();
}

std::string refusal(const std::vector<BeamShot>& shots, const BeamCalibrationOptions& options) {
  try {
    calibrateBeam(shots, options);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(BeamCalibration, NoiseFreeTranslationRecoveredWithinAcceptance) {
  const BeamShotsSpec spec = cleanSpec(60, 11);
  const auto shots = makeBeamShots(spec);
  const BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  const BeamCalibrationResult result = calibrateBeam(shots, options);
  EXPECT_TRUE(result.converged);
  EXPECT_LT(offsetError(result, spec.beamToProbe), 0.05);  // the acceptance
  EXPECT_LT(offsetError(result, spec.beamToProbe), 1e-6);  // in fact exact
  EXPECT_LT(result.rmsMm, 1e-6);
  EXPECT_EQ(result.parameterNames, (std::vector<std::string>{"tx_mm", "ty_mm", "tz_mm"}));
  ASSERT_EQ(result.parameters.size(), 3);
  EXPECT_EQ(result.speedOfSoundMps, 1450.0);
  EXPECT_TRUE(result.beamToProbe.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
  // Shots from a 50-degree cone, up to half the radius off centre: well conditioned, as the
  // dissertation's 6.2-14.2.
  EXPECT_GT(result.conditionNumber, 1.0);
  EXPECT_LT(result.conditionNumber, 15.0);
  std::cout << "[ info ] noise-free, 60 shots: offset error "
            << offsetError(result, spec.beamToProbe) << " mm, condition number "
            << result.conditionNumber << ", " << result.iterations << " iterations\n";
  // The condition number, from central differences of the reference residual (translation
  // mode: the columns are in mm, no scaling), as the dissertation's.
  Eigen::MatrixXd numeric(static_cast<Eigen::Index>(shots.size()), 3);
  for (std::size_t i = 0; i < shots.size(); ++i) {
    for (Eigen::Index k = 0; k < 3; ++k) {
      Eigen::VectorXd plus = result.parameters, minus = result.parameters;
      plus[k] += 1e-4;
      minus[k] -= 1e-4;
      numeric(static_cast<Eigen::Index>(i), k) = (referenceResidual(shots[i], options, plus) -
                                                  referenceResidual(shots[i], options, minus)) /
                                                 2e-4;
    }
  }
  const Eigen::VectorXd singular = Eigen::JacobiSVD<Eigen::MatrixXd>(numeric).singularValues();
  EXPECT_NEAR(result.conditionNumber, singular[0] / singular[2], 1e-6 * result.conditionNumber);
  // The reported residuals are r - |p - c| of the returned transform, recomputed here.
  ASSERT_EQ(result.residualsMm.size(), shots.size());
  for (std::size_t i = 0; i < shots.size(); ++i) {
    EXPECT_TRUE(result.used[i]);
    EXPECT_NEAR(result.residualsMm[i], referenceResidual(shots[i], options, result.parameters),
                1e-12);
  }
}

TEST(BeamCalibration, NoiseFreeRecoveryWithTheBeamAcrossTheProbe) {
  // A transducer mounted sideways: the beam along the probe's -x axis, known from the guess.
  BeamShotsSpec spec = cleanSpec(40, 13);
  spec.beamToProbe.linear() =
      Eigen::Matrix3d(Eigen::AngleAxisd(-kPi / 2.0, Eigen::Vector3d::UnitY()));
  Eigen::Isometry3d guess = initialGuess();
  guess.linear() = spec.beamToProbe.linear();
  for (const auto mode : {BeamCalibrationMode::Translation, BeamCalibrationMode::Beam}) {
    BeamCalibrationOptions options = beamOptionsFor(spec, guess);
    options.mode = mode;
    const BeamCalibrationResult result = calibrateBeam(makeBeamShots(spec), options);
    EXPECT_LT(offsetError(result, spec.beamToProbe), 1e-6);
    EXPECT_LT((result.beamToProbe.linear().col(2) - Eigen::Vector3d(-1.0, 0.0, 0.0)).norm(), 1e-9);
  }
}

TEST(BeamCalibration, NoiseFreeSpeedOfSoundRecovered) {
  BeamShotsSpec spec = cleanSpec(80, 12);
  spec.trueSpeedOfSoundMps = 1480.0;
  spec.minDepthMm = 15.0;
  spec.maxDepthMm = 70.0;
  for (const auto mode : {BeamCalibrationMode::Translation, BeamCalibrationMode::Beam}) {
    BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
    options.mode = mode;
    options.fitSpeedOfSound = true;
    const BeamCalibrationResult result = calibrateBeam(makeBeamShots(spec), options);
    EXPECT_NEAR(result.speedOfSoundMps, 1480.0, 0.1);
    EXPECT_LT(offsetError(result, spec.beamToProbe), 0.05);
    EXPECT_EQ(result.parameterNames.back(), "speed_mps");
    EXPECT_EQ(result.parameters[result.parameters.size() - 1], result.speedOfSoundMps);
  }
}

TEST(BeamCalibration, DissertationNoiseLevel) {
  // The noise model first: the beam point moves ~0.25 mm RMS between true and tracked poses.
  const BeamShotsSpec noisy = noisySpec(400, 21);
  BeamShotsSpec clean = noisy;
  clean.trackingRotationSigmaDeg = 0.0;
  clean.trackingTranslationSigmaMm = 0.0;
  clean.depthSigmaMm = 0.0;
  const auto noisyShots = makeBeamShots(noisy);
  const auto cleanShots = makeBeamShots(clean);
  double sum = 0.0;
  for (std::size_t i = 0; i < noisyShots.size(); ++i) {
    const Eigen::Vector3d point = noisy.beamToProbe * Eigen::Vector3d(0, 0, cleanShots[i].depthMm);
    sum +=
        (noisyShots[i].probeToTracker * point - cleanShots[i].probeToTracker * point).squaredNorm();
  }
  const double trackingRms = std::sqrt(sum / static_cast<double>(noisyShots.size()));
  EXPECT_GT(trackingRms, 0.2);
  EXPECT_LT(trackingRms, 0.3);

  // 100 shots, as a hand-held calibration: within 0.3 mm; and the reported standard deviations
  // agree with the spread over 30 independent calibrations.
  const int trials = 30;
  Eigen::MatrixXd errors(trials, 3);
  Eigen::Vector3d meanStdDev = Eigen::Vector3d::Zero();
  double worst = 0.0;
  double meanRms = 0.0;
  double meanCondition = 0.0;
  for (int trial = 0; trial < trials; ++trial) {
    const BeamShotsSpec spec = noisySpec(100, 100 + static_cast<std::uint64_t>(trial));
    const BeamCalibrationResult result =
        calibrateBeam(makeBeamShots(spec), beamOptionsFor(spec, initialGuess()));
    EXPECT_LT(offsetError(result, spec.beamToProbe), 0.3) << "trial " << trial;
    worst = std::max(worst, offsetError(result, spec.beamToProbe));
    errors.row(trial) =
        (result.beamToProbe.translation() - spec.beamToProbe.translation()).transpose();
    meanStdDev += result.parameterStdDev / trials;
    meanRms += result.rmsMm / trials;
    meanCondition += result.conditionNumber / trials;
    EXPECT_GT(result.rmsMm, 0.08);
    EXPECT_LT(result.rmsMm, 0.35);
  }
  for (int k = 0; k < 3; ++k) {
    const double spread = std::sqrt(errors.col(k).squaredNorm() / trials);
    EXPECT_GT(meanStdDev[k] / spread, 0.6) << "parameter " << k;
    EXPECT_LT(meanStdDev[k] / spread, 1.6) << "parameter " << k;
    std::cout << "[ info ] noisy, 100 shots, parameter " << k << ": reported std dev "
              << meanStdDev[k] << " mm, RMS error over " << trials << " trials " << spread
              << " mm\n";
  }
  std::cout << "[ info ] noisy, 100 shots: tracking RMS at the beam " << trackingRms
            << " mm, worst offset error " << worst << " mm, mean fit RMS " << meanRms
            << " mm, mean condition number " << meanCondition << "\n";
}

TEST(BeamCalibration, JacobianEqualsCentralDifferences) {
  BeamShotsSpec spec = cleanSpec(25, 31);
  // A beam not along the probe's z axis, to exercise the initial rotation.
  spec.beamToProbe.linear() =
      Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()));
  const auto shots = makeBeamShots(spec);
  for (const auto mode : {BeamCalibrationMode::Translation, BeamCalibrationMode::Beam}) {
    for (const bool speed : {false, true}) {
      BeamCalibrationOptions options = beamOptionsFor(spec, spec.beamToProbe);
      options.mode = mode;
      options.fitSpeedOfSound = speed;
      // Away from the solution, with non-zero tilts.
      Eigen::VectorXd x = echoreg::core::beamParameters(spec.beamToProbe, 1465.0, options);
      x.head<3>() += Eigen::Vector3d(1.5, -2.0, 0.7);
      std::vector<double> steps = {1e-4, 1e-4, 1e-4};
      if (mode == BeamCalibrationMode::Beam) {
        x[3] = 0.02;
        x[4] = -0.015;
        steps.push_back(1e-6);
        steps.push_back(1e-6);
      }
      if (speed)
        steps.push_back(1e-3);
      const Eigen::MatrixXd jacobian = echoreg::core::beamCalibrationJacobian(shots, options, x);
      ASSERT_EQ(jacobian.rows(), static_cast<Eigen::Index>(shots.size()));
      ASSERT_EQ(jacobian.cols(), x.size());
      for (Eigen::Index k = 0; k < x.size(); ++k) {
        Eigen::VectorXd numeric(jacobian.rows());
        const double h = steps[static_cast<std::size_t>(k)];
        for (std::size_t i = 0; i < shots.size(); ++i) {
          Eigen::VectorXd plus = x, minus = x;
          plus[k] += h;
          minus[k] -= h;
          numeric[static_cast<Eigen::Index>(i)] = (referenceResidual(shots[i], options, plus) -
                                                   referenceResidual(shots[i], options, minus)) /
                                                  (2.0 * h);
        }
        const double scale = numeric.cwiseAbs().maxCoeff();
        ASSERT_GT(scale, 0.0);
        EXPECT_LT((jacobian.col(k) - numeric).cwiseAbs().maxCoeff(), 1e-6 * scale)
            << "mode " << static_cast<int>(mode) << " speed " << speed << " column " << k;
      }
    }
  }
}

TEST(BeamCalibration, FittingTheSpeedOfSoundRemovesItsBias) {
  // Water at 1480 m/s while the depths assume 1450: every depth is 2 % short.
  BeamShotsSpec spec = noisySpec(400, 41);
  spec.trueSpeedOfSoundMps = 1480.0;
  spec.minDepthMm = 15.0;
  spec.maxDepthMm = 70.0;
  const auto shots = makeBeamShots(spec);
  BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  const BeamCalibrationResult biased = calibrateBeam(shots, options);
  const Eigen::Vector3d bias = biased.beamToProbe.translation() - spec.beamToProbe.translation();
  // The short depths pull the origin forward along the beam (+z), by about 2 % of the mean
  // depth (42.5 mm): ~0.9 mm.
  EXPECT_GT(bias.z(), 0.5);
  EXPECT_LT(bias.z(), 1.3);
  options.fitSpeedOfSound = true;
  const BeamCalibrationResult fitted = calibrateBeam(shots, options);
  EXPECT_LT(offsetError(fitted, spec.beamToProbe), 0.1);
  EXPECT_NEAR(fitted.speedOfSoundMps, 1480.0, 2.0);
  EXPECT_LT(fitted.rmsMm, biased.rmsMm);
  std::cout << "[ info ] assumed 1450 m/s, true 1480 m/s, 400 noisy shots, depths 15-70 mm: "
            << "translation-mode bias (" << bias.x() << ", " << bias.y() << ", " << bias.z()
            << ") mm, RMS " << biased.rmsMm << " mm; with the speed fitted: offset error "
            << offsetError(fitted, spec.beamToProbe) << " mm, speed " << fitted.speedOfSoundMps
            << " +- " << fitted.parameterStdDev[3] << " m/s, RMS " << fitted.rmsMm
            << " mm, condition number " << fitted.conditionNumber << "\n";
}

TEST(BeamCalibration, BeamModeRecoversOneDegreeTilt) {
  BeamShotsSpec spec = cleanSpec(80, 51);
  spec.minDepthMm = 15.0;
  spec.maxDepthMm = 70.0;
  // The beam tilted by 1 degree about an axis at 30 degrees between the probe's x and y axes.
  const Eigen::Vector3d tiltAxis(std::cos(30.0 * kDeg), std::sin(30.0 * kDeg), 0.0);
  spec.beamToProbe.linear() = Eigen::Matrix3d(Eigen::AngleAxisd(1.0 * kDeg, tiltAxis));
  const auto shots = makeBeamShots(spec);
  BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  options.initialBeamToProbe.linear().setIdentity();  // the guess: the beam along z
  options.mode = BeamCalibrationMode::Beam;
  const BeamCalibrationResult result = calibrateBeam(shots, options);
  const Eigen::Vector3d found = result.beamToProbe.linear().col(2);
  const Eigen::Vector3d truth = spec.beamToProbe.linear().col(2);
  const double angleDeg = std::atan2(found.cross(truth).norm(), found.dot(truth)) / kDeg;
  EXPECT_LT(angleDeg, 0.01);
  EXPECT_LT(offsetError(result, spec.beamToProbe), 0.05);
  EXPECT_LT(result.rmsMm, 1e-6);
  EXPECT_EQ(result.parameterNames,
            (std::vector<std::string>{"tx_mm", "ty_mm", "tz_mm", "tilt_x_rad", "tilt_y_rad"}));
  // The tilt found is the 1 degree put in (the roll about the beam does not matter).
  const double tiltDeg = std::atan2(found.head<2>().norm(), found.z()) / kDeg;
  EXPECT_NEAR(tiltDeg, 1.0, 0.01);
  // The translation mode cannot follow the tilt: its points leave the sphere.
  options.mode = BeamCalibrationMode::Translation;
  const BeamCalibrationResult straight = calibrateBeam(shots, options);
  EXPECT_GT(straight.rmsMm, 0.05);
  std::cout << "[ info ] 1-degree tilt, 80 noise-free shots: beam mode direction error " << angleDeg
            << " deg, offset error " << offsetError(result, spec.beamToProbe)
            << " mm, condition number " << result.conditionNumber << "; translation mode RMS "
            << straight.rmsMm << " mm, offset error " << offsetError(straight, spec.beamToProbe)
            << " mm\n";

  // beamParameters and beamGeometry are inverses (up to the roll about the beam).
  const Eigen::VectorXd x = echoreg::core::beamParameters(spec.beamToProbe, 1450.0, options);
  options.mode = BeamCalibrationMode::Beam;
  const Eigen::VectorXd xBeam = echoreg::core::beamParameters(spec.beamToProbe, 1450.0, options);
  EXPECT_EQ(x.size(), 3);
  ASSERT_EQ(xBeam.size(), 5);
  const auto geometry = echoreg::core::beamGeometry(xBeam, options);
  EXPECT_LT((geometry.beamToProbe.linear().col(2) - truth).norm(), 1e-12);
  EXPECT_LT((geometry.beamToProbe.translation() - spec.beamToProbe.translation()).norm(), 1e-12);
  EXPECT_THROW(echoreg::core::beamGeometry(x, options), std::invalid_argument);

  // With the dissertation's noise, 400 shots: the tilt within 0.3 degrees (its std dev is ~0.09 per
  // axis), the origin 0.3 mm.
  BeamShotsSpec noisy = noisySpec(400, 52);
  noisy.minDepthMm = 15.0;
  noisy.maxDepthMm = 70.0;
  noisy.beamToProbe.linear() = spec.beamToProbe.linear();
  options = beamOptionsFor(noisy, initialGuess());
  options.initialBeamToProbe.linear().setIdentity();
  options.mode = BeamCalibrationMode::Beam;
  const BeamCalibrationResult noisyResult = calibrateBeam(makeBeamShots(noisy), options);
  const Eigen::Vector3d noisyFound = noisyResult.beamToProbe.linear().col(2);
  const double noisyAngleDeg =
      std::atan2(noisyFound.cross(truth).norm(), noisyFound.dot(truth)) / kDeg;
  EXPECT_LT(noisyAngleDeg, 0.3);
  EXPECT_LT(offsetError(noisyResult, noisy.beamToProbe), 0.3);
  std::cout << "[ info ] 1-degree tilt, 400 noisy shots: direction error " << noisyAngleDeg
            << " deg (std dev of the tilts " << noisyResult.parameterStdDev[3] / kDeg << ", "
            << noisyResult.parameterStdDev[4] / kDeg << " deg), offset error "
            << offsetError(noisyResult, noisy.beamToProbe) << " mm, condition number "
            << noisyResult.conditionNumber << "\n";
}

TEST(BeamCalibration, EveryShotFromOneDirectionIsRefusedNamingTheParameter) {
  // The probe held in one orientation, the beam head-on through the centre, at several depths:
  // the beam points move along the beam only, nothing fixes the origin across it.
  BeamShotsSpec spec = cleanSpec(50, 61);
  spec.coneHalfAngleDeg = 0.0;
  spec.maxOffCentre = 0.0;
  BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  std::vector<BeamShot> shots = makeBeamShots(spec);
  for (auto& shot : shots) {  // one orientation: the first shot's
    shot.probeToTracker.linear() = shots.front().probeToTracker.linear();
  }
  // Re-place each probe so that its beam again goes through the centre at its depth.
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const Eigen::Vector3d beamDir = shots[i].probeToTracker.linear() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d origin =
        spec.sphereCentreTracker - beamDir * (spec.sphereRadiusMm + shots[i].depthMm);
    shots[i].probeToTracker.translation() =
        origin - shots[i].probeToTracker.linear() * spec.beamToProbe.translation();
  }
  std::string message = refusal(shots, options);
  EXPECT_NE(message.find("the shots do not determine"), std::string::npos) << message;
  EXPECT_TRUE(message.find("tx_mm") != std::string::npos ||
              message.find("ty_mm") != std::string::npos)
      << message;
  EXPECT_NE(message.find("off the sphere's centre"), std::string::npos) << message;
  std::cout << "[ info ] one direction, noise-free: " << message << "\n";

  // The same with the dissertation's tracking and depth noise added.
  echoreg::core::Rng rng(62);
  std::vector<BeamShot> noisy = shots;
  for (auto& shot : noisy) {
    const Eigen::Vector3d w(rng.normal(), rng.normal(), rng.normal());
    shot.probeToTracker =
        shot.probeToTracker *
        Eigen::Translation3d(0.05 * rng.normal(), 0.05 * rng.normal(), 0.05 * rng.normal()) *
        Eigen::AngleAxisd(0.04 * kDeg * w.norm(), w.normalized());
    shot.depthMm += 0.1 * rng.normal();
  }
  message = refusal(noisy, options);
  EXPECT_TRUE(message.find("tx_mm") != std::string::npos ||
              message.find("ty_mm") != std::string::npos)
      << message;
  std::cout << "[ info ] one direction, noisy: " << message << "\n";

  // Head-on from many directions is no better: in the probe's frame every surface normal is the
  // beam's, so the origin across the beam is still free.
  BeamShotsSpec headOn = cleanSpec(50, 63);
  headOn.maxOffCentre = 0.0;
  message = refusal(makeBeamShots(headOn), beamOptionsFor(headOn, initialGuess()));
  EXPECT_TRUE(message.find("tx_mm") != std::string::npos ||
              message.find("ty_mm") != std::string::npos)
      << message;

  // One depth with the speed fitted: the origin along the beam trades off against the speed.
  BeamShotsSpec oneDepth = cleanSpec(50, 64);
  oneDepth.minDepthMm = oneDepth.maxDepthMm = 40.0;
  BeamCalibrationOptions speedOptions = beamOptionsFor(oneDepth, initialGuess());
  speedOptions.fitSpeedOfSound = true;
  message = refusal(makeBeamShots(oneDepth), speedOptions);
  EXPECT_TRUE(message.find("the shots do not determine tz_mm") != std::string::npos ||
              message.find("the shots do not determine speed_mps") != std::string::npos)
      << message;
  EXPECT_NE(message.find("depths"), std::string::npos) << message;
  std::cout << "[ info ] one depth, speed fitted: " << message << "\n";
}

TEST(BeamCalibration, FewerShotsThanParametersRefused) {
  const BeamShotsSpec spec = cleanSpec(6, 71);
  const auto shots = makeBeamShots(spec);
  BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  const std::vector<BeamShot> three(shots.begin(), shots.begin() + 3);
  std::string message = refusal(three, options);
  EXPECT_NE(message.find("3 shots for 3 parameters: at least 4 needed"), std::string::npos)
      << message;
  options.mode = BeamCalibrationMode::Beam;
  options.fitSpeedOfSound = true;
  message = refusal(shots, options);
  EXPECT_NE(message.find("6 shots for 6 parameters: at least 7 needed"), std::string::npos)
      << message;
  EXPECT_NE(refusal({}, options), "");
}

TEST(BeamCalibration, BadInputRefusedNamingTheValue) {
  const BeamShotsSpec spec = cleanSpec(20, 81);
  const auto shots = makeBeamShots(spec);
  const BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  auto withShot = [&](std::size_t index, auto change) {
    auto copy = shots;
    change(copy[index]);
    return refusal(copy, options);
  };
  EXPECT_NE(withShot(4, [](BeamShot& s) { s.depthMm = std::nan(""); }).find("shot 4: depthMm"),
            std::string::npos);
  EXPECT_NE(withShot(7, [](BeamShot& s) { s.depthMm = -3.0; }).find("shot 7: depthMm must be > 0"),
            std::string::npos);
  EXPECT_NE(withShot(2, [](BeamShot& s) { s.probeToTracker.translation().x() = INFINITY; })
                .find("shot 2: probeToTracker is not finite"),
            std::string::npos);
  EXPECT_NE(withShot(3, [](BeamShot& s) { s.probeToTracker.linear() *= 1.01; })
                .find("shot 3: probeToTracker's rotation is not a rotation"),
            std::string::npos);
  auto withOptions = [&](auto change) {
    BeamCalibrationOptions copy = options;
    change(copy);
    return refusal(shots, copy);
  };
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.sphereRadiusMm = 0.0;
            }).find("sphereRadiusMm must be > 0 mm, got 0"),
            std::string::npos);
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.sphereRadiusMm = -25.4;
            }).find("sphereRadiusMm must be > 0 mm, got -25.4"),
            std::string::npos);
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.sphereCentreTracker.y() = std::numeric_limits<double>::quiet_NaN();
            }).find("sphereCentreTracker is not finite"),
            std::string::npos);
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.assumedSpeedOfSoundMps = 0.0;
            }).find("assumedSpeedOfSoundMps"),
            std::string::npos);
  // The speed the depths were measured with has no default: options that do not say it are
  // refused, not solved at a speed the shots never assumed.
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.assumedSpeedOfSoundMps = BeamCalibrationOptions{}.assumedSpeedOfSoundMps;
            }).find("assumedSpeedOfSoundMps must be > 0 m/s, got nan"),
            std::string::npos);
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) { o.maxRounds = 0; }).find("maxRounds"),
            std::string::npos);
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.initialBeamToProbe.translation().z() = std::nan("");
            }).find("initialBeamToProbe is not finite"),
            std::string::npos);
  // A limit on the condition number that good data exceed is applied too.
  EXPECT_NE(withOptions([](BeamCalibrationOptions& o) {
              o.maxConditionNumber = 1.0;
            }).find("the shots do not determine"),
            std::string::npos);
}

TEST(BeamCalibration, OutliersRejected) {
  const BeamShotsSpec spec = noisySpec(200, 91);
  auto shots = makeBeamShots(spec);
  // 5 % of the shots 5-10 mm off (a wrong echo picked, either side).
  echoreg::core::Rng rng(92);
  std::vector<bool> outlier(shots.size(), false);
  for (std::size_t k = 0; k < 10; ++k) {
    std::size_t i = 0;
    do {
      i = static_cast<std::size_t>(rng.below(shots.size()));
    } while (outlier[i]);
    outlier[i] = true;
    shots[i].depthMm += (rng.chance(0.5) ? 1.0 : -1.0) * rng.uniform(5.0, 10.0);
  }
  const BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  const BeamCalibrationResult result = calibrateBeam(shots, options);
  int inliersDropped = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    if (outlier[i]) {
      EXPECT_FALSE(result.used[i]) << "outlier " << i << " residual " << result.residualsMm[i];
    } else if (!result.used[i]) {
      ++inliersDropped;
    }
  }
  EXPECT_LE(inliersDropped, 2);
  EXPECT_GE(result.rounds, 2);
  EXPECT_LT(offsetError(result, spec.beamToProbe), 0.3);
  EXPECT_LT(result.rmsMm, 0.35);
  // One round (no rejection) is worse.
  BeamCalibrationOptions once = options;
  once.maxRounds = 1;
  const BeamCalibrationResult plain = calibrateBeam(shots, once);
  EXPECT_GT(plain.rmsMm, 1.0);
  std::cout << "[ info ] 10 outliers in 200 shots: robust offset error "
            << offsetError(result, spec.beamToProbe) << " mm (RMS " << result.rmsMm << " mm, "
            << result.rounds << " rounds, " << inliersDropped
            << " inliers dropped); without rejection " << offsetError(plain, spec.beamToProbe)
            << " mm (RMS " << plain.rmsMm << " mm)\n";
}

TEST(BeamCalibration, Deterministic) {
  BeamShotsSpec spec = noisySpec(150, 101);
  spec.trueSpeedOfSoundMps = 1475.0;
  BeamCalibrationOptions options = beamOptionsFor(spec, initialGuess());
  options.mode = BeamCalibrationMode::Beam;
  options.fitSpeedOfSound = true;
  const auto first = calibrateBeam(makeBeamShots(spec), options);
  const auto second = calibrateBeam(makeBeamShots(spec), options);
  ASSERT_EQ(first.parameters.size(), second.parameters.size());
  EXPECT_EQ(std::memcmp(first.parameters.data(), second.parameters.data(),
                        sizeof(double) * static_cast<std::size_t>(first.parameters.size())),
            0);
  EXPECT_EQ(std::memcmp(first.parameterStdDev.data(), second.parameterStdDev.data(),
                        sizeof(double) * static_cast<std::size_t>(first.parameters.size())),
            0);
  EXPECT_EQ(first.residualsMm, second.residualsMm);
  EXPECT_EQ(first.used, second.used);
  EXPECT_EQ(first.conditionNumber, second.conditionNumber);
  EXPECT_EQ(first.iterations, second.iterations);
}

}  // namespace
