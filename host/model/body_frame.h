// The accelerometer-defined body frame: the intrinsic form of the misalignments.
//
// A rate table that carries the IMU with an unknown small mount rotation R (or with an unknown zero
// offset of its innermost axis) sees y = (I + M)·R·u instead of (I + M)·u. A common rotation of both
// triads' input axes cannot be told from R by ANY campaign on that table, so the six misalignments per
// triad relative to the case are not identifiable without a trusted mount. What IS identifiable, and
// what a navigation system needs, are the intrinsic quantities: the non-orthogonality of the
// accelerometer triad and the misalignment of the gyro triad relative to it. They are expressed in the
// body frame B defined by the accelerometer axes (as in Tedaldi et al., ICRA 2014):
//   x_B along the accelerometer x axis, y_B in the plane of the accelerometer x and y axes,
// so the accelerometer matrix is lower triangular in B: accel.misalign.{xy,xz,yz} = 0 and only
// {yx, zx, zy} remain. The compensated output of a table built in this convention is in B.
//
// to_accel_body_frame() re-expresses a parameter set (case frame) in B exactly: with
// A = I + S + M (accelerometer, at T_ref) = L·Q (LQ decomposition, Q a rotation, L lower triangular
// with a positive diagonal), B = Q·case, and every input-side matrix of either triad is multiplied on
// the right by Qᵀ: gyro I + S + M, the temperature polynomials of scale and misalignment (diagonal and
// off-diagonal parts mix at second order), and the gyro g-sensitivity. Biases, and the per-axis effects
// (nonlinearity, asymmetry, cross-coupling, size effect, g²-sensitivity, thermal history, timing), are
// left as they are: rotating them changes them only at the order of (misalignment × that effect).
#pragma once

#include <Eigen/Core>

#include "host/model/catalog.h"

namespace imuforge::model {

struct BodyFrameParams {
  ParamSet params;              // the same parameters expressed in B (accel misalign xy, xz, yz = 0)
  Eigen::Matrix3d C_body_case;  // v_B = C_body_case · v_case (a rotation; ≈ I − [ε×] for small ε)
};

// O(number of catalog parameters). Never fails for |S|, |M| < 1 (A then has full rank).
BodyFrameParams to_accel_body_frame(const ParamSet& case_params);

// The intrinsic misalignment parameters compared by tests and benchmarks: accel {yx, zx, zy} and all
// six gyro misalignments, in that order, as catalog ids.
const std::vector<ParamId>& intrinsic_misalignment_ids();

}  // namespace imuforge::model
