// Private declarations of `echoreg study run` (command_study.cpp), shared by its pieces:
//   - command_study_inputs.cpp: what the run takes from the manifest and --params before it
//     writes anything (the calibration's inputs checked, the files read outside the folder noted);
//   - command_study_plan.cpp: the steps of each stage (calibration; bones: models, detection,
//     registrations; evaluation and figures; signals and statistics), built from the manifest;
//   - command_study_report.cpp: the report (report.md, report.html, results.json) from the
//     results the steps left.
// command_study.cpp runs the stages in order and ends with the report (not installed).
#pragma once

#include "capture_detection.hpp"
#include "command_register.hpp"
#include "commands.hpp"
#include "detection_params.hpp"
#include "study_manifest.hpp"
#include "study_runner.hpp"

#include "echoreg/core/error.hpp"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <chrono>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace echoreg::cli::detail {

struct StudyOptions {
  std::string dir;
  bool force = false;
  bool givenModels = false;
  std::string paramsFile;  ///< --params: detection parameters of the sweeps, over the manifest's
  /// --method, --loss: the solver of the registrations from ultrasound (register's names and
  /// defaults); the mechanical reference keeps register's defaults.
  std::string method = RegisterOptions().method;
  std::string loss = RegisterOptions().loss;
  bool json = false;
};

std::string capitalised(std::string name);

// --- The manifest's inputs (command_study_inputs.cpp) ----------------------------------------

/// The manifest's files the study reads, named as it names them; those outside the study folder
/// are listed in the provenance.
class StudyReads {
 public:
  /// `file`, noted when it lies outside the study folder.
  const std::string& operator()(const std::string& file);
  const std::set<std::string>& outside() const { return outside_; }

 private:
  std::set<std::string> outside_;
};

/// --params, read before the study folder becomes the working directory: the sweeps' detection
/// parameters (detection_params.hpp), over the manifest's detection.preset and speed of sound.
struct StudyParams {
  std::string preset;
  TunableSettings settings;
  /// Named relative to the study folder, the working directory of the steps: the steps' requests
  /// (the re-run cache) and messages hold no absolute path, so a moved or copied study (a sweep's
  /// folder) is up to date where it lies. Empty without --params.
  std::string file;
};
StudyParams readStudyParams(const StudyOptions& o, const StudyManifest& manifest);

/// "S/captures/x.igs.mha: is missing (WHY)", `file` shown under the study folder `studyDir`.
core::FileError missingInputError(const std::string& studyDir, const std::string& file,
                                  const std::string& why);

/// The calibration's inputs, checked before anything is written, the pivot capture first as its
/// step comes first: one check and one wording for every input the study needs and does not
/// hold, "S/captures/x.igs.mha: is missing (calibration.capture in S/study.json)". Returns the
/// calibration sessions (Table 5.2): the manifest's list, else its one pair, named by its keys.
/// Reads from inside the study folder (`studyDir` as the user named it, for messages).
std::vector<ManifestCalibrationSession> checkCalibrationInputs(const StudyManifest& manifest,
                                                               const std::string& studyDir);

// --- Running the stages (command_study.cpp) ---------------------------------------------------

/// The steps run so far and the first required step's failure.
struct StudyProgress {
  StudyRunner& runner;
  const Streams& streams;
  std::string studyDir;  ///< as the user named it, for messages
  std::vector<StepOutcome> outcomes;
  std::string failure;  ///< empty, or why the study stopped
  int stepIndex = 0;
  std::map<std::string, std::string> producedBy;  // output -> "step \"title\" failed" etc.

  /// Runs a stage of steps; a required step's failure ends the study (after the report of what
  /// ran). An optional step whose input is missing is skipped, saying which input and why it is
  /// missing.
  void runSteps(const std::vector<StudyStep>& steps);
};

// --- The stages' steps (command_study_plan.cpp) ------------------------------------------------

/// What every stage reads: the command's options, the manifest, --params and the results folder
/// (relative to the study folder).
struct StudyContext {
  const StudyOptions& options;
  const StudyManifest& manifest;
  const StudyParams& params;
  std::string results;
};

struct CalibrationPlan {
  std::vector<StudyStep> steps;
  std::string stylusTip;
  /// One per session; the first is the calibration the sweeps use.
  std::vector<std::string> calibrations;
  std::string figure;
};
/// The stylus pivot, every calibration session of the probe and the calibration figure.
CalibrationPlan planCalibration(const StudyContext& ctx,
                                const std::vector<ManifestCalibrationSession>& sessions,
                                StudyReads& read);

/// Targets of the evaluation, in CT, from the CT landmarks: the knee centre (between the
/// epicondyles), the hip centre, the ankle centre (between the malleoli). Empty when
/// `ctLandmarks` is empty or absent.
std::map<std::string, Eigen::Vector3d> evaluationTargets(const std::string& ctLandmarks);

struct BoneRun {
  std::string name;
  std::string model;
  bool segmented = false;
  std::vector<std::string> points;
  std::vector<std::string> ultrasound;  // registration files
  std::string mechanical;
  std::string evaluationMechanical;
  std::string evaluationTruth;
  std::string figure;
};

/// The landmarks of the start: the CT's file and the capture touching them.
struct StudyLandmarks {
  std::string ct;
  std::string capture;
};

struct BonesPlan {
  std::vector<StudyStep> steps;
  std::vector<BoneRun> bones;
};
/// The hip centre, and per bone its model, each sweep's detection and registration and the
/// mechanical reference. The steps detect through `detections`, which must outlive them.
BonesPlan planBones(const StudyContext& ctx, const CalibrationPlan& calibration,
                    const StudyLandmarks& landmarks, const std::string& preset, StudyReads& read,
                    CaptureDetections& detections);

/// Evaluation and figures of the registrations that exist; sets each bone's evaluation and
/// figure files. Writes each bone's targets file.
std::vector<StudyStep> planEvaluation(const StudyContext& ctx,
                                      const std::map<std::string, Eigen::Vector3d>& targets,
                                      std::vector<BoneRun>& bones, StudyReads& read);

struct DetectionRate {
  std::string bone, setting, csv, capture;
};

struct SignalsPlan {
  std::vector<StudyStep> steps;
  std::vector<std::pair<std::string, std::string>> signalFigures;  // file, caption
  std::vector<DetectionRate> detectionRates;
  std::string residualFigure;
};
/// The signals figures, the detection rates (Table 6.1) and the residuals box plot. Writes the
/// residuals' CSV files from the registrations.
SignalsPlan planSignals(const StudyContext& ctx, const std::vector<BoneRun>& bones,
                        const std::string& preset, StudyReads& read);

// --- The report (command_study_report.cpp) -----------------------------------------------------

struct StudyReport {
  nlohmann::json numbers;  ///< results.json
  std::string incomplete;  ///< empty, or which requested results are missing
};
/// Writes results/report.md, report.html and results.json from what the steps left.
StudyReport writeStudyReport(const StudyContext& ctx, const std::string& studyDir,
                             const std::vector<ManifestCalibrationSession>& sessions,
                             const CalibrationPlan& calibration, const std::vector<BoneRun>& bones,
                             const SignalsPlan& signals, const StudyProgress& progress,
                             StudyReads& read, std::chrono::steady_clock::time_point started);

}  // namespace echoreg::cli::detail
