// Calibration of the tracked A-mode transducer on a sphere of known centre and radius (Mozes
// 2008, section 4.2, Eqs. 4.2-4.3): each shot's point p = ProbeToTracker * BeamToProbe *
// (0, 0, d, 1) should lie on the sphere; the residual is r - |p - c|. Solved with Ceres
// (Levenberg-Marquardt), with analytic (automatic) derivatives.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace echoreg::core {

enum class BeamCalibrationMode {
  Translation,  ///< the dissertation's: 3 parameters, the beam along the probe's z axis
  Beam,         ///< beam origin (3) and direction (2 angles): 5 parameters
};

struct BeamShot {
  Eigen::Isometry3d probeToTracker = Eigen::Isometry3d::Identity();
  double depthMm = 0.0;  ///< measured with the assumed speed of sound
};

struct BeamCalibrationOptions {
  BeamCalibrationMode mode = BeamCalibrationMode::Translation;
  /// Fit the speed of sound as one more parameter (depths are scaled by c / assumed).
  bool fitSpeedOfSound = false;
  double assumedSpeedOfSoundMps = 1450.0;
  Eigen::Vector3d sphereCentreTracker = Eigen::Vector3d::Zero();
  double sphereRadiusMm = 25.4;
  /// Initial guess (the dissertation's CMM measurement). In Translation mode its rotation is kept.
  Eigen::Isometry3d initialBeamToProbe = Eigen::Isometry3d::Identity();
  /// Shots whose |residual| exceeds max(outlierSigmas * robust sigma, minOutlierMm) are dropped
  /// and the problem solved again.
  double outlierSigmas = 3.0;
  double minOutlierMm = 1.0;
  int maxRounds = 4;
  /// Refuse a solution whose condition number exceeds this (the data do not determine it).
  double maxConditionNumber = 1000.0;
};

struct BeamCalibrationResult {
  Eigen::Isometry3d beamToProbe = Eigen::Isometry3d::Identity();
  double speedOfSoundMps = 0.0;
  double rmsMm = 0.0;                       ///< over the shots used
  double conditionNumber = 0.0;             ///< largest / smallest singular value of J
  std::vector<std::string> parameterNames;  ///< e.g. "tx_mm", "ty_mm", "tz_mm", "speed_mps"
  Eigen::VectorXd parameters;
  Eigen::VectorXd parameterStdDev;          ///< sqrt(diag(sigma^2 (J^T J)^-1)), sigma^2 = SSR/(n-p)
  std::vector<double> residualsMm;          ///< per input shot, r - |p - c| at the solution
  std::vector<bool> used;                   ///< per input shot: false = rejected as an outlier
  int iterations = 0;
  bool converged = false;
};

/// Throws std::invalid_argument when there are fewer shots than parameters (+1), a bad option,
/// or the data cannot determine the parameters: the message says which parameter (direction) is
/// missing, e.g. "the shots do not determine the beam origin along the probe's x axis: shoot
/// the sphere from more directions around the probe's z axis".
BeamCalibrationResult calibrateBeam(const std::vector<BeamShot>& shots,
                                    const BeamCalibrationOptions& options);

/// The residuals' Jacobian with respect to the parameters at `parameters` (rows: shots), from
/// the same cost functions the solver uses (for tests against numeric differentiation).
Eigen::MatrixXd beamCalibrationJacobian(const std::vector<BeamShot>& shots,
                                        const BeamCalibrationOptions& options,
                                        const Eigen::VectorXd& parameters);

/// The parameter vector of a BeamToProbe (and speed) in a mode, and back.
Eigen::VectorXd beamParameters(const Eigen::Isometry3d& beamToProbe, double speedOfSoundMps,
                               const BeamCalibrationOptions& options);

}  // namespace echoreg::core
