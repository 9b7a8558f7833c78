#include "echoreg/simulation/anatomy.hpp"

#include "anatomy_detail.hpp"
#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/core/random.hpp"
#include "echoreg/simulation/sdf.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

// Sizes of an adult male knee (mean shape, seed 0). Sources:
//  - femur hip-centre-to-knee-centre (mechanical) length ~440 mm, anatomical-mechanical angle 6
//    degrees: Moreland, Bassett & Hanker 1987 (J Bone Joint Surg Am 69:745); Paley 2002,
//    "Principles of Deformity Correction" (mLDFA/aLDFA, mMPTA).
//  - femoral head radius ~23-24 mm in men, neck-shaft angle ~128, anteversion ~12 degrees,
//    femoral offset ~41-46 mm: Noble et al. 1988 (Clin Orthop 235:148); Yoshioka, Siu & Cooke
//    1987 (J Bone Joint Surg Am 69:873).
//  - mid-shaft femoral diameter 27-30 mm, cortex 5-7 mm, canal isthmus 11-16 mm: Noble 1988.
//  - bicondylar (epicondylar) width ~85 mm, distal femur AP depth ~60 mm, trochlear groove
//    ~5 mm deep: Mahfouz et al. 2012 (Clin Orthop 470:172); Yoshioka, Siu, Cooke 1987.
//  - tibial plateau ~78 mm wide, ~50 mm deep, posterior slope 3-7 degrees; tibial length
//    370-380 mm; tubercle 25-30 mm below the plateau: Mahfouz 2012; Yoshioka 1989 (J Orthop Res
//    7:132); Gray's Anatomy 41st ed.
//  - fibula head 10-15 mm below the lateral plateau, shaft 12-15 mm, lateral malleolus ~1 cm
//    more distal than the medial one: Gray's Anatomy 41st ed.; Sarrafian, "Anatomy of the Foot
//    and Ankle".
//  - patella ~45 x 45 x 22 mm: Baldwin & House 2005 (Clin Orthop 440:204, male means).
//  - tibiofemoral joint space 3-6 mm (cartilage 2-3 mm on each side): Shepherd & Seedhom 1999
//    (Ann Rheum Dis 58:27).
//  - cortical thickness femur 5-6, tibia 4-5, fibula ~2 mm at the diaphysis, ~1 mm subchondral
//    shells: Treece et al. 2010 (Med Image Anal 14:276).

