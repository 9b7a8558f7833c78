// `echoreg study run DIR`: the users' main job. The study manifest (DIR/study.json, see
// docs/formats.md) run end to end as echoreg steps — stylus pivot, transducer calibration, hip
// centre, bone models, detection, registrations, evaluation, figures — then the report
// (results/report.md, report.html, results.json). Steps whose inputs did not change are not run
// again (study_runner.hpp).
#include "command_calibrate.hpp"
#include "command_figure.hpp"
#include "command_register.hpp"
#include "commands.hpp"
#include "csv_table.hpp"
#include "detection_params.hpp"
#include "model_file.hpp"
#include "path_check.hpp"
#include "report.hpp"
#include "study_manifest.hpp"
#include "study_runner.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/markups.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/MeshIO.h"
#include "echoreg/segmentation/surface_metrics.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <utility>

namespace echoreg::cli {

namespace {

namespace fs = std::filesystem;

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

std::string number(double value, int decimals = 2) {
  return fmt::format("{:.{}f}", value, decimals);
}

/// The study folder as the working directory for the run, restored when the run ends (also when
/// it throws): the steps get paths relative to the folder and write them into their results.
class StudyFolder {
 public:
  explicit StudyFolder(const std::string& dir) : previous_(fs::current_path()) {
    std::error_code ec;
    fs::current_path(dir, ec);
    if (ec)
      throw FileError(dir, "cannot be entered: " + ec.message());
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

std::string capitalised(std::string name) {
  if (!name.empty())
    name[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(name[0])));
  return name;
}

int runStudy(const StudyOptions& o, const Streams& streams) {
  const auto started = std::chrono::steady_clock::now();
  const StudyManifest manifest = readStudyManifest(o.dir);
  // The manifest's files the study reads, named as it names them; those outside the study folder
  // are listed in the provenance.
  std::set<std::string> outside;
  const auto read = [&outside](const std::string& file) -> const std::string& {
    if (!file.empty() && outsideStudyFolder(file))
      outside.insert(file);
    return file;
  };
  // --params, read before the study folder becomes the working directory: the sweeps' detection
  // parameters (detection_params.hpp), over the manifest's detection.preset and speed of sound.
  std::string paramsPreset;
  TunableSettings paramsSettings;
  // Named relative to the study folder, the working directory of the steps: the steps' requests
  // (the re-run cache) and messages hold no absolute path, so a moved or copied study (a sweep's
  // folder) is up to date where it lies.
  std::string paramsFile;
  if (!o.paramsFile.empty()) {
    CommandPaths().input("--params", o.paramsFile).check();
    mergeParamsFile(o.paramsFile, paramsPreset, paramsSettings);
    paramsFile = fs::relative(fs::absolute(o.paramsFile), fs::absolute(manifest.dir))
                     .lexically_normal()
                     .generic_string();
  }
  // Named as the user gave it, for messages; read from inside.
  const std::string studyDir = manifest.dir;
  const StudyFolder inside(studyDir);
  // The calibration's inputs, checked before anything is written, the pivot capture first as its
  // step comes first: one check and one wording for every input the study needs and does not
  // hold, "S/captures/x.igs.mha: is missing (calibration.capture in S/study.json)". The calibration
  // sessions (Table 5.2) are the manifest's list, else its one pair, named by its keys.
  const auto missingInputError = [&](const std::string& file, const std::string& why) {
    return FileError(shownInStudy(studyDir, file), fmt::format("is missing ({})", why));
  };
  const auto requirePresent = [&](const std::string& file, const std::string& what) {
    if (!fs::exists(file))
      throw missingInputError(file, fmt::format("{} in {}", what, manifest.path));
  };
  if (!manifest.calibration.pivotCapture.empty())
    requirePresent(manifest.calibration.pivotCapture, "calibration.pivot_capture");
  std::vector<ManifestCalibrationSession> sessions = manifest.calibration.sessions;
  const bool sessionList = !sessions.empty();
  if (!sessionList) {
    sessions.push_back(
        {manifest.require(manifest.calibration.sphereCapture, "calibration.sphere_capture"),
         manifest.require(manifest.calibration.capture, "calibration.capture")});
  }
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    for (const auto& [file, key] : {std::pair{sessions[k].sphereCapture, "sphere_capture"},
                                    std::pair{sessions[k].capture, "capture"}}) {
      requirePresent(file, sessionList ? fmt::format("the {} of calibration session {} of {}", key,
                                                     k + 1, sessions.size())
                                       : fmt::format("calibration.{}", key));
    }
  }
  const std::string results = "results";
  std::error_code ec;
  fs::create_directories(results + "/figures", ec);
  fs::create_directories(results + "/points", ec);
  if (ec)
    throw FileError(results, "cannot be created: " + ec.message());
  StudyRunner runner(results + "/.study-state.json", o.force, studyDir);
  // Each sweep's detection, shared by its points and its registration (each sweep detected once).
  CaptureDetections detections;
  std::vector<StepOutcome> outcomes;
  std::string failure;

  // Runs a stage of steps; a required step's failure ends the study (after the report of what ran).
  // An optional step whose input is missing is skipped, saying which input and why it is missing.
  int stepIndex = 0;
  std::map<std::string, std::string> producedBy;  // output -> "step \"title\" failed" etc.
  auto runSteps = [&](const std::vector<StudyStep>& steps) {
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
          throw missingInputError(missingInput,
                                  fmt::format("{}; step \"{}\" needs it", why, step.title));
        outcome.id = step.id;
        outcome.title = step.title;
        outcome.status = StepOutcome::Status::Skipped;
        outcome.message = missingInputError(missingInput, why).what();
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
  };

