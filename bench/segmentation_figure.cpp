// Figures of segmented bone models (issue 13: the real CT's pelvis), rendered off-screen with
// render/ (OSMesa): the first model in bone colour, the others translucent around it for
// context, seen coronally, sagittally and transversely (the CT's patient axes). One PNG per call.
//
//   segmentation_figure OUT.png TITLE MODEL.vtp [CONTEXT.vtp ...]
//   segmentation_figure OUT.png TITLE --merge MODEL.vtp MODEL.vtp ...   (all in bone colour)
#include "echoreg/core/error.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/render/surface_figure.hpp"

#include <exception>
#include <iostream>
#include <limits>
#include <string>

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: segmentation_figure OUT.png TITLE MODEL.vtp [CONTEXT.vtp ...]\n";
    return 2;
  }
  try {
    echoreg::render::SurfaceFigure figure;
    figure.title = argv[2];
    const bool merge = std::string(argv[3]) == "--merge";
    for (int a = merge ? 4 : 3; a < argc; ++a) {
      const echoreg::core::TriangleMesh mesh = echoreg::filters::readMesh(argv[a]);
      if (a == 3 || (merge && a == 4)) {
        figure.surface = mesh;
      } else if (merge) {
        const int offset = static_cast<int>(figure.surface.vertices.size());
        figure.surface.vertices.insert(figure.surface.vertices.end(), mesh.vertices.begin(),
                                       mesh.vertices.end());
        for (const auto& t : mesh.triangles)
          figure.surface.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
      } else {
        figure.context.push_back(mesh);
      }
    }
    // No points: one band whose legend says what the colours are.
    figure.bands = {
        {std::numeric_limits<double>::infinity(), {0.89, 0.85, 0.79}, merge ? "models" : "model"}};
    figure.valueName = "";
    echoreg::render::FigureSize size;
    size.width = 1500;
    size.height = 560;
    echoreg::render::writePng(argv[1], echoreg::render::renderSurfaceFigure(figure, size));
  } catch (const std::exception& e) {
    std::cerr << "segmentation_figure: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
