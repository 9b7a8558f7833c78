#include "echoreg/simulation/specimen.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>

namespace echoreg::simulation {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGridSpacingMm = 2.5;
constexpr double kExactBandMm = 2.5;     // closer to a bone than this: exact distances
constexpr double kPhantomShellMm = 2.0;  // sawbones composite shell thickness

double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// Soft tissue thickness (skin surface to nearest bone, mm) around the limb: 8 sectors from
// anterior toward lateral (0, 45, ..., 315 degrees; 270 is medial) at stations along the segment.
// Thin over the patella, the epicondyles, the tibial crest and tubercle, the anteromedial tibia and
// the malleoli; thick over the anterior and posterior thigh and the calf. See docs/simulation.md.
struct ThicknessTable {
  std::vector<double> heightsMm;
  std::vector<std::array<double, 8>> rows;
};

const ThicknessTable& thighTable() {
  static const ThicknessTable table{{0.0, 30.0, 60.0, 120.0, 250.0, 460.0},
                                    {{{6, 8, 7, 25, 35, 25, 8, 6}},
                                     {{5, 9, 6, 25, 40, 25, 7, 7}},
                                     {{12, 14, 12, 30, 45, 30, 14, 12}},
                                     {{25, 25, 22, 40, 50, 40, 28, 25}},
                                     {{38, 35, 30, 50, 60, 55, 45, 40}},
                                     {{45, 35, 28, 55, 70, 60, 55, 45}}}};
  return table;
}

const ThicknessTable& shankTable() {
  static const ThicknessTable table{{0.0, 30.0, 60.0, 150.0, 280.0, 390.0},
                                    {{{6, 10, 12, 30, 35, 25, 10, 6}},
                                     {{4, 15, 10, 30, 40, 30, 8, 4}},
                                     {{4, 18, 15, 35, 45, 35, 8, 3.5}},
                                     {{4, 22, 16, 35, 50, 35, 7, 3}},
                                     {{4, 14, 10, 20, 30, 20, 6, 3}},
                                     {{4, 6, 4, 12, 20, 10, 4, 4}}}};
  return table;
}

// Subcutaneous fat (mm) at the mean thickness scale, thigh and shank.
constexpr double kThighFatMm = 7.0;
constexpr double kShankFatMm = 4.5;

double sampleTable(const ThicknessTable& table, double heightMm, double thetaRad) {
  // Periodic in theta (sector width 45 degrees), clamped in height.
  double sector = thetaRad / (kPi / 4.0);
  sector = std::fmod(sector, 8.0);
  if (sector < 0)
    sector += 8.0;
  const int s0 = static_cast<int>(std::floor(sector)) % 8;
  const int s1 = (s0 + 1) % 8;
  const double fs = sector - std::floor(sector);
  const auto& h = table.heightsMm;
  std::size_t r0 = 0;
  double fr = 0.0;
  if (heightMm <= h.front()) {
    r0 = 0;
  } else if (heightMm >= h.back()) {
    r0 = h.size() - 2;
    fr = 1.0;
  } else {
    while (r0 + 1 < h.size() && h[r0 + 1] < heightMm)
      ++r0;
    fr = (heightMm - h[r0]) / (h[r0 + 1] - h[r0]);
  }
  auto at = [&](std::size_t row, int sec) {
    return table.rows[row][static_cast<std::size_t>(sec)];
  };
  const double a = (1 - fs) * at(r0, s0) + fs * at(r0, s1);
  const double b = (1 - fs) * at(r0 + 1, s0) + fs * at(r0 + 1, s1);
  return (1 - fr) * a + fr * b;
}

// Signed distance to one closed mesh from its closest point, with angle-weighted pseudo-normals
// at vertices and edges for the sign (Baerentzen & Aanaes 2005): exact, no ray casting.
class SignedMesh {
 public:
  explicit SignedMesh(const core::MeshLocator& locator) : locator_(&locator) {
    const core::TriangleMesh& mesh = locator.mesh();
    vertexNormals_.assign(mesh.vertices.size(), Eigen::Vector3d::Zero());
    faceNormals_.reserve(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const auto& tri = mesh.triangles[t];
      const Eigen::Vector3d n = core::triangleNormal(mesh, static_cast<int>(t));
      faceNormals_.push_back(n);
      for (int k = 0; k < 3; ++k) {
        const int a = tri[static_cast<std::size_t>(k)];
        const int b = tri[static_cast<std::size_t>((k + 1) % 3)];
        const int c = tri[static_cast<std::size_t>((k + 2) % 3)];
        const Eigen::Vector3d e1 = (mesh.vertices[static_cast<std::size_t>(b)] -
                                    mesh.vertices[static_cast<std::size_t>(a)])
                                       .normalized();
        const Eigen::Vector3d e2 = (mesh.vertices[static_cast<std::size_t>(c)] -
                                    mesh.vertices[static_cast<std::size_t>(a)])
                                       .normalized();
        const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
        vertexNormals_[static_cast<std::size_t>(a)] += angle * n;
        // (operator[] would leave an Eigen vector uninitialised)
        auto it = edgeNormals_.try_emplace(edgeKey(a, b), Eigen::Vector3d::Zero()).first;
        it->second += n;
      }
    }
  }