namespace echoreg::simulation {

using Eigen::Vector3d;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Mean dimensions (mm, degrees).
constexpr double kHipKneeMm = 440.0;
constexpr double kHeadRadiusMm = 23.0;
constexpr double kNeckShaftDeg = 128.0;
constexpr double kAnteversionDeg = 12.0;
constexpr double kValgusDeg = 6.0;  // femoral shaft to the mechanical axis
constexpr double kShaftRadiusMm = 14.0;
constexpr double kShaftAnteriorMm = 12.0;  // femoral shaft axis in front of the notch at the joint
constexpr double kTibiaPlateauToPlafondMm = 362.0;
constexpr double kCondyleAboveKneeMm = 1.0;  // distal condyles above the knee centre
constexpr double kPlateauBelowKneeMm = 2.0;  // tibial plateau below the knee centre
constexpr double kTibiofibularGapMm = 0.8;   // cartilage gap of both tibiofibular joints
constexpr double kFemurCorticalMm = 5.5;
// The tibia turns about the transepicondylar axis without rolling back; past ~95 degrees its
// posterior plateau would run into the posterior condyles, and in hyperextension the rigidly
// following patella into the femur.
constexpr double kMaxFlexionDeg = 90.0;
constexpr double kTibiaCorticalMm = 4.5;
constexpr double kFibulaCorticalMm = 2.0;

/// Size factors of one specimen (1 = the mean shape).
struct Specimen {
  double femurLength = 1.0;
  double femurWidth = 1.0;
  double tibiaLength = 1.0;
  double tibiaWidth = 1.0;
};

Specimen drawSpecimen(std::uint64_t seed) {
  Specimen s;
  if (seed == 0)
    return s;
  core::Rng rng = core::Rng::derive(seed, "anatomy/specimen");
  // A common size and a small independent part, together within +-4 %.
  const double size = rng.uniform(-0.025, 0.025);
  auto factor = [&rng, size] {
    return 1.0 + std::clamp(size + rng.uniform(-0.015, 0.015), -0.04, 0.04);
  };
  s.femurLength = factor();
  s.femurWidth = factor();
  s.tibiaLength = factor();
  s.tibiaWidth = factor();
  return s;
}

Eigen::Matrix3d rotationZTo(const Vector3d& zAxis, const Vector3d& xHint) {
  const Vector3d z = zAxis.normalized();
  const Vector3d x = (xHint - xHint.dot(z) * z).normalized();
  Eigen::Matrix3d frame;
  frame.col(0) = x;
  frame.col(1) = z.cross(x);
  frame.col(2) = z;
  return frame;
}

/// The femur in knee-local coordinates (origin at the knee centre, CT axes).
struct FemurModel {
  sdf::Field field;
  Vector3d hip;                                  // head centre
  Vector3d shaftFoot;                            // where the shaft axis meets the joint level
  Vector3d shaftDirection;                       // proximal, unit
  Vector3d medialEpicondyle, lateralEpicondyle;  // inside points from which landmark rays start
  Eigen::AlignedBox3d searchBox;
};

FemurModel femurModel(const Specimen& s) {
  const double w = s.femurWidth;
  const double length = kHipKneeMm * s.femurLength;
  const double beta = (180.0 - kNeckShaftDeg) * kDeg;  // neck to the proximal shaft direction
  const double anteversion = kAnteversionDeg * kDeg;
  // The shaft axis meets the joint level in front of the notch, so that the condyles bulge
  // behind the shaft and the trochlea lines up with the anterior cortex.
  const Vector3d shaftFoot(0.0, -kShaftAnteriorMm * w, 0.0);
  const Vector3d hip(0.0, 0.0, length);
  const double footToHip = (hip - shaftFoot).norm();
  // Shaft frame F (origin at shaftFoot): z along the shaft, x medial, y posterior. The head
  // centre sits at the femoral offset from the shaft axis, on a neck at the neck-shaft angle,
  // turned anteriorly by the anteversion; the offset is chosen so that the shaft is at the valgus
  // angle to the line to the hip.
  const double offset = footToHip * std::sin(kValgusDeg * kDeg);
  const double neckLength = offset / std::sin(beta);
  const double neckBaseZ =
      std::sqrt(footToHip * footToHip - offset * offset) - neckLength * std::cos(beta);
  const Vector3d neckDirF = (std::cos(beta) * Vector3d::UnitZ() +
                             std::sin(beta) * (std::cos(anteversion) * Vector3d::UnitX() -
                                               std::sin(anteversion) * Vector3d::UnitY()))
                                .normalized();
  const Vector3d neckBaseF(0.0, 0.0, neckBaseZ);
  const Vector3d hipF = neckBaseF + neckLength * neckDirF;
  // Rotation from F to the knee frame: F's hip direction onto the foot-to-hip line, F's x kept in
  // the plane of that line and the knee's x.
  const Eigen::Matrix3d toKnee = rotationZTo(hip - shaftFoot, Vector3d::UnitX()) *
                                 rotationZTo(hipF, Vector3d::UnitX()).transpose();
  const Eigen::Matrix3d toShaft = toKnee.transpose();

  const double headRadius = kHeadRadiusMm * w;
  const double r = kShaftRadiusMm * w;
  const Vector3d gtCentreF(-14.0 * w, 6.0 * w, neckBaseZ + 8.0 * w);
  const Vector3d ltCentreF(9.0 * w, 11.0 * w, neckBaseZ - 38.0 * w);
  const Vector3d neckEndF = hipF - 8.0 * w * neckDirF;

  // Distal femur, directly in the knee frame (the joint line is square to the mechanical axis).
  const Vector3d condyleRadii = Vector3d(14.5, 25.0, 23.5) * w;
  const double condyleZ = kCondyleAboveKneeMm + condyleRadii.z();
  const Vector3d medialCondyle(22.0 * w, -2.0 * w, condyleZ);
  const Vector3d lateralCondyle(-22.0 * w, -2.0 * w, condyleZ);
  const Vector3d metaphysis(0.0, 0.0, 62.0 * w);
  const Vector3d medialEpi(34.5 * w, 0.0, 25.0 * w);
  const Vector3d lateralEpi(-33.5 * w, 0.0, 25.0 * w);
  const Vector3d lateralFacet(-13.0 * w, -8.0 * w, 30.0 * w);
  const Vector3d medialFacet(13.0 * w, -7.0 * w, 28.0 * w);
  const Vector3d grooveA(-2.0 * w, -35.0 * w, 10.0 * w);
  const Vector3d grooveB(-2.0 * w, -33.0 * w, 60.0 * w);

  FemurModel model;
  model.field = [=](const Vector3d& p) {
    // Distal: two condyles, trochlear facets with the groove between, metaphysis, epicondyles.
    double distal = sdf::smoothUnion(sdf::ellipsoid(p, medialCondyle, condyleRadii),
                                     sdf::ellipsoid(p, lateralCondyle, condyleRadii), 2.0 * w);
    const double facets =
        sdf::smoothUnion(sdf::ellipsoid(p, lateralFacet, Vector3d(14.0, 22.0, 22.0) * w),
                         sdf::ellipsoid(p, medialFacet, Vector3d(13.0, 20.0, 20.0) * w), 4.0 * w);
    distal = sdf::smoothUnion(distal, facets, 6.0 * w);
    distal = sdf::smoothUnion(distal, sdf::ellipsoid(p, metaphysis, Vector3d(33.0, 24.0, 42.0) * w),
                              10.0 * w);
    const double epicondyles =
        std::min(sdf::sphere(p, medialEpi, 8.5 * w), sdf::sphere(p, lateralEpi, 8.0 * w));
    distal = sdf::smoothUnion(distal, epicondyles, 6.0 * w);
    distal = sdf::smoothSubtraction(distal, sdf::capsule(p, grooveA, grooveB, 10.0 * w), 4.0 * w);

    // Shaft and proximal femur in the shaft frame.
    const Vector3d q = toShaft * (p - shaftFoot);
    const double z1 = 0.30 * length;
    const double z2 = 0.70 * length;
    double shaft = sdf::roundCone(q, Vector3d(0, 0, 50.0 * w), Vector3d(0, 0, z1), 16.0 * w, r);
    shaft = std::min(shaft, sdf::roundCone(q, Vector3d(0, 0, z1), Vector3d(0, 0, z2), r, 1.04 * r));
    shaft = sdf::smoothUnion(
        shaft, sdf::roundCone(q, Vector3d(0, 0, z2), neckBaseF, 1.04 * r, 17.0 * w), 4.0 * w);
    // Linea aspera: a low posterior ridge along the middle of the shaft.
    shaft = sdf::smoothUnion(shaft,
                             sdf::capsule(q, Vector3d(0, 12.5 * w, 0.3 * length),
                                          Vector3d(0, 13.0 * w, 0.72 * length), 3.5 * w),
                             4.0 * w);
    double proximal = sdf::roundCone(q, neckBaseF, neckEndF, 18.0 * w, 14.0 * w);
    proximal = sdf::smoothUnion(proximal, sdf::sphere(q, hipF, headRadius), 5.0 * w);
    proximal = sdf::smoothUnion(
        proximal, sdf::ellipsoid(q, gtCentreF, Vector3d(13.0, 17.0, 24.0) * w), 8.0 * w);
    shaft = sdf::smoothUnion(shaft, proximal, 12.0 * w);
    shaft = sdf::smoothUnion(shaft, sdf::sphere(q, ltCentreF, 7.0 * w), 5.0 * w);
    return sdf::smoothUnion(distal, shaft, 15.0 * w);
  };
  model.hip = shaftFoot + toKnee * hipF;
  model.shaftFoot = shaftFoot;
  model.shaftDirection = toKnee * Vector3d::UnitZ();
  model.medialEpicondyle = medialEpi;
  model.lateralEpicondyle = lateralEpi;
  model.searchBox = Eigen::AlignedBox3d(Vector3d(-110, -90, -30), Vector3d(110, 90, length + 80));
  return model;
}

/// The tibia in knee-local coordinates.
struct TibiaModel {
  sdf::Field field;
  Vector3d plateauCentre, ankle, tubercle, medialMalleolus;
  Eigen::AlignedBox3d searchBox;
};

TibiaModel tibiaModel(const Specimen& s) {
  const double w = s.tibiaWidth;
  const double length = kTibiaPlateauToPlafondMm * s.tibiaLength;
  const double top = -kPlateauBelowKneeMm;
  const double ankleZ = top - length;
  auto at = [top, length](double fraction) { return top - fraction * length; };
  const double slope = 4.0 * kDeg;  // posterior slope of the plateau
  const Vector3d plateauCentre(0.0, 3.0 * w, top);
  const Vector3d plateauNormal(0.0, std::sin(slope), std::cos(slope));
  const Vector3d condyles(0.0, 3.0 * w, top);
  // Shallow dishes under the femoral condyles (their lowest points at y = -2 w).
  constexpr double kDishRadius = 45.0;
  constexpr double kDishDepth = 1.5;
  auto plateauZ = [&](double y) { return top - std::tan(slope) * (y - plateauCentre.y()); };
  const Vector3d medialDish(22.0 * w, -2.0 * w, plateauZ(-2.0 * w) - kDishDepth + kDishRadius);
  const Vector3d lateralDish(-22.0 * w, -2.0 * w, plateauZ(-2.0 * w) - kDishDepth + kDishRadius);
  const Vector3d eminence(0.0, 1.0 * w, top - 5.0 * w);
  const Vector3d tubercle(-4.0 * w, -19.0 * w, top - 28.0 * w);
  const Vector3d medialMalleolus(18.0 * w, 3.0 * w, ankleZ + 2.0 * w);
  const Vector3d ankle(0.0, 0.0, ankleZ);

  TibiaModel model;
  model.field = [=](const Vector3d& p) {
    double head =
        sdf::smoothIntersection(sdf::ellipsoid(p, condyles, Vector3d(39.0, 25.0, 42.0) * w),
                                sdf::halfSpace(p, plateauCentre, plateauNormal), 3.0 * w);
    head = sdf::smoothSubtraction(head, sdf::sphere(p, medialDish, kDishRadius), 2.0);
    head = sdf::smoothSubtraction(head, sdf::sphere(p, lateralDish, kDishRadius), 2.0);
    head =
        sdf::smoothUnion(head, sdf::ellipsoid(p, eminence, Vector3d(8.0, 12.0, 6.0) * w), 3.0 * w);
    head =
        sdf::smoothUnion(head, sdf::ellipsoid(p, tubercle, Vector3d(10.0, 7.0, 14.0) * w), 6.0 * w);
    // Proximal metaphysis tapering into a triangular shaft: a core with the anterior crest, the
    // medial border and the interosseous (lateral) border.
    const double taper = sdf::roundCone(p, Vector3d(0, 3.0 * w, top - 23.0 * w),
                                        Vector3d(0, 1.0 * w, at(0.30)), 22.0 * w, 11.0 * w);
    double shaft = sdf::roundCone(p, Vector3d(0, 1.0 * w, at(0.18)), Vector3d(0, 1.0 * w, at(0.86)),
                                  10.0 * w, 9.5 * w);
    shaft = sdf::smoothUnion(
        shaft,
        sdf::capsule(p, Vector3d(0, -11.5 * w, at(0.13)), Vector3d(0, -8.0 * w, at(0.80)), 2.5 * w),
        8.0 * w);
    shaft = sdf::smoothUnion(shaft,
                             sdf::capsule(p, Vector3d(10.0 * w, 6.0 * w, at(0.18)),
                                          Vector3d(9.0 * w, 5.0 * w, at(0.85)), 3.0 * w),
                             8.0 * w);
    shaft = sdf::smoothUnion(shaft,
                             sdf::capsule(p, Vector3d(-10.0 * w, 4.0 * w, at(0.18)),
                                          Vector3d(-9.0 * w, 3.0 * w, at(0.85)), 2.5 * w),
                             8.0 * w);
    const double flare = sdf::roundCone(p, Vector3d(0, 1.0 * w, at(0.75)),
                                        Vector3d(0, 0.0, ankleZ + 18.0 * w), 10.0 * w, 18.0 * w);
    const double plafond = sdf::smoothIntersection(
        sdf::ellipsoid(p, Vector3d(0, 0, ankleZ + 14.0 * w), Vector3d(23.0, 19.0, 22.0) * w),
        sdf::halfSpace(p, ankle, -Vector3d::UnitZ()), 2.0 * w);
    double distal = sdf::smoothUnion(flare, plafond, 10.0 * w);
    distal = sdf::smoothUnion(
        distal, sdf::ellipsoid(p, medialMalleolus, Vector3d(7.0, 11.0, 14.0) * w), 5.0 * w);
    double bone = sdf::smoothUnion(head, taper, 12.0 * w);
    bone = sdf::smoothUnion(bone, shaft, 12.0 * w);
    return sdf::smoothUnion(bone, distal, 12.0 * w);
  };
  model.plateauCentre = plateauCentre;
  model.ankle = ankle;
  model.tubercle = tubercle;
  model.medialMalleolus = medialMalleolus;
  model.searchBox =
      Eigen::AlignedBox3d(Vector3d(-80, -70, ankleZ - 50.0), Vector3d(80, 70, top + 30.0));
  return model;
}

/// Moves `start` along the horizontal direction `direction` until `field` reads `distanceMm`
/// (the first such point outside the solid, by bisection).
Vector3d placeAtDistance(const sdf::Field& field, const Vector3d& start, const Vector3d& direction,
                         double distanceMm) {
  const Vector3d d = direction.normalized();
  double low = 0.0;
  double high = -1.0;
  for (double t = 0.0; t <= 200.0; t += 0.5) {
    if (field(start + t * d) >= distanceMm) {
      high = t;
      break;
    }
    low = t;
  }
  if (high < 0.0)
    throw std::logic_error("anatomy: could not place a bone beside the tibia");
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (low + high);
    (field(start + mid * d) < distanceMm ? low : high) = mid;
  }
  return start + 0.5 * (low + high) * d;
}