  // --- Calibration ---------------------------------------------------------------------------
  std::vector<StudyStep> stage;
  const std::string stylusTip = results + "/stylus_tip.json";
  const ManifestCalibration& given = manifest.calibration;
  const std::string pivotCapture =
      read(manifest.require(given.pivotCapture, "calibration.pivot_capture"));
  stage.push_back({"pivot-stylus",
                   "stylus tip (pivot)",
                   {"pivot", "--capture", pivotCapture, "--out", stylusTip},
                   {pivotCapture},
                   {stylusTip},
                   true});
  // Every calibration session of the probe (Table 5.2), each its own typed step; the first is
  // results/calibration.json, the calibration the sweeps use, session n > 1 calibration_n.json.
  if (!given.sphereRadiusMm)
    throw FileError(manifest.path, "names no calibration.sphere_radius_mm");
  if (!given.initialBeamToProbeMm)
    throw FileError(manifest.path, "names no calibration.initial_beam_to_probe_mm");
  std::vector<std::string> calibrations;
  for (std::size_t k = 0; k < sessions.size(); ++k) {
    const std::string suffix = k == 0 ? std::string() : fmt::format("_{}", k + 1);
    CalibrateOptions cal;
    cal.sphereCapture = read(sessions[k].sphereCapture);
    cal.capture = read(sessions[k].capture);
    cal.tipFile = stylusTip;
    cal.sphereRadius = *given.sphereRadiusMm;
    if (given.stylusTipRadiusMm)
      cal.tipRadius = *given.stylusTipRadiusMm;
    cal.fitSpeed = true;
    // The bath's speed of sound as the manifest gives it (else the shots' header gives it).
    cal.speedOfSound = given.speedOfSoundMps;
    cal.initial.assign(given.initialBeamToProbeMm->begin(), given.initialBeamToProbeMm->end());
    if (given.windowMm)
      cal.windowMm.assign(given.windowMm->begin(), given.windowMm->end());
    cal.out = results + "/calibration" + suffix + ".json";
    StudyStep step{k == 0 ? std::string("calibrate") : fmt::format("calibrate-{}", k + 1),
                   sessions.size() == 1
                       ? std::string("transducer calibration (BeamToProbe)")
                       : fmt::format("transducer calibration (BeamToProbe), session {} of {}",
                                     k + 1, sessions.size()),
                   {},
                   {cal.sphereCapture, cal.capture, stylusTip},
                   {cal.out},
                   true};
    step.command = "calibrate";
    step.request = requestJson(cal).dump();
    step.action = [cal](const Streams& io) { return runCalibrate(cal, io); };
    stage.push_back(std::move(step));
    calibrations.push_back(cal.out);
  }
  const std::string& calibration = calibrations.front();
  const std::string calibrationFigure = results + "/figures/calibration.png";
  stage.push_back(
      {"figure-calibration",
       "calibration figure",
       {"figure", "calibration", "--calibration", calibration, "--title",
        "Calibration: echoes on the sphere (distance to the sphere)", "--out", calibrationFigure},
       {calibration},
       {calibrationFigure},
       false});
  runSteps(stage);