  // Signed distance (negative inside); `cap` prunes: beyond it returns +cap (sign unknown: the
  // caller only uses capped values far from every bone).
  double signedDistance(const Eigen::Vector3d& p, double cap) const {
    const core::ClosestPoint c = locator_->closest(p, cap);
    if (c.triangle < 0)
      return cap;
    const auto& tri = locator_->mesh().triangles[static_cast<std::size_t>(c.triangle)];
    constexpr double eps = 1e-7;
    Eigen::Vector3d normal;
    const Eigen::Vector3d& w = c.barycentric;
    const int small = (w[0] < eps) + (w[1] < eps) + (w[2] < eps);
    if (small >= 2) {
      int vertex = 0;
      for (int k = 0; k < 3; ++k) {
        if (w[k] >= eps)
          vertex = tri[static_cast<std::size_t>(k)];
      }
      normal = vertexNormals_[static_cast<std::size_t>(vertex)];
    } else if (small == 1) {
      int a = -1, b = -1;
      for (int k = 0; k < 3; ++k) {
        if (w[k] >= eps)
          (a < 0 ? a : b) = tri[static_cast<std::size_t>(k)];
      }
      const auto it = edgeNormals_.find(edgeKey(a, b));
      normal = it != edgeNormals_.end() ? it->second
                                        : faceNormals_[static_cast<std::size_t>(c.triangle)];
    } else {
      normal = faceNormals_[static_cast<std::size_t>(c.triangle)];
    }
    return (p - c.point).dot(normal) >= 0.0 ? c.distance : -c.distance;
  }

 private:
  static std::uint64_t edgeKey(int a, int b) {
    const auto lo = static_cast<std::uint64_t>(std::min(a, b));
    const auto hi = static_cast<std::uint64_t>(std::max(a, b));
    return (lo << 32) | hi;
  }
  const core::MeshLocator* locator_;
  std::vector<Eigen::Vector3d> vertexNormals_;
  std::vector<Eigen::Vector3d> faceNormals_;
  std::unordered_map<std::uint64_t, Eigen::Vector3d> edgeNormals_;
};

}  // namespace

struct Specimen::Grid {
  Eigen::Vector3d origin;
  std::array<int, 3> size{};
  std::vector<float> distance;        // signed distance to the union of the bones
  std::vector<std::uint8_t> nearest;  // index of the nearest bone
  std::vector<SignedMesh> signedMeshes;

  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(size[1]) +
            static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(size[0]) +
           static_cast<std::size_t>(i);
  }

  bool contains(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d g = (p - origin) / kGridSpacingMm;
    return g.x() >= 0 && g.y() >= 0 && g.z() >= 0 && g.x() <= size[0] - 1 && g.y() <= size[1] - 1 &&
           g.z() <= size[2] - 1;
  }

  // Trilinear distance and the nearest bone of the nearest node; +inf outside the grid.
  double sample(const Eigen::Vector3d& p, std::size_t* bone) const {
    const Eigen::Vector3d g = (p - origin) / kGridSpacingMm;
    if (!(g.x() >= 0 && g.y() >= 0 && g.z() >= 0 && g.x() <= size[0] - 1 && g.y() <= size[1] - 1 &&
          g.z() <= size[2] - 1)) {
      return std::numeric_limits<double>::infinity();
    }
    const int i = std::min(static_cast<int>(g.x()), size[0] - 2);
    const int j = std::min(static_cast<int>(g.y()), size[1] - 2);
    const int k = std::min(static_cast<int>(g.z()), size[2] - 2);
    const double fx = g.x() - i, fy = g.y() - j, fz = g.z() - k;
    auto d = [&](int a, int b, int c) {
      return static_cast<double>(distance[index(i + a, j + b, k + c)]);
    };
    const double c00 = d(0, 0, 0) * (1 - fx) + d(1, 0, 0) * fx;
    const double c10 = d(0, 1, 0) * (1 - fx) + d(1, 1, 0) * fx;
    const double c01 = d(0, 0, 1) * (1 - fx) + d(1, 0, 1) * fx;
    const double c11 = d(0, 1, 1) * (1 - fx) + d(1, 1, 1) * fx;
    const double value = (c00 * (1 - fy) + c10 * fy) * (1 - fz) + (c01 * (1 - fy) + c11 * fy) * fz;
    if (bone != nullptr) {
      *bone = nearest[index(i + (fx > 0.5), j + (fy > 0.5), k + (fz > 0.5))];
    }
    return value;
  }
};

