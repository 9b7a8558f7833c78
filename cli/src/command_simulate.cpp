// `echoreg simulate --out DIR`: a whole study with ground truth (simulation/study.hpp).
#include "commands.hpp"
#include "path_check.hpp"
#include "validators.hpp"

#include "echoreg/simulation/study.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <map>
#include <memory>
#include <ostream>
#include <stdexcept>

namespace echoreg::cli {

namespace {

struct SimulateOptions {
  std::string out;
  std::string preset = "cadaver";
  std::uint64_t seed = 1;
  std::string size = "full";
  std::vector<std::string> bones;
  double flexionDeg = 0.0;
  double osteophyteMm = 0.0;
  std::string standoff = "glove";
  double speedOfSound = 0.0;
  double waterTemperature = 24.0;
  bool fibulaInTibia = false;
  std::string femurRegions = "all";
  double tissueScale = 1.0;
  double softTissueScale = 1.0;
  double probeFrequency = 0.0;
  std::string adc = "uint8";
  int framesPerBone = 0;
  int registrations = 1;
  int calibrations = 1;
  bool json = false;
};

simulation::StudyOptions toStudyOptions(const SimulateOptions& o) {
  simulation::StudyOptions s;
  s.preset =
      o.preset == "phantom" ? simulation::SpecimenKind::Phantom : simulation::SpecimenKind::Cadaver;
  s.seed = o.seed;
  s.size = o.size == "small" ? simulation::StudySize::Small : simulation::StudySize::Full;
  s.flexionDeg = o.flexionDeg;
  s.osteophyteMm = o.osteophyteMm;
  s.standoff = o.standoff == "gel"    ? simulation::Standoff::GelPad
               : o.standoff == "none" ? simulation::Standoff::None
                                      : simulation::Standoff::GloveFinger;
  s.assumedSpeedOfSoundMps = o.speedOfSound;
  s.waterTemperatureC = o.waterTemperature;
  s.fibulaInTibiaModel = o.fibulaInTibia;
  s.femurRegions = o.femurRegions == "epicondyles" ? simulation::FemurRegions::Epicondyles
                                                   : simulation::FemurRegions::All;
  s.tissueScale = o.tissueScale;
  s.underSkinScale = o.softTissueScale;
  s.probeFrequencyHz = o.probeFrequency;
  s.adc =
      o.adc == "int16-12bit" ? simulation::AdcFormat::Int16Left12 : simulation::AdcFormat::UInt8;
  s.framesPerBone = o.framesPerBone;
  s.registrations = o.registrations;
  s.calibrations = o.calibrations;
  const std::map<std::string, simulation::BoneId> names{{"femur", simulation::BoneId::Femur}};
  for (const std::string& spec : o.bones) {
    const auto eq = spec.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size()) {
      throw std::invalid_argument("--bone expects NAME=FILE (e.g. femur=femur.stl), got '" + spec +
                                  "'");
    }
    const auto it = names.find(spec.substr(0, eq));
    if (it == names.end()) {
      throw std::invalid_argument("--bone: unknown bone '" + spec.substr(0, eq) + "' (femur)");
    }
    s.meshFiles[it->second] = spec.substr(eq + 1);
    CommandPaths().input("--bone", spec.substr(eq + 1)).output("--out", o.out).check();
  }
  return s;
}

}  // namespace

