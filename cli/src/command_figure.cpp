// `echoreg figure registration|calibration|signals|boxplot ... --out FIG.png`: the publication
// figures, rendered off-screen (render/, OSMesa: no X server needed).
#include "command_figure.hpp"
#include "commands.hpp"
#include "csv_table.hpp"
#include "detection_params.hpp"
#include "model_file.hpp"
#include "path_check.hpp"
#include "validators.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/core/sequence.hpp"
#include "echoreg/core/sequence_detection.hpp"
#include "echoreg/core/statistics.hpp"
#include "echoreg/core/transform_file.hpp"
#include "echoreg/filters/detection_pipeline.h"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/filters/vtkEchoregPointToSurfaceDistance.h"
#include "echoreg/render/plot_figure.hpp"
#include "echoreg/render/surface_figure.hpp"

#include <fmt/format.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkImageData.h>
#include <vtkIntArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkTable.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

namespace echoreg::cli {

namespace {

/// Points of a CSV with columns x,y,z or x_mm,y_mm,z_mm (`echoreg detect`'s output: rows without
/// a point are skipped).
std::vector<Eigen::Vector3d> readPointsCsv(const std::string& path) {
  const CsvTable table = readCsvTable(path);
  std::array<int, 3> columns{table.column("x"), table.column("y"), table.column("z")};
  if (columns[0] < 0)
    columns = {table.column("x_mm"), table.column("y_mm"), table.column("z_mm")};
  if (columns[0] < 0 || columns[1] < 0 || columns[2] < 0) {
    throw core::FileError(path, "has no point columns (x,y,z or x_mm,y_mm,z_mm)");
  }
  std::vector<Eigen::Vector3d> points;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const auto& row = table.rows[r];
    if (row[static_cast<std::size_t>(columns[0])].empty())
      continue;  // a frame without a point
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) {
      p[a] = parseCsvNumber(
          row[static_cast<std::size_t>(columns[static_cast<std::size_t>(a)])], path, r + 2,
          table.header[static_cast<std::size_t>(columns[static_cast<std::size_t>(a)])]);
    }
    points.push_back(p);
  }
  if (points.empty())
    throw core::FileError(path, "holds no point");
  return points;
}

std::vector<render::View> parseViews(const std::vector<std::string>& names) {
  std::vector<render::View> views;
  for (const std::string& name : names) {
    if (name == "coronal")
      views.push_back(render::View::Coronal);
    else if (name == "sagittal")
      views.push_back(render::View::Sagittal);
    else if (name == "transverse" || name == "axial")
      views.push_back(render::View::Transverse);
    else
      throw std::invalid_argument("unknown view \"" + name + "\" (coronal, sagittal, transverse)");
  }
  return views;
}

// --width and --height of a figure, in pixels from `minimum` to 8192.
void addSizeOptions(CLI::App* cmd, int& width, int& height, int minimum) {
  cmd->add_option("--width", width, "Image width, pixels")
      ->capture_default_str()
      ->check(wholeNumber(minimum, 8192));
  cmd->add_option("--height", height, "Image height, pixels")
      ->capture_default_str()
      ->check(wholeNumber(minimum, 8192));
}

struct SurfaceOptions {
  std::string out;
  std::string title;
  double greenBelow = 0.0;
  double redAbove = 0.0;
  double pointRadius = 0.0;
  std::vector<std::string> views{"coronal", "sagittal", "transverse"};
  int width = 1500;
  int height = 620;
  double cropMargin = 0.0;
  bool json = false;
};

void addSurfaceOptions(CLI::App* cmd, SurfaceOptions& o, double green, double red, double radius) {
  o.greenBelow = green;
  o.redAbove = red;
  o.pointRadius = radius;
  cmd->add_option("--out", o.out, "PNG to write (written whole or not at all)")->required();
  cmd->add_option("--title", o.title, "Title over the figure");
  cmd->add_option("--green-below", o.greenBelow, "Green below this distance, mm")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--red-above", o.redAbove,
                  "Red above this distance (yellow between), mm; above --green-below")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--point-radius", o.pointRadius, "Radius of the point spheres, mm")
      ->capture_default_str()
      ->check(finiteNumber(0.0, false));
  cmd->add_option("--views", o.views,
                  "Views: coronal, sagittal, transverse (named from the CT axes)")
      ->delimiter(',')
      ->capture_default_str();
  addSizeOptions(cmd, o.width, o.height, 200);
  cmd->add_flag("--json", o.json, "Print the figure's numbers as JSON");
}

