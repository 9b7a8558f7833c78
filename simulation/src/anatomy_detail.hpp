// Internal pieces of anatomy.cpp shared with the user-mesh placement (not installed).
#pragma once

#include "echoreg/simulation/anatomy.hpp"

#include <Eigen/Core>

#include <map>
#include <string>

namespace echoreg::simulation::detail {

/// Axis ends and the inscribed-radius profile of `bone` from its mesh and a line (point,
/// direction pointing proximally) along its shaft.
void setAxisProfile(Bone& bone, const Eigen::Vector3d& axisPoint,
                    const Eigen::Vector3d& proximalDirection);

/// Directions of a femur in its mesh's coordinates, for the landmarks found on the mesh.
struct FemurAxes {
  Eigen::Vector3d axisPoint, proximal;  ///< shaft axis line, unit proximal direction
  Eigen::Vector3d hip;                  ///< head centre
  Eigen::Vector3d medial;               ///< unit medial direction (epicondylar)
  Eigen::Vector3d down;                 ///< unit distal direction of the mechanical axis
  Eigen::Vector3d epicondyleMiddle;
};

/// Landmarks defined as extreme vertices, the same way for procedural and user femurs:
/// greater_trochanter (most lateral point above 40 mm below the hip centre), lesser_trochanter
/// (most posteromedial point 50-95 mm below the hip centre, near the shaft),
/// medial/lateral_condyle_distal (most distal point on each side of the epicondyles' middle).
void addFemurMeshLandmarks(const core::TriangleMesh& mesh, const FemurAxes& axes,
                           std::map<std::string, Eigen::Vector3d>& landmarks);

/// A user's femur mesh analysed and placed in the knee.
struct PlacedFemur {
  Bone bone;  ///< CT coordinates, right femur, landmarks filled
  double hipKneeLengthMm = 0.0;
};

/// Reads `path`, checks it, finds its anatomical frame (mirroring a left femur), and places it so
/// that its knee centre is `kneeCentreCt`, its mechanical axis +z and its epicondylar axis in the
/// x-z plane pointing +x. Throws FileError naming the file.
PlacedFemur placeUserFemur(const std::string& path, const Eigen::Vector3d& kneeCentreCt);

/// Hermite smoothstep from 0 at `edge0` to 1 at `edge1`.
double smoothstep(double edge0, double edge1, double x);

}  // namespace echoreg::simulation::detail