/// The fibula in knee-local coordinates, touching the tibia at both tibiofibular joints.
struct FibulaModel {
  sdf::Field field;
  Vector3d head, distal, malleolus;
  Eigen::AlignedBox3d searchBox;
};

FibulaModel fibulaModel(const Specimen& s, const TibiaModel& tibia) {
  const double w = s.tibiaWidth;
  const double headRadius = 12.0 * w;
  // Head: posterolateral, its top ~12 mm below the lateral plateau.
  const double headZ = tibia.plateauCentre.z() - 12.0 * w - headRadius;
  const Vector3d head =
      placeAtDistance(tibia.field, Vector3d(0.0, tibia.plateauCentre.y(), headZ),
                      Vector3d(-0.72, 0.69, 0.0), headRadius + kTibiofibularGapMm);
  // Distal: in the fibular notch of the tibia just above the plafond.
  const double shaftEndRadius = 7.5 * w;
  const Vector3d distal =
      placeAtDistance(tibia.field, Vector3d(0.0, 0.0, tibia.ankle.z() + 14.0 * w),
                      Vector3d(-1.0, 0.35, 0.0), shaftEndRadius + kTibiofibularGapMm);
  const Vector3d middle = 0.5 * (head + distal);
  // Lateral malleolus: its tip ~10 mm below the medial malleolus' tip.
  const Vector3d malleolusRadii = Vector3d(7.5, 11.0, 20.0) * w;
  const Vector3d malleolus = distal + Vector3d(0.0, 1.5 * w, -16.0 * w);

  FibulaModel model;
  model.field = [=](const Vector3d& p) {
    double bone = sdf::ellipsoid(p, head, Vector3d(headRadius, headRadius, 13.0 * w));
    bone = sdf::smoothUnion(bone, sdf::roundCone(p, head, middle, 8.0 * w, 6.5 * w), 6.0 * w);
    bone =
        sdf::smoothUnion(bone, sdf::roundCone(p, middle, distal, 6.5 * w, shaftEndRadius), 4.0 * w);
    return sdf::smoothUnion(bone, sdf::ellipsoid(p, malleolus, malleolusRadii), 5.0 * w);
  };
  model.head = head;
  model.distal = distal;
  model.malleolus = malleolus;
  const Vector3d low = head.cwiseMin(malleolus) - Vector3d::Constant(45.0);
  const Vector3d high = head.cwiseMax(malleolus) + Vector3d::Constant(45.0);
  model.searchBox = Eigen::AlignedBox3d(low, high);
  return model;
}

