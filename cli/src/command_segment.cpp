// `echoreg segment`: a bone model from a CT series (Mozes 2008, section 4.3.1): from live-wire
// contours through the user's anchors (the dissertation's way, 40 sagittal slices per bone), or
// automatically from a seed point in the bone. Both end in the CT's own iso-surface around the
// segmented region (sub-voxel), a closed model in CT patient coordinates (LPS), the mask as NRRD,
// anchors proposed for the user to check, and optionally the surface accessible to a probe.
#include "commands.hpp"
#include "json_values.hpp"
#include "path_check.hpp"
#include "validators.hpp"

#include "echoreg/core/error.hpp"
#include "echoreg/core/mesh.hpp"
#include "echoreg/filters/mesh_io.h"
#include "echoreg/segmentation/accessible_surface.hpp"
#include "echoreg/segmentation/bone_labels.hpp"
#include "echoreg/segmentation/bone_mask.hpp"
#include "echoreg/segmentation/bone_surface.hpp"
#include "echoreg/segmentation/contour_surface.hpp"
#include "echoreg/segmentation/dicom_series.hpp"
#include "echoreg/segmentation/livewire_contours.hpp"
#include "echoreg/segmentation/nrrd_volume.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>

namespace echoreg::cli {

namespace {

namespace seg = echoreg::segmentation;

// A corrections curve whose name begins with "absent" (any case) marks where the bone is not.
bool isAbsentCurve(const std::string& label) {
  static const std::string kWord = "absent";
  return label.size() >= kWord.size() &&
         std::equal(kWord.begin(), kWord.end(), label.begin(), [](char a, char b) {
           return a == std::tolower(static_cast<unsigned char>(b));
         });
}

struct SegmentOptions {
  std::string dicom, bone, anchors, out, mask, plane = "sagittal", series, anchorsOut;
  std::string accessibleOut, keepRegions, corrections;
  bool automatic = false, withFibula = false, noRefine = false, json = false;
  bool refuseMetal = false;
  bool noJointSphere = false;
  std::vector<std::vector<std::string>> seedTokens;  // [BONE] X Y Z, one list per --seed
  std::string method = "watershed";
  std::string anchorsWhere = "all";
  int slices = 40;
  double isoHu = 0.0;
  std::vector<double> thresholdHu;  // STRONG WEAK
  double bandMm = 2.0;
  int smoothing = 10;
  int targetTriangles = 0;
  double separationMm = 2.4;
  double regionRadiusMm = 20.0;
  std::vector<double> viewDirections;
  double maxAngleDeg = 60.0;
};

// The folder an output goes into must exist before the work starts.
void requireOutputFolder(const std::string& path) {
  if (path.empty())
    return;
  const std::filesystem::path parent = std::filesystem::absolute(path).parent_path();
  if (!std::filesystem::is_directory(parent)) {
    throw core::FileError(path, "the output folder " + parent.string() + " does not exist");
  }
  if (std::filesystem::is_directory(path))
    throw core::FileError(path, "is a folder, not a file");
}

class Progress {
 public:
  explicit Progress(const Streams& io) : io_(io) {}
  void operator()(const std::string& stage, double fraction) {
    if (!io_.errIsTerminal)
      return;
    const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0);
    if (stage == stage_ && percent == percent_)
      return;
    stage_ = stage;
    percent_ = percent;
    io_.err << fmt::format("\rsegment: {:<28} {:3d}%", stage, percent) << std::flush;
  }
  void done() {
    if (io_.errIsTerminal && !stage_.empty())
      io_.err << "\r" << std::string(45, ' ') << "\r" << std::flush;
  }