Specimen::Specimen(Knee knee, SpecimenKind kind, const SoftTissueOptions& tissue,
                   const std::function<void(double)>& progress)
    : knee_(std::move(knee)), kind_(kind), tissue_(tissue), grid_(std::make_unique<Grid>()) {
  if (knee_.bones.empty())
    throw std::invalid_argument("specimen without bones");
  if (!(tissue_.underSkinScale > 0.0 && tissue_.underSkinScale <= 1.0)) {
    throw std::invalid_argument("under-skin tissue scale must be in (0, 1], got " +
                                std::to_string(tissue_.underSkinScale));
  }
  for (const Bone& bone : knee_.bones) {
    locators_.emplace_back(bone.mesh);
    boneBounds_.push_back(core::bounds(bone.mesh));
  }
  for (const core::MeshLocator& locator : locators_)
    grid_->signedMeshes.emplace_back(locator);

  // Limb frames from the anatomy.
  kneeCentre_ = knee_.kneeCentre;
  thighAxis_ = (knee_.hipCentre - knee_.kneeCentre).normalized();
  shankAxis_ = (knee_.ankleCentre - knee_.kneeCentre).normalized();
  thighLengthMm_ = (knee_.hipCentre - knee_.kneeCentre).norm();
  shankLengthMm_ = (knee_.ankleCentre - knee_.kneeCentre).norm();
  thighAnterior_ = (knee_.anteriorCt - knee_.anteriorCt.dot(thighAxis_) * thighAxis_).normalized();
  const Eigen::Quaterniond bend = Eigen::Quaterniond::FromTwoVectors(-thighAxis_, shankAxis_);
  shankAnterior_ = bend * thighAnterior_;
  shankAnterior_ = (shankAnterior_ - shankAnterior_.dot(shankAxis_) * shankAxis_).normalized();
  lateral_ = -knee_.medialCt.normalized();
  core::Rng rng = core::Rng::derive(tissue_.seed, "soft-tissue-variation");
  for (double& v : variation_)
    v = rng.uniform(-0.1, 0.1);
  double tableMax = 0.0;
  for (const ThicknessTable* table : {&thighTable(), &shankTable()}) {
    for (const auto& row : table->rows)
      tableMax = std::max(tableMax, *std::max_element(row.begin(), row.end()));
  }
  maxThicknessMm_ = tableMax * tissue_.thicknessScale * 1.1 + 0.5;

  // The signed distance grid over the leg's box.
  Eigen::Vector3d low = boneBounds_.front()[0], high = boneBounds_.front()[1];
  for (const auto& box : boneBounds_) {
    low = low.cwiseMin(box[0]);
    high = high.cwiseMax(box[1]);
  }
  const double margin =
      kind_ == SpecimenKind::Cadaver ? 100.0 * std::max(1.0, tissue_.thicknessScale) : 20.0;
  low -= Eigen::Vector3d(margin, margin, 25.0);
  high += Eigen::Vector3d(margin, margin, 25.0);
  Grid& grid = *grid_;
  grid.origin = low;
  for (int a = 0; a < 3; ++a) {
    grid.size[static_cast<std::size_t>(a)] =
        static_cast<int>(std::ceil((high[a] - low[a]) / kGridSpacingMm)) + 1;
  }
  const std::size_t total = static_cast<std::size_t>(grid.size[0]) *
                            static_cast<std::size_t>(grid.size[1]) *
                            static_cast<std::size_t>(grid.size[2]);
  grid.distance.assign(total, 0.0f);
  grid.nearest.assign(total, 0);
  const double cap = margin + 10.0;
  std::atomic<int> nextSlice{0};
  std::atomic<int> doneSlices{0};
  auto work = [&]() {
    for (int k = nextSlice++; k < grid.size[2]; k = nextSlice++) {
      for (int j = 0; j < grid.size[1]; ++j) {
        double previous = cap;
        for (int i = 0; i < grid.size[0]; ++i) {
          const Eigen::Vector3d p = grid.origin + kGridSpacingMm * Eigen::Vector3d(i, j, k);
          // Beyond the skin plus a margin the exact distance does not matter (air): cap there.
          const double nodeCap =
              kind_ == SpecimenKind::Cadaver
                  ? std::min(cap, softTissueThicknessMm(p) + 3.0 * kGridSpacingMm)
                  : cap;
          // The distance changes by at most one spacing between neighbours: prune with it.
          double best = std::min(nodeCap, std::abs(previous) + kGridSpacingMm * 1.01);
          std::uint8_t bestBone = 0;
          double bestSigned = best;
          for (std::size_t b = 0; b < locators_.size(); ++b) {
            const auto& box = boneBounds_[b];
            const Eigen::Vector3d outside =
                (box[0] - p).cwiseMax(p - box[1]).cwiseMax(Eigen::Vector3d::Zero());
            if (outside.norm() >= best)
              continue;
            const double sd = grid.signedMeshes[b].signedDistance(p, best);
            if (std::abs(sd) < best || (sd < 0 && bestSigned >= 0)) {
              best = std::abs(sd);
              bestSigned = sd;
              bestBone = static_cast<std::uint8_t>(b);
            }
          }
          grid.distance[grid.index(i, j, k)] = static_cast<float>(bestSigned);
          grid.nearest[grid.index(i, j, k)] = bestBone;
          previous = bestSigned;
        }
      }
      ++doneSlices;
    }
  };
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back(work);
  if (progress) {
    while (doneSlices.load() < grid.size[2]) {
      progress(static_cast<double>(doneSlices.load()) / grid.size[2]);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  for (std::thread& t : pool)
    t.join();
  if (progress)
    progress(1.0);
}

Specimen::~Specimen() = default;

const core::MeshLocator& Specimen::locator(std::size_t boneIndex) const {
  return locators_.at(boneIndex);
}

double Specimen::exactSignedDistance(const Eigen::Vector3d& p, std::size_t* bone) const {
  double best = std::numeric_limits<double>::infinity();
  double bestSigned = best;
  std::size_t bestBone = 0;
  for (std::size_t b = 0; b < locators_.size(); ++b) {
    const auto& box = boneBounds_[b];
    const Eigen::Vector3d outside =
        (box[0] - p).cwiseMax(p - box[1]).cwiseMax(Eigen::Vector3d::Zero());
    if (outside.norm() >= best)
      continue;
    const double cap = std::isfinite(best) ? best : 1e30;
    const double sd = grid_->signedMeshes[b].signedDistance(p, cap);
    if (sd < 0 && bestSigned >= 0) {  // inside a bone wins over near another
      best = -sd;
      bestSigned = sd;
      bestBone = b;
    } else if (std::abs(sd) < best && !(bestSigned < 0 && sd >= 0)) {
      best = std::abs(sd);
      bestSigned = sd;
      bestBone = b;
    }
  }
  if (bone != nullptr)
    *bone = bestBone;
  return bestSigned;
}

double Specimen::boneSignedDistance(const Eigen::Vector3d& p) const {
  const double coarse = grid_->sample(p, nullptr);
  if (std::isfinite(coarse) && std::abs(coarse) > kExactBandMm)
    return coarse;
  return exactSignedDistance(p, nullptr);
}

Specimen::LimbCoordinates Specimen::limbCoordinates(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d v = p - kneeCentre_;
  const double ht = v.dot(thighAxis_);
  const double hs = v.dot(shankAxis_);
  LimbCoordinates c;
  c.segment = ht >= hs ? Segment::Thigh : Segment::Shank;
  const Eigen::Vector3d& axis = c.segment == Segment::Thigh ? thighAxis_ : shankAxis_;
  const Eigen::Vector3d& anterior = c.segment == Segment::Thigh ? thighAnterior_ : shankAnterior_;
  c.heightMm = c.segment == Segment::Thigh ? ht : hs;
  const Eigen::Vector3d radial = v - c.heightMm * axis;
  const Eigen::Vector3d lateral = radialDirection(c.segment, kPi / 2.0);
  c.thetaRad = std::atan2(radial.dot(lateral), radial.dot(anterior));
  return c;
}

Eigen::Vector3d Specimen::axisPoint(Segment segment, double heightMm) const {
  return kneeCentre_ + heightMm * (segment == Segment::Thigh ? thighAxis_ : shankAxis_);
}

Eigen::Vector3d Specimen::radialDirection(Segment segment, double thetaRad) const {
  const Eigen::Vector3d& axis = segment == Segment::Thigh ? thighAxis_ : shankAxis_;
  const Eigen::Vector3d& anterior = segment == Segment::Thigh ? thighAnterior_ : shankAnterior_;
  Eigen::Vector3d lateral =
      lateral_ - lateral_.dot(axis) * axis - lateral_.dot(anterior) * anterior;
  lateral.normalize();
  return std::cos(thetaRad) * anterior + std::sin(thetaRad) * lateral;
}

double Specimen::softTissueThicknessMm(const Eigen::Vector3d& p) const {
  if (kind_ == SpecimenKind::Phantom)
    return 0.0;
  const Eigen::Vector3d v = p - kneeCentre_;
  const double ht = v.dot(thighAxis_);
  const double hs = v.dot(shankAxis_);
  auto theta = [&](Segment s) {
    const Eigen::Vector3d& axis = s == Segment::Thigh ? thighAxis_ : shankAxis_;
    const Eigen::Vector3d& anterior = s == Segment::Thigh ? thighAnterior_ : shankAnterior_;
    const double h = s == Segment::Thigh ? ht : hs;
    const Eigen::Vector3d radial = v - h * axis;
    return std::atan2(radial.dot(radialDirection(s, kPi / 2.0)), radial.dot(anterior));
  };
  // Blend the two maps over 50 mm around the joint line.
  const double w = smoothstep(-25.0, 25.0, ht - hs);
  double t = 0.0;
  double thetaForVariation = 0.0;
  if (w > 0.0) {
    const double th = theta(Segment::Thigh);
    t += w * sampleTable(thighTable(), ht, th);
    thetaForVariation = th;
  }
  if (w < 1.0) {
    const double th = theta(Segment::Shank);
    t += (1.0 - w) * sampleTable(shankTable(), hs, th);
    if (w < 0.5)
      thetaForVariation = th;
  }
  // Smooth variation around the limb (periodic linear interpolation of 8 values).
  double sector = std::fmod(thetaForVariation / (kPi / 4.0) + 8.0, 8.0);
  const int s0 = static_cast<int>(sector) % 8;
  const double f = sector - std::floor(sector);
  const double var = (1 - f) * variation_[static_cast<std::size_t>(s0)] +
                     f * variation_[static_cast<std::size_t>((s0 + 1) % 8)];
  const double total = t * tissue_.thicknessScale * (1.0 + var);
  if (tissue_.underSkinScale == 1.0 || total <= tissue_.skinMm)
    return total;
  return tissue_.skinMm + tissue_.underSkinScale * (total - tissue_.skinMm);
}

double Specimen::fatThicknessMm(const Eigen::Vector3d& p) const {
  return fatFor(p, softTissueThicknessMm(p));
}

double Specimen::fatFor(const Eigen::Vector3d& p, double total) const {
  const Eigen::Vector3d v = p - kneeCentre_;
  const double w = smoothstep(-25.0, 25.0, v.dot(thighAxis_) - v.dot(shankAxis_));
  const double fat =
      (w * kThighFatMm + (1 - w) * kShankFatMm) * tissue_.thicknessScale * tissue_.underSkinScale;
  const double belowSkin = std::max(0.0, total - tissue_.skinMm);
  // Where less than 2 mm of muscle would remain (over subcutaneous bone), there is none.
  if (belowSkin - fat < 2.0)
    return belowSkin;
  return fat;
}

double Specimen::legField(const Eigen::Vector3d& p) const {
  const double sd = boneSignedDistance(p);
  if (kind_ == SpecimenKind::Phantom)
    return sd;
  return sd - softTissueThicknessMm(p);
}

Tissue Specimen::softTissueAt(const Eigen::Vector3d& p, double distance) const {
  if (kind_ == SpecimenKind::Phantom)
    return Tissue::Air;
  if (distance > maxThicknessMm_)
    return Tissue::Air;
  const double total = softTissueThicknessMm(p);
  if (distance > total)
    return Tissue::Air;
  if (distance > total - tissue_.skinMm)
    return Tissue::Skin;
  const double fat = fatFor(p, total);
  const double muscle = std::max(0.0, total - tissue_.skinMm - fat);
  return distance > muscle ? Tissue::Fat : Tissue::Muscle;
}

Tissue Specimen::boneInteriorAt(const Eigen::Vector3d& p, std::size_t bone, double depth) const {
  if (kind_ == SpecimenKind::Phantom) {
    return depth < kPhantomShellMm ? Tissue::SawbonesShell : Tissue::SawbonesFoam;
  }
  const Bone& b = knee_.bones[bone];
  if (depth < b.corticalThicknessMm(p))
    return Tissue::CorticalBone;
  if (b.distanceFromAxisMm(p) < b.medullaryRadiusMm(p))
    return Tissue::Marrow;
  return Tissue::CancellousBone;
}

Tissue Specimen::tissueAt(const Eigen::Vector3d& p) const {
  std::size_t bone = 0;
  const double coarse = grid_->sample(p, &bone);
  if (!std::isfinite(coarse))
    return Tissue::Air;
  if (coarse > kExactBandMm)
    return softTissueAt(p, coarse);
  // Inside a bone the depth only places the cortex's inner wall: the grid is precise enough.
  if (coarse < -kExactBandMm)
    return boneInteriorAt(p, bone, -coarse);
  const double sd = exactSignedDistance(p, &bone);
  if (sd < 0)
    return boneInteriorAt(p, bone, -sd);
  return softTissueAt(p, sd);
}

std::optional<SurfacePoint> Specimen::surfacePoint(Segment segment, double heightMm,
                                                   double thetaRad) const {
  const Eigen::Vector3d a = axisPoint(segment, heightMm);
  const Eigen::Vector3d dir = radialDirection(segment, thetaRad);
  double outside = 200.0;
  if (legField(a + outside * dir) <= 0.0)
    return std::nullopt;
  double r = outside;
  bool found = false;
  for (; r > 0.0; r -= 1.0) {
    if (legField(a + r * dir) <= 0.0) {
      found = true;
      break;
    }
    outside = r;
  }
  if (!found)
    return std::nullopt;
  double inside = r;
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (inside + outside);
    (legField(a + mid * dir) <= 0.0 ? inside : outside) = mid;
  }
  SurfacePoint s;
  s.point = a + 0.5 * (inside + outside) * dir;
  const double h = 0.5;
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[k] = h;
    g[k] = legField(s.point + e) - legField(s.point - e);
  }
  if (g.norm() == 0.0)
    return std::nullopt;
  s.normal = g.normalized();
  return s;
}

