// Registration of points on a bone (in the bone tracker's frame, e.g. `Femur`) to the bone's
// model (CT frame): the result maps Femur -> CT (FemurToCT). Two methods side by side:
//   - Plain: the dissertation's ICP (Mozes 2008, section 4.3): every point's closest point on the
//     triangles, then the least-squares rigid transform (Horn/Umeyama), repeated until the RMS
//     (Eq. 4.4) changes by less than a tolerance. Every point counts equally; no outlier handling.
//   - Robust: point-to-plane least squares in Ceres with a robust loss (Huber, Cauchy, Tukey) or
//     trimming, closest points re-found each outer iteration; per-point weights 1 / sigma (the
//     hybrid registration of section 6.4.1: ultrasound and stylus points each weighted by their
//     own error); landmark pairs as extra residuals (Maurer et al. 1998), optionally the speed of
//     sound as one more unknown (section 6.4.2: each beam point moves along its beam,
//     p = origin + s * depth * direction), and several starts (perturbed, and/or rotated about the
//     line of two landmarks) keeping the one of least robust cost.
// docs/registration.md gives the equations and the parameters.
#pragma once

#include "echoreg/core/mesh.hpp"
#include "echoreg/core/mesh_locator.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace echoreg::core {

enum class SurfaceMethod { Plain, Robust };
enum class RobustLoss { Huber, Cauchy, Tukey, Trim };
enum class PointSource { Ultrasound, Stylus };

/// "plain" / "robust"; "huber" / "cauchy" / "tukey" / "trim"; parse* throw std::invalid_argument
/// naming the accepted values.
std::string_view surfaceMethodName(SurfaceMethod method);
SurfaceMethod parseSurfaceMethod(std::string_view name);
std::string_view robustLossName(RobustLoss loss);
RobustLoss parseRobustLoss(std::string_view name);

/// One measured point on the bone surface, in the bone frame (mm).
struct SurfacePoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  /// With a beam, the point is beamOrigin + s * depthMm * beamDirection (s = 1 reproduces
  /// `point`; the speed-of-sound scale s = c_true / c_assumed is fitted when asked). The
  /// direction must be unit length.
  bool hasBeam = false;
  Eigen::Vector3d beamOrigin = Eigen::Vector3d::Zero();
  Eigen::Vector3d beamDirection = Eigen::Vector3d::UnitZ();
  double depthMm = 0.0;
  PointSource source = PointSource::Ultrasound;
  /// Localisation error (1 sigma, mm): the point's residual is divided by it.
  double sigmaMm = 0.5;
  /// The point lies this far outside the surface (a stylus ball tip's radius; 0 for ultrasound).
  double surfaceOffsetMm = 0.0;

  /// The point at speed-of-sound scale s (`point` without a beam).
  Eigen::Vector3d at(double speedScale) const {
    return hasBeam ? Eigen::Vector3d(beamOrigin + speedScale * depthMm * beamDirection) : point;
  }
};

/// A surface point from its beam: origin + depth * direction (direction normalised here).
SurfacePoint beamSurfacePoint(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                              double depthMm, double sigmaMm = 0.5);

/// One landmark touched on the bone (bone frame) and marked on the model (CT frame).
struct LandmarkPair {
  std::string name;
  Eigen::Vector3d bone = Eigen::Vector3d::Zero();
  Eigen::Vector3d model = Eigen::Vector3d::Zero();
  double sigmaMm = 3.0;  ///< localisation error (1 sigma) of the pair, mm
};

struct SurfaceRegistrationOptions {
  SurfaceMethod method = SurfaceMethod::Robust;
  RobustLoss loss = RobustLoss::Huber;
  /// Loss scale in sigmas of the whitened residual (r / sigma_i); 0 = the usual 95 %-efficiency
  /// constant: Huber 1.345, Cauchy 2.385, Tukey 4.685.
  double lossScale = 0.0;
  /// Trim: the fraction of points with the largest residuals left out each iteration.
  double trimFraction = 0.1;
  /// Robust (not Trim): points whose whitened |r| exceeds max(gateSigmas * 1.4826 * median
  /// |r / sigma|, gateSigmas) leave that iteration's problem (they may come back later) and are
  /// reported as rejected at the end.
  double gateSigmas = 3.0;
  /// Robust: fit the speed-of-sound scale s with the pose (needs beams), bounded to
  /// [minSpeedScale, maxSpeedScale].
  bool fitSpeedOfSound = false;
  double minSpeedScale = 0.8;
  double maxSpeedScale = 1.25;
  /// Landmark pairs add their residuals (model - T * bone) / sigma in the robust method.
  bool useLandmarks = true;