 private:
  const Streams& io_;
  std::string stage_;
  int percent_ = -1;
};

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The group holding most of `points` (-1 when none lies in any group).
int majorityGroup(const core::CtImage& ct, const std::vector<Eigen::Vector3d>& points) {
  std::map<int, int> votes;
  for (const auto& p : points) {
    const int g = seg::groupContaining(ct, p);
    if (g >= 0)
      ++votes[g];
  }
  int best = -1, most = 0;
  for (const auto& [g, n] : votes) {
    if (n > most) {
      best = g;
      most = n;
    }
  }
  return best;
}

bool isNumber(const std::string& s) {
  char* end = nullptr;
  std::strtod(s.c_str(), &end);
  return !s.empty() && end == s.c_str() + s.size();
}

// The --seed tokens as seeds: "X Y Z" (the bone of --bone) or "BONE X Y Z". For tibia+fibula the
// unnamed seeds are the tibia's and the fibula's. Throws CLI::ValidationError.
std::vector<seg::BoneSeed> parseSeeds(const SegmentOptions& o) {
  std::vector<seg::BoneSeed> seeds;
  const bool tibiaFibula = o.withFibula || o.bone == "tibia+fibula";
  int unnamed = 0;
  for (const std::vector<std::string>& tokens : o.seedTokens) {
    const bool named = !tokens.empty() && !isNumber(tokens.front());
    const std::size_t first = named ? 1 : 0;
    bool ok = tokens.size() == first + 3;
    for (std::size_t t = first; ok && t < tokens.size(); ++t)
      ok = isNumber(tokens[t]);
    if (!ok) {
      std::string given;
      for (const auto& t : tokens)
        given += (given.empty() ? "" : " ") + t;
      throw CLI::ValidationError(
          "--seed", fmt::format("takes [BONE] X Y Z (LPS mm), e.g. --seed femur -95 25 -445; got "
                                "'{}'",
                                given));
    }
    seg::BoneSeed seed;
    if (named) {
      seed.bone = tokens.front();
    } else if (tibiaFibula) {
      seed.bone = unnamed == 0   ? "tibia"
                  : unnamed == 1 ? "fibula"
                                 : fmt::format("tibia+fibula#{}", unnamed + 1);
      ++unnamed;
    } else {
      seed.bone = o.bone;
    }
    for (int c = 0; c < 3; ++c)
      seed.pointLps[c] = std::strtod(tokens[first + static_cast<std::size_t>(c)].c_str(), nullptr);
    seeds.push_back(seed);
  }
  return seeds;
}

// Whether a seed's bone is part of the model asked for (--bone; tibia+fibula: both).
bool isTarget(const SegmentOptions& o, const std::string& bone) {
  const bool tibiaFibula = o.withFibula || o.bone == "tibia+fibula";
  if (tibiaFibula)
    return bone == "tibia" || bone == "fibula" || bone.rfind("tibia+fibula", 0) == 0;
  return bone == o.bone;
}

// Wrong usage (exit 2), checked while parsing.
void checkUsage(const SegmentOptions& o) {
  if (o.automatic == !o.anchors.empty()) {
    throw CLI::ValidationError("--anchors / --auto",
                               "give exactly one of --anchors FILE and --auto --seed X Y Z");
  }
  if (o.automatic && o.seedTokens.empty()) {
    throw CLI::ValidationError("--seed", "--auto needs --seed [BONE] X Y Z (once per bone)");
  }
  if (!o.automatic && !o.seedTokens.empty())
    throw CLI::ValidationError("--seed", "--seed goes with --auto");
  if (!o.automatic && !o.corrections.empty())
    throw CLI::ValidationError("--corrections", "--corrections goes with --auto");
  const std::vector<seg::BoneSeed> seeds = parseSeeds(o);
  std::size_t targets = 0;
  for (const auto& s : seeds)
    targets += isTarget(o, s.bone) ? 1u : 0u;
  if (o.automatic && targets == 0) {
    throw CLI::ValidationError("--seed",
                               fmt::format("no seed of the bone to model (--bone {}): give "
                                           "--seed {} X Y Z, or --seed X Y Z",
                                           o.bone, o.bone));
  }
  const bool tibiaFibula = o.withFibula || o.bone == "tibia+fibula";
  if (o.automatic && tibiaFibula && targets < 2) {
    throw CLI::ValidationError(
        "--seed",
        "--bone tibia+fibula with --auto needs two seeds: --seed (tibia) --seed (fibula)");
  }
  if ((!o.keepRegions.empty() || !o.viewDirections.empty()) && o.accessibleOut.empty()) {
    throw CLI::ValidationError("--accessible-out",
                               "--keep-regions / --view-direction need --accessible-out FILE.vtp");
  }
  if (o.viewDirections.size() % 3 != 0)
    throw CLI::ValidationError("--view-direction", "takes X Y Z");
}

int runSegment(const SegmentOptions& o, const Streams& io) {
  const auto start = std::chrono::steady_clock::now();
  const bool tibiaFibula = o.withFibula || o.bone == "tibia+fibula";
  const std::string boneName = tibiaFibula ? "tibia+fibula" : o.bone;
  seg::GrowOptions grow;
  if (o.thresholdHu.size() == 2) {
    grow.threshold.strongHu = o.thresholdHu[0];
    grow.threshold.weakHu = o.thresholdHu[1];
    if (grow.threshold.weakHu > grow.threshold.strongHu) {
      throw std::invalid_argument(
          fmt::format("--threshold-hu STRONG WEAK needs WEAK <= STRONG, got {} {}",
                      o.thresholdHu[0], o.thresholdHu[1]));
    }
  }
  grow.separationRadiusMm = o.separationMm;
  const seg::SlicePlane plane = seg::parseSlicePlane(o.plane);
  CommandPaths()
      .input("--dicom", o.dicom)
      .input("--anchors", o.anchors)
      .input("--corrections", o.corrections)
      .output("--out", o.out)
      .optionalOutput("--mask", o.mask)
      .optionalOutput("--anchors-out", o.anchorsOut)
      .optionalOutput("--accessible-out", o.accessibleOut)
      .check();
  for (const std::string& path : {o.out, o.mask, o.anchorsOut, o.accessibleOut})
    requireOutputFolder(path);
  std::vector<seg::AnchorSet> anchorSets, correctionSets;
  if (!o.anchors.empty())
    anchorSets = seg::readAnchors(o.anchors);  // bad files fail before the CT is read
  if (!o.corrections.empty())
    correctionSets = seg::readAnchors(o.corrections);
  std::vector<seg::SurfaceRegion> regions;
  if (!o.keepRegions.empty())
    regions = seg::readSurfaceRegions(o.keepRegions, o.regionRadiusMm);

  Progress progress(io);
  nlohmann::json timings = nlohmann::json::object();
  nlohmann::json warnings = nlohmann::json::array();

  // 1. The CT.
  auto t0 = std::chrono::steady_clock::now();
  seg::DicomReadOptions read;
  read.seriesUid = o.series;
  read.progress = [&](int done, int total) {
    progress("reading the CT", static_cast<double>(done) / total);
  };
  const seg::DicomSeriesRead series = seg::readDicomSeriesWithWarnings(o.dicom, read);
  for (const std::string& w : series.warnings)
    warnings.push_back(w);
  const core::CtImage& ct = series.image;
  timings["read_s"] = secondsSince(t0);

  // 2. The protocol group to segment in.
  const std::vector<seg::BoneSeed> allSeeds =
      o.automatic ? parseSeeds(o) : std::vector<seg::BoneSeed>{};
  std::vector<seg::BoneSeed> targetSeeds;
  for (const auto& s : allSeeds) {
    if (isTarget(o, s.bone))
      targetSeeds.push_back(s);
  }
  int group = 0;
  if (o.automatic) {
    for (const auto& s : allSeeds) {
      if (seg::groupContaining(ct, s.pointLps) < 0) {
        throw core::FileError(
            o.dicom, fmt::format("the {} seed ({:.1f}, {:.1f}, {:.1f}) mm lies outside the CT's "
                                 "slices (or in a gap between its slice groups)",
                                 s.bone, s.pointLps.x(), s.pointLps.y(), s.pointLps.z()));
      }
    }
    group = seg::groupContaining(ct, targetSeeds.front().pointLps);
    for (const auto& s : allSeeds) {
      if (seg::groupContaining(ct, s.pointLps) != group) {
        throw core::FileError(
            o.dicom, fmt::format("the seeds lie in different slice groups of the CT (the {} seed "
                                 "({:.1f}, {:.1f}, {:.1f}) mm); give seeds in one group",
                                 s.bone, s.pointLps.x(), s.pointLps.y(), s.pointLps.z()));
      }
    }
  } else {
    std::vector<Eigen::Vector3d> points;
    for (const auto& set : anchorSets)
      points.insert(points.end(), set.anchorsLps.begin(), set.anchorsLps.end());
    group = majorityGroup(ct, points);
    if (group < 0)
      throw core::FileError(o.anchors, "no anchor lies within the CT's slices");
  }
  const core::CtImage volume =
      ct.uniform() ? ct : seg::extractGroup(ct, static_cast<std::size_t>(group));
  const core::CtSliceGroup& used = ct.groups[static_cast<std::size_t>(group)];
  const double zFirst = ct.voxelToLps(Eigen::Vector3d(0, 0, used.firstSlice)).z();
  const double zLast = ct.voxelToLps(Eigen::Vector3d(0, 0, used.firstSlice + used.count - 1)).z();
  const double zLow = std::min(zFirst, zLast), zHigh = std::max(zFirst, zLast);
  if (!ct.uniform()) {
    warnings.push_back(
        fmt::format("the CT has {} slice groups; segmented in group {} ({} slices at {:.2f} mm, "
                    "z {:.1f} to {:.1f} mm): the model is closed at that group's ends",
                    ct.groups.size(), group, used.count, used.spacingMm, std::min(zFirst, zLast),
                    std::max(zFirst, zLast)));
  }

  // 3. The region: grown from the seeds, or enclosed by the live-wire contours.
  t0 = std::chrono::steady_clock::now();
  seg::VoxelMask region, exclude;
  double cortexMinHu = 600.0;  // the surface's; from the histogram with the watershed
  // The other bones around the region, by name ("" found automatically or by the threshold),
  // for the uncertain slices of --anchors-where uncertain.
  std::vector<std::pair<std::string, seg::VoxelMask>> neighbourMasks;
  nlohmann::json modeJson;
  // Where a head pressed into its socket was separated at its surface's sphere, the model is
  // bounded by it over the joint (BoneSurfaceOptions::sphereCut).
  std::optional<seg::SphereCut> sphereCut;
  if (o.automatic && o.method == "erosion") {
    nlohmann::json seedsJson = nlohmann::json::array();
    seg::VoxelMask others;
    if (targetSeeds.size() < allSeeds.size()) {
      warnings.push_back(
          "--method erosion grows each seed of the bone alone: the other bones' "
          "seeds are not used");
    }
    for (std::size_t s = 0; s < targetSeeds.size(); ++s) {
      grow.progress = [&](double f, const std::string& stage) {
        progress(fmt::format("seed {}: {}", s + 1, stage), f);
      };
      seg::GrowResult grown;
      try {
        grown = seg::growBone(volume, targetSeeds[s].pointLps, grow);
      } catch (const std::invalid_argument& e) {
        throw core::FileError(o.dicom, e.what());
      }
      seedsJson.push_back({{"bone", targetSeeds[s].bone},
                           {"seed_mm", vec(targetSeeds[s].pointLps)},
                           {"seed_hu", grown.seedHu},
                           {"volume_mm3", grown.volumeMm3}});
      region = s == 0 ? grown.mask : seg::unite(region, grown.mask);
      others = s == 0 ? grown.others : seg::unite(others, grown.others);
    }
    exclude = others;  // the other bones, but not the bones asked for
    for (std::size_t i = 0; i < exclude.voxels.size(); ++i)
      exclude.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    modeJson = {{"mode", "auto"}, {"method", "erosion"}, {"seeds", seedsJson}};
  } else if (o.automatic) {
    seg::CompetingOptions competing;
    competing.threshold = grow.threshold;
    competing.thresholdFromHistogram = o.thresholdHu.empty();
    competing.refuseMetal = o.refuseMetal;
    competing.jointFromSphere = !o.noJointSphere;
    competing.progress = [&](double f, const std::string& stage) { progress(stage, f); };
    seg::CompetingResult bones;
    try {
      bones = seg::segmentCompetingBones(volume, allSeeds, competing);
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o.dicom, e.what());
    }
    if (bones.thresholdFromHistogram)
      cortexMinHu = bones.estimate.surfaceCortexMinHu;
    nlohmann::json seedsJson = nlohmann::json::array();
    nlohmann::json bonesJson = nlohmann::json::array();
    region = seg::emptyMask(volume);
    exclude = seg::unite(seg::unite(bones.unnamed, bones.metalMask), bones.streakMask);
    for (const seg::SegmentedBone& b : bones.bones) {
      const bool target = isTarget(o, b.bone);
      for (std::size_t s = 0; s < b.seedsLps.size(); ++s) {
        seedsJson.push_back({{"bone", b.bone},
                             {"seed_mm", vec(b.seedsLps[s])},
                             {"seed_hu", b.seedHu[s]},
                             {"volume_mm3", b.volumeMm3},
                             {"modelled", target}});
      }
      bonesJson.push_back({{"bone", b.bone},
                           {"volume_mm3", b.volumeMm3},
                           {"extent_mm", vec(b.extentMm)},
                           {"modelled", target}});
      seg::VoxelMask& into = target ? region : exclude;
      into = seg::unite(into, b.mask);
      if (!target)
        neighbourMasks.emplace_back(b.bone, b.mask);
    }
    neighbourMasks.emplace_back("", bones.unnamed);
    if (!bones.metal.empty())
      neighbourMasks.emplace_back("metal", bones.metalMask);
    for (std::size_t i = 0; i < exclude.voxels.size(); ++i)
      exclude.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    // Where two named bones meet along the slices: on thick slices a joint lying along them
    // shows in no voxel, and the boundary there is a guess (docs/segmentation.md, Limits).
    nlohmann::json contactsJson = nlohmann::json::array();
    const double sliceMm = volume.spacingMm().z();
    for (const seg::SliceContact& c : seg::contactsAlongSlices(volume, bones.bones)) {
      contactsJson.push_back({{"bones", {c.first, c.second}},
                              {"area_mm2", c.areaMm2},
                              {"z_mm", {c.zMinMm, c.zMaxMm}},
                              {"centre_mm", vec(c.centreLps)}});
      if (sliceMm >= competing.jointSlabMinSliceMm && competing.jointSlabMinSliceMm > 0.0 &&
          c.areaMm2 >= 50.0) {
        warnings.push_back(fmt::format(
            "at {:.1f} mm slices the {} and the {} meet along the slices over {:.0f} mm^2 (z "
            "{:.1f} to {:.1f} mm, around ({:.1f}, {:.1f}, {:.1f}) mm): a joint lying along the "
            "slices shows in no voxel there, so that part of the boundary is a guess; check both "
            "models there (--anchors-where uncertain proposes the slices to correct), or "
            "segment a thinner series",
            sliceMm, c.first, c.second, c.areaMm2, c.zMinMm, c.zMaxMm, c.centreLps.x(),
            c.centreLps.y(), c.centreLps.z()));
      }
    }
    // A ball-and-socket joint separated by the head's sphere, after the watershed was refused.
    nlohmann::json sphereJson = nullptr;
    if (bones.jointSphere) {
      const seg::JointSphere& js = *bones.jointSphere;
      // The model is one of the two (not both, as one model): corrections by the user's
      // contours decide the region there themselves.
      const std::string& modelled = isTarget(o, js.ball) ? js.ball : js.socket;
      if (isTarget(o, js.ball) != isTarget(o, js.socket) && o.corrections.empty())
        sphereCut = seg::sphereCutFor(bones, modelled);
      sphereJson = {{"ball", js.ball},
                    {"socket", js.socket},
                    {"centre_mm", vec(js.centreLps)},
                    {"radius_mm", js.radiusMm},
                    {"rms_mm", js.rmsMm},
                    {"inliers", js.inliers},
                    {"fitted_to", js.fromSurface ? "surface" : "joint line"},
                    {"after_pass", js.afterPass},
                    {js.fromSurface ? "surface_voxels" : "joint_line_voxels", js.points},
                    {"axis", vec(js.axisLps)},
                    {"cap_degrees", js.capDegrees},
                    {"shell_voxels", js.shellVoxels},
                    {"bounds_model", sphereCut.has_value()}};
      warnings.push_back(fmt::format(
          "the {} and the {} were not told apart by the CT where their joint lies along the "
          "slices (refused, or the {} ran across the joint): they were separated by a sphere "
          "fitted to {} ({} of {} {} voxels within {:.1f} mm, radius {:.1f} mm about ({:.1f}, "
          "{:.1f}, {:.1f}) mm, over {:.0f} degrees of the {}); check both models at the joint "
          "(--anchors-where uncertain proposes the slices to correct; --no-joint-sphere refuses "
          "instead)",
          js.ball, js.socket, js.ball,
          js.fromSurface ? fmt::format("the {}'s head's surface where the {} does not cover it "
                                       "({})",
                                       js.ball, js.socket,
                                       js.afterPass ? fmt::format("a piece of the {} had been kept "
                                                                  "apart beyond it",
                                                                  js.socket)
                                                    : std::string("no joint line showed"))
                         : std::string("the joint line that shows"),
          js.inliers, js.points, js.fromSurface ? "surface" : "joint-line",
          competing.jointSphereToleranceMm, js.radiusMm, js.centreLps.x(), js.centreLps.y(),
          js.centreLps.z(), js.capDegrees, js.socket));
      if (sphereCut) {
        warnings.back() =
            warnings.back().get<std::string>() +
            fmt::format(
                "; the {}'s surface over the joint is that sphere (the CT shows no joint there)",
                modelled);
      }
    }
    nlohmann::json metalJson = nlohmann::json::array();
    for (const seg::MetalPiece& m : bones.metal) {
      metalJson.push_back({{"centre_mm", vec(m.centreLps)},
                           {"volume_mm3", m.volumeMm3},
                           {"max_hu", m.maxHu},
                           {"touches", m.touches},
                           {"streak_slices", m.streakSlices},
                           {"bright_streak_voxels", m.brightStreakVoxels},
                           {"dark_streak_voxels", m.darkStreakVoxels},
                           {"streak_reach_mm", m.streakReachMm}});
      warnings.push_back(fmt::format(
          "metal (an implant?) of {:.0f} mm^3 up to {} HU at ({:.1f}, {:.1f}, {:.1f}) mm{}: left "
          "out of the bones; streaks on {} slices up to {:.0f} mm from it ({} bright voxels "
          "left out of the bone, {} dark); the model is not reliable within a few mm of it",
          m.volumeMm3, m.maxHu, m.centreLps.x(), m.centreLps.y(), m.centreLps.z(),
          m.touches.empty() ? "" : ", on the " + m.touches, m.streakSlices, m.streakReachMm,
          m.brightStreakVoxels, m.darkStreakVoxels));
    }
    modeJson = {{"mode", "auto"},
                {"method", "watershed"},
                {"seeds", seedsJson},
                {"bones", bonesJson},
                {"automatic_neighbours", bones.automaticNeighbours},
                {"joint_slab_voxels", bones.jointSlabVoxels},
                {"contacts_along_slices", contactsJson},
                {"joint_sphere", sphereJson},
                {"marker_dynamic_mm", bones.markerDynamicMm},
                {"threshold",
                 {{"strong_hu", bones.thresholdUsed.strongHu},
                  {"weak_hu", bones.thresholdUsed.weakHu},
                  {"from", bones.thresholdFromHistogram ? "histogram" : "--threshold-hu"},
                  {"soft_tissue_hu", bones.estimate.softTissueHu},
                  {"noise_hu", bones.estimate.noiseHu},
                  {"cortex_hu", bones.estimate.cortexHu},
                  {"seed_marrow_hu", bones.estimate.marrowHu}}},
                {"metal", metalJson}};
  } else {
    std::vector<seg::SliceContour> contours;
    nlohmann::json contoursJson = nlohmann::json::array();
    // Anchors on the scan's ends (within half a slice): the contour runs straight between them.
    const double endTolerance = 0.5 * volume.spacingMm().z() + 0.01;
    int straightened = 0;
    for (std::size_t c = 0; c < anchorSets.size(); ++c) {
      progress("live-wire contours",
               static_cast<double>(c) / static_cast<double>(anchorSets.size()));
      try {
        contours.push_back(seg::liveWireContour(volume, anchorSets[c]));
      } catch (const std::invalid_argument& e) {
        throw core::FileError(o.anchors, e.what());
      }
      if (anchorSets[c].plane != seg::SlicePlane::Axial) {
        straightened +=
            seg::straightenAtScanEnds(contours.back(), anchorSets[c], zLow, zHigh, endTolerance);
      }
      contoursJson.push_back({{"label", anchorSets[c].label},
                              {"plane", seg::slicePlaneName(anchorSets[c].plane)},
                              {"position_mm", anchorSets[c].positionMm},
                              {"anchors", anchorSets[c].anchorsLps.size()},
                              {"points", contours.back().pointsLps.size()},
                              {"cost", contours.back().cost}});
    }
    progress("filling the contours", 0.0);
    try {
      region = seg::contoursToMask(contours, volume);
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o.anchors, e.what());
    }
    if (region.count() == 0)
      throw core::FileError(o.anchors, "the contours enclose no voxel of the CT");
    exclude = seg::otherBones(seg::thresholdBone(volume, grow.threshold), region, o.bandMm);
    modeJson = {{"mode", "anchors"},
                {"contours", contoursJson},
                {"straight_cuts_at_scan_ends", straightened}};
  }
  if (!correctionSets.empty()) {
    // The user's corrected slices (live-wire through their anchors) put into the automatic
    // region, fading over 3 mm into it.
    // A curve named "absent..." marks an area that is not this bone (taken as drawn, straight
    // between its anchors: it marks an area, not an edge to follow).
    std::vector<seg::SliceContour> contours, absent;
    for (const auto& set : correctionSets) {
      if (isAbsentCurve(set.label)) {
        seg::SliceContour area;
        area.plane = set.plane;
        area.positionMm = set.positionMm;
        area.pointsLps = set.anchorsLps;
        absent.push_back(std::move(area));
        continue;
      }
      try {
        contours.push_back(seg::liveWireContour(volume, set));
      } catch (const std::invalid_argument& e) {
        throw core::FileError(o.corrections, e.what());
      }
    }
    seg::SliceCorrectionResult corrected;
    try {
      corrected = seg::correctOnSlices(region, contours, 3.0, absent);
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o.corrections, e.what());
    }
    // What the corrections took away is not this bone: the surface must not follow its HU back
    // onto it (a bright neighbour, or the bone where the user says it is absent).
    for (std::size_t i = 0; i < region.voxels.size(); ++i) {
      if (region.voxels[i] && !corrected.region.voxels[i])
        exclude.voxels[i] = 1;
    }
    region = std::move(corrected.region);
    for (auto& [name, mask] : neighbourMasks) {
      for (std::size_t i = 0; i < mask.voxels.size(); ++i)
        mask.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    }
    for (std::size_t i = 0; i < exclude.voxels.size(); ++i)
      exclude.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    modeJson["corrections"] = {
        {"file", o.corrections},           {"contours", contours.size()},
        {"absent", absent.size()},         {"slices", corrected.slices},
        {"voxels_added", corrected.added}, {"voxels_removed", corrected.removed}};
  }
  if (neighbourMasks.empty()) {
    seg::VoxelMask others = exclude;
    for (std::size_t i = 0; i < others.voxels.size(); ++i)
      others.voxels[i] &= static_cast<std::uint8_t>(!region.voxels[i]);
    neighbourMasks.emplace_back("", std::move(others));
  }
  timings["region_s"] = secondsSince(t0);

  // 4. The surface.
  t0 = std::chrono::steady_clock::now();
  progress("surface", 0.0);
  seg::BoneSurfaceOptions surfaceOptions;
  surfaceOptions.isoHu = o.isoHu;
  surfaceOptions.cortexMinHu = cortexMinHu;
  surfaceOptions.bandMm = o.bandMm;
  surfaceOptions.smoothingIterations = o.smoothing;
  surfaceOptions.targetTriangles = static_cast<std::size_t>(std::max(0, o.targetTriangles));
  surfaceOptions.sphereCut = sphereCut;
  seg::BoneSurfaceResult surface;
  try {
    surface = o.noRefine ? seg::maskSurface(region, 0.6, surfaceOptions)
                         : seg::boneSurface(volume, region, &exclude, surfaceOptions);
  } catch (const std::invalid_argument& e) {
    throw core::FileError(o.dicom, std::string("no surface: ") + e.what());
  }
  const core::MeshCheck check = core::checkMesh(surface.mesh);
  if (!check.closed())
    throw core::FileError(o.dicom, "the model is " + check.describe());
  timings["surface_s"] = secondsSince(t0);

  // 5. Anchors proposed on the model, and the accessible surface.
  std::vector<seg::AnchorSet> proposed;
  nlohmann::json uncertainJson;
  if (!o.anchorsOut.empty()) {
    seg::AnchorProposalOptions proposal;
    proposal.zMinMm = zLow;
    proposal.zMaxMm = zHigh;
    proposed = seg::proposeAnchors(surface.mesh, plane, o.slices, proposal);
    if (o.anchorsWhere == "uncertain") {
      // Only the slices where the automatic boundary is uncertain: it touches another bone (the
      // joint) or has little contrast there.
      // One entry per plane: a plane may cut the model in several loops (two condyles), which
      // are one slice to check.
      std::vector<double> positions;
      std::vector<std::size_t> loops;
      for (const auto& set : proposed) {
        if (positions.empty() || std::abs(set.positionMm - positions.back()) > 1e-6) {
          positions.push_back(set.positionMm);
          loops.push_back(0);
        }
        ++loops.back();
      }
      std::vector<std::pair<std::string, const seg::VoxelMask*>> neighbours;
      for (const auto& [name, mask] : neighbourMasks)
        neighbours.emplace_back(name, &mask);
      const std::vector<seg::SliceUncertainty> u =
          seg::sliceUncertainty(volume, region, neighbours, plane, positions);
      std::vector<std::string> touches(u.size());
      uncertainJson = nlohmann::json::array();
      for (std::size_t s = 0; s < u.size(); ++s) {
        nlohmann::json names = nlohmann::json::array();
        for (const auto& n : u[s].neighbours) {
          const std::string shown = n.empty() ? "a bone found automatically" : n;
          names.push_back(shown);
          touches[s] += (touches[s].empty() ? "" : ", ") + shown;
        }
        uncertainJson.push_back({{"position_mm", u[s].positionMm},
                                 {"loops", loops[s]},
                                 {"uncertain", u[s].uncertain},
                                 {"share", u[s].share},
                                 {"contact_share", u[s].contactShare},
                                 {"low_contrast_share", u[s].lowContrastShare},
                                 {"boundary_voxels", u[s].boundaryVoxels},
                                 {"contact_voxels", u[s].contactVoxels},
                                 {"low_contrast_voxels", u[s].lowContrastVoxels},
                                 {"touches", names}});
      }
      std::vector<seg::AnchorSet> kept;
      std::size_t at = 0;  // the plane of proposed[s]
      for (std::size_t s = 0; s < proposed.size(); ++s) {
        while (at + 1 < positions.size() && std::abs(proposed[s].positionMm - positions[at]) > 1e-6)
          ++at;
        if (!u[at].uncertain)
          continue;
        seg::AnchorSet set = proposed[s];
        set.label =
            fmt::format("uncertain {} {:.1f} mm{}", o.plane, set.positionMm,
                        touches[at].empty() ? ": low contrast" : ": touches " + touches[at]);
        kept.push_back(std::move(set));
      }
      proposed = std::move(kept);
      if (proposed.empty()) {
        warnings.push_back(fmt::format(
            "--anchors-where uncertain: none of the {} {} slices is uncertain (the model touches "
            "no other bone and has contrast all round): {} not written",
            o.slices, o.plane, o.anchorsOut));
      }
    }
  }
  std::unique_ptr<seg::AccessibleSurface> accessible;
  if (!o.accessibleOut.empty()) {
    seg::AccessibleSurfaceOptions ao;
    ao.regions = regions;
    for (std::size_t i = 0; i + 2 < o.viewDirections.size(); i += 3) {
      ao.viewDirections.emplace_back(o.viewDirections[i], o.viewDirections[i + 1],
                                     o.viewDirections[i + 2]);
    }
    ao.maxAngleDeg = o.maxAngleDeg;
    try {
      accessible =
          std::make_unique<seg::AccessibleSurface>(seg::accessibleSurface(surface.mesh, ao));
    } catch (const std::invalid_argument& e) {
      throw core::FileError(o.accessibleOut, e.what());
    }
  }

  // 6. Outputs (each written atomically; all the work is done before the first).
  progress("writing", 1.0);
  filters::writeMesh(o.out, surface.mesh);
  if (!o.mask.empty())
    seg::writeNrrdVolume(o.mask, region.geometry, region.voxels);
  if (!o.anchorsOut.empty() && !proposed.empty())
    seg::writeAnchors(o.anchorsOut, proposed);
  if (accessible)
    filters::writeMesh(o.accessibleOut, accessible->mesh);
  progress.done();
  timings["total_s"] = secondsSince(start);

  const Eigen::Vector3d spacing = volume.spacingMm();
  nlohmann::json result = {{"bone", boneName},
                           {"out", o.out},
                           {"ct",
                            {{"folder", o.dicom},
                             {"series_uid", ct.seriesInstanceUid},
                             {"slices", ct.dimensions[2]},
                             {"groups", ct.groups.size()}}},
                           {"group",
                            {{"index", group},
                             {"slices", used.count},
                             {"spacing_mm", vec(spacing)},
                             {"z_first_mm", zFirst},
                             {"z_last_mm", zLast}}},
                           {"mask",
                            {{"voxels", region.count()},
                             {"volume_mm3", static_cast<double>(region.count()) * spacing.prod()}}},
                           {"surface",
                            {{"refined_with_ct", !o.noRefine},
                             {"iso_hu", surface.isoHu},
                             {"cortex_hu", surface.cortexHu},
                             {"soft_tissue_hu", surface.softTissueHu},
                             {"triangles", check.triangles},
                             {"vertices", check.vertices},
                             {"area_mm2", check.areaMm2},
                             {"volume_mm3", check.volumeMm3},
                             {"closed", check.closed()},
                             {"pieces", surface.components},
                             {"dropped_pieces", surface.droppedComponents},
                             {"decimated", surface.decimated}}},
                           {"timings", timings},
                           {"warnings", warnings}};
  result.update(modeJson);
  if (!o.mask.empty())
    result["mask"]["out"] = o.mask;
  if (!o.anchorsOut.empty()) {
    std::size_t anchors = 0;
    for (const auto& s : proposed)
      anchors += s.anchorsLps.size();
    result["anchors_out"] = {{"file", o.anchorsOut},
                             {"contours", proposed.size()},
                             {"anchors", anchors},
                             {"where", o.anchorsWhere},
                             {"written", !proposed.empty()}};
    if (!uncertainJson.is_null())
      result["anchors_out"]["slices"] = uncertainJson;
  }
  if (accessible) {
    result["accessible"] = {{"file", o.accessibleOut},
                            {"triangles", accessible->mesh.triangles.size()},
                            {"area_mm2", accessible->areaMm2},
                            {"fraction_of_area", accessible->fractionOfArea}};
  }
  if (o.json) {
    io.out << result.dump(2) << "\n";
  } else {
    for (const auto& w : warnings)
      io.err << "echoreg segment: note: " << w.get<std::string>() << "\n";
    io.out << fmt::format(
        "{}: {} ({}), {} triangles, {:.0f} mm^3, closed; iso-surface at {:.0f} HU (cortex {:.0f}, "
        "soft tissue "
        "{:.0f}); {:.1f} s\n",
        o.out, boneName,
        o.automatic ? "from the seed"
                    : fmt::format("from {} live-wire contours", anchorSets.size()),
        check.triangles, check.volumeMm3, surface.isoHu, surface.cortexHu, surface.softTissueHu,
        secondsSince(start));
    if (!o.anchorsOut.empty() && !proposed.empty()) {
      io.out << fmt::format(
          "{}: {} contours of proposed anchors on {}{} {} slices\n", o.anchorsOut, proposed.size(),
          o.anchorsWhere == "uncertain" ? "the uncertain of " : "", o.slices, o.plane);
    }
    if (accessible) {
      io.out << fmt::format("{}: accessible surface, {:.0f} mm^2 ({:.0f} % of the model)\n",
                            o.accessibleOut, accessible->areaMm2,
                            100.0 * accessible->fractionOfArea);
    }
  }
  return 0;
}

}  // namespace