BeamTrace Specimen::traceBeam(const Eigen::Vector3d& o, const Eigen::Vector3d& u, Tissue standoff,
                              double maxDepthMm) const {
  BeamTrace trace;
  // The first bone along the beam, exactly.
  double boneT = std::numeric_limits<double>::infinity();
  Eigen::Vector3d boneNormal = Eigen::Vector3d::Zero();
  for (std::size_t b = 0; b < locators_.size(); ++b) {
    const auto hit = locators_[b].firstHit(o, u, maxDepthMm);
    if (hit && hit->t < boneT) {
      boneT = hit->t;
      boneNormal = hit->normal;
      trace.boneIndex = static_cast<int>(b);
      trace.hitPoint = hit->point;
    }
  }
  const double end = std::min(boneT, maxDepthMm);
  auto gradientAngle = [&](const Eigen::Vector3d& p, bool skin) {
    const double h = 0.3;
    Eigen::Vector3d g;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[k] = h;
      g[k] = skin ? legField(p + e) - legField(p - e)
                  : boneSignedDistance(p + e) - boneSignedDistance(p - e);
    }
    if (g.norm() == 0.0)
      return 0.0;
    return std::acos(std::min(1.0, std::abs(g.normalized().dot(u)))) * 180.0 / kPi;
  };

  std::vector<PathLayer>& layers = trace.path.layers;
  if (kind_ == SpecimenKind::Phantom) {
    layers.push_back({Tissue::Water, end, 0.0});
  } else {
    // Standoff up to the skin, then the tissues in order: classify on a fine march and bisect
    // every change of tissue. "Air" before the skin is the standoff; after it, the beam has left
    // the leg.
    auto classify = [&](double t) {
      const Eigen::Vector3d p = o + t * u;
      const double sd = boneSignedDistance(p);
      return sd < 0 ? Tissue::CorticalBone : softTissueAt(p, sd);
    };
    // The deep intermuscular septum of thick muscle (> 12 mm), a specular sheet at 45 % depth.
    auto septum = [&](double t) {
      const Eigen::Vector3d p = o + t * u;
      const double total = softTissueThicknessMm(p);
      const double muscle = std::max(0.0, total - tissue_.skinMm - fatThicknessMm(p));
      if (muscle < 12.0)
        return std::numeric_limits<double>::quiet_NaN();
      return boneSignedDistance(p) - 0.45 * muscle;
    };
    constexpr double step = 0.1;
    bool inLeg = false;
    double layerStart = 0.0;
    Tissue current = classify(0.0);
    if (current != Tissue::Air) {
      // The transducer face is already under the skin (pressed in): no standoff.
      inLeg = true;
    }
    double previousSeptum = septum(0.0);
    double t = 0.0;
    bool exited = false;
    while (t < end && !exited) {
      const double next = std::min(end, t + step);
      const Tissue tissue = next < end ? classify(next) : current;
      if (current == Tissue::Muscle) {
        const double q = septum(next);
        if (std::isfinite(q) && std::isfinite(previousSeptum) && (q < 0) != (previousSeptum < 0)) {
          trace.path.fasciaDepthsMm.push_back(0.5 * (t + next));
        }
        previousSeptum = q;
      } else {
        previousSeptum = septum(next);
      }
      if (tissue != current) {
        double a = t, b = next;
        for (int it = 0; it < 30; ++it) {
          const double mid = 0.5 * (a + b);
          (classify(mid) == current ? a : b) = mid;
        }
        const double boundary = 0.5 * (a + b);
        const bool skin = current == Tissue::Air || tissue == Tissue::Air;
        const double angle = gradientAngle(o + boundary * u, skin);
        Tissue layerTissue = current;
        if (current == Tissue::Air && !inLeg)
          layerTissue = standoff;
        if (boundary - layerStart > 0.0)
          layers.push_back({layerTissue, boundary - layerStart, angle});
        if (tissue == Tissue::Skin && !inLeg) {
          trace.skinDepthMm = boundary;
          inLeg = true;
        }
        if (tissue == Tissue::Air && inLeg) {
          layers.push_back({Tissue::Air, 1e6, 0.0});  // the beam leaves the leg: total reflection
          exited = true;
        }
        layerStart = boundary;
        current = tissue;
      }
      t = next;
    }
    if (!exited) {
      Tissue layerTissue = current == Tissue::Air && !inLeg ? standoff : current;
      layers.push_back({layerTissue, end - layerStart, 0.0});
    }
  }
  double oneWayTimeS = 0.0;
  double length = 0.0;
  for (const PathLayer& layer : layers) {
    if (layer.lengthMm >= 1e5)
      break;
    oneWayTimeS += layer.lengthMm * 1e-3 / properties(layer.tissue).speedMps;
    length += layer.lengthMm;
  }
  trace.meanSpeedMps = oneWayTimeS > 0 ? length * 1e-3 / oneWayTimeS : 0.0;
  const bool exitedLeg =
      !layers.empty() && layers.back().tissue == Tissue::Air && layers.back().lengthMm >= 1e5;
  if (trace.boneIndex >= 0 && boneT <= maxDepthMm && !exitedLeg) {
    trace.boneDepthMm = boneT;
    trace.incidenceDeg = std::acos(std::min(1.0, std::abs(boneNormal.dot(u)))) * 180.0 / kPi;
    layers.back().exitIncidenceDeg = trace.incidenceDeg;
    layers.push_back(
        {kind_ == SpecimenKind::Phantom ? Tissue::SawbonesShell : Tissue::CorticalBone, 1e6, 0.0});
  } else {
    trace.boneIndex = -1;
    if (!layers.empty() && layers.back().tissue != Tissue::Air)
      layers.back().lengthMm = 1e6;
  }
  return trace;
}

}  // namespace echoreg::simulation