Bone meshedBone(BoneId id, const sdf::Field& field, const Eigen::AlignedBox3d& searchBox,
                double resolutionMm) {
  const Eigen::AlignedBox3d box = sdf::solidBounds(field, searchBox, 4.0, 3.0);
  Bone bone;
  bone.id = id;
  bone.mesh = sdf::meshField(field, box, resolutionMm, std::string(boneName(id)));
  return bone;
}

void translate(Bone& bone, const Vector3d& offset) {
  for (Vector3d& v : bone.mesh.vertices)
    v += offset;
  for (auto& entry : bone.landmarks)
    entry.second += offset;
  bone.axisProximal += offset;
  bone.axisDistal += offset;
}

void transformBone(Bone& bone, const Eigen::Isometry3d& motion) {
  bone.mesh = core::transformed(bone.mesh, motion);
  for (auto& entry : bone.landmarks)
    entry.second = motion * entry.second;
  bone.axisProximal = motion * bone.axisProximal;
  bone.axisDistal = motion * bone.axisDistal;
}

/// The patella: an ellipsoid in front of the trochlea, pushed back until it is
/// `gapMm` (KneeOptions::patellofemoralGapMm: 4 mm of cartilage of patella and trochlea by
/// default) from the femur's surface (its vertices, knee-local).
Bone patellaBone(const Specimen& s, const core::TriangleMesh& femurLocal, double resolutionMm,
                 double gapMm) {
  const double w = s.femurWidth;
  const Vector3d radii = Vector3d(22.5, 11.0, 22.5) * w;
  const double x = -3.0 * w;
  const double z = 42.0 * w;
  std::vector<Vector3d> near;
  for (const Vector3d& v : femurLocal.vertices) {
    if (std::abs(v.x() - x) < radii.x() + 10.0 && std::abs(v.z() - z) < radii.z() + 10.0) {
      near.push_back(v);
    }
  }
  auto gap = [&](double y) {
    double best = std::numeric_limits<double>::infinity();
    for (const Vector3d& v : near)
      best = std::min(best, sdf::ellipsoid(v, Vector3d(x, y, z), radii));
    return best;
  };
  double anterior = -150.0;  // far in front: large gap
  double posterior = 0.0;    // inside the femur
  if (near.empty() || gap(anterior) < gapMm) {
    throw std::logic_error("anatomy: no trochlea found in front of which to place the patella");
  }
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (anterior + posterior);
    (gap(mid) >= gapMm ? anterior : posterior) = mid;
  }
  const Vector3d centre(x, anterior, z);
  const sdf::Field field = [=](const Vector3d& p) { return sdf::ellipsoid(p, centre, radii); };
  Bone bone = meshedBone(BoneId::Patella, field,
                         Eigen::AlignedBox3d(centre - radii - Vector3d::Constant(10.0),
                                             centre + radii + Vector3d::Constant(10.0)),
                         resolutionMm);
  bone.landmarks["patella_centre"] = centre;
  bone.diaphysisCorticalMm = Bone::kEndCorticalMm;
  bone.axisDistal = centre - radii.z() * Vector3d::UnitZ();
  bone.axisProximal = centre + radii.z() * Vector3d::UnitZ();
  return bone;  // no medullary canal: profile left empty
}

