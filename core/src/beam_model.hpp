// The beam calibration's model (beam_calibration.cpp), shared with the solver module that fits it
// with Ceres (solve/module/beam.cpp): one shot reduced to what its residual needs, and the
// residual for each parameter layout. Private to echoreg::core and the module.
#pragma once

#include <Eigen/Core>

#include <cmath>

namespace echoreg::core::detail {

/// One shot, reduced to what the residual needs: p - c = R_i t + (R_i R0) q(d) + (t_i - c).
struct ShotData {
  Eigen::Matrix3d probeRotation;  ///< R_i of ProbeToTracker
  Eigen::Matrix3d beamRotation;   ///< R_i R0 (R0: the initial BeamToProbe rotation)
  Eigen::Vector3d offset;         ///< t_i - c
  double depthMm = 0.0;
  double radiusMm = 0.0;
  double inverseAssumedSpeed = 0.0;  ///< s / m
};

/// r - |p - c| for one shot; the parameter layout follows from their number: 3 translation,
/// 4 translation + speed, 5 translation + tilts, 6 translation + tilts + speed.
template <int kCount>
struct ShotResidual {
  static constexpr bool kTilt = kCount >= 5;
  static constexpr bool kSpeed = kCount == 4 || kCount == 6;

  explicit ShotResidual(const ShotData& shot) : data(shot) {}

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    const T scale = kSpeed ? T(x[kCount - 1] * data.inverseAssumedSpeed) : T(1.0);
    const T along = scale * data.depthMm;  // distance along the beam, mm
    // The beam point in the initial beam frame: Rx(tilt_x) Ry(tilt_y) (0, 0, along).
    T q[3] = {T(0.0), T(0.0), along};
    if constexpr (kTilt) {
      using std::cos;
      using std::sin;
      const T sinY = sin(x[4]);
      const T cosY = cos(x[4]);
      q[0] = along * sinY;
      q[1] = -sin(x[3]) * along * cosY;
      q[2] = cos(x[3]) * along * cosY;
    }
    T squared = T(0.0);
    for (int row = 0; row < 3; ++row) {
      T value = T(data.offset[row]);
      for (int col = 0; col < 3; ++col) {
        value += data.probeRotation(row, col) * x[col] + data.beamRotation(row, col) * q[col];
      }
      squared += value * value;
    }
    using std::sqrt;
    residual[0] = T(data.radiusMm) - sqrt(squared);
    return true;
  }

  ShotData data;
};

}  // namespace echoreg::core::detail
