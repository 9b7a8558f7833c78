// Reads the few things the tests need from PLUS device-set and result XML files (attributes of
// <Transform> and <Landmark> elements), so that goldens use the numbers PLUS used, not copies.
#pragma once

#include <Eigen/Core>

#include <string>
#include <utility>
#include <vector>

namespace echoreg::test {

/// The Matrix of the first <Transform From=FROM To=TO ...> element of a PLUS XML file. Throws
/// std::runtime_error when the file cannot be read or has no such transform.
Eigen::Matrix4d plusTransform(const std::string& path, const std::string& from,
                              const std::string& to);

/// The <Landmark Name=... Position="x y z"/> elements inside <Landmarks>, in order. Throws
/// std::runtime_error when the file cannot be read or has none.
std::vector<std::pair<std::string, Eigen::Vector3d>> plusLandmarks(const std::string& path);

}  // namespace echoreg::test
