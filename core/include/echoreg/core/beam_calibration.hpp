// Calibration of the tracked A-mode transducer on a sphere of known centre and radius (Mozes
// 2008, section 4.2, Eqs. 4.2-4.3): each shot's point p = ProbeToTracker * BeamToProbe *
// (0, 0, d, 1) should lie on the sphere; the residual is r - |p - c|. Solved with Ceres
// (Levenberg-Marquardt), with analytic (automatic) derivatives.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <limits>
#include <string>
#include <vector>

namespace echoreg::core {

enum class BeamCalibrationMode {
  Translation,  ///< the dissertation's: 3 parameters, the beam along the probe's z axis
  Beam,         ///< beam origin (3) and direction (2 angles): 5 parameters
};

/// One shot at the sphere: the probe's tracked pose and the depth of the sphere's echo.
struct BeamShot {
  Eigen::Isometry3d probeToTracker = Eigen::Isometry3d::Identity();
  double depthMm = 0.0;  ///< measured with the assumed speed of sound
};

/// The sphere, the initial guess, what to fit and the robust rounds.
struct BeamCalibrationOptions {
  BeamCalibrationMode mode = BeamCalibrationMode::Translation;
  /// Fit the speed of sound as one more parameter (depths are scaled by c / assumed).
  bool fitSpeedOfSound = false;
  /// The speed the shots' depths were measured with, m/s. No default: it is the detection's
  /// (echoreg calibrate: the resolved detection parameters; the filter: the capture's header).
  double assumedSpeedOfSoundMps = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d sphereCentreTracker = Eigen::Vector3d::Zero();
  double sphereRadiusMm = 25.4;
  /// Initial guess (the dissertation's CMM measurement). In Translation mode its rotation is kept.
  Eigen::Isometry3d initialBeamToProbe = Eigen::Isometry3d::Identity();
  /// Shots whose |residual| exceeds max(outlierSigmas * robust sigma, minOutlierMm) are dropped
  /// and the problem solved again.
  double outlierSigmas = 3.0;
  double minOutlierMm = 1.0;
  int maxRounds = 4;
  /// Refuse a solution whose condition number exceeds this (the data do not determine it). The
  /// dissertation's five calibrations had 6.2-14.2; simulated hand-held shots give 4-10
  /// (Translation) and 20-45 (Beam); every shot head-on from one direction gives 130-150 with
  /// 0.25 mm of tracking noise (infinite without). With 100 shots of 0.12 mm RMS the weakest
  /// direction's standard deviation is about 0.01 mm times the condition number.
  double maxConditionNumber = 100.0;
};

/// The calibration found, with its fit statistics.
struct BeamCalibrationResult {
  Eigen::Isometry3d beamToProbe = Eigen::Isometry3d::Identity();
  double speedOfSoundMps = 0.0;
  double rmsMm = 0.0;  ///< over the shots used
  /// Largest / smallest singular value of J over the shots used, with every column in mm of
  /// movement of the beam point: translations per mm (as the dissertation's Table 5.2), tilts
  /// per (1 / mean depth) rad and the speed per (assumed speed / mean depth) m/s, i.e. the step
  /// that moves a point at the mean depth by 1 mm.
  double conditionNumber = 0.0;
  std::vector<std::string> parameterNames;  ///< e.g. "tx_mm", "ty_mm", "tz_mm", "speed_mps"
  Eigen::VectorXd parameters;
  Eigen::VectorXd parameterStdDev;  ///< sqrt(diag(sigma^2 (J^T J)^-1)), sigma^2 = SSR/(n-p)
  std::vector<double> residualsMm;  ///< per input shot, r - |p - c| at the solution
  std::vector<bool> used;           ///< per input shot: false = rejected as an outlier
  int iterations = 0;      ///< Levenberg-Marquardt iterations, summed over the robust rounds
  int rounds = 0;          ///< solves (the first on every shot, then without the outliers)
  bool converged = false;  ///< the last solve met Ceres' convergence tolerances
};

/// Robust rounds: solve on every shot, drop the shots beyond max(outlierSigmas * 1.4826 * median
/// |residual|, minOutlierMm), solve again, up to maxRounds solves. Throws std::invalid_argument
/// when there are fewer shots than parameters (+1), a non-finite or bad input (naming the shot
/// or option), or the data cannot determine the parameters (condition number above the limit):
/// the message names the parameter of the weakest direction and says how to shoot, e.g. "the
/// shots do not determine tx_mm (the beam origin along the probe's x axis): condition number 143
/// above the limit 100 with 50 shots; aim the beam off the sphere's centre on every side ...".
/// A shot tells only where the sphere's centre lies in the probe's frame, so the remedy is to
/// spread that: off the beam's axis on every side, and at more depths.
BeamCalibrationResult calibrateBeam(const std::vector<BeamShot>& shots,
                                    const BeamCalibrationOptions& options);

/// The residuals' Jacobian with respect to the parameters at `parameters` (rows: shots), from
/// the same cost functions the solver uses (for tests against numeric differentiation).
Eigen::MatrixXd beamCalibrationJacobian(const std::vector<BeamShot>& shots,
                                        const BeamCalibrationOptions& options,
                                        const Eigen::VectorXd& parameters);

/// The parameter vector of a BeamToProbe (and speed) in a mode, and back. Translation mode
/// ignores the rotation of `beamToProbe` (the initial guess's is kept); Beam mode gives the tilts
/// of its z axis from the initial guess's (the roll about the beam is dropped).
Eigen::VectorXd beamParameters(const Eigen::Isometry3d& beamToProbe, double speedOfSoundMps,
                               const BeamCalibrationOptions& options);

/// What a parameter vector stands for.
struct BeamGeometry {
  /// Translation (tx, ty, tz); rotation initial * Rx(tilt_x) * Ry(tilt_y) (Beam mode) or the
  /// initial guess's (Translation mode).
  Eigen::Isometry3d beamToProbe = Eigen::Isometry3d::Identity();
  double speedOfSoundMps = 0.0;  ///< the fitted speed, or the assumed one when it is not fitted
};

/// The inverse of beamParameters. Throws std::invalid_argument when the vector's size does not
/// match the mode.
BeamGeometry beamGeometry(const Eigen::VectorXd& parameters, const BeamCalibrationOptions& options);

/// The names of a mode's parameters, in order ("tx_mm", "ty_mm", "tz_mm", "tilt_x_rad",
/// "tilt_y_rad", "speed_mps").
std::vector<std::string> beamParameterNames(const BeamCalibrationOptions& options);

}  // namespace echoreg::core