CommandAction addSimulateCommand(CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Simulate a whole study with ground truth: a knee's bones (procedural, or a mesh of your\n"
      "own), a leg of skin, fat and muscle, a CT written as a DICOM series, and the captures of\n"
      "every step (calibration sphere, stylus pivot, ultrasound sweeps per bone, mechanical "
      "probe,\n"
      "landmarks, hip rotation) as PLUS sequence files. Layout in docs/formats.md; physics and\n"
      "sources in docs/simulation.md.");
  cmd->add_option("--out", o->out, "Study folder to create (must not exist, or be empty)")
      ->required();
  cmd->add_option("--preset", o->preset,
                  "cadaver (tissue, standoff, double echo) or phantom (sawbones in a water bath)")
      ->check(CLI::IsMember({"cadaver", "phantom"}))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Random seed: same seed, same bytes")->capture_default_str();
  cmd->add_option(
         "--size", o->size,
         "full (the dissertation's CT: 512x512 at 0.48 mm, hip/knee/ankle groups) or small "
         "(for tests and the demo)")
      ->check(CLI::IsMember({"small", "full"}))
      ->capture_default_str();
  cmd->add_option("--bone", o->bones,
                  "Use a mesh of your own for the femur: femur=FILE (.stl, .vtp, .ply or .obj; a "
                  "closed surface in mm, either side; placed by its head, knee and epicondyles)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            const auto eq = value.find('=');
            if (eq == std::string::npos || eq + 1 == value.size()) {
              return "expects NAME=FILE, e.g. femur=femur.stl";
            }
            if (value.substr(0, eq) != "femur") {
              return "only the femur can be given as a mesh (tibia, fibula and patella are "
                     "procedural), got '" +
                     value.substr(0, eq) + "'";
            }
            return "";
          },
          "femur=FILE"));
  cmd->add_option("--flexion", o->flexionDeg,
                  "Knee flexion in degrees, 0 (straight) to 90, in the CT and the captures")
      ->check(finiteRange(0.0, 90.0))
      ->capture_default_str();
  cmd->add_option("--osteophytes", o->osteophyteMm,
                  "Marginal osteophytes of an arthritic knee, mm, 0 (none) to 8: bony ridges of\n"
                  "this radius along the medial and lateral margins of the tibiofemoral joint,\n"
                  "on the plateau and under the condyles, cut back to 0.5 mm from the other\n"
                  "bone (they bridge the joint). In the CT and the truth meshes; needs the\n"
                  "procedural femur (not with --bone femur=FILE)")
      ->check(finiteRange(0.0, 8.0))
      ->capture_default_str();
  cmd->add_option("--standoff", o->standoff,
                  "glove (water-filled glove finger), gel (Aquaflex-like pad) or none (cadaver)")
      ->check(CLI::IsMember({"glove", "gel", "none"}))
      ->capture_default_str();
  cmd->add_option("--speed-of-sound", o->speedOfSound,
                  "Speed of sound the capture software assumes, m/s (default: phantom 1450, "
                  "cadaver 1540, as in the dissertation)")
      ->check(finiteRange(1000.0, 2000.0));
  cmd->add_option("--water-temperature", o->waterTemperature,
                  "Bath and standoff water temperature, C (sets its true speed of sound)")
      ->check(finiteRange(0.0, 60.0))
      ->capture_default_str();
  cmd->add_flag("--fibula-in-tibia", o->fibulaInTibia,
                "truth/tibia.vtp holds the tibia and the fibula (the dissertation's specimen #3)");
  cmd->add_option("--femur-regions", o->femurRegions,
                  "all (anterior distal femur and epicondyles) or epicondyles (specimen #3)")
      ->check(CLI::IsMember({"all", "epicondyles"}))
      ->capture_default_str();
  cmd->add_option("--tissue-scale", o->tissueScale, "Soft tissue thickness factor (1 = mean adult)")
      ->check(finiteRange(0.5, 2.0))
      ->capture_default_str();
  cmd->add_option("--soft-tissue-scale", o->softTissueScale,
                  "Thickness factor of the fat and muscle under the skin (the skin stays): 0.3 "
                  "puts the bone 2-10 mm under the skin, the knee in vivo")
      ->check(finiteRange(0.05, 1.0))
      ->capture_default_str();
  cmd->add_option("--probe-frequency", o->probeFrequency,
                  "Centre frequency of the probe in Hz, e.g. 7e6 (default: the Olympus V312's "
                  "9 MHz); written as EchoregTransducerFrequencyHz")
      ->check(finiteRange(1e6, 20e6));
  cmd->add_option("--adc", o->adc,
                  "uint8 (the 8-bit card, mid-scale 128) or int16-12bit (a 12-bit card "
                  "left-justified in int16, with DC offset, baseline wander and a short ring-down "
                  "with a tail, as in-vivo A-mode front ends)")
      ->check(CLI::IsMember({"uint8", "int16-12bit"}))
      ->capture_default_str();
  cmd->add_option("--frames-per-bone", o->framesPerBone,
                  "Ultrasound frames per bone (default: small 800, full 3000)")
      ->check(wholeNumber(10, 100000));
  cmd->add_option("--registrations", o->registrations,
                  "Ultrasound captures per bone, each its own sweep (the dissertation did 5): "
                  "femur_ultrasound.igs.mha, femur_ultrasound_2.igs.mha, ...")
      ->check(wholeNumber(1, 20))
      ->capture_default_str();
  cmd->add_option(
         "--calibrations", o->calibrations,
         "Calibration sessions of the one probe, the bath set up anew each time (Table 5.1 "
         "has 5): calibration_shots.igs.mha, calibration_shots_2.igs.mha, ...")
      ->check(wholeNumber(1, 20))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "Print the summary as JSON");
  cmd->parse_complete_callback([o] {
    if (o->osteophyteMm > 0.0 && !o->bones.empty()) {
      throw CLI::ValidationError("simulate",
                                 "--osteophytes needs the procedural femur (the spurs are grown "
                                 "on its shape), not --bone " +
                                     o->bones.front());
    }
  });

  return [o](const Streams& io) {
    const simulation::StudyOptions options = toStudyOptions(*o);
    std::string lastStep;
    int lastPercent = -1;
    const simulation::StudySummary summary =
        simulation::generateStudy(options, o->out, [&](const std::string& step, double fraction) {
          if (!io.errIsTerminal)
            return;
          const int percent = static_cast<int>(fraction * 100.0);
          if (step == lastStep && percent == lastPercent)
            return;
          if (step != lastStep && !lastStep.empty())
            io.err << "\n";
          io.err << fmt::format("\rsimulate: {} {:3d}%", step, percent) << std::flush;
          lastStep = step;
          lastPercent = percent;
        });
    if (io.errIsTerminal && !lastStep.empty())
      io.err << "\n";
    nlohmann::json json;
    json["folder"] = summary.folder;
    json["captures"] = summary.captures;
    json["ultrasound_frames"] = summary.ultrasoundFrames;
    json["ct"] = {
        {"slices", summary.ctSlices}, {"columns", summary.ctSize[0]}, {"rows", summary.ctSize[1]}};
    nlohmann::json steps = nlohmann::json::object();
    double total = 0.0;
    for (const auto& [step, seconds] : summary.stepSeconds) {
      steps[step] = seconds;
      total += seconds;
    }
    json["seconds"] = steps;
    nlohmann::json regions = nlohmann::json::array();
    for (const simulation::RegionShare& r : summary.regions) {
      regions.push_back(
          {{"capture", r.capture},
           {"region", r.region},
           {"frames", r.frames},
           {"should_accept", r.shouldAccept},
           {"share", r.frames > 0 ? static_cast<double>(r.shouldAccept) / r.frames : 0.0},
           {"on_femur", r.onBone[0]},
           {"on_tibia", r.onBone[1]},
           {"on_fibula", r.onBone[2]},
           {"on_patella", r.onBone[3]}});
    }
    json["regions"] = regions;
    if (o->json) {
      io.out << json.dump(2) << "\n";
      return 0;
    }
    io.out << fmt::format(
        "{}: study written ({} captures, {} ultrasound frames, CT {}x{}x{}) in {:.1f} s\n",
        summary.folder, summary.captures, summary.ultrasoundFrames, summary.ctSize[0],
        summary.ctSize[1], summary.ctSlices, total);
    for (const simulation::RegionShare& r : summary.regions) {
      io.out << fmt::format("  {:<28} {:<26} {:5d} frames, {:5.1f} % should be accepted\n",
                            r.capture, r.region, r.frames,
                            r.frames > 0 ? 100.0 * r.shouldAccept / r.frames : 0.0);
    }
    return 0;
  };
}

}  // namespace echoreg::cli
