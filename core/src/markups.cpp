#include "echoreg/core/markups.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

namespace echoreg::core {

namespace {

const char* const kSchema =
    "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/"
    "Schema/markups-schema-v1.0.3.json#";

}  // namespace

static std::vector<Markup> interpretMarkups(const std::string& path, const nlohmann::json& doc);

std::vector<Markup> readMarkups(const std::string& path) {
  const nlohmann::json doc = readJsonFile(path, "markups file");
  try {
    return interpretMarkups(path, doc);
  } catch (const nlohmann::json::exception& e) {
    // A value of another type than Slicer writes, e.g. "type": null.
    throw FileError(
        path, "holds a value of the wrong type for a 3D Slicer markups file: " + jsonProblem(e));
  }
}

static std::vector<Markup> interpretMarkups(const std::string& path, const nlohmann::json& doc) {
  if (!doc.is_object() || !doc.contains("markups") || !doc["markups"].is_array()) {
    throw FileError(path, "no \"markups\" array (not a 3D Slicer .mrk.json file)");
  }
  std::vector<Markup> result;
  int markupIndex = 0;
  for (const auto& m : doc["markups"]) {
    ++markupIndex;
    if (!m.is_object())
      throw FileError(path, "markup " + std::to_string(markupIndex) + " is not an object");
    Markup markup;
    markup.type = m.value("type", std::string("Fiducial"));
    markup.name = m.value("name", std::string());
    const std::string system = m.value("coordinateSystem", std::string("LPS"));
    double flip = 1.0;
    if (system == "RAS") {
      flip = -1.0;
    } else if (system != "LPS") {
      throw FileError(path, "markup " + std::to_string(markupIndex) + ": coordinate system \"" +
                                system + "\" (expected LPS or RAS)");
    }
    const std::string units = m.value("coordinateUnits", std::string("mm"));
    if (units != "mm") {
      throw FileError(path, "markup " + std::to_string(markupIndex) + ": coordinate units \"" +
                                units + "\" (expected mm)");
    }
    if (m.contains("controlPoints")) {
      if (!m["controlPoints"].is_array()) {
        throw FileError(
            path, "markup " + std::to_string(markupIndex) + ": controlPoints is not an array");
      }
      int pointIndex = 0;
      for (const auto& cp : m["controlPoints"]) {
        ++pointIndex;
        const std::string where = "markup " + std::to_string(markupIndex) + ", control point " +
                                  std::to_string(pointIndex);
        if (!cp.is_object())
          throw FileError(path, where + " is not an object");
        if (cp.value("positionStatus", std::string("defined")) == "undefined")
          continue;
        if (!cp.contains("position") || !cp["position"].is_array() || cp["position"].size() != 3) {
          throw FileError(path, where + ": no position of 3 numbers");
        }
        MarkupPoint point;
        point.label = cp.value("label", std::string());
        for (int i = 0; i < 3; ++i) {
          const auto& v = cp["position"][static_cast<std::size_t>(i)];
          if (!v.is_number())
            throw FileError(path, where + ": position is not numeric");
          const double x = v.get<double>();
          if (!std::isfinite(x))
            throw FileError(path, where + ": position is not finite");
          point.positionLps[i] = (i < 2) ? flip * x : x;
        }
        markup.points.push_back(std::move(point));
      }
    }
    result.push_back(std::move(markup));
  }
  return result;
}

std::vector<MarkupPoint> readMarkupPoints(const std::string& path) {
  std::vector<MarkupPoint> points;
  for (auto& markup : readMarkups(path)) {
    if (markup.type != "Fiducial")
      continue;
    for (auto& p : markup.points)
      points.push_back(std::move(p));
  }
  if (points.empty())
    throw FileError(path, "holds no landmark (no Fiducial control point)");
  return points;
}

void writeMarkups(const std::string& path, const std::vector<Markup>& markups) {
  nlohmann::json list = nlohmann::json::array();
  for (const Markup& markup : markups) {
    nlohmann::json controlPoints = nlohmann::json::array();
    int id = 1;
    for (const MarkupPoint& p : markup.points) {
      for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(p.positionLps[i])) {
          throw FileError(path, "point \"" + p.label + "\" is not finite; nothing written");
        }
      }
      controlPoints.push_back(
          {{"id", std::to_string(id++)},
           {"label", p.label},
           {"position", {p.positionLps.x(), p.positionLps.y(), p.positionLps.z()}},
           {"orientation", {-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0}},
           {"selected", true},
           {"locked", false},
           {"visibility", true},
           {"positionStatus", "defined"}});
    }
    nlohmann::json m = {{"type", markup.type},     {"coordinateSystem", "LPS"},
                        {"coordinateUnits", "mm"}, {"locked", false},
                        {"labelFormat", "%N-%d"},  {"controlPoints", controlPoints}};
    if (!markup.name.empty())
      m["name"] = markup.name;
    list.push_back(std::move(m));
  }
  nlohmann::json doc = {{"@schema", kSchema}, {"markups", list}};
  AtomicFile file(path);
  file.stream() << doc.dump(2) << "\n";
  file.commit();
}

void writeMarkupPoints(const std::string& path, const std::vector<MarkupPoint>& points) {
  Markup markup;
  markup.points = points;
  writeMarkups(path, {markup});
}

}  // namespace echoreg::core