void validate(const KneeOptions& options) {
  if (!std::isfinite(options.flexionDeg) || options.flexionDeg < 0.0 ||
      options.flexionDeg > kMaxFlexionDeg) {
    throw std::invalid_argument("flexionDeg must be within 0 to 90 degrees, got " +
                                std::to_string(options.flexionDeg));
  }
  if (!std::isfinite(options.meshResolutionMm) || options.meshResolutionMm < 0.2 ||
      options.meshResolutionMm > 5.0) {
    throw std::invalid_argument("meshResolutionMm must be within 0.2 to 5 mm, got " +
                                std::to_string(options.meshResolutionMm));
  }
  for (const auto& [id, path] : options.meshFiles) {
    if (id != BoneId::Femur) {
      throw std::invalid_argument("meshFiles: a " + std::string(boneName(id)) +
                                  " mesh cannot replace the procedural bone (only a femur mesh "
                                  "is supported)");
    }
    if (path.empty())
      throw std::invalid_argument("meshFiles: the femur mesh path is empty");
  }
  if (!std::isfinite(options.tibiofemoralGapMm) || options.tibiofemoralGapMm > 10.0) {
    throw std::invalid_argument(
        "tibiofemoralGapMm must be at most 10 mm (negative: the healthy "
        "joint), got " +
        std::to_string(options.tibiofemoralGapMm));
  }
  if (!std::isfinite(options.osteophyteMm) || options.osteophyteMm < 0.0 ||
      options.osteophyteMm > 8.0) {
    throw std::invalid_argument("osteophyteMm must be within 0 to 8 mm, got " +
                                std::to_string(options.osteophyteMm));
  }
  if (options.osteophyteMm > 0.0 && options.meshFiles.count(BoneId::Femur) != 0) {
    throw std::invalid_argument(
        "osteophyteMm needs the procedural femur (the osteophytes are grown on its shape), not "
        "the femur mesh " +
        options.meshFiles.at(BoneId::Femur));
  }
  if (!std::isfinite(options.patellofemoralGapMm) || options.patellofemoralGapMm < 0.0 ||
      options.patellofemoralGapMm > 10.0) {
    throw std::invalid_argument("patellofemoralGapMm must be within 0 to 10 mm, got " +
                                std::to_string(options.patellofemoralGapMm));
  }
}

