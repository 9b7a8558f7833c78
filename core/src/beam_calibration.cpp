#include "echoreg/core/beam_calibration.hpp"

#include "beam_model.hpp"
#include "echoreg/core/number_text.hpp"
#include "robust_solve.hpp"
#include "solve_calls.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::core {

namespace {

void require(bool condition, const std::string& message) {
  if (!condition)
    throw std::invalid_argument("beam calibration: " + message);
}

bool finite(const Eigen::Isometry3d& pose) {
  return pose.matrix().allFinite();
}

bool orthonormal(const Eigen::Matrix3d& rotation) {
  return (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
         rotation.determinant() > 0.0;
}

/// Where the parameters sit in the vector of a mode.
struct Layout {
  bool tilt = false;
  bool speed = false;
  int count = 3;
  int speedIndex = -1;
};

Layout layoutOf(const BeamCalibrationOptions& options) {
  Layout layout;
  layout.tilt = options.mode == BeamCalibrationMode::Beam;
  layout.speed = options.fitSpeedOfSound;
  layout.count = 3 + (layout.tilt ? 2 : 0);
  if (layout.speed)
    layout.speedIndex = layout.count++;
  return layout;
}

detail::ShotData shotData(const BeamShot& shot, const BeamCalibrationOptions& options) {
  detail::ShotData data;
  data.probeRotation = shot.probeToTracker.linear();
  data.beamRotation = data.probeRotation * options.initialBeamToProbe.linear();
  data.offset = shot.probeToTracker.translation() - options.sphereCentreTracker;
  data.depthMm = shot.depthMm;
  data.radiusMm = options.sphereRadiusMm;
  data.inverseAssumedSpeed = 1.0 / options.assumedSpeedOfSoundMps;
  return data;
}

/// The residual alone (the solver's functor, without derivatives).
double residualAt(int count, const detail::ShotData& data, const double* x) {
  double value = 0.0;
  switch (count) {
    case 3:
      detail::ShotResidual<3>{data}(x, &value);
      break;
    case 4:
      detail::ShotResidual<4>{data}(x, &value);
      break;
    case 5:
      detail::ShotResidual<5>{data}(x, &value);
      break;
    default:
      detail::ShotResidual<6>{data}(x, &value);
      break;
  }
  return value;
}

void validate(const BeamCalibrationOptions& options) {
  require(
      options.mode == BeamCalibrationMode::Translation || options.mode == BeamCalibrationMode::Beam,
      "unknown mode " + std::to_string(static_cast<int>(options.mode)));
  require(std::isfinite(options.assumedSpeedOfSoundMps) && options.assumedSpeedOfSoundMps > 0.0,
          "assumedSpeedOfSoundMps must be > 0 m/s, got " +
              number(options.assumedSpeedOfSoundMps, "%.6g"));
  require(options.sphereCentreTracker.allFinite(), "sphereCentreTracker is not finite");
  require(std::isfinite(options.sphereRadiusMm) && options.sphereRadiusMm > 0.0,
          "sphereRadiusMm must be > 0 mm, got " + number(options.sphereRadiusMm, "%.6g"));
  require(finite(options.initialBeamToProbe), "initialBeamToProbe is not finite");
  require(orthonormal(options.initialBeamToProbe.linear()),
          "initialBeamToProbe's rotation is not a rotation (orthonormal, determinant +1)");
  require(std::isfinite(options.outlierSigmas) && options.outlierSigmas > 0.0,
          "outlierSigmas must be > 0, got " + number(options.outlierSigmas, "%.6g"));
  require(std::isfinite(options.minOutlierMm) && options.minOutlierMm >= 0.0,
          "minOutlierMm must be >= 0 mm, got " + number(options.minOutlierMm, "%.6g"));
  require(options.maxRounds >= 1,
          "maxRounds must be >= 1, got " + std::to_string(options.maxRounds));
  require(options.maxConditionNumber >= 1.0,
          "maxConditionNumber must be >= 1, got " + number(options.maxConditionNumber, "%.6g"));
}

void validate(const std::vector<BeamShot>& shots, const BeamCalibrationOptions& options) {
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const std::string which = "shot " + std::to_string(i);
    require(finite(shots[i].probeToTracker), which + ": probeToTracker is not finite");
    require(orthonormal(shots[i].probeToTracker.linear()),
            which + ": probeToTracker's rotation is not a rotation (orthonormal, determinant +1)");
    require(std::isfinite(shots[i].depthMm) && shots[i].depthMm > 0.0,
            which + ": depthMm must be > 0 mm, got " + number(shots[i].depthMm, "%.6g"));
  }
  const Layout layout = layoutOf(options);
  const std::size_t needed = static_cast<std::size_t>(layout.count) + 1;
  require(shots.size() >= needed, std::to_string(shots.size()) + " shots for " +
                                      std::to_string(layout.count) + " parameters: at least " +
                                      std::to_string(needed) + " needed");
}

/// What a parameter means and how to make the shots determine it.
struct ParameterHelp {
  const char* meaning;
  const char* remedy;
};

ParameterHelp help(const std::string& name) {
  // A shot tells only where the sphere's centre lies in the probe's frame (turning the probe
  // about the centre changes nothing), so what helps is spreading that: off the beam's axis on
  // every side, and along it (depths).
  constexpr const char* kAcross =
      "aim the beam off the sphere's centre on every side (so that it meets the surface from "
      "more directions, up to 20-30 degrees oblique), not only head-on";
  constexpr const char* kDepths =
      "shoot at more depths (vary the distance between the probe and the sphere by 20 mm or "
      "more)";
  constexpr const char* kBoth =
      "shoot at more depths (vary the distance between the probe and the sphere by 20 mm or "
      "more) and aim the beam off the sphere's centre on every side, not only head-on";
  if (name == "tx_mm")
    return {"the beam origin along the probe's x axis", kAcross};
  if (name == "ty_mm")
    return {"the beam origin along the probe's y axis", kAcross};
  if (name == "tz_mm")
    return {"the beam origin along the probe's z axis", kDepths};
  if (name == "tilt_x_rad")
    return {"the beam's tilt about the probe's x axis", kBoth};
  if (name == "tilt_y_rad")
    return {"the beam's tilt about the probe's y axis", kBoth};
  return {"the speed of sound", kDepths};
}

/// SVD of the Jacobian with its columns in mm of beam-point movement (see conditionNumber).
struct Conditioning {
  Eigen::VectorXd columnScale;  ///< J_scaled = J * diag(columnScale)
  Eigen::VectorXd singularValues;
  Eigen::MatrixXd v;
  double conditionNumber = 0.0;
};

Conditioning conditioning(const Eigen::MatrixXd& jacobian, const Layout& layout, double meanDepthMm,
                          double assumedSpeedMps) {
  Conditioning c;
  c.columnScale = Eigen::VectorXd::Ones(layout.count);
  if (layout.tilt) {
    c.columnScale[3] = 1.0 / meanDepthMm;
    c.columnScale[4] = 1.0 / meanDepthMm;
  }
  if (layout.speed)
    c.columnScale[layout.speedIndex] = assumedSpeedMps / meanDepthMm;
  const Eigen::MatrixXd scaled = jacobian * c.columnScale.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinV);
  c.singularValues = svd.singularValues();
  c.v = svd.matrixV();
  const double largest = c.singularValues[0];
  const double smallest = c.singularValues[layout.count - 1];
  c.conditionNumber =
      smallest > 1e-12 * largest ? largest / smallest : std::numeric_limits<double>::infinity();
  return c;
}