  // --- Bones: hip centre, models, detection, registrations, evaluation, figures ---------------
  const std::string preset = !paramsPreset.empty()       ? paramsPreset
                             : manifest.detection.preset ? *manifest.detection.preset
                                                         : "default";
  const std::string ctLandmarks = read(manifest.landmarks.ct);
  const std::string landmarkCapture = read(manifest.landmarks.capture);
  const std::vector<std::string>& landmarkOrder = manifest.landmarks.order;
  // Targets of the evaluation, in CT, from the CT landmarks: the knee centre (between the
  // epicondyles), the hip centre, the ankle centre (between the malleoli).
  std::map<std::string, Eigen::Vector3d> targets;
  if (!ctLandmarks.empty() && fs::exists(ctLandmarks)) {
    std::map<std::string, Eigen::Vector3d> picked;
    for (const core::MarkupPoint& p : core::readMarkupPoints(ctLandmarks))
      picked[p.label] = p.positionLps;
    auto midpoint = [&](const char* a, const char* b, const char* name) {
      if (picked.count(a) != 0 && picked.count(b) != 0)
        targets[name] = 0.5 * (picked[a] + picked[b]);
    };
    midpoint("medial_epicondyle", "lateral_epicondyle", "knee_centre");
    midpoint("medial_malleolus", "lateral_malleolus", "ankle_centre");
    if (picked.count("hip_centre") != 0)
      targets["hip_centre"] = picked["hip_centre"];
  }
  // Each bone's targets: the knee centre, and the hip (femur) or ankle (tibia) centre.
  auto targetsFileOf = [&](const std::string& bone) {
    std::vector<core::MarkupPoint> list;
    for (const auto& [name, p] : targets) {
      if (name == "knee_centre" || (bone == "femur" && name == "hip_centre") ||
          (bone == "tibia" && name == "ankle_centre")) {
        list.push_back({name, p});
      }
    }
    if (list.empty())
      return std::string();
    const std::string path = results + "/targets_" + bone + ".mrk.json";
    core::writeMarkupPoints(path, list);
    return path;
  };
  // Landmarks touched on each bone, in touch order (the femur's epicondyles, the malleoli of the
  // tibia and fibula).
  auto landmarksOf = [&](const std::string& bone) {
    std::pair<std::vector<std::string>, std::vector<int>> labelsAndDwells;
    for (std::size_t i = 0; i < landmarkOrder.size(); ++i) {
      const std::string& label = landmarkOrder[i];
      const bool femoral = label.find("epicondyle") != std::string::npos;
      const bool ankle = label.find("malleolus") != std::string::npos;
      if ((bone == "femur" && femoral) || (bone == "tibia" && ankle)) {
        labelsAndDwells.first.push_back(label);
        labelsAndDwells.second.push_back(static_cast<int>(i));  // touched in the manifest's order
      }
    }
    return labelsAndDwells;
  };
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
  std::vector<BoneRun> boneRuns;
  if (failure.empty()) {
    stage.clear();
    const std::string hipCentre = results + "/hip_centre.json";
    const ManifestBone* femur = manifest.bone("femur");
    const std::string hipCapture = femur != nullptr ? read(femur->hipRotation) : std::string();
    if (!hipCapture.empty()) {
      stage.push_back(
          {"pivot-hip",
           "hip centre (femur pivot)",
           {"pivot", "--capture", hipCapture, "--marker", "FemurToTracker", "--out", hipCentre},
           {hipCapture},
           {hipCentre},
           false});
    }
    fs::create_directories(results + "/registrations", ec);
    fs::create_directories(results + "/evaluation", ec);
    for (const ManifestBone& entry : manifest.bones) {
      const std::string& bone = entry.name;
      BoneRun run;
      run.name = bone;
      const std::string Bone = capitalised(bone);
      const std::string marker = Bone + "ToTracker";
      // The model: segmented from the CT when the manifest gives seeds (unless --given-models),
      // else the manifest's model.
      const std::string ctFolder = read(manifest.ctDicom);
      if (!o.givenModels && !entry.seedsCt.empty() && !ctFolder.empty()) {
        fs::create_directories(results + "/models", ec);
        run.model = fmt::format("{}/models/{}.vtp", results, bone);
        run.segmented = true;
        std::vector<std::string> args = {"segment", "--dicom", ctFolder, "--bone", bone, "--auto"};
        // The manifest's seeds of every bone compete: this bone's make the model, the others'
        // keep it out of the bones it touches (a tibia+fibula's second seed is the fibula's).
        for (const ManifestBone& other : manifest.bones) {
          for (std::size_t n = 0; n < other.seedsCt.size(); ++n) {
            args.push_back("--seed");
            args.push_back(other.withFibula && n == 1 ? std::string("fibula") : other.name);
            for (const double v : other.seedsCt[n])
              args.push_back(fmt::format("{}", v));
          }
        }
        if (entry.withFibula)
          args.push_back("--with-fibula");
        args.insert(args.end(), {"--out", run.model});
        stage.push_back({"segment-" + bone,
                         bone + " model segmented from the CT",
                         args,
                         {ctFolder},
                         {run.model},
                         true});
      } else {
        run.model = read(manifest.require(entry.model, "bones." + bone + ".model"));
      }
      // The start: the landmarks touched on this bone (+ the hip centre for the femur).
      RegisterOptions start;
      start.model = run.model;
      start.bone = Bone;
      start.openEnds = run.segmented;  // a segmented model is cut by the scan range
      std::vector<std::string> startInputs;
      const auto [labels, dwells] = landmarksOf(bone);
      if (!ctLandmarks.empty() && !landmarkCapture.empty() && !labels.empty()) {
        std::string joined;
        for (const std::string& l : labels)
          joined += (joined.empty() ? "" : ",") + l;
        start.landmarksCt = ctLandmarks;
        start.landmarksCapture = landmarkCapture;
        start.tipFile = stylusTip;
        start.landmarkLabels = joined;
        start.landmarkDwells = dwells;
        startInputs = {ctLandmarks, landmarkCapture, stylusTip};
        if (bone == "femur" && !hipCapture.empty()) {
          start.hipCentre = hipCentre;
          startInputs.push_back(hipCentre);
        }
      } else if (const std::string initial = read(entry.initial); !initial.empty()) {
        start.initial = initial;
        startInputs = {initial};
      } else {
        throw FileError(manifest.path,
                        "bones." + bone +
                            ": no landmarks (landmarks.ct, landmarks.capture, "
                            "landmarks.order) and no initial transform to start the registration");
      }
      int n = 0;
      for (const std::string& capture : entry.ultrasound) {
        ++n;
        const std::string path = read(capture);
        // One detection of the sweep (capture_detection.hpp) gives both its points, for the
        // figures, and its registration.
        RegisterOptions reg = start;
        reg.captures = {path};
        reg.calibration = calibration;
        reg.preset = preset;
        reg.fitSpeed = true;
        reg.method = o.method;
        reg.loss = o.loss;
        if (manifest.detection.speedOfSoundMps)
          reg.detection["speed-of-sound"] = *manifest.detection.speedOfSoundMps;
        for (const auto& [name, value] : paramsSettings)
          reg.detection[name] = value;  // --params over the manifest
        reg.out = fmt::format("{}/registrations/{}_ultrasound_{}.json", results, bone, n);
        const std::string points = fmt::format("{}/points/{}_ultrasound_{}.csv", results, bone, n);
        const auto sweepRequest = [reg, path, calibration] {
          return sweepDetectionRequest(reg, path,
                                       readTransformFile(calibration, "Beam", "Probe").matrix);
        };
        nlohmann::json pointsRequest = sweepRequest().json();
        pointsRequest.erase("beam_to_probe");  // the calibration's bytes are an input
        pointsRequest["beam_to_probe_file"] = calibration;
        pointsRequest["out"] = points;
        StudyStep pointsStep{fmt::format("detect-{}-{}", bone, n),
                             fmt::format("{} sweep {}: bone echoes", bone, n),
                             {},
                             {path, calibration},
                             {points},
                             true};
        pointsStep.command = "detect";
        pointsStep.request = pointsRequest.dump();
        pointsStep.action = [&detections, sweepRequest, points](const Streams&) {
          detections.get(sweepRequest()).pipeline.write(points);
          return 0;
        };
        stage.push_back(std::move(pointsStep));
        run.points.push_back(points);
        std::vector<std::string> inputs = {run.model, path, calibration};
        inputs.insert(inputs.end(), startInputs.begin(), startInputs.end());
        StudyStep registerStep{fmt::format("register-{}-ultrasound-{}", bone, n),
                               fmt::format("{} registration {} from ultrasound", bone, n),
                               {},
                               inputs,
                               {reg.out},
                               false};
        registerStep.command = "register";
        registerStep.request = requestJson(reg).dump();
        registerStep.action = [&detections, reg](const Streams& io) {
          return runRegister(reg, io, &detections);
        };
        stage.push_back(std::move(registerStep));
        run.ultrasound.push_back(reg.out);
      }
      // The reference: the mechanical probe on the exposed bone (section 5.2).
      if (const std::string mech = read(entry.mechanical); !mech.empty()) {
        run.mechanical = fmt::format("{}/registrations/{}_mechanical.json", results, bone);
        RegisterOptions reg = start;
        reg.stylusCaptures = {mech};
        reg.stylusTipRadius = entry.mechanicalTipRadiusMm;
        reg.tipFile = stylusTip;
        reg.out = run.mechanical;
        std::vector<std::string> inputs = {run.model, mech, stylusTip};
        inputs.insert(inputs.end(), startInputs.begin(), startInputs.end());
        StudyStep mechanicalStep{
            fmt::format("register-{}-mechanical", bone),
            fmt::format("{} registration from the mechanical probe (reference)", bone),
            {},
            inputs,
            {run.mechanical},
            false};
        mechanicalStep.command = "register";
        mechanicalStep.request = requestJson(reg).dump();
        mechanicalStep.action = [reg](const Streams& io) { return runRegister(reg, io); };
        stage.push_back(std::move(mechanicalStep));
      }
      boneRuns.push_back(run);
    }
    runSteps(stage);

    // Evaluation and figures: only the registrations that exist.
    stage.clear();
    const std::string truthTransforms = read(manifest.truth.transforms);
    for (BoneRun& run : boneRuns) {
      const std::string Bone = capitalised(run.name);
      std::vector<std::string> estimates;
      for (const std::string& r : run.ultrasound) {
        if (fs::exists(r))
          estimates.push_back(r);
      }
      if (estimates.empty())
        continue;
      std::vector<std::string> common;
      for (const std::string& e : estimates)
        common.insert(common.end(), {"--estimate", e});
      const std::string targetsFile = targetsFileOf(run.name);
      if (!targetsFile.empty())
        common.insert(common.end(), {"--targets", targetsFile});
      if (targets.count("knee_centre") != 0) {
        const Eigen::Vector3d& c = targets["knee_centre"];
        common.insert(common.end(), {"--centre", fmt::format("{}", c.x()), fmt::format("{}", c.y()),
                                     fmt::format("{}", c.z())});
      }
      std::vector<std::string> inputs = estimates;
      if (!targetsFile.empty())
        inputs.push_back(targetsFile);
      if (!run.mechanical.empty() && fs::exists(run.mechanical)) {
        run.evaluationMechanical =
            fmt::format("{}/evaluation/{}_vs_mechanical.csv", results, run.name);
        std::vector<std::string> args = {"evaluate", "--reference", run.mechanical};
        args.insert(args.end(), common.begin(), common.end());
        args.insert(args.end(), {"--out", run.evaluationMechanical});
        std::vector<std::string> in = inputs;
        in.push_back(run.mechanical);
        stage.push_back({fmt::format("evaluate-{}-mechanical", run.name),
                         fmt::format("{}: ultrasound against the mechanical probe", run.name),
                         args,
                         in,
                         {run.evaluationMechanical},
                         false});
      }
      const std::string truth = fmt::format("truth/{}ToCT.json", Bone);
      if (!truthTransforms.empty() && fs::exists(truth)) {
        run.evaluationTruth = fmt::format("{}/evaluation/{}_vs_truth.csv", results, run.name);
        std::vector<std::string> args = {"evaluate", "--reference", truth};
        args.insert(args.end(), common.begin(), common.end());
        if (!run.mechanical.empty() && fs::exists(run.mechanical)) {
          args.insert(args.end(), {"--estimate", run.mechanical});
        }
        args.insert(args.end(), {"--out", run.evaluationTruth});
        std::vector<std::string> in = inputs;
        in.push_back(truth);
        stage.push_back({fmt::format("evaluate-{}-truth", run.name),
                         fmt::format("{}: registrations against the simulation's truth", run.name),
                         args,
                         in,
                         {run.evaluationTruth},
                         false});
      }
      // The points of the first sweep on the model through the reference registration (Eq. 4.6).
      const std::string reference = !run.mechanical.empty() && fs::exists(run.mechanical)
                                        ? run.mechanical
                                        : estimates.front();
      run.figure = fmt::format("{}/figures/{}_registration.png", results, run.name);
      std::vector<std::string> figureArgs = {
          "figure",
          "registration",
          "--model",
          run.model,
          "--points",
          run.points.front(),
          "--transform",
          reference,
          "--title",
          fmt::format("{}: ultrasound points through the {} registration", Bone,
                      reference == run.mechanical ? "mechanical-probe" : "ultrasound"),
          "--out",
          run.figure};
      std::vector<std::string> figureInputs = {run.model, run.points.front(), reference};
      // The patella beside the femur (a simulated study's truth): where its stray echoes land.
      if (const std::string patella = read(manifest.truth.patella);
          run.name == "femur" && !patella.empty() && fs::exists(patella)) {
        figureArgs.insert(figureArgs.end(), {"--context", patella});
        figureInputs.push_back(patella);
      }
      stage.push_back({fmt::format("figure-{}-registration", run.name),
                       fmt::format("{}: registration figure", run.name),
                       figureArgs,
                       figureInputs,
                       {run.figure},
                       false});
    }
    runSteps(stage);
  }