// The smallest distance from the tibia's vertices near the joint to the femur's surface.
double tibiofemoralGap(const core::MeshLocator& femur, const core::TriangleMesh& tibia,
                       double jointZ) {
  double best = std::numeric_limits<double>::infinity();
  for (const Vector3d& v : tibia.vertices) {
    if (v.z() > jointZ - 25.0)
      best = std::min(best, femur.closest(v).distance);
  }
  return best;
}

/// Marginal osteophytes (KneeOptions::osteophyteMm) on the placed femur and tibia: their fields
/// in knee-local coordinates (the tibia's shifted by `tibiaShiftMm`, its move when the joint was
/// narrowed), each joined smoothly with its ridges, the femur's cut back from the tibia, then
/// the tibia's from the new femur, and both meshed again (the bones' landmarks and profiles stay:
/// the ridges lie at the joint's margins only).
void addOsteophytes(double radiusMm, const Specimen& s, const sdf::Field& femurField,
                    const Eigen::AlignedBox3d& femurBox, const TibiaModel& tibiaShape,
                    const Vector3d& tibiaShiftMm, double resolutionMm, Bone& femur, Bone& tibia) {
  const double wf = s.femurWidth, wt = s.tibiaWidth;
  const double plateauZ = -kPlateauBelowKneeMm + tibiaShiftMm.z();
  const sdf::Field tibiaField = [=](const Vector3d& p) {
    return tibiaShape.field(p - tibiaShiftMm);
  };
  std::vector<std::pair<Vector3d, Vector3d>> tibialRidges, femoralRidges;
  for (double side : {1.0, -1.0}) {
    const double xt = side * 31.0 * wt, xf = side * 31.0 * wf;
    tibialRidges.emplace_back(Vector3d(xt, -12.0 * wt, plateauZ), Vector3d(xt, 8.0 * wt, plateauZ));
    // The condyle's underside above the margin: from inside it, straight down.
    const Vector3d under =
        sdf::rayExit(femurField, Vector3d(xf, -2.0 * wf, 15.0 * wf), -Vector3d::UnitZ());
    femoralRidges.emplace_back(Vector3d(xf, -14.0 * wf, under.z()),
                               Vector3d(xf, 6.0 * wf, under.z()));
  }
  auto ridges = [radiusMm](const std::vector<std::pair<Vector3d, Vector3d>>& r, const Vector3d& p) {
    double d = std::numeric_limits<double>::infinity();
    for (const auto& [a, b] : r)
      d = std::min(d, sdf::capsule(p, a, b, radiusMm));
    return d;
  };
  const sdf::Field femurWithRidges = [=](const Vector3d& p) {
    const double bone = sdf::smoothUnion(femurField(p), ridges(femoralRidges, p), 2.0);
    return std::max(bone, kOsteophyteClearanceMm - tibiaField(p));
  };
  const sdf::Field tibiaWithRidges = [=](const Vector3d& p) {
    const double bone = sdf::smoothUnion(tibiaField(p), ridges(tibialRidges, p), 2.0);
    return std::max(bone, kOsteophyteClearanceMm - femurWithRidges(p));
  };
  const Vector3d knee = kKneeCentreCt;
  femur.mesh =
      core::transformed(meshedBone(BoneId::Femur, femurWithRidges, femurBox, resolutionMm).mesh,
                        Eigen::Isometry3d(Eigen::Translation3d(knee)));
  const Eigen::AlignedBox3d tibiaBox(tibiaShape.searchBox.min() + tibiaShiftMm,
                                     tibiaShape.searchBox.max() + tibiaShiftMm);
  tibia.mesh =
      core::transformed(meshedBone(BoneId::Tibia, tibiaWithRidges, tibiaBox, resolutionMm).mesh,
                        Eigen::Isometry3d(Eigen::Translation3d(knee)));
}

}  // namespace