// The bands' limits in the flags' words (before any file is read).
void checkBands(const SurfaceOptions& o) {
  if (!(o.redAbove > o.greenBelow)) {
    throw std::invalid_argument(
        fmt::format("--red-above {:g} must be above --green-below {:g}", o.redAbove, o.greenBelow));
  }
}

void addCropOption(CLI::App* cmd, SurfaceOptions& o, double margin) {
  o.cropMargin = margin;
  cmd->add_option("--crop-margin", o.cropMargin,
                  "Show the model only within this margin of the points, mm (0: the whole model)")
      ->capture_default_str()
      ->check(finiteNumber(0.0, true));
}

// The figure's scene: its bands, views, point radius, title and crop from the options.
render::Scene surfaceSceneOf(render::SurfaceFigure& figure, const SurfaceOptions& o) {
  figure.bands = render::registrationBands(o.greenBelow, o.redAbove);
  figure.views = parseViews(o.views);
  figure.pointRadiusMm = o.pointRadius;
  figure.title = o.title;
  figure.cropMarginMm = o.cropMargin;
  return render::surfaceScene(figure, {o.width, o.height});
}

// Renders the scene, writes it, and reports the per-band counts and distance statistics of its
// point set (signed values; the bands colour their magnitude).
int finishSurfaceFigure(const render::Scene& scene, const SurfaceOptions& o, const Streams& streams,
                        const std::string& kind) {
  render::writePng(o.out, render::renderScene(scene, {o.width, o.height}));
  const render::ScenePoints& set = scene.pointSets.front();
  vtkDataArray* values = set.points->GetPointData()->GetArray(set.scalarName.c_str());
  const auto count = static_cast<std::size_t>(set.points->GetNumberOfPoints());
  std::vector<int> counts(set.colourMap.size(), 0);
  double sumSquares = 0.0;
  double sumSigned = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double value = values->GetComponent(static_cast<vtkIdType>(i), 0);
    ++counts[static_cast<std::size_t>(render::bandOf(set.colourMap, value))];
    sumSquares += value * value;
    sumSigned += value;
  }
  const double n = static_cast<double>(count);
  nlohmann::json bands = nlohmann::json::array();
  for (std::size_t b = 0; b < set.colourMap.size(); ++b) {
    bands.push_back({{"label", set.colourMap[b].label}, {"points", counts[b]}});
  }
  const nlohmann::json summary = {{"figure", kind},
                                  {"out", o.out},
                                  {"points", count},
                                  {"rms_mm", n > 0 ? std::sqrt(sumSquares / n) : 0.0},
                                  {"mean_signed_mm", n > 0 ? sumSigned / n : 0.0},
                                  {"bands", bands}};
  if (o.json) {
    streams.out << summary.dump(2) << "\n";
  } else {
    streams.out << fmt::format("{} figure: {} points, rms {:.2f} mm; wrote {}\n", kind, count,
                               summary["rms_mm"].get<double>(), o.out);
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------

struct RegistrationOptions : SurfaceOptions {
  std::string model;
  std::string points;
  std::string transform;
  std::vector<std::string> context;
};

CommandAction addRegistrationFigure(CLI::App* parent) {
  auto o = std::make_shared<RegistrationOptions>();
  CLI::App* cmd = parent->add_subcommand(
      "registration",
      "The bone model with the ultrasound points mapped by a registration (Eq. 4.6), as spheres\n"
      "coloured by their distance to the surface (Figs. 5.6-5.9, 5.30-5.35).");
  cmd->add_option("--model", o->model, "Bone model in CT coordinates (.vtp, .stl, .ply, .obj)")
      ->required();
  cmd->add_option("--points", o->points,
                  "CSV of points in the bone tracker's frame: columns x,y,z or x_mm,y_mm,z_mm\n"
                  "(the output of `echoreg detect --reference`)")
      ->required();
  cmd->add_option("--transform", o->transform,
                  "Registration mapping the points' frame to CT, e.g. FemurToCT.json")
      ->required();
  cmd->add_option(
      "--context", o->context,
      "Neighbouring models drawn translucent (CT coordinates), e.g. the patella; repeat");
  addSurfaceOptions(cmd, *o, 3.0, 5.0, 1.5);
  addCropOption(cmd, *o, 30.0);
  return [o, cmd](const Streams& streams) {
    (void)cmd;
    checkBands(*o);
    CommandPaths()
        .input("--model", o->model)
        .input("--points", o->points)
        .input("--transform", o->transform)
        .inputs("--context", o->context)
        .output("--out", o->out)
        .check();
    requirePngName("--out", o->out);
    render::SurfaceFigure figure;
    figure.surface = readModelFile(o->model);
    for (const std::string& path : o->context)
      figure.context.push_back(readModelFile(path));
    const core::TransformFile transform = core::readTransformFile(o->transform, "", "CT");
    const Eigen::Isometry3d toCt(transform.matrix);
    // The points in CT (double, as read) and their signed distance to the model ("DistanceMm")
    // from vtkEchoregPointToSurfaceDistance.
    vtkNew<vtkPoints> inCt;
    inCt->SetDataTypeToDouble();
    for (const Eigen::Vector3d& p : readPointsCsv(o->points)) {
      const Eigen::Vector3d q = toCt * p;
      inCt->InsertNextPoint(q.data());
    }
    vtkNew<vtkPolyData> pointsInCt;
    pointsInCt->SetPoints(inCt);
    vtkNew<vtkEchoregPointToSurfaceDistance> measure;
    measure->SetInputData(0, pointsInCt);
    measure->SetSurfaceData(filters::toPolyData(figure.surface));
    measure->SetSignedDistance(true);
    {
      const filters::VtkMessageCapture quiet;  // the command's own words, not VTK's lines
      measure->Update();
    }
    if (!measure->GetLastError().empty())
      throw core::FileError(o->model, measure->GetLastError());
    const vtkSmartPointer<vtkPolyData> distances = measure->GetOutput();
    render::Scene scene = surfaceSceneOf(figure, *o);
    render::ScenePoints& points = scene.pointSets.front();
    points.points = distances;
    points.scalarName = "DistanceMm";
    scene.legend = render::pointsLegend(points, figure.valueName);
    return finishSurfaceFigure(scene, *o, streams, "registration");
  };
}

struct CalibrationOptions : SurfaceOptions {
  std::string calibration;
};

CommandAction addCalibrationFigure(CLI::App* parent) {
  auto o = std::make_shared<CalibrationOptions>();
  CLI::App* cmd = parent->add_subcommand(
      "calibration",
      "The calibration sphere with the calibration points (each shot's echo mapped with the\n"
      "calibration), coloured by their distance to the sphere (Figs. 5.1-5.5).");
  cmd->add_option("--calibration", o->calibration,
                  "Output of `echoreg calibrate` (BeamToProbe JSON with its shots)")
      ->required();
  addSurfaceOptions(cmd, *o, 0.5, 1.0, 1.0);
  o->views = {"coronal", "sagittal", "transverse"};
  return [o](const Streams& streams) {
    checkBands(*o);
    CommandPaths().input("--calibration", o->calibration).output("--out", o->out).check();
    requirePngName("--out", o->out);
    const nlohmann::json doc = core::readJsonFile(o->calibration);
    if (!doc.is_object() || !doc.contains("sphere_center_mm") ||
        !doc.contains("sphere_radius_mm") || !doc.contains("shots")) {
      throw core::FileError(o->calibration,
                            "not an `echoreg calibrate` result (no sphere_center_mm, "
                            "sphere_radius_mm or shots)");
    }
    render::SurfaceFigure figure;
    figure.surfaceRgb = {0.80, 0.84, 0.90};
    // Values of another type or count than `echoreg calibrate` writes are named, not reported as
    // nlohmann's "type must be number, but is null".
    const auto point = [&](const nlohmann::json& value, const std::string& name) {
      if (!value.is_array() || value.size() != 3 ||
          !std::all_of(value.begin(), value.end(),
                       [](const nlohmann::json& x) { return x.is_number(); })) {
        throw core::FileError(o->calibration, name + " is not 3 numbers, got " + value.dump());
      }
      const Eigen::Vector3d p(value[0].get<double>(), value[1].get<double>(),
                              value[2].get<double>());
      if (!p.allFinite())
        throw core::FileError(o->calibration, name + " is not finite");
      return p;
    };
    const auto positive = [&](const nlohmann::json& value, const std::string& name) {
      if (!value.is_number() || !(value.get<double>() >= 0.0) ||
          !std::isfinite(value.get<double>())) {
        throw core::FileError(o->calibration,
                              name + " is not a finite number >= 0, got " + value.dump());
      }
      return value.get<double>();
    };
    const Eigen::Vector3d c = point(doc["sphere_center_mm"], "sphere_center_mm");
    const double radius = positive(doc["sphere_radius_mm"], "sphere_radius_mm");
    figure.surface = core::uvSphere(c, radius);
    if (!doc["shots"].is_array())
      throw core::FileError(o->calibration, "shots is not a list");
    for (std::size_t i = 0; i < doc["shots"].size(); ++i) {
      const nlohmann::json& shot = doc["shots"][i];
      const std::string where = fmt::format("shots[{}]", i);
      if (!shot.is_object() || !shot.contains("point_mm")) {
        throw core::FileError(o->calibration,
                              where + " has no point_mm (re-run `echoreg calibrate`)");
      }
      const nlohmann::json used = shot.value("used", nlohmann::json(true));
      if (!used.is_boolean())
        throw core::FileError(o->calibration, where + ".used is not true or false");
      if (!used.get<bool>())
        continue;
      figure.points.push_back(point(shot["point_mm"], where + ".point_mm"));
      const nlohmann::json residualValue = shot.value("residual_mm", nlohmann::json());
      if (!residualValue.is_number() || !std::isfinite(residualValue.get<double>())) {
        throw core::FileError(o->calibration, where + ".residual_mm is not a finite number, got " +
                                                  residualValue.dump());
      }
      const double residual = residualValue.get<double>();
      figure.valuesMm.push_back(residual);  // signed; coloured by its magnitude
    }
    if (figure.points.empty())
      throw core::FileError(o->calibration, "has no used shot to draw");
    figure.valueName = "distance to the sphere";
    // The sphere and points are in the tracker's frame, not the CT's: name the views so.
    for (const std::string& view : o->views) {
      figure.viewLabels.push_back(view == "coronal"    ? "along tracker +y"
                                  : view == "sagittal" ? "along tracker +x"
                                                       : "along tracker -z");
    }
    return finishSurfaceFigure(surfaceSceneOf(figure, *o), *o, streams, "calibration");
  };
}

// ---------------------------------------------------------------------------------------------

struct SignalsOptions {
  std::string capture;
  int frame = 0;
  std::vector<std::string> presets{"mozes2008", "default"};
  std::string paramsFile;
  TunableSettings settings;
  std::string out;
  std::string title;
  int width = 1400;
  int height = 1000;
  bool json = false;
};

// One row of the envelope image (x sample, y frame) of the envelope filter's output.
std::vector<double> envelopeRow(vtkImageData* image, int frame) {
  int dimensions[3];
  image->GetDimensions(dimensions);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  const int row = frame - image->GetExtent()[2];
  std::vector<double> values(static_cast<std::size_t>(dimensions[0]));
  for (int i = 0; i < dimensions[0]; ++i) {
    values[static_cast<std::size_t>(i)] =
        scalars->GetComponent(static_cast<vtkIdType>(row) * dimensions[0] + i, 0);
  }
  return values;
}

}  // namespace

