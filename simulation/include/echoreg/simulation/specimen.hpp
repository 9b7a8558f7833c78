// A whole simulated specimen: the bones of a knee (anatomy.hpp) inside a leg of skin, fat and
// muscle whose thickness varies around the limb, or sawbones in a water bath. It answers what
// tissue lies at a point (for the CT) and what a beam meets on its way into the leg (for the
// A-lines), from one geometry, so the CT and the A-lines agree.
//
// The soft tissue is defined by the distance d to the nearest bone surface and a thickness map
// T(theta, h) around the limb (theta from anterior toward lateral, h along the thigh or the shank):
// skin where T - skin < d <= T, fat below it down to the deep fascia, muscle between the fascia
// and the bone. Values and sources in docs/simulation.md.
#pragma once

#include "echoreg/core/mesh_locator.hpp"
#include "echoreg/simulation/anatomy.hpp"
#include "echoreg/simulation/ct.hpp"
#include "echoreg/simulation/pulse_echo.hpp"
#include "echoreg/simulation/tissue.hpp"

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace echoreg::simulation {

enum class SpecimenKind {
  Phantom,  ///< sawbones in a water bath (CT: bones in air)
  Cadaver,  ///< bones in a leg of skin, fat and muscle
};

enum class Segment { Thigh, Shank };

struct SoftTissueOptions {
  double thicknessScale = 1.0;  ///< 1 = the table's mean adult; 0.8 lean, 1.3 heavy
  double skinMm = 1.8;          ///< dermis + epidermis over the knee (1.5-2.5 mm)
  /// Thickness factor of what lies under the skin (fat and muscle), in (0, 1]; the skin keeps
  /// its `skinMm`. 0.3 puts the bone 2-10 mm under the skin around the knee (in vivo, pressed by
  /// a bare probe); applies after `thicknessScale`.
  double underSkinScale = 1.0;
  std::uint64_t seed = 1;  ///< smooth variation of the map around the limb (+-10 %)
};

/// Where the beam goes and what it meets, with the truth of the shot.
struct BeamTrace {
  BeamPath path;              ///< layers from the transducer face, for simulateALine
  int boneIndex = -1;         ///< index into knee().bones of the first bone hit, -1 none
  double boneDepthMm = 0.0;   ///< distance from the beam origin to the bone surface
  double incidenceDeg = 0.0;  ///< beam versus the bone's normal at the hit
  double skinDepthMm = 0.0;   ///< distance from the beam origin to the skin (0 in a bath)
  double meanSpeedMps = 0.0;  ///< path length / one-way time to the bone (or to maxDepth)
  Eigen::Vector3d hitPoint = Eigen::Vector3d::Zero();
};

/// A point on the skin (or, for a phantom, on the bone) and its outward unit normal.
struct SurfacePoint {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;
};

class Specimen final : public TissueField {
 public:
  /// Builds the bone locators and the distance grid (a few seconds; progress in [0, 1]).
  Specimen(Knee knee, SpecimenKind kind, const SoftTissueOptions& tissue,
           const std::function<void(double)>& progress = {});
  ~Specimen() override;

  const Knee& knee() const { return knee_; }
  SpecimenKind kind() const { return kind_; }
  const core::MeshLocator& locator(std::size_t boneIndex) const;

  /// CT view: air outside the skin (outside the bones for a phantom), soft tissues, cortical and
  /// cancellous bone, marrow.
  Tissue tissueAt(const Eigen::Vector3d& pointCt) const override;

  /// Signed distance to the union of the bones (negative inside), exact near the surface.
  double boneSignedDistance(const Eigen::Vector3d& pointCt) const;
  /// Soft tissue thickness T (skin surface to nearest bone) and the subcutaneous fat F at a point.
  double softTissueThicknessMm(const Eigen::Vector3d& pointCt) const;
  double fatThicknessMm(const Eigen::Vector3d& pointCt) const;
  /// < 0 inside the leg (under the skin), > 0 outside; the skin is its zero level.
  double legField(const Eigen::Vector3d& pointCt) const;

  /// Limb coordinates: the point's segment, its height h (mm from the knee centre along the
  /// segment's axis, toward the hip or the ankle) and its angle theta (rad, 0 anterior, +pi/2
  /// lateral, pi posterior, -pi/2 medial).
  struct LimbCoordinates {
    Segment segment;
    double heightMm;
    double thetaRad;
  };
  LimbCoordinates limbCoordinates(const Eigen::Vector3d& pointCt) const;
  /// The axis point of a segment at height h and the outward radial direction at theta.
  Eigen::Vector3d axisPoint(Segment segment, double heightMm) const;
  Eigen::Vector3d radialDirection(Segment segment, double thetaRad) const;

  /// The outermost skin point (cadaver) or bone point (phantom) seen from the limb's axis at
  /// (h, theta), with its outward normal; nothing when the ray from the axis finds no surface.
  std::optional<SurfacePoint> surfacePoint(Segment segment, double heightMm, double thetaRad) const;

  /// Traces a beam from `originCt` along the unit `directionCt`: the standoff medium up to the skin
  /// (`standoff`, ignored for a phantom: the bath is water), then the tissues, up to the first bone
  /// or `maxDepthMm`. `waterSpeedMps` sets the speed of sound of water (bath or standoff).
  BeamTrace traceBeam(const Eigen::Vector3d& originCt, const Eigen::Vector3d& directionCt,
                      Tissue standoff, double maxDepthMm) const;

 private:
  struct Grid;
  Tissue softTissueAt(const Eigen::Vector3d& p, double distance) const;
  Tissue boneInteriorAt(const Eigen::Vector3d& p, std::size_t bone, double depth) const;
  double exactSignedDistance(const Eigen::Vector3d& p, std::size_t* bone) const;
  double fatFor(const Eigen::Vector3d& p, double totalThicknessMm) const;

  Knee knee_;
  SpecimenKind kind_;
  SoftTissueOptions tissue_;
  std::vector<core::MeshLocator> locators_;
  std::vector<std::array<Eigen::Vector3d, 2>> boneBounds_;
  std::unique_ptr<Grid> grid_;
  // Limb frames.
  Eigen::Vector3d kneeCentre_, thighAxis_, shankAxis_, thighAnterior_, shankAnterior_;
  Eigen::Vector3d lateral_;
  double thighLengthMm_ = 0.0, shankLengthMm_ = 0.0;
  std::array<double, 8> variation_{};  // smooth +-10 % modulation around the limb
  double maxThicknessMm_ = 0.0;        // no soft tissue farther than this from a bone
};

}  // namespace echoreg::simulation