namespace detail {

double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

void setAxisProfile(Bone& bone, const Vector3d& axisPoint, const Vector3d& proximalDirection) {
  const Vector3d d = proximalDirection.normalized();
  double low = std::numeric_limits<double>::infinity();
  double high = -low;
  for (const Vector3d& v : bone.mesh.vertices) {
    const double t = (v - axisPoint).dot(d);
    low = std::min(low, t);
    high = std::max(high, t);
  }
  bone.axisDistal = axisPoint + low * d;
  bone.axisProximal = axisPoint + high * d;
  constexpr std::size_t kBins = 100;
  bone.inscribedRadiusMm.assign(kBins, std::numeric_limits<double>::infinity());
  for (const Vector3d& v : bone.mesh.vertices) {
    const double t = (v - axisPoint).dot(d);
    const double u = (t - low) / (high - low);
    const std::size_t bin = std::min(
        kBins - 1, static_cast<std::size_t>(std::max(0.0, u) * static_cast<double>(kBins)));
    const double radial = (v - axisPoint - t * d).norm();
    bone.inscribedRadiusMm[bin] = std::min(bone.inscribedRadiusMm[bin], radial);
  }
  for (double& r : bone.inscribedRadiusMm) {
    if (!std::isfinite(r))
      r = 0.0;
  }
}

}  // namespace detail

std::string_view boneName(BoneId id) {
  switch (id) {
    case BoneId::Femur:
      return "femur";
    case BoneId::Tibia:
      return "tibia";
    case BoneId::Fibula:
      return "fibula";
    case BoneId::Patella:
      return "patella";
  }
  return "unknown";
}

double Bone::axialFraction(const Vector3d& pointCt) const {
  const Vector3d axis = axisProximal - axisDistal;
  const double length2 = axis.squaredNorm();
  if (length2 == 0.0)
    return 0.5;
  return (pointCt - axisDistal).dot(axis) / length2;
}

double Bone::distanceFromAxisMm(const Vector3d& pointCt) const {
  const Vector3d axis = axisProximal - axisDistal;
  const double length = axis.norm();
  if (length == 0.0)
    return (pointCt - axisDistal).norm();
  const Vector3d d = axis / length;
  const Vector3d r = pointCt - axisDistal;
  return (r - r.dot(d) * d).norm();
}

double Bone::corticalThicknessMm(const Vector3d& pointCt) const {
  const double u = std::clamp(axialFraction(pointCt), 0.0, 1.0);
  const double fromEnd = std::min(u, 1.0 - u);
  return kEndCorticalMm +
         (diaphysisCorticalMm - kEndCorticalMm) * detail::smoothstep(0.06, 0.22, fromEnd);
}

double Bone::medullaryRadiusMm(const Vector3d& pointCt) const {
  if (inscribedRadiusMm.empty())
    return 0.0;
  const double u = axialFraction(pointCt);
  if (u <= 0.0 || u >= 1.0)
    return 0.0;
  const double presence = detail::smoothstep(0.15, 0.25, std::min(u, 1.0 - u));
  if (presence == 0.0)
    return 0.0;
  const std::size_t n = inscribedRadiusMm.size();
  const std::size_t bin = std::min(n - 1, static_cast<std::size_t>(u * static_cast<double>(n)));
  double room = inscribedRadiusMm[bin];
  if (bin > 0)
    room = std::min(room, inscribedRadiusMm[bin - 1]);
  if (bin + 1 < n)
    room = std::min(room, inscribedRadiusMm[bin + 1]);
  return presence * std::max(0.0, room - corticalThicknessMm(pointCt) - 1.0);
}

const Bone& Knee::bone(BoneId id) const {
  for (const Bone& b : bones) {
    if (b.id == id)
      return b;
  }
  throw std::out_of_range("Knee::bone: no " + std::string(boneName(id)));
}