  Eigen::Isometry3d initial = Eigen::Isometry3d::Identity();  ///< bone -> model
  /// This many extra starts (either method; the least truncated cost wins) from the initial pose
  /// perturbed by a random rotation of up to restartRotationDeg (about the points' centroid) and a
  /// translation of up to restartTranslationMm (seeded: same seed, same starts).
  int restarts = 0;
  double restartRotationDeg = 10.0;
  double restartTranslationMm = 10.0;
  std::uint64_t seed = 1;
  /// Starts rotated about a line (bone frame), e.g. through two landmarks whose rotation
  /// about their line the landmarks cannot fix: axisStarts starts evenly over 360 deg.
  bool searchAboutAxis = false;
  Eigen::Vector3d axisPoint = Eigen::Vector3d::Zero();
  Eigen::Vector3d axisDirection = Eigen::Vector3d::UnitZ();
  int axisStarts = 12;

  int maxIterations = 100;  ///< outer iterations (closest points re-found) per start
  /// Robust: stop when no point moves more than this in one iteration (or the objective no longer
  /// decreases).
  double toleranceMm = 1e-6;
  /// Plain: stop when the RMS (Eq. 4.4) changes by less than this in one iteration.
  double plainRmsChangeMm = 1e-4;
  /// converged = false when the inliers' RMS exceeds this (the points end far from the surface)
  /// or fewer than minInlierFraction of the points (and fewer than 3) remain.
  double maxRmsMm = 2.0;
  double minInlierFraction = 0.5;
  /// converged = false when, at every start, the points' median distance to the surface exceeds
  /// this (wrong frame, wrong model or a wild start: any fit from there would be a guess).
  double maxStartDistanceMm = 30.0;
  /// Triangles of the model that are not bone surface (empty, or one flag per triangle): e.g. the
  /// flat caps where the CT's scan range cut a segmented model. A point whose closest point lies
  /// on one is not used (robust method): beyond the scan it has nothing to match.
  std::vector<bool> excludedTriangles;
  /// Not converged when the solution leaves a rotation less determined than this (1 sigma, deg)
  /// or a translation less determined than maxTranslationSigmaMm (see the result).
  double maxRotationSigmaDeg = 3.0;
  double maxTranslationSigmaMm = 3.0;
  /// Not converged when another start ends more than ambiguityDeg / ambiguityMm (at the points'
  /// centroid) from the chosen pose with a truncated cost within ambiguityCostRatio x the best:
  /// two poses the points cannot tell apart (the femur from its two epicondyles alone).
  double ambiguityCostRatio = 1.5;
  double ambiguityDeg = 3.0;
  double ambiguityMm = 3.0;
};

/// The flat end caps of a model cut by the scan range: triangles whose three vertices lie within
/// `toleranceMm` of the model's lowest or highest z and whose normal is within 10 degrees of z,
/// and the ring of triangles touching them (the rim), as SurfaceRegistrationOptions'
/// excludedTriangles.
std::vector<bool> scanEndCaps(const TriangleMesh& mesh, double toleranceMm = 0.5);

