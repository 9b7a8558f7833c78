// Values as the commands write them into their JSON results, one definition for every command.
#pragma once

#include <Eigen/Core>

#include <nlohmann/json.hpp>

namespace echoreg::cli {

/// [x, y, z].
inline nlohmann::json vec(const Eigen::Vector3d& v) {
  return {v.x(), v.y(), v.z()};
}

}  // namespace echoreg::cli
