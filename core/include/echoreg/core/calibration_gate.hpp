// The quality gate of a transducer calibration (issue 15, item 4): a BeamToProbe that Ceres
// converged to is still refused when its fit, its speed of sound or its geometry is implausible.
// docs/calibration.md ("Quality gate") gives the thresholds and why.
#pragma once

#include "echoreg/core/beam_calibration.hpp"

#include <string>
#include <vector>

namespace echoreg::core {

struct CalibrationGate {
  /// Largest RMS of the shots used (and of the stylus points on the sphere), mm. The
  /// dissertation's five calibrations: 0.55-0.91 mm; simulated sessions 0.06-0.15 mm.
  double maxRmsMm = 1.5;
  /// Speeds of sound accepted, assumed or fitted, m/s: water from 0 to 100 degC is 1402-1555 m/s,
  /// tissue-mimicking gels and oils 1400-1650.
  double minSpeedOfSoundMps = 1350.0;
  double maxSpeedOfSoundMps = 1700.0;
  /// Largest share of the shots used whose echo lies on the sphere's far side (the beam passing
  /// through the sphere before the echo): a solution with the transducer on the wrong side.
  double maxFarSideShare = 0.1;
  /// Largest difference between the radius the stylus points give (fitted free) and the sphere's
  /// plus the ball tip's, mm: a wrong tip radius moves the sphere's centre, and the calibration,
  /// by as much (checked by `echoreg calibrate`, which fits both).
  double maxRadiusErrorMm = 1.0;
};

/// Why a converged calibration is refused, one sentence each (empty when it passes): RMS, the
/// fitted speed of sound, and the geometry of every used shot (the beam origin outside the
/// sphere, pointing toward its centre, the echo on its near side). `sphereFitRmsMm` is the stylus
/// points' RMS on the sphere. The condition number is gated by calibrateBeam itself
/// (BeamCalibrationOptions::maxConditionNumber).
std::vector<std::string> calibrationGateProblems(const std::vector<BeamShot>& shots,
                                                 const BeamCalibrationOptions& options,
                                                 const BeamCalibrationResult& result,
                                                 double sphereFitRmsMm,
                                                 const CalibrationGate& gate);

}  // namespace echoreg::core
