#include "simulated_knee.hpp"

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/simulation/specimen.hpp"

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <utility>
#include <vector>

namespace echoreg::test {

namespace {

// The CT takes seconds to synthesise; ctest runs each test in its own process, so the volume is
// cached in the tests' temporary folder, keyed by a checksum of the bone meshes it was made from
// (a changed knee makes a new volume). Written under a temporary name and renamed.
std::uint64_t checksum(const simulation::Knee& knee) {
  std::uint64_t h = 1469598103934665603ULL;
  auto mix = [&](double v) {
    const auto q = static_cast<std::int64_t>(std::llround(v * 1e6));
    h = (h ^ static_cast<std::uint64_t>(q)) * 1099511628211ULL;
  };
  for (const auto& bone : knee.bones) {
    for (const auto& v : bone.mesh.vertices) {
      mix(v.x());
      mix(v.y());
      mix(v.z());
    }
  }
  return h;
}

std::string cachePath(std::uint64_t key) {
  const char* base = std::getenv("ECHOREG_TEST_TMP");
  const std::filesystem::path dir =
      base ? std::filesystem::path(base) : std::filesystem::temp_directory_path() / "echoreg-tests";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  return (dir / ("simulated-knee-ct-v1-" + std::to_string(key) + ".bin")).string();
}

template <class T>
void put(std::ostream& o, const T& v) {
  o.write(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
bool get(std::istream& in, T& v) {
  return static_cast<bool>(in.read(reinterpret_cast<char*>(&v), sizeof v));
}

bool loadCache(const std::string& path, SimulatedKnee& s) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return false;
  core::CtImage& ct = s.ct;
  std::uint64_t slices = 0;
  if (!get(in, ct.dimensions) || !get(in, ct.originMm) || !get(in, ct.pixelSpacingMm) ||
      !get(in, s.kneeZMinMm) || !get(in, s.kneeZMaxMm) || !get(in, slices) ||
      slices != static_cast<std::uint64_t>(ct.dimensions[2])) {
    return false;
  }
  ct.slicePositionsMm.resize(slices);
  for (double& z : ct.slicePositionsMm)
    get(in, z);
  ct.hu.resize(ct.voxelCount());
  in.read(reinterpret_cast<char*>(ct.hu.data()),
          static_cast<std::streamsize>(ct.hu.size() * sizeof(std::int16_t)));
  if (!in)
    return false;
  ct.groups = {
      {0, ct.dimensions[2], ct.slicePositionsMm.size() > 1 ? ct.slicePositionsMm[1] : 0.0}};
  ct.seriesInstanceUid = "simulated";
  return true;
}

void saveCache(const std::string& path, const SimulatedKnee& s) {
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream o(temporary, std::ios::binary);
    put(o, s.ct.dimensions);
    put(o, s.ct.originMm);
    put(o, s.ct.pixelSpacingMm);
    put(o, s.kneeZMinMm);
    put(o, s.kneeZMaxMm);
    put(o, static_cast<std::uint64_t>(s.ct.slicePositionsMm.size()));
    for (double z : s.ct.slicePositionsMm)
      put(o, z);
    o.write(reinterpret_cast<const char*>(s.ct.hu.data()),
            static_cast<std::streamsize>(s.ct.hu.size() * sizeof(std::int16_t)));
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec)
    std::filesystem::remove(temporary, ec);
}

}  // namespace

namespace {

std::unique_ptr<SimulatedKnee> buildSimulatedKnee(const KneeVariant& variant) {
  const auto start = std::chrono::steady_clock::now();
  auto s = std::make_unique<SimulatedKnee>();
  simulation::KneeOptions options;
  options.seed = static_cast<std::uint64_t>(variant.seed);
  options.meshResolutionMm = 1.2;
  options.tibiofemoralGapMm = variant.tibiofemoralGapMm;
  options.patellofemoralGapMm = variant.patellofemoralGapMm;
  options.osteophyteMm = variant.osteophyteMm;
  if (!variant.femurMesh.empty())
    options.meshFiles[simulation::BoneId::Femur] = variant.femurMesh;
  s->knee = simulation::buildKnee(options);
  const double tKnee =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::uint64_t key = checksum(s->knee);
  if (variant.cancellousHu != 300.0 || variant.halfRangeMm != 32.0) {
    key = (key ^ static_cast<std::uint64_t>(std::llround(variant.cancellousHu * 16.0 + 65536.0))) *
          1099511628211ULL;
    key = (key ^ static_cast<std::uint64_t>(std::llround(variant.halfRangeMm * 16.0))) *
          1099511628211ULL;
  }
  if (variant.sliceMm != 1.0) {
    key = (key ^ static_cast<std::uint64_t>(std::llround(variant.sliceMm * 256.0 + 7.0))) *
          1099511628211ULL;
  }
  if (variant.columns != 144) {
    key = (key ^ static_cast<std::uint64_t>(variant.columns * 131 + 5)) * 1099511628211ULL;
  }
  if (variant.seed != 3) {
    key = (key ^ static_cast<std::uint64_t>(variant.seed * 977 + 11)) * 1099511628211ULL;
  }
  const std::string cache = cachePath(key);
  if (loadCache(cache, *s)) {
    std::cout << "[ fixture  ] simulated knee CT " << s->ct.dimensions[0] << " x "
              << s->ct.dimensions[1] << " x " << s->ct.dimensions[2] << " from " << cache
              << " (bones " << tKnee << " s)\n";
    return s;
  }
  simulation::SoftTissueOptions tissue;
  tissue.seed = static_cast<std::uint64_t>(variant.seed);
  const simulation::Specimen specimen(s->knee, simulation::SpecimenKind::Cadaver, tissue);
  const double tSpecimen =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const Eigen::Vector2d centre = (0.5 * (s->knee.hipCentre + s->knee.kneeCentre)).head<2>() * 0.5 +
                                 s->knee.kneeCentre.head<2>() * 0.5;
  simulation::CtProtocol protocol = simulation::smallProtocol(
      s->knee.hipCentre.z(), s->knee.kneeCentre.z(), s->knee.ankleCentre.z(), centre);
  // The knee group only, over +-32 mm, on 144 x 144 pixels (115 mm) centred on the knee: every
  // bone's section fits; the leg's skin lies outside the field of view (as in a tight scan).
  protocol.groups = {protocol.groups[1]};
  protocol.groups[0].firstZMm = s->knee.kneeCentre.z() - variant.halfRangeMm;
  protocol.groups[0].lastZMm = s->knee.kneeCentre.z() + variant.halfRangeMm;
  protocol.groups[0].spacingMm = variant.sliceMm;
  protocol.columns = variant.columns;
  protocol.rows = variant.columns;
  protocol.centreXYMm = s->knee.kneeCentre.head<2>();
  if (variant.cancellousHu != 300.0)
    protocol.cancellousHu = variant.cancellousHu;
  s->ct = simulation::synthesizeCt(specimen, protocol, static_cast<std::uint64_t>(variant.seed));
  s->ct.seriesInstanceUid = "simulated";
  s->kneeZMinMm = s->ct.sliceLocationsMm.front();
  s->kneeZMaxMm = s->ct.sliceLocationsMm.back();
  saveCache(cache, *s);
  std::cout << "[ fixture  ] simulated knee CT " << s->ct.dimensions[0] << " x "
            << s->ct.dimensions[1] << " x " << s->ct.dimensions[2] << " in "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
            << " s (bones " << tKnee << " s, leg " << tSpecimen - tKnee << " s)\n";
  return s;
}

}  // namespace

const SimulatedKnee& simulatedKnee() {
  static const std::unique_ptr<SimulatedKnee> shared = buildSimulatedKnee(KneeVariant{});
  return *shared;
}

const SimulatedKnee& simulatedKnee(const KneeVariant& variant) {
  static std::vector<std::pair<KneeVariant, std::unique_ptr<SimulatedKnee>>> built;
  for (const auto& [v, knee] : built) {
    if (v.tibiofemoralGapMm == variant.tibiofemoralGapMm &&
        v.patellofemoralGapMm == variant.patellofemoralGapMm &&
        v.cancellousHu == variant.cancellousHu && v.halfRangeMm == variant.halfRangeMm &&
        v.sliceMm == variant.sliceMm && v.osteophyteMm == variant.osteophyteMm &&
        v.seed == variant.seed && v.femurMesh == variant.femurMesh && v.columns == variant.columns)
      return *knee;
  }
  built.emplace_back(variant, buildSimulatedKnee(variant));
  return *built.back().second;
}

std::optional<Eigen::Vector3d> insidePoint(const simulation::Bone& bone, double z) {
  const core::MeshLocator locator(bone.mesh);
  const auto b = core::bounds(bone.mesh);
  std::vector<Eigen::Vector3d> inside;
  for (double y = b[0].y(); y <= b[1].y(); y += 1.0) {
    for (double x = b[0].x(); x <= b[1].x(); x += 1.0) {
      if (locator.signedDistance({x, y, z}) < -3.0)
        inside.emplace_back(x, y, z);
    }
  }
  if (inside.empty())
    return std::nullopt;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : inside)
    c += p;
  c /= static_cast<double>(inside.size());
  return *std::min_element(inside.begin(), inside.end(), [&](const auto& a, const auto& b2) {
    return (a - c).norm() < (b2 - c).norm();
  });
}

std::optional<Eigen::Vector3d> seedPoint(const SimulatedKnee& sim, simulation::BoneId id) {
  const simulation::Bone& bone = sim.knee.bone(id);
  const auto box = core::bounds(bone.mesh);
  const double lo = std::max(sim.kneeZMinMm + 6.0, box[0].z() + 6.0);
  const double hi = std::min(sim.kneeZMaxMm - 6.0, box[1].z() - 6.0);
  // Femur and patella seeded high, tibia and fibula low: away from the joints.
  const bool high = id == simulation::BoneId::Femur || id == simulation::BoneId::Patella;
  std::optional<Eigen::Vector3d> p;
  for (double t = 0.0; t <= 1.0 && !p; t += 0.1)
    p = insidePoint(bone, high ? hi - t * (hi - lo) : lo + t * (hi - lo));
  return p;
}

}  // namespace echoreg::test