int runSignalsFigure(const SignalsFigureRequest& request, const Streams& streams) {
  const SignalsFigureRequest* o = &request;
  {
    CommandPaths paths;
    paths.input("--capture", o->capture);
    for (const SignalsSetting& setting : o->settings)
      paths.input("--params", setting.paramsFile);
    paths.output("--out", o->out).check();
  }
  requirePngName("--out", o->out);
  // reader -> envelope -> peaks (with its peak list), reconfigured per setting: the capture is
  // read once (detection_pipeline.h).
  filters::DetectionPipeline pipeline;
  const core::Sequence& sequence = pipeline.open(o->capture, {});
  if (!sequence.hasPixels())
    throw core::FileError(o->capture, "holds no A-lines (tracker-only capture)");
  if (o->frame < 0 || static_cast<std::size_t>(o->frame) >= sequence.frameCount()) {
    throw core::FileError(o->capture, fmt::format("has no frame {} (frames 0-{})", o->frame,
                                                  sequence.frameCount() - 1));
  }
  std::vector<float> samples;
  sequence.frameSamples(static_cast<std::size_t>(o->frame), samples);
  std::vector<render::PlotPanel> panels;
  nlohmann::json verdicts = nlohmann::json::array();
  const core::DepthConversion depth =
      core::depthFromSequence(sequence, core::detectionPreset("default").depth);
  render::PlotPanel raw;
  raw.title = fmt::format("raw A-line, frame {}", o->frame);
  raw.xLabel = "depth (mm)";
  raw.yLabel = "amplitude";
  render::Series rawSeries;
  rawSeries.rgb = {0.35, 0.35, 0.35};
  rawSeries.lineWidth = 1.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    rawSeries.x.push_back(depth.depthMm(static_cast<double>(i)));
    rawSeries.y.push_back(samples[i]);
  }
  raw.series.push_back(rawSeries);
  panels.push_back(raw);
  const std::array<std::array<double, 3>, 4> colours{
      {{0.0, 0.3, 0.85}, {0.0, 0.55, 0.3}, {0.55, 0.2, 0.7}, {0.75, 0.45, 0.0}}};
  pipeline.peaks->PeakListOn();
  for (std::size_t s = 0; s < o->settings.size(); ++s) {
    const SignalsSetting& setting = o->settings[s];
    const bool tuned = !setting.paramsFile.empty() || !setting.settings.empty();
    std::string name = setting.preset;
    TunableSettings settings = setting.settings;
    ParamsSources sources{setting.paramsFile, {}};
    if (!setting.paramsFile.empty())
      sources.fromFile = mergeParamsFile(setting.paramsFile, name, settings);
    const core::DetectionParams params = [&] {
      try {
        return resolveParams(name, settings, sequence, sources);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("bad parameter: ") + e.what());
      }
    }();
    try {
      pipeline.configure(params, core::PointFrameOptions{});
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o->capture, e.what());
    }
    try {
      pipeline.updatePeaks();
    } catch (const std::runtime_error& e) {
      throw core::FileError(o->capture, e.what());
    }
    const core::DetectionParams& used = pipeline.params();
    vtkTable* verdict = pipeline.peaks->GetOutput(0);
    vtkTable* peakList = pipeline.peaks->GetOutput(1);
    const auto row = static_cast<vtkIdType>(o->frame);
    const std::string reason = verdict->GetValueByName(row, "reason").ToString();
    const double threshold = verdict->GetValueByName(row, "threshold").ToDouble();
    const double depthMm = verdict->GetValueByName(row, "depth_mm").ToDouble();
    const bool accepted = reason.empty();
    render::PlotPanel panel;
    panel.title = tuned ? fmt::format("envelope: preset \"{}\" with the given settings", name)
                        : fmt::format("envelope: preset \"{}\"", name);
    panel.xLabel = "depth (mm)";
    panel.yLabel = "envelope";
    render::Series env;
    env.name = "envelope";
    env.rgb = colours[s % colours.size()];
    const std::vector<double> envelope = envelopeRow(pipeline.envelope->GetOutput(), o->frame);
    for (std::size_t i = 0; i < envelope.size(); ++i) {
      env.x.push_back(used.depth.depthMm(static_cast<double>(i)));
      env.y.push_back(envelope[i]);
    }
    panel.series.push_back(env);
    render::Series peaks;
    peaks.name = "peaks";
    peaks.markersOnly = true;
    peaks.rgb = {0.85, 0.1, 0.1};
    auto* listFrames = vtkIntArray::SafeDownCast(peakList->GetColumnByName("frame"));
    auto* listIndices = vtkIntArray::SafeDownCast(peakList->GetColumnByName("sample_index"));
    auto* listValues = vtkDoubleArray::SafeDownCast(peakList->GetColumnByName("value"));
    for (vtkIdType p = 0; p < peakList->GetNumberOfRows(); ++p) {
      if (listFrames->GetValue(p) != o->frame)
        continue;
      peaks.x.push_back(used.depth.depthMm(listIndices->GetValue(p)));
      peaks.y.push_back(listValues->GetValue(p));
    }
    if (!peaks.x.empty())
      panel.series.push_back(peaks);
    panel.horizontalLines.push_back({"threshold", threshold});
    panel.note = accepted ? fmt::format("accepted: {:.2f} mm", depthMm)
                          : fmt::format("rejected: {}", reason);
    panel.noteRgb =
        accepted ? std::array<double, 3>{0.0, 0.5, 0.15} : std::array<double, 3>{0.75, 0.1, 0.1};
    panels.push_back(panel);
    verdicts.push_back({{"preset", name},
                        {"accepted", accepted},
                        {"reason", reason},
                        {"peaks", verdict->GetValueByName(row, "peaks").ToInt()},
                        {"threshold", threshold},
                        {"depth_mm", accepted ? nlohmann::json(depthMm) : nlohmann::json()}});
  }
  const int columns = panels.size() <= 2 ? 1 : 2;
  const std::string title =
      o->title.empty()
          ? fmt::format("{}, frame {}", std::filesystem::path(o->capture).filename().string(),
                        o->frame)
          : o->title;
  render::writePng(o->out, render::renderPlots(panels, columns, title, {o->width, o->height}));
  if (o->json) {
    streams.out << nlohmann::json{{"figure", "signals"},
                                  {"out", o->out},
                                  {"frame", o->frame},
                                  {"settings", verdicts}}
                       .dump(2)
                << "\n";
  } else {
    streams.out << fmt::format("signals figure: frame {}, {} settings; wrote {}\n", o->frame,
                               o->settings.size(), o->out);
  }
  return 0;
}

