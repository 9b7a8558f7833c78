// `echoreg figure signals` as a typed request: the command parses its flags into one, and the
// study fills one per figure with its own settings, with no command line in between.
#pragma once

#include "commands.hpp"
#include "detection_params.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace echoreg::cli {

/// One setting compared: a preset with a --params file over it (none when empty) and tunable
/// flags over that, resolved as `detect` resolves them (resolveParams).
struct SignalsSetting {
  std::string preset;  ///< empty: the file's own preset
  std::string paramsFile;
  TunableSettings settings;
};

/// Every setting of a signals figure; the defaults are the command's.
struct SignalsFigureRequest {
  std::string capture;
  int frame = 0;
  std::vector<SignalsSetting> settings;
  std::string out;
  std::string title;
  int width = 1400;
  int height = 1000;
  bool json = false;
};

/// The request as JSON: every setting, for a study step's cache key (the files' bytes are added
/// by the study runner).
nlohmann::json requestJson(const SignalsFigureRequest& request);

/// Draws the figure: the raw A-line of the frame, then per setting its envelope, threshold, peaks
/// and verdict, through detect's pipeline (reader -> envelope -> peaks, the reader read once;
/// each setting's executions tallied as run() tallies them). Writes the PNG (whole or not at all)
/// and the summary (or --json) to `io.out`; returns 0, throws for bad input as the command does.
int runSignalsFigure(const SignalsFigureRequest& request, const Streams& io);

}  // namespace echoreg::cli
