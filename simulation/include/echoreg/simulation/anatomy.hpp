// The bones of a simulated right knee in CT coordinates (LPS, mm): procedural femur, tibia,
// fibula and patella built from smooth signed-distance primitives with adult male sizes, or a
// user's femur mesh placed in the knee. Landmarks are the ones Mozes (2008, section 4.3) collects
// for the initial point-pair registration (hip centre, epicondyles, malleoli) plus a few more.
#pragma once

#include "echoreg/core/mesh.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace echoreg::simulation {

enum class BoneId { Femur, Tibia, Fibula, Patella };

/// "femur", "tibia", "fibula", "patella".
std::string_view boneName(BoneId id);

/// One bone: its closed outer surface, landmarks, long axis and the internal structure the CT and
/// A-line models need (cortical shell thickness, fatty medullary canal).
struct Bone {
  BoneId id = BoneId::Femur;
  core::TriangleMesh mesh;  ///< CT coordinates, closed, wound outward
  /// CT coordinates. Femur: hip_centre (head centre), greater_trochanter (its most lateral
  /// point), lesser_trochanter (most posteromedial point), medial_epicondyle,
  /// lateral_epicondyle (most medial/lateral points of the distal femur), knee_centre (notch
  /// centre at the joint, 1 mm below the condyles), medial_condyle_distal,
  /// lateral_condyle_distal (lowest points). Tibia: plateau_centre, tibial_tubercle,
  /// medial_malleolus, ankle_centre. Fibula: fibular_head, lateral_malleolus. Patella:
  /// patella_centre.
  std::map<std::string, Eigen::Vector3d> landmarks;
  Eigen::Vector3d axisProximal = Eigen::Vector3d::Zero();  ///< proximal end of the long axis (CT)
  Eigen::Vector3d axisDistal = Eigen::Vector3d::Zero();    ///< distal end of the long axis (CT)
  /// Cortical thickness in the diaphysis (mm); it thins to kEndCorticalMm at the bone's ends.
  double diaphysisCorticalMm = 1.0;
  /// Smallest distance from the axis to the surface in equal bins along the axis, from
  /// axisDistal (first) to axisProximal (last): the room the medullary canal has.
  std::vector<double> inscribedRadiusMm;

  /// Cortical thickness at the bone's ends (epiphyses, patella), mm.
  static constexpr double kEndCorticalMm = 1.0;

  /// Cortical thickness (mm) for a point inside the bone, from its position along the axis:
  /// thick in the diaphysis (femur ~5.5, tibia ~4.5, fibula ~2 mm), thinning to ~1 mm at the ends.
  double corticalThicknessMm(const Eigen::Vector3d& pointCt) const;
  /// Radius of the fatty medullary canal at the point's axial position, 0 in the metaphyses and
  /// epiphyses (cancellous bone there). Always leaves at least the cortical thickness (plus
  /// 1 mm) between the canal and the surface.
  double medullaryRadiusMm(const Eigen::Vector3d& pointCt) const;
  /// Distance of the point from the axis line (for comparing with medullaryRadiusMm).
  double distanceFromAxisMm(const Eigen::Vector3d& pointCt) const;
  /// Position along the axis: 0 at axisDistal, 1 at axisProximal (not clamped).
  double axialFraction(const Eigen::Vector3d& pointCt) const;
};

struct KneeOptions {
  /// Tibia, fibula (and patella, following rigidly) rotated about the transepicondylar axis;
  /// 0 = straight leg, positive = flexion (the ankle moves posterior). Allowed 0 to 90 (a
  /// rotation without roll-back: beyond ~95 degrees the plateau would meet the condyles).
  double flexionDeg = 0.0;
  double meshResolutionMm = 1.0;  ///< marching grid spacing for procedural bones, 0.2 to 5 mm
  /// Small shape variation (lengths and widths within +-4 %), so that another seed gives another
  /// specimen; seed 0 = the mean shape.
  std::uint64_t seed = 1;
  /// A user mesh replaces the procedural bone. Only the femur is supported (.stl, .vtp, .ply,
  /// .obj in mm, closed; a left femur is mirrored to a right one). It is placed rigidly with its
  /// knee centre on kKneeCentreCt, its hip centre (sphere fit to the head) straight above and its
  /// epicondylar axis along +x; the knee's hip-knee length is then the mesh's own.
  std::map<BoneId, std::string> meshFiles;
  /// The narrowest gap between femur and tibia (the joint space an arthritic knee narrows), mm:
  /// the tibia and fibula move along the mechanical axis until their nearest vertex is this far
  /// from the femur's surface (0: touching). Negative keeps the healthy joint (about 3 mm).
  double tibiofemoralGapMm = -1.0;
  /// The narrowest gap between patella and trochlea, mm (0: touching); 0 to 10.
  double patellofemoralGapMm = 4.0;
  /// Marginal osteophytes of an arthritic knee, mm (0: none; at most 8): bony ridges along the
  /// medial and lateral margins of the tibiofemoral joint, where the joint space opens into a
  /// wedge between the rounded condyles and the flat plateau. One ridge rises from each side of
  /// the tibial plateau (centred on its rim's level, 9 widths outside the condyle's centre line)
  /// and one hangs from each femoral condyle's underside above it, each of this radius, along
  /// the front-to-back middle of the compartment; each is cut back to kOsteophyteClearanceMm
  /// from the other bone, so the spurs bridge the joint's margin (they touch through less than
  /// a voxel of soft tissue). Added after the joint is narrowed (tibiofemoralGapMm); needs the
  /// procedural femur.
  double osteophyteMm = 0.0;
};

/// What the osteophytes leave between femur and tibia at the joint's margins, mm.
inline constexpr double kOsteophyteClearanceMm = 0.5;

/// The four bones of a right leg, supine: medial +x, anterior -y, proximal +z.
struct Knee {
  std::vector<Bone> bones;  ///< femur, tibia, fibula, patella in that order
  /// The bone with that id (throws std::out_of_range when absent).
  const Bone& bone(BoneId id) const;
  Eigen::Vector3d hipCentre = Eigen::Vector3d::Zero();    ///< CT
  Eigen::Vector3d kneeCentre = Eigen::Vector3d::Zero();   ///< CT, (-95, 20, -480)
  Eigen::Vector3d ankleCentre = Eigen::Vector3d::Zero();  ///< CT (moves with flexion)
  Eigen::Vector3d medialCt = Eigen::Vector3d::UnitX();    ///< unit medial direction of the knee
  /// Unit anterior direction of the knee: -y when straight; in flexion the bisector of the femur's
  /// and the tibia's anterior directions (where the front of the knee faces).
  Eigen::Vector3d anteriorCt = -Eigen::Vector3d::UnitY();
};

/// Where the knee centre lies in CT (mm).
inline const Eigen::Vector3d kKneeCentreCt{-95.0, 20.0, -480.0};

/// Builds the bones. Throws std::invalid_argument naming a bad option, FileError naming a mesh
/// file that cannot be read, is not closed, or does not look like a femur.
Knee buildKnee(const KneeOptions& options);

}  // namespace echoreg::simulation
