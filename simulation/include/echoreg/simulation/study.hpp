// A whole simulated study on disk: the CT as a DICOM series, the captures of every step of the
// dissertation's protocol as PLUS sequence files, the manifest, and the ground truth. The layout
// and every file are described in docs/formats.md ("Simulated studies").
#pragma once

#include "echoreg/simulation/anatomy.hpp"
#include "echoreg/simulation/specimen.hpp"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace echoreg::simulation {

enum class StudySize { Small, Full };
enum class Standoff { GloveFinger, GelPad, None };
enum class FemurRegions { All, Epicondyles };

struct StudyOptions {
  SpecimenKind preset = SpecimenKind::Cadaver;
  std::uint64_t seed = 1;
  StudySize size = StudySize::Full;
  double flexionDeg = 0.0;
  /// Marginal osteophytes of an arthritic knee, mm (KneeOptions::osteophyteMm: 0 none, at most
  /// 8; needs the procedural femur).
  double osteophyteMm = 0.0;
  std::map<BoneId, std::string> meshFiles;  ///< --bone femur=FILE.stl
  Standoff standoff = Standoff::GloveFinger;
  /// Speed of sound the capture software assumes (written in the captures' headers); 0 = the
  /// dissertation's choice for the preset (phantom 1450, cadaver 1540 m/s).
  double assumedSpeedOfSoundMps = 0.0;
  double waterTemperatureC = 24.0;  ///< bath and standoff water: sets its true speed of sound
  bool fibulaInTibiaModel = false;  ///< truth/tibia.vtp holds tibia and fibula (specimen #3)
  FemurRegions femurRegions = FemurRegions::All;
  double tissueScale = 1.0;  ///< soft tissue thickness factor
  /// Thickness factor of the fat and muscle under the skin, (0, 1] (--soft-tissue-scale; 0.3: the
  /// knee in vivo, bone 2-10 mm under the skin).
  double underSkinScale = 1.0;
  /// Centre frequency of the probe, Hz, for every A-line capture; 0 = the Olympus V312's 9 MHz.
  double probeFrequencyHz = 0.0;
  /// The front end: the 5072PR and 8-bit card (UInt8), or a 12-bit int16 card with DC offset,
  /// baseline wander and a short ring-down with a tail (Int16Left12).
  AdcFormat adc = AdcFormat::UInt8;
  int framesPerBone = 0;  ///< ultrasound frames per bone; 0 = by size (small 800, full 3000)
  int registrations = 1;  ///< ultrasound captures per bone (the dissertation: 5)
  int calibrations = 1;   ///< calibration sessions of the one probe (Table 5.1: 5)
};

/// Shares of frames that a correct detector should accept, per capture and region.
struct RegionShare {
  std::string capture, region;
  int frames = 0;
  int shouldAccept = 0;
  int onBone[4] = {0, 0, 0, 0};  ///< frames whose beam hits femur, tibia, fibula, patella
};

struct StudySummary {
  std::string folder;
  std::vector<std::pair<std::string, double>> stepSeconds;  ///< in order
  std::vector<RegionShare> regions;
  int ctSlices = 0;
  std::array<int, 2> ctSize{0, 0};
  int captures = 0;
  int ultrasoundFrames = 0;
};

/// Progress: the step's name and its fraction done.
using StudyProgress = std::function<void(const std::string& step, double fraction)>;

/// Writes the study into `folder`, which must not exist or be empty. Everything is written into a
/// temporary sibling folder first and renamed at the end, so a failure leaves nothing behind.
/// Throws FileError (naming the file) or std::invalid_argument (naming the option).
StudySummary generateStudy(const StudyOptions& options, const std::string& folder,
                           const StudyProgress& progress = {});

std::string_view presetName(SpecimenKind kind);
std::string_view standoffName(Standoff standoff);

}  // namespace echoreg::simulation