[[noreturn]] void refuseUndetermined(const Conditioning& c, const std::vector<std::string>& names,
                                     std::size_t usedShots, double limit) {
  const Eigen::VectorXd weakest = c.v.col(c.v.cols() - 1).cwiseAbs();
  Eigen::Index first = 0;
  weakest.maxCoeff(&first);
  Eigen::Index second = -1;
  for (Eigen::Index k = 0; k < weakest.size(); ++k) {
    if (k != first && weakest[k] > 0.3 && (second < 0 || weakest[k] > weakest[second]))
      second = k;
  }
  const std::string& name = names[static_cast<std::size_t>(first)];
  const ParameterHelp h = help(name);
  std::string message = "the shots do not determine " + name + " (" + h.meaning + ")";
  if (second >= 0) {
    message += ", which trades off against " + names[static_cast<std::size_t>(second)];
  }
  message += ": condition number " +
             (std::isfinite(c.conditionNumber) ? number(c.conditionNumber, "%.3g")
                                               : std::string("infinite (rank-deficient)")) +
             " above the limit " + number(limit, "%.4g") + " with " + std::to_string(usedShots) +
             " shots; " + h.remedy;
  throw std::invalid_argument("beam calibration: " + message);
}

}  // namespace

std::vector<std::string> beamParameterNames(const BeamCalibrationOptions& options) {
  std::vector<std::string> names = {"tx_mm", "ty_mm", "tz_mm"};
  if (options.mode == BeamCalibrationMode::Beam) {
    names.emplace_back("tilt_x_rad");
    names.emplace_back("tilt_y_rad");
  }
  if (options.fitSpeedOfSound)
    names.emplace_back("speed_mps");
  return names;
}

