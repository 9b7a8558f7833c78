// `echoreg evaluate`: registrations against a reference (Mozes 2008, Eq. 4.5): per estimate the
// translations along and rotations about the CT axes and the distances at targets; the last row
// the mean of absolute values, as the dissertation's Tables 5.3-5.7.
#include "commands.hpp"
#include "path_check.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/markups.hpp"
#include "echoreg/core/rigid_error.hpp"
#include "echoreg/core/transform_file.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace echoreg::cli {

namespace {

struct EvaluateOptions {
  std::string reference;
  std::vector<std::string> estimates;
  std::string targets, out;
  std::vector<double> centre;
  bool json = false;
};

Eigen::Isometry3d isometry(const core::TransformFile& t) {
  Eigen::Isometry3d m;
  m.matrix() = t.matrix;
  return m;
}

nlohmann::json rowJson(const std::string& name, const core::RigidError& e,
                       const std::vector<core::MarkupPoint>& targets) {
  nlohmann::json row = {{"name", name},
                        {"tx_mm", e.translationMm.x()},
                        {"ty_mm", e.translationMm.y()},
                        {"tz_mm", e.translationMm.z()},
                        {"rx_deg", e.rotationDeg.x()},
                        {"ry_deg", e.rotationDeg.y()},
                        {"rz_deg", e.rotationDeg.z()}};
  nlohmann::json t = nlohmann::json::object();
  for (std::size_t i = 0; i < targets.size(); ++i)
    t[targets[i].label] = e.targetErrorsMm[i];
  row["target_errors_mm"] = t;
  return row;
}

int runEvaluate(const EvaluateOptions& o, const Streams& io) {
  CommandPaths()
      .input("--reference", o.reference)
      .inputs("--estimate", o.estimates)
      .input("--targets", o.targets)
      .output("--out", o.out)
      .check();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  if (o.centre.size() == 3)
    centre = Eigen::Vector3d(o.centre[0], o.centre[1], o.centre[2]);
  const core::TransformFile reference = core::readTransformFile(o.reference);
  std::vector<core::MarkupPoint> targets;
  if (!o.targets.empty())
    targets = core::readMarkupPoints(o.targets);
  std::vector<Eigen::Vector3d> targetPositions;
  for (const core::MarkupPoint& t : targets)
    targetPositions.push_back(t.positionLps);

  std::vector<core::RigidError> rows;
  std::vector<std::string> names;
  for (const std::string& path : o.estimates) {
    // The estimate must map the same frames as the reference.
    const core::TransformFile estimate = core::readTransformFile(path);
    if (estimate.from != reference.from || estimate.to != reference.to) {
      throw core::FileError(path, fmt::format("maps {} to {} but the reference {} maps {} to {}",
                                              estimate.from.empty() ? "?" : estimate.from,
                                              estimate.to.empty() ? "?" : estimate.to, o.reference,
                                              reference.from.empty() ? "?" : reference.from,
                                              reference.to.empty() ? "?" : reference.to));
    }
    try {
      rows.push_back(
          core::rigidError(isometry(reference), isometry(estimate), targetPositions, centre));
    } catch (const std::invalid_argument& e) {
      throw core::FileError(path, e.what());
    }
    names.push_back(std::filesystem::path(path).filename().string());
  }
  const core::RigidError mean = core::meanAbsoluteError(rows);

  core::AtomicFile file(o.out);
  std::ostream& csv = file.stream();
  csv << "estimate,tx_mm,ty_mm,tz_mm,rx_deg,ry_deg,rz_deg";
  for (const core::MarkupPoint& t : targets)
    csv << ",target_" << t.label << "_mm";
  csv << "\n";
  auto writeRow = [&](const std::string& name, const core::RigidError& e) {
    csv << name;
    for (Eigen::Index k = 0; k < 3; ++k)
      csv << fmt::format(",{:.6g}", e.translationMm[k]);
    for (Eigen::Index k = 0; k < 3; ++k)
      csv << fmt::format(",{:.6g}", e.rotationDeg[k]);
    for (double d : e.targetErrorsMm)
      csv << fmt::format(",{:.6g}", d);
    csv << "\n";
  };
  for (std::size_t i = 0; i < rows.size(); ++i)
    writeRow(names[i], rows[i]);
  writeRow("mean_abs", mean);
  file.commit();

  if (o.json) {
    nlohmann::json summary = {{"out", o.out},
                              {"reference", o.reference},
                              {"from", reference.from},
                              {"to", reference.to},
                              {"centre_mm", {centre.x(), centre.y(), centre.z()}}};
    nlohmann::json list = nlohmann::json::array();
    for (std::size_t i = 0; i < rows.size(); ++i)
      list.push_back(rowJson(names[i], rows[i], targets));
    summary["estimates"] = list;
    summary["mean_abs"] = rowJson("mean_abs", mean, targets);
    io.out << summary.dump(2) << "\n";
  } else {
    io.out << fmt::format(
        "{}: {} estimates against {}; mean |error| translation ({:.2f}, {:.2f}, {:.2f}) mm, "
        "rotation ({:.2f}, {:.2f}, {:.2f}) deg\n",
        o.out, rows.size(), o.reference, mean.translationMm.x(), mean.translationMm.y(),
        mean.translationMm.z(), mean.rotationDeg.x(), mean.rotationDeg.y(), mean.rotationDeg.z());
  }
  return 0;
}

}  // namespace

CommandAction addEvaluateCommand(CLI::App& app) {
  auto o = std::make_shared<EvaluateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate",
      "Errors of registrations against a reference (Mozes 2008, Eq. 4.5): E = estimate *\n"
      "inverse(reference) in CT space, translations along CT x, y, z (of --centre, default the CT\n"
      "origin) and rotations about them (R = Rz Ry Rx), and |E(t) - t| at each target. One CSV "
      "row\n"
      "per estimate, the last the mean of absolute values (Tables 5.3-5.7).");
  cmd->add_option("--reference", o->reference,
                  "Reference transform JSON, e.g. truth/FemurToCT.json")
      ->required();
  cmd->add_option("--estimate", o->estimates, "Estimated transform JSON (repeat for several)")
      ->required();
  cmd->add_option("--targets", o->targets, "Target points in CT (3D Slicer .mrk.json)");
  cmd->add_option("--centre", o->centre,
                  "Point X Y Z (CT, mm) whose displacement is the translation")
      ->expected(3);
  cmd->add_option("--out", o->out, "CSV to write")->required();
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  return [o](const Streams& io) { return runEvaluate(*o, io); };
}

}  // namespace echoreg::cli