  // --- Signals and statistics figures ---------------------------------------------------------
  std::vector<std::pair<std::string, std::string>> signalFigures;  // file, caption
  struct DetectionRate {
    std::string bone, setting, csv, capture;
  };
  std::vector<DetectionRate> detectionRates;
  std::string residualFigure;
  if (failure.empty() && !boneRuns.empty()) {
    stage.clear();
    const BoneRun& first = boneRuns.front();
    if (!first.points.empty() && fs::exists(first.points.front())) {
      const std::string capture = read(manifest.bone(first.name)->ultrasound.front());
      const CsvTable table = readCsvTable(first.points.front());
      const int status = table.column("status");
      const int reason = table.column("reason");
      const int frame = table.column("frame");
      std::string accepted, rejected;
      for (const auto& row : table.rows) {
        if (status < 0 || frame < 0 || reason < 0)
          break;
        const std::string& st = row[static_cast<std::size_t>(status)];
        if (accepted.empty() && st == "accepted")
          accepted = row[static_cast<std::size_t>(frame)];
        if (rejected.empty() && st == "rejected" &&
            row[static_cast<std::size_t>(reason)] == "not-bone") {
          rejected = row[static_cast<std::size_t>(frame)];
        }
      }
      for (const auto& [which, f] :
           {std::pair<std::string, std::string>{"accepted", accepted}, {"rejected", rejected}}) {
        if (f.empty())
          continue;
        const std::string out =
            fmt::format("{}/figures/signals_{}_{}.png", results, first.name, which);
        // The dissertation's chain as it was, and the study's as its sweeps were detected: its
        // preset with the study's --params.
        SignalsFigureRequest figure;
        figure.capture = capture;
        figure.frame = std::stoi(f);
        figure.settings = {{"mozes2008", "", {}}, {preset, paramsFile, {}}};
        figure.title =
            fmt::format("{} sweep, frame {} ({} by the study's detection)", first.name, f, which);
        figure.out = out;
        StudyStep step(fmt::format("figure-signals-{}", which),
                       fmt::format("signals figure ({} frame)", which), {}, {capture}, {out},
                       false);
        if (!paramsFile.empty())
          step.inputs.push_back(paramsFile);
        step.command = "figure signals";
        step.request = requestJson(figure).dump();
        step.action = [figure](const Streams& io) { return runSignalsFigure(figure, io); };
        stage.push_back(step);
        signalFigures.push_back(
            {out, fmt::format("Frame {} of the {} sweep, {} by the study's detection: the raw "
                              "A-line, then the envelope, threshold, peaks and verdict of the "
                              "dissertation's chain (mozes2008) and of the study's preset ({}{}), "
                              "as Figs. 5.10-5.29.",
                              f, first.name, which, preset,
                              paramsFile.empty() ? "" : " with its --params settings")});
      }
    }
    // Table 6.1: the single-signal chain's detection rates under several filter settings, on
    // every ultrasound sweep, against the simulation's truth (when it has one).
    const std::string shots = read(manifest.truth.shots);
    if (!shots.empty() && fs::exists(shots)) {
      fs::create_directories(results + "/detection", ec);
      const std::vector<std::pair<std::string, std::vector<std::string>>> settings = {
          {"mozes2008, cutoff 0.005", {"--preset", "mozes2008", "--cutoff", "0.005"}},
          {"mozes2008, cutoff 0.01", {"--preset", "mozes2008", "--cutoff", "0.01"}},
          {"mozes2008, cutoff 0.02", {"--preset", "mozes2008", "--cutoff", "0.02"}},
          {preset + " (the study's)", {"--preset", preset}}};
      for (const BoneRun& run : boneRuns) {
        const std::vector<std::string>& sweeps = manifest.bone(run.name)->ultrasound;
        if (sweeps.empty())
          continue;  // no sweep to rate
        const std::string sweep = read(sweeps.front());
        for (std::size_t k = 0; k < settings.size(); ++k) {
          const std::string out =
              fmt::format("{}/detection/{}_setting_{}.csv", results, run.name, k + 1);
          std::vector<std::string> args = {"detect",          sweep, "--history", "1",
                                           "--min-spread-mm", "0",   "--out",     out};
          args.insert(args.end(), settings[k].second.begin(), settings[k].second.end());
          const bool study = k + 1 == settings.size() && !paramsFile.empty();
          if (const auto c = manifest.detection.speedOfSoundMps;
              c && !(study && paramsSettings.count("speed-of-sound") != 0)) {
            args.insert(args.end(), {"--speed-of-sound", fmt::format("{}", *c)});
          }
          if (study)
            args.insert(args.end(), {"--params", paramsFile});  // the study's own setting
          stage.push_back({fmt::format("detect-rates-{}-{}", run.name, k + 1),
                           fmt::format("{}: detection rates, {}", run.name, settings[k].first),
                           args,
                           study ? std::vector<std::string>{sweep, paramsFile}
                                 : std::vector<std::string>{sweep},
                           {out},
                           false});
          detectionRates.push_back({run.name, settings[k].first, out, sweep});
        }
      }
    }
    // The ultrasound points' distances to the model after each bone's first registration.
    std::vector<std::string> groups;
    std::vector<std::string> inputs;
    for (const BoneRun& run : boneRuns) {
      if (run.ultrasound.empty() || !fs::exists(run.ultrasound.front()))
        continue;
      const nlohmann::json reg = readJsonFile(run.ultrasound.front());
      const std::string csv = fmt::format("{}/evaluation/{}_residuals.csv", results, run.name);
      AtomicFile file(csv);
      file.stream() << "point,residual_mm,abs_residual_mm,inlier\n";
      int i = 0;
      for (const auto& point : reg.value("points", nlohmann::json::array())) {
        // The points the registration used (the rejected ones are counted in its table).
        if (!point.value("inlier", false))
          continue;
        const double r = point.value("residual_mm", 0.0);
        file.stream() << fmt::format("{},{:.4f},{:.4f},1\n", i++, r, std::abs(r));
      }
      file.commit();
      groups.insert(groups.end(), {"--group", run.name + "=" + csv});
      inputs.push_back(csv);
    }
    if (groups.size() >= 2) {
      residualFigure = results + "/figures/residuals.png";
      std::vector<std::string> args = {
          "figure",   "boxplot",
          "--column", "abs_residual_mm",
          "--title",  "Distance of the ultrasound points used to the model after registration",
          "--ylabel", "|distance| (mm)",
          "--out",    residualFigure};
      args.insert(args.end(), groups.begin(), groups.end());
      stage.push_back(
          {"figure-residuals", "residuals box plot", args, inputs, {residualFigure}, false});
    }
    runSteps(stage);
  }

