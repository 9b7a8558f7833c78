// `echoreg study run`: the steps of each stage, built from the manifest
// (command_study_detail.hpp). Building a stage runs nothing; command_study.cpp runs it.
#include "command_study_detail.hpp"

#include "command_calibrate.hpp"
#include "command_figure.hpp"
#include "csv_table.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/markups.hpp"
#include "echoreg/core/transform_file.hpp"

#include <fmt/format.h>

#include <filesystem>

namespace echoreg::cli::detail {

namespace fs = std::filesystem;

namespace {

// Each bone's targets: the knee centre, and the hip (femur) or ankle (tibia) centre.
std::string targetsFileOf(const std::map<std::string, Eigen::Vector3d>& targets,
                          const std::string& results, const std::string& bone) {
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
}

// Landmarks touched on each bone, in touch order (the femur's epicondyles, the malleoli of the
// tibia and fibula).
std::pair<std::vector<std::string>, std::vector<int>> landmarksOf(
    const std::vector<std::string>& landmarkOrder, const std::string& bone) {
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
}

}  // namespace

CalibrationPlan planCalibration(const StudyContext& ctx,
                                const std::vector<ManifestCalibrationSession>& sessions,
                                StudyReads& read) {
  const StudyManifest& manifest = ctx.manifest;
  const std::string& results = ctx.results;
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
    throw core::FileError(manifest.path, "names no calibration.sphere_radius_mm");
  if (!given.initialBeamToProbeMm)
    throw core::FileError(manifest.path, "names no calibration.initial_beam_to_probe_mm");
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
  return {std::move(stage), stylusTip, std::move(calibrations), calibrationFigure};
}

std::map<std::string, Eigen::Vector3d> evaluationTargets(const std::string& ctLandmarks) {
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
  return targets;
}

BonesPlan planBones(const StudyContext& ctx, const CalibrationPlan& calibrationPlan,
                    const StudyLandmarks& landmarks, const std::string& preset, StudyReads& read,
                    CaptureDetections& detections) {
  const StudyOptions& o = ctx.options;
  const StudyManifest& manifest = ctx.manifest;
  const std::string& results = ctx.results;
  const std::string& stylusTip = calibrationPlan.stylusTip;
  const std::string& calibration = calibrationPlan.calibrations.front();
  const std::string& ctLandmarks = landmarks.ct;
  const std::string& landmarkCapture = landmarks.capture;
  const TunableSettings& paramsSettings = ctx.params.settings;
  std::vector<StudyStep> stage;
  std::vector<BoneRun> boneRuns;
  std::error_code ec;
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
    const auto [labels, dwells] = landmarksOf(manifest.landmarks.order, bone);
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
      throw core::FileError(
          manifest.path, "bones." + bone +
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
                                     core::readTransformFile(calibration, "Beam", "Probe").matrix);
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
  return {std::move(stage), std::move(boneRuns)};
}

std::vector<StudyStep> planEvaluation(const StudyContext& ctx,
                                      const std::map<std::string, Eigen::Vector3d>& targets,
                                      std::vector<BoneRun>& boneRuns, StudyReads& read) {
  const StudyManifest& manifest = ctx.manifest;
  const std::string& results = ctx.results;
  std::vector<StudyStep> stage;
  // Evaluation and figures: only the registrations that exist.
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
    const std::string targetsFile = targetsFileOf(targets, results, run.name);
    if (!targetsFile.empty())
      common.insert(common.end(), {"--targets", targetsFile});
    if (targets.count("knee_centre") != 0) {
      const Eigen::Vector3d& c = targets.at("knee_centre");
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
    const std::string reference =
        !run.mechanical.empty() && fs::exists(run.mechanical) ? run.mechanical : estimates.front();
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
  return stage;
}

SignalsPlan planSignals(const StudyContext& ctx, const std::vector<BoneRun>& boneRuns,
                        const std::string& preset, StudyReads& read) {
  const StudyManifest& manifest = ctx.manifest;
  const std::string& results = ctx.results;
  const std::string& paramsFile = ctx.params.file;
  const TunableSettings& paramsSettings = ctx.params.settings;
  std::vector<StudyStep> stage;
  std::vector<std::pair<std::string, std::string>> signalFigures;  // file, caption
  std::vector<DetectionRate> detectionRates;
  std::string residualFigure;
  std::error_code ec;
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
                     fmt::format("signals figure ({} frame)", which), {}, {capture}, {out}, false);
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
        stage.push_back(
            {fmt::format("detect-rates-{}-{}", run.name, k + 1),
             fmt::format("{}: detection rates, {}", run.name, settings[k].first),
             args,
             study ? std::vector<std::string>{sweep, paramsFile} : std::vector<std::string>{sweep},
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
    const nlohmann::json reg = core::readJsonFile(run.ultrasound.front());
    const std::string csv = fmt::format("{}/evaluation/{}_residuals.csv", results, run.name);
    core::AtomicFile file(csv);
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
  return {std::move(stage), std::move(signalFigures), std::move(detectionRates), residualFigure};
}

}  // namespace echoreg::cli::detail
