#include "simulated_knee.hpp"

#include "echoreg/simulation/specimen.hpp"

#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>

namespace echoreg::test {

segmentation::CtImage toCtImage(const simulation::CtVolume& volume) {
  segmentation::CtImage image;
  image.dimensions = {volume.columns, volume.rows, volume.slices()};
  image.originMm = volume.voxelCentreMm(0, 0, 0);
  image.pixelSpacingMm = {volume.pixelSpacingMm, volume.pixelSpacingMm};
  for (double z : volume.sliceZMm) image.slicePositionsMm.push_back(z - volume.sliceZMm.front());
  int first = 0;
  for (int k = 1; k <= volume.slices(); ++k) {
    const auto kk = static_cast<std::size_t>(k);
    const bool breakHere = k == volume.slices() || volume.sliceGroup[kk] != volume.sliceGroup[kk - 1];
    if (!breakHere) continue;
    const int count = k - first;
    const double spacing = count > 1 ? volume.sliceZMm[static_cast<std::size_t>(first + 1)] -
                                           volume.sliceZMm[static_cast<std::size_t>(first)]
                                     : 0.0;
    image.groups.push_back({first, count, spacing});
    first = k;
  }
  image.hu = volume.hu;
  image.seriesInstanceUid = "simulated";
  return image;
}

const SimulatedKnee& simulatedKnee() {
  static const std::unique_ptr<SimulatedKnee> shared = [] {
    const auto start = std::chrono::steady_clock::now();
    auto s = std::make_unique<SimulatedKnee>();
    simulation::KneeOptions options;
    options.seed = 3;
    options.meshResolutionMm = 1.2;
    s->knee = simulation::buildKnee(options);
    const double tKnee = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    simulation::SoftTissueOptions tissue;
    tissue.seed = 3;
    const simulation::Specimen specimen(s->knee, simulation::SpecimenKind::Cadaver, tissue);
    const double tSpecimen = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const Eigen::Vector2d centre = (0.5 * (s->knee.hipCentre + s->knee.kneeCentre)).head<2>() * 0.5 +
                                   s->knee.kneeCentre.head<2>() * 0.5;
    simulation::CtProtocol protocol = simulation::smallProtocol(
        s->knee.hipCentre.z(), s->knee.kneeCentre.z(), s->knee.ankleCentre.z(), centre);
    // The knee group only, over +-32 mm, on 144 x 144 pixels (115 mm) centred on the knee: every
    // bone's section fits; the leg's skin lies outside the field of view (as in a tight scan).
    protocol.groups = {protocol.groups[1]};
    protocol.groups[0].firstZMm = s->knee.kneeCentre.z() - 32.0;
    protocol.groups[0].lastZMm = s->knee.kneeCentre.z() + 32.0;
    protocol.columns = 144;
    protocol.rows = 144;
    protocol.centreXYMm = s->knee.kneeCentre.head<2>();
    const simulation::CtVolume volume = simulation::synthesizeCt(specimen, protocol, 3);
    s->ct = toCtImage(volume);
    s->kneeZMinMm = volume.sliceZMm.front();
    s->kneeZMaxMm = volume.sliceZMm.back();
    std::cout << "[ fixture  ] simulated knee CT " << volume.columns << " x " << volume.rows << " x "
              << volume.slices() << " in "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() << " s (bones "
              << tKnee << " s, leg " << tSpecimen - tKnee << " s)\n";
    return s;
  }();
  return *shared;
}

}  // namespace echoreg::test
