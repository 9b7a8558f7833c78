// The checks of a scene that its description (pointsLegend) and its drawing (the renderer module,
// render/module/draw_scene.cpp) share. Internal to render/.
#pragma once

#include "echoreg/render/scene.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace echoreg::render::detail {

/// The points and values of a point set, checked: throws std::invalid_argument for an empty
/// colour map, a missing array (or one of another length or more components) or a point or value
/// that is not finite. No points: empty.
struct CheckedPoints {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> values;
};
CheckedPoints checkedPoints(const ScenePoints& set);

/// Throws std::invalid_argument when x and y differ in length or hold a value that is not finite;
/// `where` starts the message.
void checkSeries(const Series& s, const std::string& where);

}  // namespace echoreg::render::detail