CommandAction addSegmentCommand(CLI::App& app) {
  auto o = std::make_shared<SegmentOptions>();
  CLI::App* cmd = app.add_subcommand(
      "segment",
      "Segment one bone of a CT series into a closed surface model in CT patient\n"
      "coordinates (LPS, mm). --anchors: live-wire contours through the anchors of each slice\n"
      "(the dissertation's 40 sagittal slices), filled and interpolated between slices; --auto:\n"
      "the bone grown from --seed (hysteresis threshold, marrow filled; bones touching at a\n"
      "joint grow against each other from their seeds, a watershed of the bone's distance\n"
      "map, neighbours without a seed found automatically). Either region is then refined by the "
      "CT itself: the\n"
      "model is the iso-surface half way between the cortex (the brightest HU within 1.5 mm in\n"
      "the slice, at least the bone's median) and the soft tissue inside a band around the\n"
      "region (sub-voxel; --no-refine keeps the region's own smoothed surface). A series of\n"
      "several slice groups (hip 5 mm / knee 1 mm / ankle 5 mm) is segmented in the group of the\n"
      "seed or of most anchors; the model is closed at that group's ends.");
  cmd->add_option("--dicom", o->dicom, "DICOM series folder")->required();
  cmd->add_option("--series", o->series,
                  "SeriesInstanceUID to read (default: the CT series with most files)");
  cmd->add_option("--bone", o->bone,
                  "Name of the bone: femur, tibia, fibula, patella, tibia+fibula, or any name")
      ->required();
  cmd->add_flag("--with-fibula", o->withFibula,
                "Model the tibia and the fibula as one (same as --bone tibia+fibula)");
  cmd->add_option("--anchors", o->anchors,
                  "Anchors: Slicer .mrk.json closed curves, or echoreg anchors JSON");
  cmd->add_flag("--auto", o->automatic, "Grow the bone from --seed instead of live-wire contours");
  cmd->add_option("--corrections", o->corrections,
                  "--auto: anchors of a few corrected slices (e.g. the --anchors-where uncertain "
                  "file, edited in Slicer): live-wire through them replaces the automatic "
                  "boundary on their slices, fading into it over 3 mm; a curve named "
                  "\"absent...\" encloses an area that is not this bone on its slice (around "
                  "the whole section where the bone should be absent)");
  // 1 to 4 values per --seed so that the help says "[BONE] X Y Z" (CLI11 would print "x 3" for
  // 3 to 4); parseSeeds checks each --seed holds 3 numbers, after a name or not.
  cmd->add_option("--seed", o->seedTokens,
                  "A point inside a bone: [BONE] X Y Z (LPS mm; without BONE, the bone of --bone). "
                  "Repeat for every bone that touches it (femur, tibia, fibula, patella; hip, "
                  "sacrum): they grow against each other and only --bone's seeds make the model")
      ->type_name("[BONE] X Y Z")
      ->expected(1, 4)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--method", o->method,
                  "--auto: watershed (bones compete from their seeds; neighbours without a seed "
                  "found automatically) or erosion (each seed's bone cut off by --separation-mm)")
      ->check(CLI::IsMember({"watershed", "erosion"}))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Model to write (.vtp or .stl)")->required();
  cmd->add_option("--mask", o->mask,
                  "Write the region's mask as NRRD (uint8, LPS geometry; 3D Slicer opens it)");
  cmd->add_option("--plane", o->plane, "Plane of the proposed anchors' slices")
      ->check(CLI::IsMember({"sagittal", "coronal", "axial"}))
      ->capture_default_str();
  cmd->add_option("--slices", o->slices,
                  "Number of slices of proposed anchors, evenly over the bone")
      ->check(wholeNumber(1, 1000))
      ->capture_default_str();
  cmd->add_option(
      "--anchors-out", o->anchorsOut,
      "Write anchors proposed on the model (Slicer .mrk.json closed curves) to edit and feed back "
      "with --anchors");
  cmd->add_option("--anchors-where", o->anchorsWhere,
                  "--anchors-out: on every one of --slices (all), or only on those where the "
                  "automatic boundary is uncertain (uncertain: it touches another bone, the joint, "
                  "or has little contrast), to correct a few slices instead of all")
      ->check(CLI::IsMember({"all", "uncertain"}))
      ->capture_default_str();
  cmd->add_flag("--refuse-metal", o->refuseMetal,
                "--auto watershed: refuse a CT with metal (>= 2500 HU: an implant), naming where "
                "it is, instead of segmenting the bone around it");
  cmd->add_flag("--no-joint-sphere", o->noJointSphere,
                "--auto watershed: never fit a sphere to a ball-and-socket joint (a hip on "
                "thick slices, its acetabular roof along them), neither to the joint line it "
                "shows nor, where none shows (the head pressed into its socket), to the head's "
                "surface: where two seeded bones cannot be told apart, refuse; where they can but "
                "the ball runs across the sphere (slices of 4 mm or more), keep that growth");
  cmd->add_option("--threshold-hu", o->thresholdHu,
                  "Bone threshold STRONG WEAK, HU: voxels >= STRONG, and >= WEAK connected to them "
                  "(default with --method watershed: from this CT's histogram around the seeds, "
                  "at most 600 200; --method erosion and --anchors: 600 200)")
      ->expected(2);
  cmd->add_option("--separation-mm", o->separationMm,
                  "--method erosion: radius of the erosion that separates bones touching at a "
                  "joint, mm, at least 2 voxels (0 = none)")
      ->check(finiteRange(0.0, 10.0))
      ->capture_default_str();
  cmd->add_option("--iso-hu", o->isoHu,
                  "One iso level for the whole surface, HU (default: half way between the "
                  "local cortex and the soft tissue, per voxel)");
  cmd->add_option("--band-mm", o->bandMm,
                  "Band around the region in which the CT decides the surface, mm")
      ->check(finiteRange(0.5, 10.0))
      ->capture_default_str();
  cmd->add_flag("--no-refine", o->noRefine,
                "The region's own surface (smoothed mask), not the CT's iso-surface");
  cmd->add_option("--smoothing", o->smoothing, "Windowed-sinc smoothing iterations (0 = none)")
      ->check(wholeNumber(0, 200))
      ->capture_default_str();
  cmd->add_option("--decimate", o->targetTriangles,
                  "Decimate the model to about this many triangles (0 = keep all)")
      ->check(wholeNumber(0, 100000000));
  cmd->add_option("--accessible-out", o->accessibleOut,
                  "Write the accessible part of the model (.vtp) for the registration");
  cmd->add_option("--keep-regions", o->keepRegions,
                  "Accessible part: points of a Slicer .mrk.json, each keeping the surface within "
                  "--region-radius");
  cmd->add_option("--region-radius", o->regionRadiusMm, "Radius of each kept region, mm")
      ->check(finiteNumber(0.0, false))
      ->capture_default_str();
  cmd->add_option("--view-direction", o->viewDirections,
                  "Accessible part: a direction X Y Z from the bone toward the probe (repeatable); "
                  "keeps the "
                  "triangles facing it within --max-angle-deg with nothing of the bone in front")
      ->expected(3)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--max-angle-deg", o->maxAngleDeg,
                  "Largest angle between a kept triangle's normal and a view direction")
      ->check(finiteRange(1.0, 90.0))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "Print the result as JSON");
  cmd->callback([o] { checkUsage(*o); });
  return [o](const Streams& io) { return runSegment(*o, io); };
}

}  // namespace echoreg::cli
