// `echoreg calibrate` as a typed request: the command parses its flags into CalibrateOptions, and
// the study fills one per calibration session (Table 5.2) with no command line in between.
#pragma once

#include "commands.hpp"
#include "detection_params.hpp"

#include "echoreg/core/beam_calibration.hpp"
#include "echoreg/core/calibration_gate.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace echoreg::cli {

/// Every setting of a calibration; the defaults are the command's.
struct CalibrateOptions {
  std::string sphereCapture, tipFile, capture, out;
  double sphereRadius = 25.4;
  double tipRadius = 0.0;
  bool freeRadius = false;
  std::vector<double> initial;
  std::optional<double> speedOfSound;  ///< the bath's, when given (else the header's)
  std::vector<double> windowMm;
  std::string paramsFile;     ///< --params: detection tunables (detection_params.hpp)
  TunableSettings detection;  ///< the shared table's flags given
  std::string mode = "translation";
  bool fitSpeed = false;
  bool json = false;
  core::CalibrationGate gate;
  std::vector<double> speedRange{gate.minSpeedOfSoundMps, gate.maxSpeedOfSoundMps};
  double maxCondition = core::BeamCalibrationOptions{}.maxConditionNumber;
};

/// The options as JSON: every setting, for a study step's cache key (the files' bytes are added by
/// the study runner).
nlohmann::json requestJson(const CalibrateOptions& options);

/// Runs the calibration and writes options.out (and the .tfm beside it); returns the exit code.
/// Throws FileError / std::invalid_argument for bad input, as the command reports them.
int runCalibrate(const CalibrateOptions& options, const Streams& io);

}  // namespace echoreg::cli
