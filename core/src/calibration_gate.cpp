#include "echoreg/core/calibration_gate.hpp"

#include "echoreg/core/number_text.hpp"

#include <cmath>

namespace echoreg::core {

std::vector<std::string> calibrationGateProblems(const std::vector<BeamShot>& shots,
                                                 const BeamCalibrationOptions& options,
                                                 const BeamCalibrationResult& result,
                                                 double sphereFitRmsMm,
                                                 const CalibrationGate& gate) {
  std::vector<std::string> problems;
  if (!(sphereFitRmsMm <= gate.maxRmsMm)) {
    problems.push_back("the stylus points lie " + number(sphereFitRmsMm, 2) +
                       " mm RMS off the sphere (above " + number(gate.maxRmsMm, 2) +
                       " mm): check --stylus-tip-to-stylus, --stylus-tip-radius and "
                       "--sphere-radius");
  }
  if (!(result.rmsMm <= gate.maxRmsMm)) {
    problems.push_back("the echoes lie " + number(result.rmsMm, 2) +
                       " mm RMS off the sphere (above " + number(gate.maxRmsMm, 2) + " mm)");
  }
  const double speed = result.speedOfSoundMps;
  if (!(speed >= gate.minSpeedOfSoundMps && speed <= gate.maxSpeedOfSoundMps)) {
    problems.push_back(std::string(options.fitSpeedOfSound ? "the fitted" : "the assumed") +
                       " speed of sound " + number(speed, 1) + " m/s is outside " +
                       number(gate.minSpeedOfSoundMps, 0) + "-" +
                       number(gate.maxSpeedOfSoundMps, 0) + " m/s");
  }
  // Geometry: every used shot's beam starts outside the sphere and points toward its centre, and
  // its echo lies on the near side (where the surface faces the beam).
  const double scale = options.assumedSpeedOfSoundMps > 0.0
                           ? result.speedOfSoundMps / options.assumedSpeedOfSoundMps
                           : 1.0;
  const Eigen::Vector3d& centre = options.sphereCentreTracker;
  int used = 0, inside = 0, away = 0, farSide = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    if (i < result.used.size() && !result.used[i])
      continue;
    ++used;
    const Eigen::Isometry3d beamToTracker = shots[i].probeToTracker * result.beamToProbe;
    const Eigen::Vector3d origin = beamToTracker.translation();
    const Eigen::Vector3d direction = beamToTracker.linear().col(2).normalized();
    const Eigen::Vector3d echo = origin + scale * shots[i].depthMm * direction;
    if ((origin - centre).norm() <= options.sphereRadiusMm)
      ++inside;
    if ((centre - origin).dot(direction) <= 0.0)
      ++away;
    if ((echo - centre).dot(direction) > 0.0)
      ++farSide;
  }
  if (inside > 0 || away > 0) {
    problems.push_back("the solution puts the beam's origin inside the sphere in " +
                       std::to_string(inside) + " and points the beam away from it in " +
                       std::to_string(away) + " of " + std::to_string(used) +
                       " shots: start --initial nearer (e.g. a CMM measurement)");
  } else if (used > 0 && farSide > gate.maxFarSideShare * used) {
    problems.push_back("the solution puts " + std::to_string(farSide) + " of " +
                       std::to_string(used) +
                       " echoes on the sphere's far side (the beam through the sphere): a "
                       "transducer on the wrong side, start --initial nearer (e.g. a CMM "
                       "measurement)");
  }
  return problems;
}

}  // namespace echoreg::core
