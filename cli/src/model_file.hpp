// Bone models read for a command (issue 15, items 8 and 13): VTK's readers say nothing of a
// vertex that is not a number (an OBJ's "v nan 0 0" became a spike in the model and the figure)
// and print their own coloured log lines before our one-line message, so both are handled here.
#pragma once

#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/filters/MeshIO.h"

#include <vtkObject.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

namespace echoreg::cli {

/// VTK 9.1's OBJ reader turns a coordinate that is not a finite number ("nan", "inf", "1e999",
/// "x") into a finite one without a word, so the vertex lines are checked in the text: throws
/// FileError naming the line.
inline void checkObjVertices(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t lineNumber = 0;
  std::size_t vertex = 0;
  while (std::getline(in, line)) {
    ++lineNumber;
    if (line.size() < 2 || line[0] != 'v' || (line[1] != ' ' && line[1] != '\t'))
      continue;  // not a vertex position (vn, vt, f, comments, ...)
    ++vertex;
    std::istringstream words(line.substr(2));
    std::string word;
    for (int axis = 0; axis < 3; ++axis) {
      double value = 0.0;
      const bool read = static_cast<bool>(words >> word);
      const char* end = word.data() + word.size();
      const auto parsed =
          read ? std::from_chars(word.data(), end, value) : std::from_chars_result{};
      if (!read || parsed.ec != std::errc() || parsed.ptr != end || !std::isfinite(value)) {
        if (!line.empty() && line.back() == '\r')
          line.pop_back();
        throw FileError(path, fmt::format("line {}: vertex {} \"{}\" is not three finite numbers: "
                                          "a damaged model (a NaN or infinite coordinate)",
                                          lineNumber, vertex, line));
      }
    }
  }
}

/// filters::readMesh(path) with VTK's own warnings and errors kept off stderr (the FileError that
/// follows names the file and the problem), refusing a model with a vertex that is not finite.
inline core::TriangleMesh readModelFile(const std::string& path) {
  struct QuietVtk {
    int was = vtkObject::GetGlobalWarningDisplay();
    QuietVtk() { vtkObject::GlobalWarningDisplayOff(); }
    ~QuietVtk() { vtkObject::SetGlobalWarningDisplay(was); }
  };
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj" && std::filesystem::is_regular_file(path))
    checkObjVertices(path);
  core::TriangleMesh mesh;
  {
    const QuietVtk quiet;
    mesh = filters::readMesh(path);
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d& v = mesh.vertices[i];
    if (!v.allFinite()) {
      throw FileError(path, fmt::format("vertex {} of {} is not a finite point ({} {} {}): a "
                                        "damaged model (a NaN or infinite coordinate)",
                                        i + 1, mesh.vertices.size(), v.x(), v.y(), v.z()));
    }
  }
  return mesh;
}

}  // namespace echoreg::cli