struct SurfaceRegistrationResult {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  ///< bone -> model
  /// Eq. 4.4: RMS distance from each transformed point to the nearest point on the triangles,
  /// minus its surface offset, over the inliers (rmsMm) and over every point (rmsAllMm).
  double rmsMm = 0.0;
  double rmsAllMm = 0.0;
  int pointsUsed = 0;
  int pointsRejected = 0;
  /// Of the rejected: points closest to an excluded triangle (beyond the scanned model).
  int pointsBeyondModel = 0;
  double speedOfSoundScale = 1.0;  ///< s = c_true / c_assumed (1 unless fitted)
  int iterations = 0;              ///< outer iterations of the chosen start
  int starts = 1;                  ///< starts tried
  double cost = 0.0;               ///< truncated robust cost of the chosen start (see docs)
  /// How well the inliers (and landmarks) determine the pose: the 1-sigma uncertainty, from the
  /// inverse Gauss-Newton matrix of the whitened residuals, of the worst-determined rotation
  /// (degrees, about `weakestAxis`, through the points' centroid) and of the worst-determined
  /// translation (mm). A surface patch that can slide along itself (the condyles turning about
  /// the transepicondylar axis) shows here; beyond maxRotationSigmaDeg / maxTranslationSigmaMm
  /// the result is not converged.
  double rotationSigmaDeg = 0.0;
  double translationSigmaMm = 0.0;
  Eigen::Vector3d weakestAxis = Eigen::Vector3d::UnitX();  ///< model frame
  bool converged = false;
  std::string message;  ///< why not converged ("" when converged)
  /// Per input point: signed distance to the surface after registration minus its offset (mm,
  /// positive outside), and whether it was an inlier at the end.
  std::vector<double> residualsMm;
  std::vector<bool> inlier;
  /// Per landmark pair: |T * bone - model|, mm.
  std::vector<double> landmarkResidualsMm;
};

/// A bone model prepared for registration: checked closed and its closest-point hierarchy built
/// once, then any number of registrations (const, thread-safe).
class SurfaceRegistration {
 public:
  /// Throws std::invalid_argument when the model is empty or not a closed, consistently oriented
  /// surface (checkMesh's description), or from MeshLocator for bad indices / non-finite vertices.
  explicit SurfaceRegistration(TriangleMesh model);

  const MeshLocator& locator() const { return locator_; }

  /// Registers `points` (bone frame) to the model. converged = false also when fewer than 6
  /// constraints remain (a surface point fixes one degree of freedom, a landmark three) or the
  /// points start far from the surface (maxStartDistanceMm). Throws std::invalid_argument for bad
  /// input, naming the point, landmark or option: fewer than 3 points, a non-finite coordinate, a
  /// sigma
  /// <= 0, a beam direction not unit, a negative depth, a speed-of-sound fit without any beam, or
  /// an option out of range. Never returns a silently wrong transform: converged = false (with
  /// `message`) when the iterations did not settle, too few inliers remain or the inliers' RMS
  /// exceeds maxRmsMm.
  SurfaceRegistrationResult registerPoints(const std::vector<SurfacePoint>& points,
                                           const std::vector<LandmarkPair>& landmarks,
                                           const SurfaceRegistrationOptions& options) const;

 private:
  MeshLocator locator_;
};

/// An initial pose from two landmark pairs: the midpoints coincide, the bone's line a->b maps
/// onto the model's, and the rotation about that line is `angleRad` from a fixed, deterministic
/// choice (two landmarks cannot fix it: search it with SurfaceRegistrationOptions::
/// searchAboutAxis). Throws std::invalid_argument when a pair's points lie within 1 mm of each
/// other or the two distances differ by more than `maxLengthMismatchMm`.
Eigen::Isometry3d poseFromTwoLandmarks(const LandmarkPair& a, const LandmarkPair& b,
                                       double angleRad = 0.0, double maxLengthMismatchMm = 20.0);

/// The two landmarks farthest apart, and whether any other lies off their line by more than
/// `minOffLineMm` (then the landmarks fix the rotation). Throws std::invalid_argument for fewer
/// than 2 landmarks.
struct LandmarkSpread {
  int first = 0;
  int second = 1;
  double lengthMm = 0.0;
  double maxOffLineMm = 0.0;  ///< largest distance of another landmark (bone side) from the line
  bool collinear = true;
};
LandmarkSpread landmarkSpread(const std::vector<LandmarkPair>& landmarks,
                              double minOffLineMm = 5.0);

/// Eq. 4.4 for given points and transform: RMS of the distances from transform * p_i to the
/// triangles (no offsets, all points). Throws std::invalid_argument for no points.
double surfaceRmsMm(const MeshLocator& locator, const std::vector<Eigen::Vector3d>& points,
                    const Eigen::Isometry3d& transform);

}  // namespace echoreg::core
