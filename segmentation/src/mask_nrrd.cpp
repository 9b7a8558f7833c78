#include "echoreg/segmentation/mask_nrrd.hpp"

#include "echoreg/core/atomic_file.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace echoreg::segmentation {

void writeMaskNrrd(const std::string& path, const VoxelMask& mask) {
  const CtImage& g = mask.geometry;
  if (g.voxelCount() == 0 || mask.voxels.size() != g.voxelCount()) {
    throw std::invalid_argument("writeMaskNrrd: the mask is empty");
  }
  if (!g.uniform())
    throw std::invalid_argument("writeMaskNrrd: the mask's grid has several slice spacings");
  const Eigen::Vector3d s = g.spacingMm();
  AtomicFile file(path);
  std::ostream& o = file.stream();
  o << "NRRD0004\n";
  o << "# bone mask written by echoreg segment (1 = bone)\n";
  o << "type: unsigned char\n";
  o << "dimension: 3\n";
  o << "space: left-posterior-superior\n";
  o << fmt::format("sizes: {} {} {}\n", g.dimensions[0], g.dimensions[1], g.dimensions[2]);
  o << "space directions:";
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d d = g.direction.col(a) * s[a];
    o << fmt::format(" ({:.17g},{:.17g},{:.17g})", d.x(), d.y(), d.z());
  }
  o << "\n";
  o << "kinds: domain domain domain\n";
  o << "endian: little\n";
  o << "encoding: raw\n";
  o << fmt::format("space origin: ({:.17g},{:.17g},{:.17g})\n", g.originMm.x(), g.originMm.y(),
                   g.originMm.z());
  o << "\n";
  o.write(reinterpret_cast<const char*>(mask.voxels.data()),
          static_cast<std::streamsize>(mask.voxels.size()));
  file.commit();
}

}  // namespace echoreg::segmentation
