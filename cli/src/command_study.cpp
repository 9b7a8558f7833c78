// `echoreg study run DIR`: the users' main job. The study manifest (DIR/study.json, see
// docs/formats.md) run end to end as echoreg steps — stylus pivot, transducer calibration, hip
// centre, bone models, detection, registrations, evaluation, figures — then the report
// (results/report.md, report.html, results.json). Steps whose inputs did not change are not run
// again (study_runner.hpp). The stages' steps are built in command_study_plan.cpp, the report
// written in command_study_report.cpp (command_study_detail.hpp).
#include "command_study_detail.hpp"

#include "commands.hpp"

#include "echoreg/core/error.hpp"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <utility>

namespace echoreg::cli {

namespace detail {

namespace fs = std::filesystem;

void StudyProgress::runSteps(const std::vector<StudyStep>& steps) {
  for (const StudyStep& step : steps) {
    if (!failure.empty())
      break;
    ++stepIndex;
    std::string missingInput;
    for (const std::string& input : step.inputs) {
      if (missingInput.empty() && !fs::exists(input))
        missingInput = input;
    }
    StepOutcome outcome;
    if (!missingInput.empty()) {
      const auto by = producedBy.find(missingInput);
      const std::string why =
          by != producedBy.end() ? by->second : "the study folder does not hold it";
      if (step.required)
        throw missingInputError(studyDir, missingInput,
                                fmt::format("{}; step \"{}\" needs it", why, step.title));
      outcome.id = step.id;
      outcome.title = step.title;
      outcome.status = StepOutcome::Status::Skipped;
      outcome.message = missingInputError(studyDir, missingInput, why).what();
    } else {
      outcome = runner.run(step, streams, stepIndex, 0);
      if (outcome.status == StepOutcome::Status::Failed && step.required) {
        failure = fmt::format("step \"{}\" failed: {}", step.title, outcome.message);
      }
    }
    if (outcome.status == StepOutcome::Status::Failed ||
        outcome.status == StepOutcome::Status::Skipped) {
      for (const std::string& output : step.outputs) {
        producedBy[output] =
            fmt::format("step \"{}\" {}", step.title,
                        outcome.status == StepOutcome::Status::Failed ? "failed" : "was skipped");
      }
    }
    outcomes.push_back(std::move(outcome));
  }
  runner.save();
}

}  // namespace detail

namespace {

namespace fs = std::filesystem;
using namespace detail;

/// The study folder as the working directory for the run, restored when the run ends (also when
/// it throws): the steps get paths relative to the folder and write them into their results.
class StudyFolder {
 public:
  explicit StudyFolder(const std::string& dir) : previous_(fs::current_path()) {
    std::error_code ec;
    fs::current_path(dir, ec);
    if (ec)
      throw core::FileError(dir, "cannot be entered: " + ec.message());
  }
  ~StudyFolder() {
    std::error_code ec;
    fs::current_path(previous_, ec);
  }
  StudyFolder(const StudyFolder&) = delete;
  StudyFolder& operator=(const StudyFolder&) = delete;