Eigen::VectorXd beamParameters(const Eigen::Isometry3d& beamToProbe, double speedOfSoundMps,
                               const BeamCalibrationOptions& options) {
  const Layout layout = layoutOf(options);
  Eigen::VectorXd x(layout.count);
  x.head<3>() = beamToProbe.translation();
  if (layout.tilt) {
    // The beam direction in the initial beam frame: Rx(a) Ry(b) e_z = (sin b, -sin a cos b,
    // cos a cos b).
    const Eigen::Vector3d d =
        options.initialBeamToProbe.linear().transpose() * beamToProbe.linear().col(2);
    x[3] = std::atan2(-d.y(), d.z());
    x[4] = std::asin(std::clamp(d.x() / d.norm(), -1.0, 1.0));
  }
  if (layout.speed)
    x[layout.speedIndex] = speedOfSoundMps;
  return x;
}

BeamGeometry beamGeometry(const Eigen::VectorXd& parameters,
                          const BeamCalibrationOptions& options) {
  const Layout layout = layoutOf(options);
  require(parameters.size() == layout.count, std::to_string(parameters.size()) +
                                                 " parameters given, the mode has " +
                                                 std::to_string(layout.count));
  BeamGeometry geometry;
  geometry.beamToProbe.linear() = options.initialBeamToProbe.linear();
  if (layout.tilt) {
    geometry.beamToProbe.linear() = options.initialBeamToProbe.linear() *
                                    (Eigen::AngleAxisd(parameters[3], Eigen::Vector3d::UnitX()) *
                                     Eigen::AngleAxisd(parameters[4], Eigen::Vector3d::UnitY()))
                                        .toRotationMatrix();
  }
  geometry.beamToProbe.translation() = parameters.head<3>();
  geometry.speedOfSoundMps =
      layout.speed ? parameters[layout.speedIndex] : options.assumedSpeedOfSoundMps;
  return geometry;
}

Eigen::MatrixXd beamCalibrationJacobian(const std::vector<BeamShot>& shots,
                                        const BeamCalibrationOptions& options,
                                        const Eigen::VectorXd& parameters) {
  validate(options);
  const Layout layout = layoutOf(options);
  require(parameters.size() == layout.count, std::to_string(parameters.size()) +
                                                 " parameters given, the mode has " +
                                                 std::to_string(layout.count));
  require(parameters.allFinite(), "the parameters are not finite");
  std::vector<detail::ShotData> data;
  data.reserve(shots.size());
  for (const BeamShot& shot : shots)
    data.push_back(shotData(shot, options));
  detail::ShotJacobian jacobian;
  const int failed = detail::beamJacobianInSolverModule(layout.count, data, parameters, jacobian);
  require(failed < 0, "shot " + std::to_string(failed) + ": the residual cannot be evaluated");
  return jacobian;
}

