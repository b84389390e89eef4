// Kim & Lee Section III: how the least-squares twist moves when the mouse
// positions are off, to first order (eqs. (29)-(30)).
//
// With A the stacked point Jacobian (eq. (6)), P = A^T A (eq. (24)) and
// position deviations dp (dA of eq. (34), dP = dA^T A + A^T dA, eq. (25)):
//   dv_m ~ dv_m1 + dv_m2 + dv_m3,                              (29)
//   dv_m1 =  P^-1 dA^T v_s      (the deviation itself)
//   dv_m2 = -P^-1 dP   v_m      (its effect on the normal matrix)
//   dv_m3 =  P^-1 A^T dv_s      (the perturbation of the measurements) (30)
// where v_m = P^-1 A^T v_s is the estimate with the nominal positions
// (an erratum of Kim & Lee eq. (30) as printed: the third term is the measurement
// perturbation). The exact counterpart is the LS estimate with the
// perturbed positions on the perturbed measurements minus v_m.
// Velocities here are the sensor points' robot-frame velocities (m/s), as
// in Kim & Lee (mice aligned with the robot: the mounts' yaw, scale and
// mirroring are already undone).
#pragma once

#include <Eigen/Core>
#include <array>

#include "moa/core/array.hpp"

namespace moa {

struct SensitivityTerms {
  Eigen::Vector3d dv1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d dv2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d dv3 = Eigen::Vector3d::Zero();
  Eigen::Vector3d total() const { return dv1 + dv2 + dv3; }
};

/// Stacked values, one 2-vector per sensor.
using PointVectors = std::array<Eigen::Vector2d, kMaxSensors>;

/// First-order change of the LS twist (eqs. (29)-(30)) for position
/// deviations dp (m), measured point velocities v_s and their change dv_s.
SensitivityTerms first_order_sensitivity(const SensorArray& nominal, const PointVectors& dp,
                                         const PointVectors& v_s, const PointVectors& dv_s);

/// The exact change: LS twist with positions p + dp on v_s + dv_s, minus the
/// LS twist with positions p on v_s (unweighted, all sensors).
Eigen::Vector3d exact_sensitivity(const SensorArray& nominal, const PointVectors& dp,
                                  const PointVectors& v_s, const PointVectors& dv_s);

}  // namespace moa
