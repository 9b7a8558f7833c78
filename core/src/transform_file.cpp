#include "echoreg/core/transform_file.hpp"

#include "echoreg/core/atomic_file.hpp"
#include "echoreg/core/error.hpp"
#include "echoreg/core/json_file.hpp"

#include <Eigen/LU>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace echoreg::core {

namespace {

std::string fixed(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

}  // namespace

nlohmann::json matrixRows(const Eigen::Matrix4d& matrix) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c)
      row.push_back(matrix(r, c));
    rows.push_back(row);
  }
  return rows;
}

TransformFile readTransformFile(const std::string& path, const std::string& expectedFrom,
                                const std::string& expectedTo) {
  const nlohmann::json doc = readJsonFile(path);
  if (!doc.is_object())
    throw FileError(path, "must hold a JSON object with \"matrix\"");
  const auto matrixIt = doc.find("matrix");
  if (matrixIt == doc.end() || !matrixIt->is_array() || matrixIt->size() != 4) {
    throw FileError(path, "needs \"matrix\": 4 rows of 4 numbers");
  }
  TransformFile transform;
  for (int r = 0; r < 4; ++r) {
    const auto& row = (*matrixIt)[static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 4)
      throw FileError(path, "needs \"matrix\": 4 rows of 4 numbers");
    for (int c = 0; c < 4; ++c) {
      const auto& value = row[static_cast<std::size_t>(c)];
      if (!value.is_number() || !std::isfinite(value.get<double>())) {
        throw FileError(path, "matrix[" + std::to_string(r) + "][" + std::to_string(c) +
                                  "] is not a finite number");
      }
      transform.matrix(r, c) = value.get<double>();
    }
  }
  if ((transform.matrix.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    throw FileError(path, "the matrix's last row must be 0 0 0 1");
  }
  const Eigen::Matrix3d rotation = transform.matrix.topLeftCorner<3, 3>();
  const double orthogonality =
      (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-6 || rotation.determinant() < 0) {
    throw FileError(path, "the matrix is not a rigid transform (its 3x3 part is not a rotation)");
  }
  for (const char* key : {"from", "to"}) {
    const auto it = doc.find(key);
    if (it == doc.end())
      continue;
    if (!it->is_string())
      throw FileError(path, std::string("\"") + key + "\" must be a string");
  }
  transform.from = doc.value("from", "");
  transform.to = doc.value("to", "");
  if (!expectedFrom.empty() && !transform.from.empty() && transform.from != expectedFrom) {
    throw FileError(path, "expected a " + expectedFrom + "To" +
                              (expectedTo.empty() ? "..." : expectedTo) +
                              " transform, got \"from\": \"" + transform.from + "\"");
  }
  if (!expectedTo.empty() && !transform.to.empty() && transform.to != expectedTo) {
    throw FileError(
        path, "expected a transform to " + expectedTo + ", got \"to\": \"" + transform.to + "\"");
  }
  for (const auto& [key, value] : doc.items()) {
    if (key != "from" && key != "to" && key != "matrix")
      transform.extra[key] = value;
  }
  return transform;
}

std::string slicerTfmText(const Eigen::Matrix4d& matrix) {
  const Eigen::Matrix4d inverse = matrix.inverse();
  std::ostringstream text;
  text << "#Insight Transform File V1.0\n#Transform 0\nTransform: AffineTransform_double_3_3\n";
  text << "Parameters:";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      text << " " << fixed(inverse(r, c));
  }
  for (int r = 0; r < 3; ++r)
    text << " " << fixed(inverse(r, 3));
  text << "\nFixedParameters: 0 0 0\n";
  return text.str();
}

std::string writeTransformFile(const std::string& path, const TransformFile& transform,
                               bool withTfm) {
  nlohmann::json doc = nlohmann::json::object();
  doc["from"] = transform.from;
  doc["to"] = transform.to;
  doc["matrix"] = matrixRows(transform.matrix);
  for (const auto& [key, value] : transform.extra.items())
    doc[key] = value;
  std::string tfmPath;
  // Both files are complete before either is renamed into place.
  AtomicFile json(path);
  json.stream() << doc.dump(2) << "\n";
  if (withTfm) {
    tfmPath = std::filesystem::path(path).replace_extension(".tfm").string();
    if (tfmPath == path) {
      throw FileError(path,
                      "ends in .tfm: the transform JSON and the Slicer .tfm written beside it "
                      "would be the same file; give the JSON a .json name");
    }
    AtomicFile tfm(tfmPath);
    tfm.stream() << slicerTfmText(transform.matrix);
    tfm.commit();
  }
  json.commit();
  return tfmPath;
}

}  // namespace echoreg::core