  // --- Report ----------------------------------------------------------------------------------
  Report report;
  nlohmann::json numbers;
  fs::path studyPath = fs::absolute(studyDir).lexically_normal();
  if (studyPath.filename().empty())
    studyPath = studyPath.parent_path();  // "S/"
  const std::string studyName = studyPath.filename().string();
  report.heading("Study report: " + studyName, 1);
  const nlohmann::json& generator = manifest.generator;
  if (generator.is_object()) {
    report.paragraph(fmt::format(
        "Simulated by {} (preset {}, seed {}, size {}).", generator.value("tool", std::string("?")),
        generator.value("preset", std::string("?")), generator.value("seed", 0),
        generator.value("size", std::string("?"))));
  }
  if (fs::exists(calibration)) {
    const nlohmann::json cal = readJsonFile(calibration);
    report.heading("Calibration of the transducer (Table 5.1)");
    const auto& m = cal.at("matrix");
    report.table(
        {"", "x (mm)", "y (mm)", "z (mm)", "RMS (mm)", "speed of sound (m/s)", "shots used"},
        {{"BeamToProbe translation", number(m[0][3].get<double>()), number(m[1][3].get<double>()),
          number(m[2][3].get<double>()), number(cal.value("rms_mm", 0.0), 3),
          number(cal.value("speed_of_sound_mps", 0.0), 1),
          fmt::format("{}", cal.value("shots_used", 0))}});
    numbers["calibration"] = {{"beam_to_probe_mm", {m[0][3], m[1][3], m[2][3]}},
                              {"rms_mm", cal.value("rms_mm", 0.0)},
                              {"speed_of_sound_mps", cal.value("speed_of_sound_mps", 0.0)},
                              {"shots_used", cal.value("shots_used", 0)}};
    if (fs::exists(calibrationFigure)) {
      report.figure("figures/calibration.png",
                    "Calibration points on the sphere, coloured by their distance to it "
                    "(green < 0.5 mm, yellow 0.5-1.0 mm, red > 1.0 mm), as Figs. 5.1-5.5.");
    }
  }
  // Table 5.2: the repeatability of the calibration over the manifest's sessions.
  if (calibrations.size() >= 2) {
    // x, y, z (mm), RMS (mm), condition number, speed of sound (m/s) of each session calibrated.
    std::vector<std::array<double, 6>> values;
    std::vector<std::vector<std::string>> rows;
    nlohmann::json entries = nlohmann::json::array();
    for (std::size_t k = 0; k < calibrations.size(); ++k) {
      const std::string shots = fs::path(sessions[k].capture).filename().string();
      if (!fs::exists(calibrations[k])) {
        rows.push_back({fmt::format("{}", k + 1), shots, "—", "—", "—", "—", "—", "—", "—"});
        continue;
      }
      const nlohmann::json cal = readJsonFile(calibrations[k]);
      const auto& m = cal.at("matrix");
      const std::array<double, 6> v = {m[0][3].get<double>(),
                                       m[1][3].get<double>(),
                                       m[2][3].get<double>(),
                                       cal.value("rms_mm", 0.0),
                                       cal.value("condition_number", 0.0),
                                       cal.value("speed_of_sound_mps", 0.0)};
      values.push_back(v);
      rows.push_back({fmt::format("{}", k + 1), shots, number(v[0]), number(v[1]), number(v[2]),
                      number(v[3], 3), number(v[4]), number(v[5], 1),
                      fmt::format("{}", cal.value("shots_used", 0))});
      entries.push_back({{"session", k + 1},
                         {"sphere_capture", sessions[k].sphereCapture},
                         {"capture", sessions[k].capture},
                         {"calibration", calibrations[k]},
                         {"beam_to_probe_mm", {v[0], v[1], v[2]}},
                         {"rms_mm", v[3]},
                         {"condition_number", v[4]},
                         {"speed_of_sound_mps", v[5]},
                         {"shots_used", cal.value("shots_used", 0)}});
    }
    nlohmann::json table = {{"sessions", entries}};
    if (!values.empty()) {
      std::array<double, 6> mean{}, low = values.front(), high = values.front();
      for (const auto& v : values) {
        for (std::size_t i = 0; i < v.size(); ++i) {
          mean[i] += v[i] / static_cast<double>(values.size());
          low[i] = std::min(low[i], v[i]);
          high[i] = std::max(high[i], v[i]);
        }
      }
      std::array<double, 6> spread{};
      for (std::size_t i = 0; i < spread.size(); ++i)
        spread[i] = high[i] - low[i];
      const auto summary = [&](const std::string& name, const std::array<double, 6>& v) {
        rows.push_back({name, "", number(v[0]), number(v[1]), number(v[2]), number(v[3], 3),
                        number(v[4]), number(v[5], 1), ""});
        return nlohmann::json{{"beam_to_probe_mm", {v[0], v[1], v[2]}},
                              {"rms_mm", v[3]},
                              {"condition_number", v[4]},
                              {"speed_of_sound_mps", v[5]}};
      };
      table["mean"] = summary("mean", mean);
      table["spread"] = summary("spread (max - min)", spread);
    }
    // A simulated study knows the probe's true BeamToProbe.
    if (const std::string truthFile = read(manifest.truth.transforms);
        !truthFile.empty() && fs::exists(truthFile)) {
      const nlohmann::json truth = readJsonFile(truthFile);
      if (truth.contains("BeamToProbe")) {
        const auto& t = truth.at("BeamToProbe");
        const std::array<double, 3> offset = {
            t.at(0).at(3).get<double>(), t.at(1).at(3).get<double>(), t.at(2).at(3).get<double>()};
        rows.push_back({"truth (simulation)", "", number(offset[0]), number(offset[1]),
                        number(offset[2]), "", "", "", ""});
        table["truth_beam_to_probe_mm"] = offset;
      }
    }
    report.heading("Repeatability of the calibration (Table 5.2)");
    report.paragraph(fmt::format(
        "The probe calibrated in each of the manifest's {} sessions (the bath set up anew), the "
        "speed of sound fitted: BeamToProbe's translation, the RMS of the echoes' distances to the "
        "sphere, the condition number of the fit (lower: the shots spread better) and the fitted "
        "speed of sound. The sweeps use session 1's calibration.",
        calibrations.size()));
    report.table({"session", "shots", "x (mm)", "y (mm)", "z (mm)", "RMS (mm)", "condition number",
                  "speed of sound (m/s)", "shots used"},
                 rows);
    numbers["calibration_sessions"] = table;
  }
  // Segmentation accuracy against the simulation's truth (within the model's slab).
  {
    std::vector<std::vector<std::string>> rows;
    nlohmann::json seg = nlohmann::json::object();
    for (const BoneRun& run : boneRuns) {
      if (!run.segmented || !fs::exists(run.model))
        continue;
      const auto truthEntry = manifest.truth.model.find(run.name);
      const std::string truthModel =
          truthEntry == manifest.truth.model.end() ? std::string() : read(truthEntry->second);
      if (truthModel.empty() || !fs::exists(truthModel))
        continue;
      const core::TriangleMesh model = readModelFile(run.model);
      const core::TriangleMesh truth = readModelFile(truthModel);
      const auto box = core::bounds(model);
      segmentation::SurfaceComparisonOptions options;
      options.zMinMm = box[0].z() + 2.0;  // the model is closed at its scan's ends
      options.zMaxMm = box[1].z() - 2.0;
      const segmentation::SurfaceComparison c =
          segmentation::compareSurfaces(model, truth, options);
      rows.push_back({run.name, number(c.meanMm, 3), number(c.p95Mm, 3), number(c.maxMm, 2),
                      number(c.dice, 4)});
      seg[run.name] = {{"mean_surface_distance_mm", c.meanMm},
                       {"p95_mm", c.p95Mm},
                       {"max_mm", c.maxMm},
                       {"dice", c.dice},
                       {"z_range_mm", {options.zMinMm, options.zMaxMm}}};
    }
    if (!rows.empty()) {
      report.heading("Segmentation of the CT");
      report.paragraph(
          "Each bone grown from the manifest's seed and refined by the CT's own "
          "iso-surface (echoreg segment --auto), compared with the simulation's true "
          "surface over the scanned knee group (2 mm inside its ends).");
      report.table(
          {"bone", "mean surface distance (mm)", "95th percentile (mm)", "max (mm)", "Dice"}, rows);
      numbers["segmentation"] = seg;
    }
  }

