// compare_surfaces MODEL TRUTH [ZMIN ZMAX]: accuracy of a segmented model against a reference
// surface (segmentation/surface_metrics.hpp): mean symmetric surface distance, its 95th
// percentile and maximum, and Dice, optionally inside a slab of CT z (the scanned group). Prints
// one JSON line. Used for the numbers in docs/segmentation.md.
#include "echoreg/filters/mesh_io.h"
#include "echoreg/segmentation/surface_metrics.hpp"

#include <nlohmann/json.hpp>

#include <exception>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  if (argc != 3 && argc != 5) {
    std::cerr << "usage: compare_surfaces MODEL TRUTH [ZMIN ZMAX]\n";
    return 2;
  }
  try {
    echoreg::segmentation::SurfaceComparisonOptions options;
    if (argc == 5) {
      options.zMinMm = std::stod(argv[3]);
      options.zMaxMm = std::stod(argv[4]);
    }
    const auto model = echoreg::filters::readMesh(argv[1]);
    const auto truth = echoreg::filters::readMesh(argv[2]);
    const auto c = echoreg::segmentation::compareSurfaces(model, truth, options);
    const nlohmann::json out = {{"model", argv[1]},
                                {"truth", argv[2]},
                                {"msd_mm", c.meanMm},
                                {"p95_mm", c.p95Mm},
                                {"max_mm", c.maxMm},
                                {"model_to_truth_mm", c.meanEstimateToTruthMm},
                                {"truth_to_model_mm", c.meanTruthToEstimateMm},
                                {"dice", c.dice},
                                {"volume_model_mm3", c.volumeEstimateMm3},
                                {"volume_truth_mm3", c.volumeTruthMm3}};
    std::cout << out.dump() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "compare_surfaces: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