BeamCalibrationResult calibrateBeam(const std::vector<BeamShot>& shots,
                                    const BeamCalibrationOptions& options) {
  validate(options);
  validate(shots, options);
  const Layout layout = layoutOf(options);
  const std::size_t count = static_cast<std::size_t>(layout.count);

  std::vector<detail::ShotData> data;
  data.reserve(shots.size());
  for (const BeamShot& shot : shots)
    data.push_back(shotData(shot, options));

  BeamCalibrationResult result;
  result.parameterNames = beamParameterNames(options);
  Eigen::VectorXd x =
      beamParameters(options.initialBeamToProbe, options.assumedSpeedOfSoundMps, options);
  std::vector<bool> used(shots.size(), true);
  std::vector<double> residuals(shots.size(), 0.0);
  for (int round = 1; round <= options.maxRounds; ++round) {
    const detail::BeamRound solved = detail::beamRoundInSolverModule(layout.count, data, used, x);
    if (!solved.usable || !x.allFinite())
      throw std::runtime_error("beam calibration: the solver failed: " + solved.message);
    result.iterations += solved.iterations;
    result.rounds = round;
    result.converged = solved.converged;
    for (std::size_t i = 0; i < data.size(); ++i)
      residuals[i] = residualAt(layout.count, data[i], x.data());
    if (round == options.maxRounds)
      break;
    // Robust sigma: 1.4826 x the median absolute residual over every shot (residuals are about
    // zero on the sphere), so that rejected shots may come back.
    std::vector<double> absolute(residuals.size());
    std::transform(residuals.begin(), residuals.end(), absolute.begin(),
                   [](double r) { return std::abs(r); });
    const double threshold =
        detail::robustThreshold(absolute, options.outlierSigmas, options.minOutlierMm);
    std::vector<bool> next(shots.size());
    for (std::size_t i = 0; i < shots.size(); ++i)
      next[i] = absolute[i] <= threshold;
    if (next == used)
      break;
    const std::size_t kept = static_cast<std::size_t>(std::count(next.begin(), next.end(), true));
    require(kept >= count + 1,
            "only " + std::to_string(kept) + " of " + std::to_string(shots.size()) +
                " shots lie within " + number(threshold, "%.3g") + " mm of the sphere: at least " +
                std::to_string(count + 1) +
                " needed (check the sphere's centre and radius, and the initial guess)");
    used = std::move(next);
  }

  // Statistics over the shots used.
  std::vector<BeamShot> usedShots;
  double sumSquares = 0.0;
  double depthSum = 0.0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    if (!used[i])
      continue;
    usedShots.push_back(shots[i]);
    sumSquares += residuals[i] * residuals[i];
    depthSum += shots[i].depthMm;
  }
  const std::size_t n = usedShots.size();
  const double meanDepthMm = depthSum / static_cast<double>(n);
  const Eigen::MatrixXd jacobian = beamCalibrationJacobian(usedShots, options, x);
  const Conditioning c =
      conditioning(jacobian, layout, meanDepthMm, options.assumedSpeedOfSoundMps);
  if (!(c.conditionNumber <= options.maxConditionNumber)) {
    refuseUndetermined(c, result.parameterNames, n, options.maxConditionNumber);
  }
  // (J^T J)^-1 = S V diag(1 / sigma_k^2) V^T S for J S = U diag(sigma_k) V^T.
  const Eigen::MatrixXd sv = c.columnScale.asDiagonal() * c.v;
  const Eigen::MatrixXd inverse =
      sv * c.singularValues.cwiseAbs2().cwiseInverse().asDiagonal() * sv.transpose();
  const double variance = sumSquares / static_cast<double>(n - count);

  const BeamGeometry geometry = beamGeometry(x, options);
  result.beamToProbe = geometry.beamToProbe;
  result.speedOfSoundMps = geometry.speedOfSoundMps;
  result.rmsMm = std::sqrt(sumSquares / static_cast<double>(n));
  result.conditionNumber = c.conditionNumber;
  result.parameters = x;
  result.parameterStdDev = (variance * inverse.diagonal()).cwiseSqrt();
  result.residualsMm = std::move(residuals);
  result.used = std::move(used);
  return result;
}

}  // namespace echoreg::core
