// Transform files: `{"from": "Beam", "to": "Probe", "matrix": [[4 numbers] x 4]}` (mm, p_to =
// matrix * p_from), with any further result keys, and the 3D Slicer / ITK `.tfm` written beside.
// docs/formats.md ("Transforms").
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <string>

namespace echoreg::core {

struct TransformFile {
  std::string from;
  std::string to;
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  nlohmann::json extra = nlohmann::json::object();  ///< every other key, as read or to write
};

/// Reads and checks a transform file: valid JSON, "matrix" of 4 rows of 4 finite numbers, last
/// row 0 0 0 1, a rotation part that is orthonormal with determinant +1 (within 1e-6). When
/// `expectedFrom` / `expectedTo` are not empty and the file names its frames, they must match.
/// Throws FileError naming the file and the problem.
TransformFile readTransformFile(const std::string& path, const std::string& expectedFrom = "",
                                const std::string& expectedTo = "");

/// Writes the JSON (atomically) and, when `withTfm`, the `.tfm` beside it (same name with the
/// extension replaced). Returns the .tfm path ("" when not written). Throws FileError, writing
/// nothing, when `path` itself ends in .tfm (the two would be one file).
std::string writeTransformFile(const std::string& path, const TransformFile& transform,
                               bool withTfm = true);

/// The ITK/Slicer text of a linear transform. ITK stores the resampling (FromParent) transform in
/// LPS; Slicer shows the ToParent transform in RAS. Treating echoreg's frames as LPS (as the CT),
/// the file holds inverse(matrix), so that Slicer displays `matrix` converted to RAS.
std::string slicerTfmText(const Eigen::Matrix4d& matrix);

/// The JSON rows of a matrix (4 arrays of 4 numbers).
nlohmann::json matrixRows(const Eigen::Matrix4d& matrix);

}  // namespace echoreg::core