nlohmann::json requestJson(const SignalsFigureRequest& r) {
  nlohmann::json settings = nlohmann::json::array();
  for (const SignalsSetting& setting : r.settings) {
    settings.push_back({{"preset", setting.preset},
                        {"params", setting.paramsFile},
                        {"settings", settingsJson(setting.settings)}});
  }
  return {{"capture", r.capture}, {"frame", r.frame}, {"settings", settings}, {"out", r.out},
          {"title", r.title},     {"width", r.width}, {"height", r.height},   {"json", r.json}};
}

namespace {

CommandAction addSignalsFigure(CLI::App* parent) {
  auto o = std::make_shared<SignalsOptions>();
  CLI::App* cmd = parent->add_subcommand(
      "signals",
      "One raw A-line and its envelope under several filter settings, with the threshold, the\n"
      "peaks found and each setting's verdict (Figs. 5.10-5.29). Each setting is a --preset with\n"
      "the --params file and the flags over it, resolved as `echoreg detect` resolves them, and\n"
      "runs through detect's pipeline (reader -> envelope -> peaks).");
  cmd->add_option("--capture", o->capture, "A-line capture (.igs.mha, .igs.nrrd)")->required();
  cmd->add_option("--frame", o->frame, "Frame index (from 0)")->capture_default_str();
  CLI::Option* preset =
      cmd->add_option("--preset", o->presets,
                      "Detection presets to compare (repeat): " +
                          fmt::format("{}", fmt::join(core::detectionPresetNames(), ", ")) +
                          "; without it, the --params file's preset alone when it names one")
          ->capture_default_str();
  cmd->add_option("--params", o->paramsFile,
                  "JSON object of detection parameters named as detect's flags, without dashes,\n"
                  "applied over each preset");
  cmd->add_option("--out", o->out, "PNG to write")->required();
  cmd->add_option("--title", o->title, "Title over the figure");
  addSizeOptions(cmd, o->width, o->height, 300);
  cmd->add_flag("--json", o->json, "Print each setting's verdict as JSON");
  addTunableFlags(cmd, o->settings);
  return [o, preset](const Streams& streams) {
    CommandPaths()
        .input("--capture", o->capture)
        .input("--params", o->paramsFile)
        .output("--out", o->out)
        .check();
    requirePngName("--out", o->out);
    // The settings compared: each --preset with the file and the flags over it; without
    // --preset, the file's own preset when it names one.
    std::vector<std::string> presets = o->presets;
    if (preset->count() == 0 && !o->paramsFile.empty()) {
      std::string filePreset;
      TunableSettings ignored;
      mergeParamsFile(o->paramsFile, filePreset, ignored);
      if (!filePreset.empty())
        presets = {filePreset};
    }
    SignalsFigureRequest request;
    request.capture = o->capture;
    request.frame = o->frame;
    for (const std::string& name : presets)
      request.settings.push_back({name, o->paramsFile, o->settings});
    request.out = o->out;
    request.title = o->title;
    request.width = o->width;
    request.height = o->height;
    request.json = o->json;
    return runSignalsFigure(request, streams);
  };
}

// ---------------------------------------------------------------------------------------------

struct BoxplotOptions {
  std::vector<std::string> groups;
  std::string column = "error_mm";
  std::string out;
  std::string title;
  std::string yLabel;
  int width = 900;
  int height = 650;
  bool json = false;
};

CommandAction addBoxplotFigure(CLI::App* parent) {
  auto o = std::make_shared<BoxplotOptions>();
  CLI::App* cmd = parent->add_subcommand(
      "boxplot",
      "Box plots of a value between groups with the one-way ANOVA p-value (Figs. 6.1, 6.3,\n"
      "6.7-6.9).");
  cmd->add_option("--group", o->groups,
                  "A group: NAME=FILE.csv (the column --column of every row) or\n"
                  "NAME=FILE.csv:COLUMN; repeat for each group")
      ->required();
  cmd->add_option("--column", o->column, "Column read from each CSV (unless the group names one)")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "PNG to write")->required();
  cmd->add_option("--title", o->title, "Title over the figure");
  cmd->add_option("--ylabel", o->yLabel, "Label of the value axis (default: the column)");
  addSizeOptions(cmd, o->width, o->height, 300);
  cmd->add_flag("--json", o->json, "Print the groups' summaries and the ANOVA as JSON");
  return [o](const Streams& streams) {
    std::vector<render::BoxGroup> groups;
    for (const std::string& spec : o->groups) {
      const auto eq = spec.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size()) {
        throw std::invalid_argument("--group \"" + spec + "\": expected NAME=FILE.csv[:COLUMN]");
      }
      std::string file = spec.substr(eq + 1);
      std::string column = o->column;
      const auto colon = file.rfind(':');
      if (colon != std::string::npos && colon > 0) {
        column = file.substr(colon + 1);
        file = file.substr(0, colon);
      }
      CommandPaths().input("--group", file).output("--out", o->out).check();
      const CsvTable table = readCsvTable(file);
      const int c = table.column(column);
      if (c < 0)
        throw core::FileError(file, "has no column \"" + column + "\"");
      render::BoxGroup group;
      group.label = spec.substr(0, eq);
      for (std::size_t r = 0; r < table.rows.size(); ++r) {
        const std::string& cell = table.rows[r][static_cast<std::size_t>(c)];
        if (cell.empty() || table.rows[r][0] == "mean_abs")
          continue;  // evaluate's summary row
        group.values.push_back(parseCsvNumber(cell, file, r + 2, column));
      }
      if (group.values.empty())
        throw core::FileError(file, "has no value in column \"" + column + "\"");
      groups.push_back(std::move(group));
    }
    requirePngName("--out", o->out);
    render::writePng(
        o->out, render::renderBoxPlot(groups, o->title, o->yLabel.empty() ? o->column : o->yLabel,
                                      {o->width, o->height}));
    nlohmann::json summary = {{"figure", "boxplot"}, {"out", o->out}};
    nlohmann::json list = nlohmann::json::array();
    std::vector<std::vector<double>> values;
    for (const auto& g : groups) {
      const core::BoxSummary b = core::boxSummary(g.values);
      list.push_back({{"label", g.label},
                      {"n", b.count},
                      {"mean", b.mean},
                      {"median", b.median},
                      {"q1", b.q1},
                      {"q3", b.q3},
                      {"outliers", b.outliers.size()}});
      values.push_back(g.values);
    }
    summary["groups"] = list;
    if (groups.size() >= 2) {
      try {
        const core::AnovaResult r = core::oneWayAnova(values);
        summary["anova"] = {
            {"f", r.f}, {"df_between", r.dfBetween}, {"df_within", r.dfWithin}, {"p", r.pValue}};
      } catch (const std::invalid_argument& e) {
        summary["anova"] = {{"undefined", e.what()}};
      }
    }
    if (o->json) {
      streams.out << summary.dump(2) << "\n";
    } else {
      streams.out << fmt::format("boxplot figure: {} groups; wrote {}\n", groups.size(), o->out);
    }
    return 0;
  };
}

}  // namespace

CommandAction addFigureCommand(CLI::App& app) {
  CLI::App* cmd = app.add_subcommand(
      "figure",
      "Publication figures, rendered off-screen (no X server needed): registration, calibration,\n"
      "signals, boxplot. PNG out, written whole or not at all.");
  cmd->require_subcommand(1);
  auto actions = std::make_shared<std::map<std::string, CommandAction>>();
  (*actions)["registration"] = addRegistrationFigure(cmd);
  (*actions)["calibration"] = addCalibrationFigure(cmd);
  (*actions)["signals"] = addSignalsFigure(cmd);
  (*actions)["boxplot"] = addBoxplotFigure(cmd);
  return [cmd, actions](const Streams& streams) {
    for (CLI::App* sub : cmd->get_subcommands())
      return actions->at(sub->get_name())(streams);
    return 2;
  };
}

}  // namespace echoreg::cli