Knee buildKnee(const KneeOptions& options) {
  validate(options);
  const Specimen specimen = drawSpecimen(options.seed);
  const Vector3d knee = kKneeCentreCt;
  const double resolution = options.meshResolutionMm;

  // Femur: procedural, or the user's mesh placed with its knee centre here and its hip straight
  // above (the mechanical axis along +z).
  Bone femur;
  double hipKneeLength = 0.0;
  sdf::Field femurField;  // knee-local, the procedural femur's (for the osteophytes)
  Eigen::AlignedBox3d femurBox;
  const auto userFemur = options.meshFiles.find(BoneId::Femur);
  if (userFemur != options.meshFiles.end()) {
    detail::PlacedFemur placed = detail::placeUserFemur(userFemur->second, knee);
    femur = std::move(placed.bone);
    hipKneeLength = placed.hipKneeLengthMm;
  } else {
    const FemurModel model = femurModel(specimen);
    femur = meshedBone(BoneId::Femur, model.field, model.searchBox, resolution);
    femurField = model.field;
    femurBox = model.searchBox;
    femur.landmarks["hip_centre"] = model.hip;
    femur.landmarks["knee_centre"] = Vector3d::Zero();
    femur.landmarks["medial_epicondyle"] =
        sdf::rayExit(model.field, model.medialEpicondyle, Vector3d::UnitX());
    femur.landmarks["lateral_epicondyle"] =
        sdf::rayExit(model.field, model.lateralEpicondyle, -Vector3d::UnitX());
    detail::FemurAxes axes;
    axes.axisPoint = model.shaftFoot;
    axes.proximal = model.shaftDirection;
    axes.hip = model.hip;
    axes.medial = Vector3d::UnitX();
    axes.down = -Vector3d::UnitZ();
    axes.epicondyleMiddle =
        0.5 * (femur.landmarks["medial_epicondyle"] + femur.landmarks["lateral_epicondyle"]);
    detail::addFemurMeshLandmarks(femur.mesh, axes, femur.landmarks);
    femur.diaphysisCorticalMm = kFemurCorticalMm;
    detail::setAxisProfile(femur, model.shaftFoot, model.shaftDirection);
    hipKneeLength = model.hip.norm();
    translate(femur, knee);
  }

  const TibiaModel tibiaShape = tibiaModel(specimen);
  Bone tibia = meshedBone(BoneId::Tibia, tibiaShape.field, tibiaShape.searchBox, resolution);
  tibia.landmarks["plateau_centre"] = tibiaShape.plateauCentre;
  tibia.landmarks["ankle_centre"] = tibiaShape.ankle;
  tibia.landmarks["tibial_tubercle"] =
      sdf::rayExit(tibiaShape.field, tibiaShape.tubercle, -Vector3d::UnitY());
  tibia.landmarks["medial_malleolus"] =
      sdf::rayExit(tibiaShape.field, tibiaShape.medialMalleolus, Vector3d::UnitX());
  tibia.diaphysisCorticalMm = kTibiaCorticalMm;
  detail::setAxisProfile(tibia, tibiaShape.ankle, tibiaShape.plateauCentre - tibiaShape.ankle);
  translate(tibia, knee);

  const FibulaModel fibulaShape = fibulaModel(specimen, tibiaShape);
  Bone fibula = meshedBone(BoneId::Fibula, fibulaShape.field, fibulaShape.searchBox, resolution);
  fibula.landmarks["fibular_head"] =
      sdf::rayExit(fibulaShape.field, fibulaShape.head, Vector3d(-1.0, 0.5, 0.0));
  fibula.landmarks["lateral_malleolus"] =
      sdf::rayExit(fibulaShape.field, fibulaShape.malleolus, -Vector3d::UnitX());
  fibula.diaphysisCorticalMm = kFibulaCorticalMm;
  detail::setAxisProfile(fibula, fibulaShape.distal, fibulaShape.head - fibulaShape.distal);
  translate(fibula, knee);

  Vector3d tibiaShift = Vector3d::Zero();
  if (options.tibiofemoralGapMm >= 0.0) {
    // A narrowed joint: the tibia (and the fibula with it) moves up until its nearest vertex is
    // the gap from the femur (each step closes what is left; the gap shrinks about as fast as the
    // tibia moves, since the nearest points face each other along the axis).
    const core::MeshLocator femurLocator(femur.mesh);
    for (int step = 0; step < 30; ++step) {
      const double left =
          tibiofemoralGap(femurLocator, tibia.mesh, knee.z()) - options.tibiofemoralGapMm;
      if (std::abs(left) < 0.01)
        break;
      const Vector3d move(0.0, 0.0, 0.8 * left);
      translate(tibia, move);
      translate(fibula, move);
      tibiaShift += move;
    }
  }
  if (options.osteophyteMm > 0.0) {
    addOsteophytes(options.osteophyteMm, specimen, femurField, femurBox, tibiaShape, tibiaShift,
                   resolution, femur, tibia);
  }

  Bone patella = patellaBone(
      specimen, core::transformed(femur.mesh, Eigen::Isometry3d(Eigen::Translation3d(-knee))),
      resolution, options.patellofemoralGapMm);
  translate(patella, knee);

  Knee result;
  result.kneeCentre = knee;
  result.hipCentre = knee + hipKneeLength * Vector3d::UnitZ();
  result.ankleCentre = tibia.landmarks.at("ankle_centre");
  const Vector3d medialEpi = femur.landmarks.at("medial_epicondyle");
  const Vector3d lateralEpi = femur.landmarks.at("lateral_epicondyle");
  const Vector3d epicondylarAxis = (medialEpi - lateralEpi).normalized();
  result.medialCt = epicondylarAxis;
  result.anteriorCt = -Vector3d::UnitY();
  if (options.flexionDeg != 0.0) {
    // Flexion: a rotation about the transepicondylar axis; positive about the medial direction
    // swings the ankle posteriorly.
    const Vector3d pivot = 0.5 * (medialEpi + lateralEpi);
    const Eigen::Isometry3d motion = Eigen::Translation3d(pivot) *
                                     Eigen::AngleAxisd(options.flexionDeg * kDeg, epicondylarAxis) *
                                     Eigen::Translation3d(-pivot);
    for (Bone* bone : {&tibia, &fibula, &patella})
      transformBone(*bone, motion);
    result.ankleCentre = motion * result.ankleCentre;
    const Vector3d tibiaAnterior = motion.linear() * -Vector3d::UnitY();
    result.anteriorCt = (-Vector3d::UnitY() + tibiaAnterior).normalized();
  }
  result.bones.push_back(std::move(femur));
  result.bones.push_back(std::move(tibia));
  result.bones.push_back(std::move(fibula));
  result.bones.push_back(std::move(patella));
  return result;
}

}  // namespace echoreg::simulation
