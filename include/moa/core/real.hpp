// The core's floating-point type, chosen at build time: double (the
// default, every host build), or float with MOA_SCALAR_FLOAT defined (the
// Cortex-M4F build with -DMOA_M4F_SCALAR=float, embedded/CMakeLists.txt), for
// FPUs that have only single precision. The core's quantities (counts,
// twists, poses, covariances, thresholds) are `real`; time stamps (s) stay
// double in both, since a float loses the 1 ms epochs after about 1000 s
// (its spacing at 1000 s is 61 us), as do the chi-square quantiles (chi2.hpp,
// computed once at construction by series accurate to ~1e-14).
#pragma once

#include <Eigen/Core>

namespace moa {

#if defined(MOA_SCALAR_FLOAT)
using real = float;
#else
using real = double;
#endif

template <int Rows, int Cols>
using Mat = Eigen::Matrix<real, Rows, Cols>;
using Vec2 = Mat<2, 1>;
using Vec3 = Mat<3, 1>;
using Vec4 = Mat<4, 1>;
using Mat2 = Mat<2, 2>;
using Mat3 = Mat<3, 3>;
using Mat4 = Mat<4, 4>;

}  // namespace moa