 private:
  fs::path previous_;
};

int runStudy(const StudyOptions& o, const Streams& streams) {
  const auto started = std::chrono::steady_clock::now();
  const StudyManifest manifest = readStudyManifest(o.dir);
  StudyReads read;
  const StudyParams params = readStudyParams(o, manifest);
  // Named as the user gave it, for messages; read from inside.
  const std::string studyDir = manifest.dir;
  const StudyFolder inside(studyDir);
  const std::vector<ManifestCalibrationSession> sessions =
      checkCalibrationInputs(manifest, studyDir);
  const std::string results = "results";
  std::error_code ec;
  fs::create_directories(results + "/figures", ec);
  fs::create_directories(results + "/points", ec);
  if (ec)
    throw core::FileError(results, "cannot be created: " + ec.message());
  StudyRunner runner(results + "/.study-state.json", o.force, studyDir);
  // Each sweep's detection, shared by its points and its registration (each sweep detected once).
  CaptureDetections detections;
  StudyProgress progress{runner, streams, studyDir, {}, {}, 0, {}};
  const StudyContext ctx{o, manifest, params, results};

  const CalibrationPlan calibration = planCalibration(ctx, sessions, read);
  progress.runSteps(calibration.steps);

  // --- Bones: hip centre, models, detection, registrations, evaluation, figures ---------------
  const std::string preset = !params.preset.empty()      ? params.preset
                             : manifest.detection.preset ? *manifest.detection.preset
                                                         : "default";
  StudyLandmarks landmarks;
  landmarks.ct = read(manifest.landmarks.ct);
  landmarks.capture = read(manifest.landmarks.capture);
  const std::map<std::string, Eigen::Vector3d> targets = evaluationTargets(landmarks.ct);
  std::vector<BoneRun> boneRuns;
  if (progress.failure.empty()) {
    BonesPlan bones = planBones(ctx, calibration, landmarks, preset, read, detections);
    boneRuns = std::move(bones.bones);
    progress.runSteps(bones.steps);
    progress.runSteps(planEvaluation(ctx, targets, boneRuns, read));
  }

  // --- Signals and statistics figures ---------------------------------------------------------
  SignalsPlan signals;
  if (progress.failure.empty() && !boneRuns.empty()) {
    signals = planSignals(ctx, boneRuns, preset, read);
    progress.runSteps(signals.steps);
  }

  // --- Report ----------------------------------------------------------------------------------
  const StudyReport written = writeStudyReport(ctx, studyDir, sessions, calibration, boneRuns,
                                               signals, progress, read, started);
  const nlohmann::json& numbers = written.numbers;
  const std::string& failure = progress.failure;
  const std::string& incomplete = written.incomplete;
  if (o.json) {
    streams.out << numbers.dump(2) << "\n";
  } else {
    streams.out << fmt::format("study {}: report in {}\n",
                               !failure.empty()      ? "stopped"
                               : !incomplete.empty() ? "incomplete"
                                                     : "done",
                               fs::absolute(results + "/report.html").lexically_normal().string());
    // What the steps' commands said of their results (printed under each step on a terminal).
    std::vector<std::string> noted;
    for (const StepOutcome& outcome : progress.outcomes) {
      if (!outcome.notes.empty())
        noted.push_back(outcome.title);
    }
    if (!noted.empty() && !streams.errIsTerminal) {
      std::string list;
      for (std::size_t i = 0; i < noted.size() && i < 3; ++i)
        list += (i ? "; " : "") + noted[i];
      streams.err << fmt::format(
          "echoreg study: {} step{} noted something about {} results ({}{}): see the report's "
          "steps\n",
          noted.size(), noted.size() == 1 ? "" : "s", noted.size() == 1 ? "its" : "their", list,
          noted.size() > 3 ? "; ..." : "");
    }
  }
  if (!failure.empty()) {
    streams.err << "echoreg study: " << studyDir << ": " << failure
                << " (paths relative to the study folder)\n";
    return 1;
  }
  if (!incomplete.empty()) {
    streams.err << "echoreg study: " << studyDir << ": incomplete, " << incomplete << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

CommandAction addStudyCommand(CLI::App& app) {
  CLI::App* cmd = app.add_subcommand(
      "study", "The main job: a study folder (study.json) run end to end into a report.");
  cmd->require_subcommand(1);
  auto o = std::make_shared<StudyOptions>();
  CLI::App* run = cmd->add_subcommand(
      "run",
      "Runs the study: stylus pivot, calibration (every session of calibration.sessions, with\n"
      "their repeatability as Table 5.2), hip centre, the bones segmented from the CT\n"
      "(the manifest's seeds), detection, registrations from ultrasound and from the mechanical\n"
      "probe, evaluation, figures; then writes DIR/results/report.html, report.md and\n"
      "results.json (docs/study.md). Steps whose request (or command line) and input files did\n"
      "not change since the last run, and whose outputs are as they wrote them, are not run\n"
      "again (--force runs all). Exits 1 when a requested result is missing (a step failed or\n"
      "was skipped), naming each. Progress on a terminal.");
  run->add_option("dir", o->dir, "Study folder (holds study.json)")->required();
  run->add_flag("--force", o->force, "Run every step again");
  run->add_flag("--given-models", o->givenModels,
                "Use the manifest's bone models instead of segmenting the CT from its seeds");
  run->add_flag("--json", o->json, "Print every number of the report as JSON");
  run->add_option("--params", o->paramsFile,
                  "JSON object of detection parameters for the sweeps, named as echoreg detect's "
                  "flags without dashes; over the manifest's detection.preset and "
                  "speed_of_sound_mps (a change re-runs the sweeps' points and registrations)");
  // register's own options: its names, checks and defaults.
  addSolverOptions(run, o->method, o->loss);
  for (const char* flag : {"--method", "--loss"}) {
    CLI::Option* option = run->get_option(flag);
    option->description("The registrations from ultrasound (a change re-runs them): " +
                        option->get_description());
  }
  const CommandAction compare = addStudyCompareCommand(*cmd);
  const CommandAction sweep = addStudySweepCommand(*cmd);
  CLI::App* sweepCmd = cmd->get_subcommand("sweep");
  return [o, run, compare, sweep, sweepCmd](const Streams& streams) {
    return run->parsed()        ? runStudy(*o, streams)
           : sweepCmd->parsed() ? sweep(streams)
                                : compare(streams);
  };
}

}  // namespace echoreg::cli