  // Registrations: each bone's results and its errors (Tables 5.3-5.7).
  auto evaluationTable = [&](const std::string& csv) {
    const CsvTable table = readCsvTable(csv);
    std::vector<std::string> header;
    for (const std::string& h : table.header) {
      std::string name = h;
      if (name.rfind("target_", 0) == 0)
        name = "error at " + name.substr(7);
      for (const char* unit : {"_mm", "_deg"}) {
        const auto at = name.rfind(unit);
        if (at != std::string::npos && at + std::string(unit).size() == name.size()) {
          name = name.substr(0, at) + (std::string(unit) == "_mm" ? " (mm)" : " (deg)");
        }
      }
      header.push_back(name);
    }
    std::vector<std::vector<std::string>> rows;
    nlohmann::json json = nlohmann::json::array();
    for (const auto& row : table.rows) {
      std::vector<std::string> cells{row[0] == "mean_abs" ? "mean of absolute values" : row[0]};
      nlohmann::json entry = {{"estimate", row[0]}};
      for (std::size_t c = 1; c < row.size(); ++c) {
        const double v = parseCsvNumber(row[c], csv, 0, table.header[c]);
        cells.push_back(number(v, 2));
        entry[table.header[c]] = v;
      }
      rows.push_back(cells);
      json.push_back(entry);
    }
    report.table(header, rows);
    return json;
  };
  nlohmann::json registrations = nlohmann::json::object();
  for (const BoneRun& run : boneRuns) {
    report.heading("Registration of the " + run.name);
    std::vector<std::vector<std::string>> rows;
    nlohmann::json list = nlohmann::json::array();
    std::vector<std::string> files = run.ultrasound;
    if (!run.mechanical.empty())
      files.push_back(run.mechanical);
    for (const std::string& file : files) {
      const std::string name = fs::path(file).stem().string();
      if (!fs::exists(file)) {
        rows.push_back({name, "failed", "", "", "", "", ""});
        list.push_back({{"name", name}, {"failed", true}});
        continue;
      }
      const nlohmann::json r = readJsonFile(file);
      rows.push_back({name, r.value("converged", false) ? "yes" : "NO",
                      number(r.value("rms_mm", 0.0), 3),
                      fmt::format("{}", r.value("points_used", 0)),
                      fmt::format("{}", r.value("points_rejected", 0)),
                      number(r.value("speed_of_sound_scale", 1.0), 4),
                      fmt::format("{}", r.value("iterations", 0))});
      list.push_back({{"name", name},
                      {"file", fs::relative(file, results).generic_string()},
                      {"converged", r.value("converged", false)},
                      {"rms_mm", r.value("rms_mm", 0.0)},
                      {"points_used", r.value("points_used", 0)},
                      {"points_rejected", r.value("points_rejected", 0)},
                      {"speed_of_sound_scale", r.value("speed_of_sound_scale", 1.0)},
                      {"iterations", r.value("iterations", 0)},
                      {"matrix", r.at("matrix")}});
    }
    report.paragraph(
        fmt::format("Model: {}{}.", fs::path(run.model).lexically_normal().generic_string(),
                    run.segmented ? " (segmented from the CT)" : " (given by the manifest)"));
    report.table({"registration", "converged", "RMS (mm, Eq. 4.4)", "points used",
                  "points rejected", "speed-of-sound scale", "iterations"},
                 rows);
    nlohmann::json entry = {{"registrations", list}};
    if (!run.evaluationMechanical.empty() && fs::exists(run.evaluationMechanical)) {
      report.paragraph(
          "Ultrasound against the mechanical-probe registration (Eq. 4.5, in CT space: "
          "translations along CT x, y, z of the knee centre, rotations about them):");
      entry["against_mechanical"] = evaluationTable(run.evaluationMechanical);
    }
    if (!run.evaluationTruth.empty() && fs::exists(run.evaluationTruth)) {
      report.paragraph("Against the simulation's true registration:");
      entry["against_truth"] = evaluationTable(run.evaluationTruth);
    }
    if (!run.figure.empty() && fs::exists(run.figure)) {
      report.figure(
          fs::relative(run.figure, results).generic_string(),
          fmt::format("The {}'s ultrasound points mapped by the reference registration "
                      "(Eq. 4.6), coloured by their distance to the model: green < 3 mm, "
                      "yellow 3-5 mm, red > 5 mm (Figs. 5.6-5.9, 5.30-5.35); the patella, "
                      "when the study has it, translucent blue.",
                      run.name));
    }
    registrations[run.name] = entry;
  }
  if (!boneRuns.empty())
    numbers["registrations"] = registrations;
  if (!detectionRates.empty()) {
    // Truth per frame of each capture: should a correct detector accept it?
    const CsvTable truth = readCsvTable(manifest.truth.shots);
    const int capCol = truth.column("capture"), frameCol = truth.column("frame"),
              acceptCol = truth.column("should_accept");
    std::map<std::pair<std::string, std::string>, bool> shouldAccept;
    for (const auto& row : truth.rows) {
      shouldAccept[{row[static_cast<std::size_t>(capCol)],
                    row[static_cast<std::size_t>(frameCol)]}] =
          row[static_cast<std::size_t>(acceptCol)] == "1";
    }
    std::vector<std::vector<std::string>> rows;
    nlohmann::json rates = nlohmann::json::array();
    for (const DetectionRate& d : detectionRates) {
      if (!fs::exists(d.csv))
        continue;
      const CsvTable detected = readCsvTable(d.csv);
      const int f = detected.column("frame"), st = detected.column("status"),
                why = detected.column("reason");
      const std::string name = fs::path(d.capture).filename().string();
      int bone = 0, notBone = 0, falseNegative = 0, falsePositive = 0;
      for (const auto& row : detected.rows) {
        if (row[static_cast<std::size_t>(why)] == "invalid-pose")
          continue;
        const auto it = shouldAccept.find({name, row[static_cast<std::size_t>(f)]});
        if (it == shouldAccept.end())
          continue;
        const bool accepted = row[static_cast<std::size_t>(st)] == "accepted";
        if (it->second) {
          ++bone;
          falseNegative += accepted ? 0 : 1;
        } else {
          ++notBone;
          falsePositive += accepted ? 1 : 0;
        }
      }
      const double fn = bone > 0 ? 100.0 * falseNegative / bone : 0.0;
      const double fp = notBone > 0 ? 100.0 * falsePositive / notBone : 0.0;
      rows.push_back({d.bone, d.setting, fmt::format("{}", bone), fmt::format("{}", notBone),
                      number(fn, 1), number(fp, 1)});
      rates.push_back({{"bone", d.bone},
                       {"setting", d.setting},
                       {"bone_frames", bone},
                       {"other_frames", notBone},
                       {"false_negative_pct", fn},
                       {"false_positive_pct", fp}});
    }
    if (!rows.empty()) {
      report.heading("Detection rates (Table 6.1)");
      report.paragraph(
          "Each A-line judged alone (no inter-signal filter) under the dissertation's "
          "chain at three low-pass cutoffs and under the study's preset, against the "
          "simulation's truth: false negatives among the frames a correct detector should "
          "accept, false positives among the others.");
      report.table({"bone", "setting", "bone frames", "other frames", "false negatives (%)",
                    "false positives (%)"},
                   rows);
      numbers["detection_rates"] = rates;
    }
  }
  if (!signalFigures.empty() || !residualFigure.empty())
    report.heading("Signals and statistics");
  for (const auto& [file, caption] : signalFigures) {
    if (fs::exists(file))
      report.figure(fs::relative(file, results).generic_string(), caption);
  }
  if (!residualFigure.empty() && fs::exists(residualFigure)) {
    report.figure(fs::relative(residualFigure, results).generic_string(),
                  "Distances of each bone's ultrasound points (those the registration used) to its "
                  "model after registration, with the one-way ANOVA between the bones (as Figs. "
                  "6.1, 6.3, 6.7-6.9).");
  }
  report.heading("For 3D Slicer");
  report.paragraph(
      "Models (.vtp) in results/models (or the manifest's), transforms as .tfm beside "
      "each JSON in results/registrations (drag onto the model's transform), "
      "the evaluation targets as .mrk.json in results/.");
  report.heading("Steps");
  report.paragraph(
      "Each step is one echoreg command; a step whose command line and input files "
      "did not change since the last run is up to date and shows its last time.");
  std::vector<std::vector<std::string>> rows;
  nlohmann::json stepsJson = nlohmann::json::array();
  for (const StepOutcome& s : outcomes) {
    std::string note = s.message;
    for (char& c : note)
      c = c == '\n' ? ' ' : c;
    rows.push_back({s.title, statusName(s.status), number(s.seconds, 2), note});
    stepsJson.push_back({{"id", s.id},
                         {"title", s.title},
                         {"status", statusName(s.status)},
                         {"seconds", s.seconds}});
  }
  report.table({"step", "status", "time (s)", "message"}, rows);
  numbers["steps"] = stepsJson;
  const double total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  numbers["seconds"] = total;
  if (!failure.empty()) {
    report.paragraph("The study stopped: " + failure);
    numbers["failure"] = failure;
  }
  // Provenance: every path in the results is relative to the study folder; what was read from
  // outside it is listed, so that a copy of the folder alone is known to be incomplete.
  {
    const std::vector<std::string> outsideList(outside.begin(), outside.end());
    numbers["provenance"] = {{"paths", "relative to the study folder"},
                             {"read_outside_study", outsideList}};
    // The sweeps' detection parameters of this run (--params: its preset and settings, not its
    // path), so that runs of one study with other parameters (a sweep's points) tell apart.
    numbers["provenance"]["detection_params"] =
        paramsFile.empty()
            ? nlohmann::json(nullptr)
            : nlohmann::json{{"preset", paramsPreset.empty() ? nlohmann::json(nullptr)
                                                             : nlohmann::json(paramsPreset)},
                             {"settings", settingsJson(paramsSettings)}};
    // The solver of the registrations from ultrasound (--method, --loss: a sweep's point).
    numbers["provenance"]["solver"] = solverJson(o.method, o.loss);
    // Which echoreg made these numbers (echoreg study compare lists it per study).
    numbers["echoreg_version"] = ECHOREG_VERSION;
    report.heading("Provenance");
    report.paragraph(fmt::format(
        "Registrations from ultrasound: method {}{} (study run --method, --loss); the reference "
        "from the mechanical probe: register's defaults.",
        o.method,
        numbers["provenance"]["solver"]["loss"].is_null() ? std::string(" (no loss)")
                                                          : ", loss " + o.loss));
    if (outside.empty()) {
      report.paragraph(
          "Every input was read inside the study folder; the paths in the results are "
          "relative to it.");
    } else {
      std::string list;
      for (const std::string& path : outside)
        list += (list.empty() ? "" : ", ") + path;
      report.paragraph(
          fmt::format("Read outside the study folder (a copy of the folder alone does "
                      "not hold them): {}. The other paths in the results are relative "
                      "to the study folder.",
                      list));
    }
  }
  // Every result the study was asked for is there, or the study says which are not and fails.
  std::vector<std::string> missing;
  for (const StepOutcome& s : outcomes) {
    if (s.status != StepOutcome::Status::Failed && s.status != StepOutcome::Status::Skipped)
      continue;
    const std::string firstLine = s.message.substr(0, s.message.find('\n'));
    missing.push_back(fmt::format("{} ({}: {})", s.title,
                                  s.status == StepOutcome::Status::Failed ? "failed" : "skipped",
                                  firstLine));
  }
  std::string incomplete;
  if (failure.empty() && !missing.empty()) {
    incomplete = fmt::format("{} requested result{} missing:", missing.size(),
                             missing.size() == 1 ? " is" : "s are");
    for (const std::string& m : missing)
      incomplete += "\n  " + m;
    report.paragraph("The study is incomplete: " + incomplete);
    numbers["missing"] = missing;
  }
  {
    AtomicFile md(results + "/report.md");
    md.stream() << report.markdown();
    md.commit();
    AtomicFile html(results + "/report.html");
    html.stream() << report.html("Study report: " + studyName);
    html.commit();
    AtomicFile json(results + "/results.json");
    json.stream() << numbers.dump(2) << "\n";
    json.commit();
  }
  if (o.json) {
    streams.out << numbers.dump(2) << "\n";
  } else {
    streams.out << fmt::format("study {}: report in {}\n",
                               !failure.empty()      ? "stopped"
                               : !incomplete.empty() ? "incomplete"
                                                     : "done",
                               fs::absolute(results + "/report.html").lexically_normal().string());
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
