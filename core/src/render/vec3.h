// render/vec3.h: small vector helpers of the renderer (shading and the
// camera: no proof depends on them), and argument_of. Internal header;
// inline so that the tracer's inner loops still inline them.
#pragma once

#include <cmath>
#include <limits>

#include "argand/render.h"
#include "../constants.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline void normalize3(double* v) {
    const double n = std::sqrt(dot3(v, v));
    if (n > 0) { v[0] /= n; v[1] /= n; v[2] /= n; }
}
inline void cross3(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
/// out = M v for a row-major 3x3 matrix.
inline void mat_vec(const double* m, const double* v, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = m[3 * r] * v[0] + m[3 * r + 1] * v[1] + m[3 * r + 2] * v[2];
}
/// out = M^T v.
inline void mat_t_vec(const double* m, const double* v, double* out) {
    for (int c = 0; c < 3; ++c) out[c] = m[c] * v[0] + m[3 + c] * v[1] + m[6 + c] * v[2];
}
inline void to_object(const SurfaceSpec& s, const double* world_point, double* out) {
    const double d[3] = {world_point[0] - s.translate[0], world_point[1] - s.translate[1], world_point[2] - s.translate[2]};
    mat_vec(s.linear, d, out);
}

/// std::atan2(y, x), without the call when y is a zero and x is not
/// (a real root): C11 F.10.1.4 fixes atan2(+-0, x > 0) = +-0 and
/// atan2(+-0, x < 0) = +-pi (the double nearest pi), so the value is the
/// same to the bit (tests/render/test_frames.py checks it against the library).
inline double argument_of(double y, double x) {
    if (y == 0.0) {
        if (x > 0) return y;
        if (x < 0) return std::copysign(kPi, y);
    }
    return std::atan2(y, x);
}

}  // namespace argand::detail

#pragma GCC visibility pop
