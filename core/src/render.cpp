// render.cpp: the complex-space ray caster: plan a frame, trace pixels,
// decide each pixel with proofs and an escalation ladder, shade.
//
// A pixel's decision (pixel_decision.h) is proven for the exact ray
// polynomial of its ray (ray_polynomial.h): the root discs come from
// find_roots with the coefficients' error radii, and every comparison
// (band, clipping sphere, ordering by modulus, realness) is outward-rounded.
// When a decision is not proven the pixel climbs the ladder (LadderLevel):
// the root core's double-double tier, a retry without neighbour seeds,
// double-double ray coefficients that shrink the deciding discs, then (for
// a primary ray, within the tile's budget) the exact tier: an ExactSolver
// given by the caller decides the pixel on the exact rational ray
// polynomial.
#include "argand/render.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <limits>
#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "argand/arith.h"
#include "argand/roots_batch.h"
#include "pixel_decision.h"
#include "polish.h"
#include "ray_polynomial.h"
#include "refine_dd.h"
#include "root_kernels.h"

namespace argand {
namespace {

using detail::ObjectRay;
using detail::RayCoefficients;
using detail::Verdict;

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------
// Small vector helpers (shading and the camera: no proof depends on them)
// ---------------------------------------------------------------------------
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

/// Sample centre -> unit world direction (the one formula for render_tile,
/// primary_ray and explain_pixel). (sx, sy) is a cell of the frame's grid
/// of samples, side times finer than the pixels: the samples of a W x H
/// frame are the pixel centres of the (side W) x (side H) frame, to the bit
/// (the aspect W / H is the same correctly rounded quotient).
void sample_direction(const FramePlan& plan, int sx_cell, int sy_cell, int side, double* d) {
    const FrameParams& fp = plan.params;
    const double aspect = static_cast<double>(fp.width) / fp.height;
    const double cols = static_cast<double>(side) * fp.width, rows = static_cast<double>(side) * fp.height;
    const double sx = (2.0 * (sx_cell + 0.5) / cols - 1.0) * plan.tan_half_fov * aspect;
    const double sy = (1.0 - 2.0 * (sy_cell + 0.5) / rows) * plan.tan_half_fov;
    for (int a = 0; a < 3; ++a) d[a] = plan.forward[a] + sx * plan.right[a] + sy * plan.up[a];
    normalize3(d);
}

/// Gradient of F at a complex object-space point (for the normal).
void gradient(const SurfaceSpec& s, const Complex<double>* z, Complex<double>* grad) {
    Complex<double> pw[3][kMaxDegree + 1];
    for (int a = 0; a < 3; ++a) {
        pw[a][0] = Complex<double>(1.0, 0.0);
        for (int k = 1; k <= s.degree; ++k) pw[a][k] = pw[a][k - 1] * z[a];
    }
    for (int a = 0; a < 3; ++a) grad[a] = Complex<double>(0.0, 0.0);
    for (const Term& t : s.terms) {
        const int e[3] = {t.ex, t.ey, t.ez};
        for (int a = 0; a < 3; ++a) {
            if (e[a] == 0) continue;
            Complex<double> v(t.coeff * e[a], 0.0);
            for (int b = 0; b < 3; ++b) v = v * pw[b][b == a ? e[b] - 1 : e[b]];
            grad[a] = grad[a] + v;
        }
    }
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

/// True when spec = specular * pow(rv, shininess) is so small that
/// diffuse[a] + spec == diffuse[a] (round to nearest) for a = 0, 1, 2, so
/// that shade may leave spec (and pow) out with the same bits. For
/// 0 < rv <= 1 and shininess >= k >= 1 (k <= 64): pow(rv, shininess) <=
/// rv^k (1 + 2^-52) (glibc's pow is within 1 ulp), and rv^k <= q (1 + 2^-48)
/// + 2^-1070 for q = rv^k by binary powering (at most 14 roundings, each
/// within a factor 1 + 2^-53 or, below the normal range, 2^-1075 of the
/// product; every factor is at most 1, so no error grows). So
/// |spec| < |specular| (4 q + 2^-1000) / 2 when that is finite, and the
/// test below keeps |spec| under a quarter of half an ulp of the least
/// |diffuse[a]| (2^(e - 53), 2^e <= |diffuse[a]| < 2^(e + 1), each normal):
/// x + s rounds to x for |s| below half the spacing of the doubles next to
/// x, which is at least 2^(e - 53) / 2 on either side. A NaN or an
/// infinity anywhere fails a comparison: pow.
inline bool specular_negligible(int k, double rv, double specular, const double* diffuse) {
    double q = 1.0, b = rv;
    for (;;) {
        if (k & 1) q = q * b;
        k >>= 1;
        if (k == 0) break;
        b = b * b;
    }
    std::uint64_t bits[3];
    std::memcpy(bits, diffuse, sizeof bits);
    std::uint64_t f = 0x7ff;
    for (int a = 0; a < 3; ++a) f = std::min(f, (bits[a] >> 52) & 0x7ff);
    // (f = 0: a zero or subnormal; 0x7ff: not finite; f - 1023 - 53 >= -1000
    // keeps 2^(e - 53) normal and far above the 2^-1000 slack.)
    bool finite = true;
    for (int a = 0; a < 3; ++a) finite &= ((bits[a] >> 52) & 0x7ff) != 0x7ff;
    if (!finite || f < 1023 + 53 - 1000 + 64) return false;
    double half_ulp;
    const std::uint64_t hb = (f - 53) << 52;
    std::memcpy(&half_ulp, &hb, sizeof half_ulp);
    return std::fabs(specular) * (4.0 * q + 0x1p-1000) < half_ulp;
}

/// One term of the gradient, flattened: d/d axis of coeff x^ex y^ey z^ez is
/// ce x^k[0] y^k[1] z^k[2] with ce = coeff * e[axis] (the same double
/// product as gradient()'s) and k = the exponents, axis's lowered by one.
struct GradientTerm {
    double ce;
    int axis;
    int k[3];
    // gradient_real's factors: flat indices k[b] * 3 + b into its power
    // table pw[k][b] of the axes b with k[b] != 0, in axis order, then 0
    // (pw[0][0] = 1.0: a product by it is exact, v * 1.0 = v).
    int f[3];
};

/// What shading needs that depends only on the frame (built once per
/// Tracer). Every value is made by the same operations as the per-pixel
/// code it replaces, so the pixels keep their bits.
struct ShadePlan {
    struct Object {
        std::vector<GradientTerm> terms;  // gradient()'s order: term by term, axis 0..2 within a term
        int k_max[3] = {0, 0, 0};         // highest power of each coordinate the terms use
        int k_top = 0;                    // max of k_max
        bool real_ok = false;             // every ce finite and nonzero (gradient_real may run)
        int ce_lo = 0, ce_hi = 0;         // ilogb range of the ce
        // gradient_real's range check, per coordinate (see there): the
        // biased exponent field f of every x_a in [real_f_lo, real_f_hi]
        // (real_ok false where no x passes).
        std::uint32_t real_f_lo = 1, real_f_hi = 0;
        // spec_k >= 1: shade may skip pow(rv, shininess) for 0 < rv <= 1
        // when its product with the specular factor cannot change the
        // diffuse terms it is added to (rv^shininess <= rv^spec_k there);
        // 0: always pow.
        int spec_k = 0;
        // specular_negligible cannot hold for rv > spec_rv_cut (a filter
        // only: that test decides).
        double spec_rv_cut = 0.0;
        double eye_object[3];             // to_object(eye): the primary rays' origin in object space
        bool identity = false;            // linear is the identity, bit for bit (see linear_apply)
    };
    std::vector<Object> objects;
    struct LightRec {
        double dir[3];  // a directional light's normalize3(vector)
        // l.intensity * l.color[a]: shade's `l.intensity * l.color[a] * (...)`
        // parses as (l.intensity * l.color[a]) * (...), so the product formed
        // once per frame is the same double.
        double ic[3];
        bool directional;
    };
    std::vector<LightRec> lights;  // the scene's, in order
    // Some light is a point light, or some object bounces rays: shade
    // needs the hit point.
    bool need_point = false;
    // ShadeMode::Reference: shade() runs its plain per-pixel code
    // (gradient(), std::pow, std::exp, std::atan2 always), the reference
    // the fast paths are tested against to the bit (tests/render/test_shade.py).
    bool reference = false;

    void build(const FramePlan& plan) {
        reference = plan.params.engine.shade == ShadeMode::Reference;
        const SceneSpec& sc = plan.scene;
        objects.assign(sc.objects.size(), Object{});
        for (std::size_t i = 0; i < sc.objects.size(); ++i) {
            const SurfaceSpec& s = sc.objects[i];
            Object& ob = objects[i];
            ob.real_ok = true;
            bool first = true;
            for (const Term& t : s.terms) {
                const int e[3] = {t.ex, t.ey, t.ez};
                for (int a = 0; a < 3; ++a) {
                    if (e[a] == 0) continue;
                    GradientTerm g{t.coeff * e[a], a, {e[0], e[1], e[2]}, {0, 0, 0}};
                    g.k[a] -= 1;
                    for (int b = 0, j = 0; b < 3; ++b)
                        if (g.k[b] != 0) g.f[j++] = g.k[b] * 3 + b;
                    for (int b = 0; b < 3; ++b) ob.k_max[b] = std::max(ob.k_max[b], g.k[b]);
                    ob.terms.push_back(g);
                    if (!std::isfinite(g.ce) || g.ce == 0.0) {
                        ob.real_ok = false;
                        continue;
                    }
                    const int l = std::ilogb(g.ce);
                    ob.ce_lo = first ? l : std::min(ob.ce_lo, l);
                    ob.ce_hi = first ? l : std::max(ob.ce_hi, l);
                    first = false;
                }
            }
            ob.k_top = std::max(ob.k_max[0], std::max(ob.k_max[1], ob.k_max[2]));
            // gradient_real's condition on (lo, hi) (lo = min(0, min l_a),
            // hi = max(0, max l_a + 1), l_a = ilogb x_a): A(lo) and B(hi),
            // A true from some lo_min <= 0 upward, B up to some hi_max >= 0
            // (monotone in lo and hi; D >= 1). So it holds iff every l_a is
            // in [lo_min, hi_max - 1] (if A(0) and B(0) hold at all), read
            // as a range of the biased exponent field (1..0x7fe: normal).
            {
                const long D = s.degree;
                const auto A = [&](long lo) { return ob.ce_lo + D * lo - 1 >= -1021 && D * lo - 1 >= -1021; };
                const auto B = [&](long hi) { return ob.ce_hi + D * hi + 2 <= 1023 && D * hi + 1 <= 1023; };
                if (D >= 1 && A(0) && B(0)) {
                    long lo = 0, hi = 0;
                    while (A(lo - 1)) --lo;
                    while (B(hi + 1)) ++hi;
                    const long f_lo = std::max(1L, lo + 1023), f_hi = std::min(0x7feL, hi - 1 + 1023);
                    if (f_lo <= f_hi) {
                        ob.real_f_lo = static_cast<std::uint32_t>(f_lo);
                        ob.real_f_hi = static_cast<std::uint32_t>(f_hi);
                    } else {
                        ob.real_ok = false;
                    }
                } else {
                    ob.real_ok = false;
                }
            }
            const double sh = s.material.shininess;
            ob.spec_k = sh >= 1.0 ? static_cast<int>(std::min(64.0, std::floor(sh))) : 0;
            // |diffuse[a]| <= |m.diffuse| |ndl| max(1, |color|) (base <= 1
            // with hues; |ndl| <= 1 but for rounding), and the test needs
            // 4 |specular| rv^k < 2^-53 min |diffuse[a]|.
            if (ob.spec_k > 0) {
                const Material& mt = s.material;
                double cmax = 1.0;
                for (int a = 0; a < 3; ++a) cmax = std::max(cmax, std::fabs(mt.color[a]));
                const double room = std::fabs(mt.diffuse) * cmax * 1.01 * 0x1p-53 / (4.0 * std::fabs(mt.specular));
                const double cut = std::pow(room, 1.0 / ob.spec_k) * 1.01;
                ob.spec_rv_cut = std::isnan(cut) ? 1.0 : cut;
            }
            to_object(s, plan.eye, ob.eye_object);
            static const double kIdentity[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
            ob.identity = std::memcmp(s.linear, kIdentity, sizeof kIdentity) == 0;  // +0 entries, not -0
        }
        lights.assign(sc.lights.size(), LightRec{});
        for (std::size_t i = 0; i < sc.lights.size(); ++i) {
            for (int a = 0; a < 3; ++a) lights[i].dir[a] = sc.lights[i].vector[a];
            normalize3(lights[i].dir);
            for (int a = 0; a < 3; ++a) lights[i].ic[a] = sc.lights[i].intensity * sc.lights[i].color[a];
            lights[i].directional = sc.lights[i].directional;
            need_point = need_point || !sc.lights[i].directional;
        }
        for (const SurfaceSpec& s : sc.objects)
            need_point = need_point || s.material.reflectivity > 0 || s.material.transparency > 0;
    }
};

/// mat_vec (transpose false) or mat_t_vec (true) of s.linear and v, with no
/// products where `identity` (linear is the identity to the bit) and every
/// v[a] is finite and nonzero.
///
/// Contract (-ffp-contract=off, round to nearest): both compute
/// out[r] = (m_0 v_0 + m_1 v_1) + m_2 v_2 with the row's (or column's) three
/// entries, here one exactly 1.0 and two +0.0. 1.0 * v_r = v_r exactly; +0.0
/// * v for a finite v is a zero (of either sign); and x + (+-0) = (+-0) + x = x
/// exactly for every nonzero x. So every sum, in either order, is v_r to the
/// bit. A zero v_r (whose sign the sum may change), an infinity or a NaN
/// (0 * inf = NaN) takes the products.
[[gnu::always_inline]] inline void linear_apply(const SurfaceSpec& s, bool identity, bool transpose, const double* v,
                                                double* out) {
    // From the bits: with the sign shifted out, a finite nonzero double is
    // 0 < b << 1 < 0x7ff << 53 (zero: 0; infinity: 0x7ff << 53; NaN: above),
    // i.e. (b << 1) - 1 < (0x7ff << 53) - 1 in unsigned arithmetic.
    std::uint64_t b[3];
    std::memcpy(b, v, sizeof b);
    constexpr std::uint64_t kTop = (std::uint64_t{0x7ff} << 53) - 1;
    const bool plain = identity & ((b[0] << 1) - 1 < kTop) & ((b[1] << 1) - 1 < kTop) & ((b[2] << 1) - 1 < kTop);
    if (plain) {
        for (int a = 0; a < 3; ++a) out[a] = v[a];
    } else if (transpose) {
        mat_t_vec(s.linear, v, out);
    } else {
        mat_vec(s.linear, v, out);
    }
}

/// gradient() from the flattened terms: the same complex operations in the
/// same order (a product by pw[b][0] = 1 included: it is not always exact
/// in complex arithmetic, e.g. for a signed zero or an infinity), only the
/// powers no term uses are not formed. The real parts, to the bit.
void gradient_flat(const ShadePlan::Object& ob, const Complex<double>* z, double* grad_re) {
    // The powers k = 1..max k_max, the axes side by side (as in
    // gradient_real: an axis's powers beyond its k_max are never read, each
    // one read is the same chain pw[k - 1][a] * z[a]).
    Complex<double> pw[kMaxDegree + 1][3];
    for (int a = 0; a < 3; ++a) pw[0][a] = Complex<double>(1.0, 0.0);
    for (int k = 1; k <= ob.k_top; ++k)
        for (int a = 0; a < 3; ++a) pw[k][a] = pw[k - 1][a] * z[a];
    Complex<double> grad[3] = {Complex<double>(0.0, 0.0), Complex<double>(0.0, 0.0), Complex<double>(0.0, 0.0)};
    for (const GradientTerm& g : ob.terms) {
        Complex<double> v(g.ce, 0.0);
        for (int b = 0; b < 3; ++b) v = v * pw[g.k[b]][b];
        grad[g.axis] = grad[g.axis] + v;
    }
    for (int a = 0; a < 3; ++a) grad_re[a] = grad[a].re;
}

/// The real parts of gradient() at a real point z = x + 0i (a real root:
/// t.im = 0, so z.im = 0 + t.im od = +0), in real arithmetic; false (and
/// nothing written) where that is not proven to give the same bits.
///
/// Contract: gradient()'s complex products are (a.re b.re - a.im b.im,
/// a.re b.im + a.im b.re). If every imaginary part is a zero and every
/// a.re b.re is a finite nonzero double, the real part is
/// a.re b.re - (+-0) = a.re b.re exactly and the imaginary part is again a
/// zero (finite * zero + zero * finite); the sums grad + v are the same
/// double additions in both. So the real parts agree to the bit as soon as
/// every real product formed (powers of x_a, ce times powers) is finite and
/// nonzero, and a product by 1 may then be skipped (x * 1 = x). The check:
/// with 2^lo_a <= |x_a| < 2^(lo_a + 1), L = min(0, min lo_a), H = max(0,
/// max lo_a + 1), D = degree, every exact product of ce (2^ce_lo <= |ce| <
/// 2^(ce_hi + 1)) and at most D coordinates lies in [2^(ce_lo + D L),
/// 2^(ce_hi + 1 + D H)); each of its at most D + 3 roundings (normal range,
/// round to nearest) changes it by a factor within (1 -+ 2^-53), and
/// (1 - 2^-53)^67 > 1/2, (1 + 2^-53)^67 < 2. So ce_lo + D L - 1 >= -1021
/// and ce_hi + D H + 2 <= 1023 keep every product normal and finite (by
/// induction over the chain: each partial product has a subset of the
/// factors, inside the same range since L <= 0 <= H), and likewise
/// D L - 1 >= -1021, D H + 1 <= 1023 for the powers alone.
bool gradient_real(const ShadePlan::Object& ob, const double* x, double* grad_re) {
    if (!ob.real_ok) return false;
    // The check above, per coordinate (ShadePlan::build): the biased
    // exponent f of x_a in [real_f_lo, real_f_hi] (within 1..0x7fe, so a
    // zero, subnormal or non-finite x_a takes the complex path).
    std::uint64_t b[3];
    std::memcpy(b, x, sizeof b);
    const std::uint32_t span = ob.real_f_hi - ob.real_f_lo;
    bool in = true;
    for (int a = 0; a < 3; ++a)
        in &= static_cast<std::uint32_t>((b[a] >> 52) & 0x7ff) - ob.real_f_lo <= span;
    if (!in) return false;
    // The powers k = 1..max k_max, the three axes side by side (an axis's
    // powers beyond its k_max are formed but never read; each one read is
    // the same chain pw[a][k - 1] * x[a] as before, so the same double).
    double pw[kMaxDegree + 1][3];
    for (int a = 0; a < 3; ++a) pw[0][a] = 1.0;
    for (int k = 1; k <= ob.k_top; ++k)
        for (int a = 0; a < 3; ++a) pw[k][a] = pw[k - 1][a] * x[a];
    double g[3] = {0.0, 0.0, 0.0};
    // (The factors by GradientTerm::f: the same products in the same order,
    // and products by pw[0][0] = 1.0, exact, in place of the branches.)
    const double* pwf = &pw[0][0];
    for (const GradientTerm& t : ob.terms) {
        const double v = ((t.ce * pwf[t.f[0]]) * pwf[t.f[1]]) * pwf[t.f[2]];
        g[t.axis] = g[t.axis] + v;
    }
    for (int a = 0; a < 3; ++a) grad_re[a] = g[a];
    return true;
}

// ---------------------------------------------------------------------------
// Tracing
// ---------------------------------------------------------------------------

/// The discs the decisions read (ObjectRoots::res), with RootsResult's
/// field names: discs[i], n_discs, n_infinite, wants_exact, escalation.
/// It points either at the tracer's own RootsResult (the scalar path, and a
/// batched sample whose discs refine changes) or straight at PrimaryBatch's
/// storage of the sample's RootsResult (no copy per sample), which stays
/// unchanged until the batch's next solve, after the sample's decisions.
struct RootsView {
    const RootDisc* discs = nullptr;
    std::int32_t n_discs = 0;
    std::int32_t n_infinite = 0;
    bool wants_exact = false;
    std::int32_t escalation = 0;
    void bind(const RootsResult& r) {
        discs = r.discs;
        n_discs = r.n_discs;
        n_infinite = r.n_infinite;
        wants_exact = r.wants_exact;
        escalation = r.escalation;
    }
};

/// One object's roots along the current ray.
///
/// For an object solved in a batch (PrimaryBatch::fill), res views the
/// batch's RootsResult, and poly and ray are copied only where something
/// reads them: poly for record (explain_pixel), ray where the object has a
/// clipping sphere (the only decisions that read it) or for record. A
/// batched object is never solved again by solve() (seeded is false), so
/// its poly is not needed there.
struct ObjectRoots {
    // (User-provided: a Tracer's slots are not zeroed first, some 2 KB of
    // discs and coefficients each; every field is written before it is
    // read, as for RootsResult.)
    ObjectRoots() {}
    RayCoefficients<double> poly;
    ObjectRay ray;
    RootsView res;      // what the decisions read
    RootsResult own;    // the discs of solve(), and refine's copy (writable())
    Status status = Status::Ok;
    bool seeded = false;
    bool complete = false;   // status Ok, finite, every disc verified
    bool outside_sphere = false;  // set_outside_sphere: not solved, a proven miss
    // The batch's lane merged its discs into clusters instead of solving
    // the row again (SoaRows::provisional): proven discs, which
    // PrimaryBatch::settle replaces with find_roots' answer from the lane's
    // approximations where a decision needs more than they prove.
    bool provisional = false;
    bool settled = false;  // (its merged discs did not decide: solved again, for --explain)
    bool have_dd = false;
    // ray.origin holds the object's plan origin (a primary ray's, as fill
    // and primary_ray_polynomial write it): fill need not copy it again.
    bool origin_is_plan = false;
    RayCoefficients<DoubleDouble> poly_dd;

    /// The discs as a RootsResult refine may change: own, holding a copy
    /// of the batch's discs first if res views the batch's (copy on write;
    /// the same fields fill used to copy). res views own afterwards; call
    /// res.bind(own) again after changing own's header.
    RootsResult& writable() {
        if (res.discs != own.discs) {
            own.n_discs = res.n_discs;
            own.n_infinite = res.n_infinite;
            own.wants_exact = res.wants_exact;
            own.escalation = res.escalation;
            std::copy(res.discs, res.discs + res.n_discs, own.discs);
            res.bind(own);
        }
        return own;
    }

    /// The ray provably misses the object's clipping sphere
    /// (detail::ray_misses_sphere): no root can be the pixel's, so nothing
    /// is solved, and the object holds no disc and blocks nothing (status
    /// Ok, complete: the decisions then see a proven miss, as they would
    /// with every disc's inside_clip No). Every header field is defined, as
    /// in set_non_finite.
    void set_outside_sphere() {
        set_empty(Status::Ok);
        complete = true;
        outside_sphere = true;
    }

    /// A ray polynomial whose coefficients are not all finite: nothing is
    /// solved or claimed. Every header field is defined (no discs, no
    /// roots at infinity, no root tier, not seeded), so nothing of the
    /// slot's previous sample (its escalation, say, which sets the pixel's
    /// ladder level) is read for this one.
    void set_non_finite() { set_empty(Status::NonFinite); }

private:
    /// No discs, no roots at infinity, no root tier, not seeded, not
    /// complete, with status s.
    void set_empty(Status s) {
        status = s;
        seeded = false;
        complete = false;
        outside_sphere = false;
        provisional = false;
        settled = false;
        own.n_discs = 0;
        own.n_infinite = 0;
        own.wants_exact = false;
        own.escalation = 0;
        res.bind(own);
    }
};

/// Per-disc decisions of the current ray.
struct DiscInfo {
    int object;
    int index;               // into the object's res.discs
    double lo, hi;           // modulus bounds
    bool real, at_origin, live, eligible;
    Verdict band, clip;
};

struct HitInfo {
    bool hit = false;
    int object = -1;
    RootDisc disc{};
    double modulus = kInf;
    int eligible = 0;
    std::uint8_t status = kCertified;
    std::uint8_t level = kLevelFirst;
};

struct Seeds {
    // Per object, the previous pixel's roots (in t).
    double re[kMaxDegree], im[kMaxDegree];
    bool valid = false;
};

/// Approximate band test of a disc's centre (for the picture of an
/// undecided pixel only; proves nothing).
bool centre_in_band(const RootDisc& d, double sigma, double delta, bool complex_space) {
    if (!complex_space) return std::fabs(d.im) <= 1e-9 * std::fabs(d.re) && d.re > 0.0;
    const double theta = std::fabs(std::atan2(d.im, d.re));
    return theta >= sigma && theta <= sigma + delta;
}

/// The root kernel an engine option names, Auto resolved to the widest this
/// CPU runs (plan_frame has refused the ones it does not run).
BatchIsa resolved_kernel(const EngineOptions& engine) {
    return engine.kernel == BatchIsa::Auto ? batch_isa_best() : engine.kernel;
}

/// The primary rays' root discs of a run of samples (consecutive cells of
/// one row of samples), solved ahead of their decisions: per object, the
/// samples' ray polynomials (with their coefficient radii) go into
/// find_roots_rows as one structure-of-arrays batch. Each row's discs carry
/// find_roots' contract for the family within the radii (the lanes prove
/// them with Smith's family term; rows the lanes drop are solved by
/// find_roots exactly as the scalar path solves them, without seeds), so
/// the decisions that follow, per sample, are proven as before. Objects of
/// degree above kBatchKernelMaxDegree, method "paper" and the scalar kernel
/// keep the sample-by-sample path (with neighbour seeds).
///
/// Seeds (degree 5 to 12, seed_from_neighbour): a lane starts from the roots
/// of the sample above it (the same cell of the previous row of samples of
/// the tile), the nearest neighbour that is already solved when a row is
/// batched; the first row of a tile starts on the circle. Seeds never change
/// what is proven, only how many Aberth sweeps a block needs.
class PrimaryBatch {
public:
    static constexpr int kCells = 32;  // samples per batch (two blocks of 16 lanes)

    PrimaryBatch(const FramePlan& plan, BatchIsa isa, bool cull) : plan_(plan), isa_(isa), cull_(cull) {
        static_assert(kCells == detail::kRunCells && kBatchKernelMaxDegree <= detail::kRunMaxDegree,
                      "PrimaryBatch's runs are primary_ray_polynomial_run's");
        const int n_obj = static_cast<int>(plan.scene.objects.size());
        objects_.resize(static_cast<std::size_t>(n_obj));
        for (int obj = 0; obj < n_obj; ++obj) {
            const int n = plan.scene.objects[obj].degree;
            Object& o = objects_[obj];
            o.batched = isa != BatchIsa::Scalar && plan.params.method != Method::Paper && n <= kBatchKernelMaxDegree;
            any_ = any_ || o.batched;
            if (!o.batched) continue;
            o.seeded = plan.params.seed_from_neighbour && n > 4;
            o.clipped = plan.scene.objects[obj].clip_radius > 0.0;
        }
    }

    /// Starts a tile whose rows of samples are `cells` wide: no seeds yet.
    void begin_tile(int cells) {
        row_cells_ = cells;
        for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
            Object& o = objects_[obj];
            if (!o.seeded) continue;
            const int n = plan_.scene.objects[obj].degree;
            o.above_re.assign(static_cast<std::size_t>(cells) * n, kNaN);
            o.above_im.assign(static_cast<std::size_t>(cells) * n, kNaN);
        }
    }

    /// True when some object is solved in batches.
    bool any() const { return any_; }
    bool batched(int obj) const { return objects_[obj].batched; }
    BatchIsa isa() const { return isa_; }

    /// Solves the primary rays along the unit world directions (dx[c],
    /// dy[c], dz[c]) of cells 0..cells-1 (cells <= kCells), which are cells
    /// first..first+cells-1 of the tile's row of samples (begin_tile's
    /// count). Per object, the cells' ray polynomials are computed lane by
    /// lane (primary_ray_polynomial_run: primary_ray_polynomial's bits) in
    /// structure-of-arrays form and go as they are into find_roots_soa
    /// (find_roots_rows' answers, row by row; a cell whose coefficients
    /// overflowed is skipped: nothing claimed, as solve() does; a row whose
    /// status is not Ok, the ray in the surface, keeps that status).
    void solve(const double* dx, const double* dy, const double* dz, int cells, int first) {
        const int n_obj = static_cast<int>(objects_.size());
        for (int obj = 0; obj < n_obj; ++obj) {
            Object& o = objects_[obj];
            if (!o.batched) continue;
            const int n = plan_.scene.objects[obj].degree;
            prepare(obj, dx, dy, dz, cells);
            // The seeds are the above arrays themselves (structure of
            // arrays along the tile's row of samples; a NaN in root 0 marks
            // a cell without seeds, which find_roots_soa starts on the
            // circle as before).
            SoaRows rows;
            rows.coeffs = &o.run.c[0][0];
            rows.radius = &o.run.r[0][0];
            rows.start_re = o.seeded ? o.above_re.data() + first : nullptr;
            rows.start_im = o.seeded ? o.above_im.data() + first : nullptr;
            rows.start_stride = row_cells_;
            rows.skip = o.skip;
            rows.rows = cells;
            rows.stride = kCells;
            rows.n_coeffs = n + 1;
            rows.provisional = o.provisional;
            rows.lane_re = o.lane_re;
            rows.lane_im = o.lane_im;
            find_roots_soa(rows, plan_.params.method, o.res, o.status, isa_);
            // What fill's ObjectRoots::complete was (status Ok, every disc
            // verified), once per cell here.
            for (int c = 0; c < cells; ++c) {
                bool complete = !o.skip[c] && o.status[c] == Status::Ok;
                if (complete) {
                    const RootDisc* dd = o.res[c].discs;
                    const int nd = o.res[c].n_discs;
                    int i = 0;
                    for (; i + 4 <= nd; i += 4)
                        complete &= dd[i].verified & dd[i + 1].verified & dd[i + 2].verified & dd[i + 3].verified;
                    for (; i < nd; ++i) complete &= dd[i].verified;
                }
                o.complete[c] = complete ? 1 : 0;
            }
            if (!o.seeded) continue;
            // These samples' roots seed the samples below them (as the
            // scalar path's seeds: every root, with multiplicity; NaN in
            // root 0 where there are not n).
            const std::size_t w = static_cast<std::size_t>(row_cells_);
            for (int c = 0; c < cells; ++c) {
                const std::size_t a = static_cast<std::size_t>(first + c);
                int m = 0;
                if (!o.skip[c] && o.provisional[c]) {
                    // (The lane's own approximations: n distinct ones, where
                    // its merged discs would repeat a cluster's centre.)
                    for (; m < n; ++m) {
                        o.above_re[m * w + a] = o.lane_re[c * n + m];
                        o.above_im[m * w + a] = o.lane_im[c * n + m];
                    }
                } else if (!o.skip[c] && o.status[c] == Status::Ok && o.res[c].n_infinite == 0) {
                    const RootsResult& res = o.res[c];
                    for (int i = 0; i < res.n_discs && m < n; ++i)
                        for (int k = 0; k < std::max(1, static_cast<int>(res.discs[i].count)) && m < n; ++k) {
                            o.above_re[m * w + a] = res.discs[i].re;
                            o.above_im[m * w + a] = res.discs[i].im;
                            ++m;
                        }
                }
                if (m != n) o.above_re[a] = kNaN;
            }
        }
    }

    /// solve's answers for its last cells (0..cells-1), appended to a root
    /// field's tape: per batched object and cell that was solved (not
    /// skipped: skip is recomputed on replay from the same polynomials),
    /// status, flags, the discs' header and discs, and for a provisional
    /// cell the lane's approximations settle starts from.
    void record(std::vector<std::uint8_t>& tape, int cells) const {
        for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
            const Object& o = objects_[obj];
            if (!o.batched) continue;
            const int n = plan_.scene.objects[obj].degree;
            for (int c = 0; c < cells; ++c) {
                if (o.skip[c]) continue;
                const RootsResult& res = o.res[c];
                const std::uint8_t head[5] = {static_cast<std::uint8_t>(o.status[c]),
                                              static_cast<std::uint8_t>((o.provisional[c] ? 1 : 0) |
                                                                        (res.wants_exact ? 2 : 0)),
                                              static_cast<std::uint8_t>(res.n_discs),
                                              static_cast<std::uint8_t>(res.n_infinite),
                                              static_cast<std::uint8_t>(res.escalation)};
                tape.insert(tape.end(), head, head + 5);
                for (int i = 0; i < res.n_discs; ++i) {
                    const RootDisc& d = res.discs[i];
                    put(tape, d.re);
                    put(tape, d.im);
                    put(tape, d.radius);
                    tape.push_back(static_cast<std::uint8_t>(d.count));
                    tape.push_back(static_cast<std::uint8_t>((d.verified ? 1 : 0) | (d.real ? 2 : 0)));
                }
                if (o.provisional[c])
                    for (int m = 0; m < n; ++m) {
                        put(tape, o.lane_re[c * n + m]);
                        put(tape, o.lane_im[c * n + m]);
                    }
            }
        }
    }

    /// solve without solving: the cells' ray polynomials, clip tests and
    /// skips as solve computes them (the same bits), their answers read from
    /// a root field's tape at `at` (record's layout), which `at` then
    /// passes. What fill and settle read afterwards is what they read after
    /// the solve that recorded the tape, so every decision is that solve's.
    /// Throws std::invalid_argument where the tape does not hold what the
    /// cells need (a tape of other rays, cut short or damaged).
    void replay(const double* dx, const double* dy, const double* dz, int cells, const std::uint8_t* tape,
                std::size_t size, std::size_t& at) {
        for (std::size_t k = 0; k < objects_.size(); ++k) {
            const int obj = static_cast<int>(k);
            Object& o = objects_[obj];
            if (!o.batched) continue;
            const int n = plan_.scene.objects[obj].degree;
            prepare(obj, dx, dy, dz, cells);
            for (int c = 0; c < cells; ++c) {
                o.provisional[c] = 0;
                o.complete[c] = 0;
                if (o.skip[c]) continue;
                need(size, at, 5);
                const std::uint8_t* h = tape + at;
                at += 5;
                const int n_discs = h[2], n_inf = h[3];
                if (h[0] > static_cast<int>(Status::TooLarge) || (h[1] & ~3) != 0 || n_discs > n || n_inf > n)
                    throw std::invalid_argument("root field: a damaged entry");
                RootsResult& res = o.res[c];
                o.status[c] = static_cast<Status>(h[0]);
                o.provisional[c] = (h[1] & 1) ? 1 : 0;
                res.wants_exact = (h[1] & 2) != 0;
                res.n_discs = n_discs;
                res.n_infinite = n_inf;
                res.escalation = h[4];
                bool complete = o.status[c] == Status::Ok;
                for (int i = 0; i < n_discs; ++i) {
                    need(size, at, 26);
                    RootDisc& d = res.discs[i];
                    std::memcpy(&d.re, tape + at, 8);
                    std::memcpy(&d.im, tape + at + 8, 8);
                    std::memcpy(&d.radius, tape + at + 16, 8);
                    d.count = tape[at + 24];
                    if ((tape[at + 25] & ~3) != 0 || d.count < 0 || d.count > n)
                        throw std::invalid_argument("root field: a damaged disc");
                    d.verified = (tape[at + 25] & 1) != 0;
                    d.real = (tape[at + 25] & 2) != 0;
                    at += 26;
                    complete = complete && d.verified;
                }
                o.complete[c] = complete ? 1 : 0;
                if (o.provisional[c]) {
                    need(size, at, static_cast<std::size_t>(16) * n);
                    for (int m = 0; m < n; ++m) {
                        std::memcpy(&o.lane_re[c * n + m], tape + at, 8);
                        std::memcpy(&o.lane_im[c * n + m], tape + at + 8, 8);
                        at += 16;
                    }
                }
            }
        }
    }

    /// Cell c's roots for object obj (batched(obj)), in the tracer's form:
    /// what primary_ray_polynomial and find_roots_rows gave before, read
    /// from the run's structure of arrays (coefficients and radii up to the
    /// degree, the discs that exist).
    /// `all`: also the polynomial and the ray whatever the object (record
    /// reads them); otherwise the ray only for an object with a clipping
    /// sphere and the polynomial not at all (see ObjectRoots). r.res views
    /// the batch's RootsResult of the cell (valid until the next solve).
    void fill(int obj, int c, ObjectRoots& r, bool all) const {
        const Object& o = objects_[obj];
        const detail::PrimaryRun& p = o.run;
        if (all) {
            const int n = p.n;
            r.poly.n = n;
            r.poly.finite = p.finite[c] != 0;
            for (int k = 0; k <= n; ++k) {
                r.poly.c[k] = p.c[k][c];
                r.poly.r[k] = p.r[k][c];
            }
        }
        if (all || o.clipped) {
            if (!r.origin_is_plan) {
                const FramePlan::ObjectPlan& op = plan_.objects[obj];
                for (int a = 0; a < 3; ++a) r.ray.origin[a] = op.origin[a];
                r.origin_is_plan = true;
            }
            r.ray.direction[0] = Ball(p.dir[0][c], p.dir_rad[0][c]);
            r.ray.direction[1] = Ball(p.dir[1][c], p.dir_rad[1][c]);
            r.ray.direction[2] = Ball(p.dir[2][c], p.dir_rad[2][c]);
        }
        r.seeded = false;
        if (o.outside[c]) {
            r.set_outside_sphere();
            return;
        }
        if (o.skip[c]) {
            r.set_non_finite();
            return;
        }
        r.outside_sphere = false;
        r.res.bind(o.res[c]);
        r.status = o.status[c];
        r.complete = o.complete[c] != 0;
        r.provisional = o.provisional[c] != 0;
        r.settled = false;
    }

    /// Cell c's ray polynomial coefficients for object obj (batched(obj)),
    /// c[0..degree]: the doubles its discs were proven for.
    void coefficients(int obj, int c, double* out) const {
        const detail::PrimaryRun& p = objects_[obj].run;
        for (int k = 0; k <= p.n; ++k) out[k] = p.c[k][c];
    }

    /// Replaces the provisional (merged) discs of cell c of object obj in
    /// r with find_roots' answer from the lane's approximations: what
    /// find_roots_soa answers without SoaRows::provisional, to the bit.
    void settle(int obj, int c, ObjectRoots& r) const {
        const Object& o = objects_[obj];
        const detail::PrimaryRun& p = o.run;
        const int n = p.n;
        double coeffs[kMaxDegree + 1], radius[kMaxDegree + 1];
        for (int k = 0; k <= n; ++k) {
            coeffs[k] = p.c[k][c];
            radius[k] = p.r[k][c];
        }
        r.status = detail::find_roots_lane_seeded(coeffs, n + 1, plan_.params.method, r.own, o.lane_re + c * n,
                                                  o.lane_im + c * n, radius);
        r.res.bind(r.own);
        r.complete = r.status == Status::Ok;
        for (int i = 0; i < r.res.n_discs && r.complete; ++i) r.complete = r.res.discs[i].verified;
        r.provisional = false;
        r.settled = true;
    }

private:
    /// The cells' ray polynomials of object obj (structure of arrays), its
    /// clip test and which cells are not solved (coefficients not finite,
    /// or the ray provably misses the clipping sphere).
    void prepare(int obj, const double* dx, const double* dy, const double* dz, int cells) {
        Object& o = objects_[obj];
        const SurfaceSpec& s = plan_.scene.objects[obj];
        detail::primary_ray_polynomial_run(s, plan_.objects[obj], dx, dy, dz, cells, o.run, isa_);
        // A cell whose ray provably misses the clipping sphere is not
        // solved either (intersect's test, on the same balls).
        if (o.clipped && cull_) {
            detail::ObjectRay ray;
            for (int a = 0; a < 3; ++a) ray.origin[a] = plan_.objects[obj].origin[a];
            for (int c = 0; c < cells; ++c) {
                for (int a = 0; a < 3; ++a) ray.direction[a] = Ball(o.run.dir[a][c], o.run.dir_rad[a][c]);
                o.outside[c] = detail::ray_misses_sphere(ray, s.clip_radius) ? 1 : 0;
            }
        }
        for (int c = 0; c < cells; ++c) o.skip[c] = o.run.finite[c] == 0 || o.outside[c] != 0;
    }

    static void put(std::vector<std::uint8_t>& tape, double v) {
        std::uint8_t b[8];
        std::memcpy(b, &v, 8);
        tape.insert(tape.end(), b, b + 8);
    }

    static void need(std::size_t size, std::size_t at, std::size_t bytes) {
        if (at > size || size - at < bytes) throw std::invalid_argument("root field: the tape ends early");
    }

    struct Object {
        // (User-provided: objects_ is not zeroed first, some 70 KB per
        // object per tile; res, status and complete are written by solve
        // before fill reads them, run by primary_ray_polynomial_run.)
        Object() {}
        bool batched = false;
        bool seeded = false;   // lanes start from the roots of the sample above
        detail::PrimaryRun run;  // the cells' ray polynomials (structure of arrays)
        std::uint8_t skip[kCells] = {};  // cell not solved: coefficients not finite, or outside
        std::uint8_t outside[kCells] = {};  // the cell's ray provably misses the clipping sphere
        // Seeds: root i of the sample above cell c of the tile's row of
        // samples at [i * row_cells_ + c] (NaN at i = 0: none).
        std::vector<double> above_re, above_im;
        RootsResult res[kCells];
        Status status[kCells];
        std::uint8_t complete[kCells];  // solved, status Ok, every disc verified
        std::uint8_t provisional[kCells];  // SoaRows::provisional (its lane's merged discs)
        double lane_re[kCells * kBatchKernelMaxDegree], lane_im[kCells * kBatchKernelMaxDegree];  // (cell c's at c * n)
        bool clipped = false;  // a clipping sphere: the decisions read the ray
    };
    const FramePlan& plan_;
    BatchIsa isa_;
    bool cull_;  // rays that provably miss the clipping sphere are not solved
    bool any_ = false;
    int row_cells_ = 0;
    std::vector<Object> objects_;
};

/// A sample's place in a solved PrimaryBatch.
struct BatchedCell {
    const PrimaryBatch* batch;
    int cell;
};

class Tracer {
public:
    explicit Tracer(const FramePlan& plan, const ExactSolver* exact = nullptr, bool cull = true)
        : plan_(plan), exact_(exact), cull_(cull) {
        const int levels = plan.params.max_depth + 2;
        scratch_.resize(static_cast<std::size_t>(levels) * plan.scene.objects.size());
        infos_.resize(static_cast<std::size_t>(levels));
        const DecideMode mode = plan.params.engine.decide;
        full_only_ = mode == DecideMode::Full;
        classify_ = detail::classify_discs_best(mode == DecideMode::FastScalar);
        for (const SurfaceSpec& s : plan.scene.objects) {
            classify_plans_.push_back(detail::classify_plan(plan, s.complex_space, s.clip_radius));
            seed_objects_ = seed_objects_ || (s.degree > 4 && plan.params.seed_from_neighbour);
        }
    }

    std::int64_t root_calls = 0;

    /// Intersects a ray with every object and decides the pixel's root,
    /// climbing the ladder while the decision is not proven. `primary`: the
    /// ray is a primary ray (the plan's eye, the Taylor plan). `trace`
    /// (optional) receives every decision.
    /// `pre` (primary rays only): the sample's roots, solved in a batch, for
    /// the objects the batch covers.
    /// `filled` (with pre): intersect_batched has put the batch's roots in
    /// the depth-0 slots already and decide_fast did not certify them: they
    /// are not filled again, and decided in full straight away.
    HitInfo intersect(const double* o, const double* d, bool primary, Seeds* seeds, int depth, PixelExplanation* trace,
                      const BatchedCell* pre = nullptr, bool filled = false) {
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        const int slot = std::min(depth, plan_.params.max_depth + 1);
        ObjectRoots* roots = scratch_.data() + static_cast<std::size_t>(slot) * n_obj;
        std::vector<DiscInfo>& infos = infos_[slot];
        bool any_seeded = false;
        std::uint8_t level = kLevelFirst;
        recording_ = trace != nullptr;
        for (int obj = 0; obj < n_obj; ++obj) {
            const SurfaceSpec& s = plan_.scene.objects[obj];
            ObjectRoots& r = roots[obj];
            if (primary && pre != nullptr && pre->batch->batched(obj)) {
                if (!filled) pre->batch->fill(obj, pre->cell, r, trace != nullptr);
                if (!r.outside_sphere) ++root_calls;
                r.have_dd = false;
                if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
                continue;
            }
            if (primary) detail::primary_ray_polynomial(s, plan_.objects[obj], d, r.poly, r.ray);
            else detail::general_ray_polynomial(s, o, d, r.poly, r.ray);
            r.origin_is_plan = primary;
            r.have_dd = false;
            if (cull_ && s.clip_radius > 0.0 && detail::ray_misses_sphere(r.ray, s.clip_radius)) {
                r.set_outside_sphere();  // (not solved: no root call)
                continue;
            }
            const bool use_seed = seeds && seeds[obj].valid && plan_.params.seed_from_neighbour && s.degree > 4;
            solve(r, s.degree, use_seed ? seeds + obj : nullptr);
            any_seeded = any_seeded || r.seeded;
            if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
        }
        HitInfo h = filled ? decide_full(roots, infos) : decide(roots, infos);
        if (h.status != kCertified && primary && pre != nullptr) {
            // Discs a lane merged into clusters did not prove the pixel:
            // the rows solved as find_roots_soa would without merging, and
            // decided again (the batch's answer; not a ladder level).
            bool settled = false;
            for (int obj = 0; obj < n_obj; ++obj) {
                ObjectRoots& r = roots[obj];
                if (!r.provisional) continue;
                pre->batch->settle(obj, pre->cell, r);
                settled = true;
                if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
            }
            if (settled) h = decide(roots, infos);
        }
        if (h.status != kCertified && any_seeded) {
            level = kLevelUnseeded;
            for (int obj = 0; obj < n_obj; ++obj)
                if (roots[obj].seeded) solve(roots[obj], plan_.scene.objects[obj].degree, nullptr);
            h = decide(roots, infos);
        }
        if (h.status != kCertified && primary && refine(roots, infos)) {
            level = kLevelDoubleDouble;
            h = decide(roots, infos);
        }
        const bool exact_tier = h.status != kCertified && primary && exact_ && *exact_ &&
                                plan_.params.exact_pixels_per_tile > 0 && plan_.params.method != Method::Unverified &&
                                (trace != nullptr || !explaining_);
        bool exact_ran = false;
        if (exact_tier) {
            // Level 4: the exact tier, within the tile's budget (--explain
            // runs it for its pixel whatever the budget).
            if (trace == nullptr && exact_used_ >= plan_.params.exact_pixels_per_tile) {
                level = kLevelExactOverCap;
            } else {
                ++exact_used_;
                ExactQuery q{pixel_x_, pixel_y_, Ray{}, trace != nullptr};
                for (int a = 0; a < 3; ++a) {
                    q.ray.origin[a] = o[a];
                    q.ray.direction[a] = d[a];
                }
                // (The answer, strings and all, exists only here: not
                // made and destroyed for every ray.)
                ExactAnswer answer = (*exact_)(plan_, q);
                exact_ran = true;
                level = answer.multiple ? kLevelExactMultiple : kLevelExact;
                h.status = answer.status;
                if (answer.decided) {
                    h.hit = answer.hit;
                    h.eligible = answer.eligible;
                    if (answer.hit) {
                        h.object = answer.object;
                        h.disc = RootDisc{answer.re, answer.im, 0.0, 1, true, answer.im == 0.0};
                        h.modulus = answer.modulus;
                    } else {
                        h.object = -1;
                        h.modulus = kInf;
                    }
                }
                if (trace) trace->exact = std::move(answer);
            }
        }
        if (h.hit && detail::wants_polish(h.disc)) {
            double c[kMaxDegree + 1];
            const int n = plan_.scene.objects[h.object].degree;
            if (primary && pre != nullptr && pre->batch->batched(h.object)) pre->batch->coefficients(h.object, pre->cell, c);
            else std::copy(roots[h.object].poly.c, roots[h.object].poly.c + n + 1, c);
            polish(h, c, n);
        }
        h.level = level;
        if (seeds && seed_objects_) {
            // Only for the objects whose seeds a later sample may read: the
            // scalar path's (intersect's use_seed: degree > 4 and
            // seed_from_neighbour), and not those this batch solves (the
            // batch's lanes take their seeds from its own arrays; a tile
            // with a batch gives every primary sample its BatchedCell).
            // Any other object's Seeds stay as they were, never read.
            for (int obj = 0; obj < n_obj; ++obj) {
                const int n = plan_.scene.objects[obj].degree;
                if (n <= 4 || !plan_.params.seed_from_neighbour) continue;
                if (primary && pre != nullptr && pre->batch->batched(obj)) continue;
                const ObjectRoots& r = roots[obj];
                int m = 0;
                for (int i = 0; i < r.res.n_discs && m < n; ++i)
                    for (int c = 0; c < std::max(1, static_cast<int>(r.res.discs[i].count)) && m < n; ++c) {
                        seeds[obj].re[m] = r.res.discs[i].re;
                        seeds[obj].im[m] = r.res.discs[i].im;
                        ++m;
                    }
                seeds[obj].valid = r.status == Status::Ok && m == n && r.res.n_infinite == 0;
            }
        }
        if (trace) {
            record(roots, infos, h, trace);
            trace->exact_ran = exact_ran;
            if (!exact_ran) trace->exact = ExactAnswer{};
            if (exact_ran && trace->exact.decided) trace->chosen = -1;  // the root is the exact tier's
            trace->root_re = h.disc.re;
            trace->root_im = h.disc.im;
        }
        return h;
    }

    /// intersect for a primary ray whose objects the batch solved, every
    /// one of them (pre), in the common case: decide_fast certifies the
    /// pixel. Then it does what intersect does for that ray (the batch's
    /// roots into the depth-0 slots, the level, decide's result, the root
    /// calls counted) without the rest of the ladder, and returns true with
    /// h (default-constructed by the caller) exactly intersect's result.
    /// Otherwise false (nothing counted, h unspecified), with `filled` true
    /// when the slots hold the batch's roots (decide_fast ran and did not
    /// certify): the caller runs intersect with that, which decides them in
    /// full without filling them again.
    bool intersect_batched(const BatchedCell& pre, HitInfo& h, bool& filled) {
        filled = false;
        if (full_only_) return false;
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        ObjectRoots* roots = scratch_.data();  // (depth 0's slots)
        std::uint8_t level = kLevelFirst;
        recording_ = false;
        int calls = 0;
        for (int obj = 0; obj < n_obj; ++obj) {
            ObjectRoots& r = roots[obj];
            pre.batch->fill(obj, pre.cell, r, false);
            r.have_dd = false;
            calls += !r.outside_sphere;
            if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
        }
        // (decide_fast, for one object straight to its decide_one.)
        filled = true;
        if (!(n_obj == 1 ? decide_one(roots, h) : decide_fast(roots, h))) return false;
        root_calls += calls;
        if (h.hit && detail::wants_polish(h.disc)) {
            double c[kMaxDegree + 1];
            pre.batch->coefficients(h.object, pre.cell, c);
            polish(h, c, plan_.scene.objects[h.object].degree);
        }
        h.level = level;
        return true;
    }

    /// The hit's value (its disc's centre, which the AOVs and the shading
    /// read) replaced by the disc's one root to double accuracy
    /// (polish_root), where it settles; the disc's proof and the decision
    /// stay. So a wide disc writes its root, not the solver's approximation.
    static void polish(HitInfo& h, const double* c, int n) {
        double re, im;
        if (!detail::polish_root(c, n, h.disc, re, im)) return;
        h.disc.re = re;
        h.disc.im = im;
        h.modulus = im == 0.0 && !std::isnan(re) ? std::fabs(re) : std::hypot(re, im);
    }

    /// Colour seen along a ray (recursion for real reflective / transparent
    /// objects). `hit` is the already computed intersection.
    void shade(const double* o, const double* d, const HitInfo& hit, int depth, double* rgb) {
        const SceneSpec& sc = plan_.scene;
        if (!hit.hit) {
            for (int a = 0; a < 3; ++a) rgb[a] = sc.background[a];
            return;
        }
        if (!shading_ready_) {
            shading_.build(plan_);
            shading_ready_ = true;
        }
        const SurfaceSpec& s = sc.objects[hit.object];
        const ShadePlan::Object& sob = shading_.objects[hit.object];
        const Material& m = s.material;
        const bool ref = shading_.reference;
        // Hit point: distance |t| along the ray (a real point for every root).
        // (Read only by a point light and the bounces: formed only where
        // one of them may read it.)
        double p[3];
        if (ref || shading_.need_point) for (int a = 0; a < 3; ++a) p[a] = o[a] + hit.modulus * d[a];
        // Normal: real part of grad F at the complex point o' + t d'.
        // (The primary rays' origin, the eye, is in object space once per
        // frame: the same to_object, the same bits. Depth 0 is a primary
        // ray, whose origin is the eye's doubles: trace_sample.)
        double oo[3], od[3];
        if (!ref && (depth == 0 || std::memcmp(o, plan_.eye, sizeof oo) == 0)) {
            for (int a = 0; a < 3; ++a) oo[a] = sob.eye_object[a];
        } else {
            to_object(s, o, oo);
        }
        if (ref) {
            mat_vec(s.linear, d, od);
        } else {
            linear_apply(s, sob.identity, false, d, od);
        }
        double gobj[3];
        bool real_done = false;
        if (ref) {
            const Complex<double> t(hit.disc.re, hit.disc.im);
            Complex<double> z[3], g[3];
            for (int a = 0; a < 3; ++a) z[a] = Complex<double>(oo[a], 0.0) + mul_real(t, od[a]);
            gradient(s, z, g);
            for (int a = 0; a < 3; ++a) gobj[a] = g[a].re;
            real_done = true;
        } else if (hit.disc.im == 0.0) {
            // A real root: z = oo + t.re od (+0 i), in real arithmetic
            // where gradient_real proves the bits are gradient()'s.
            double x[3];
            for (int a = 0; a < 3; ++a) x[a] = oo[a] + hit.disc.re * od[a];
            real_done = gradient_real(sob, x, gobj);
        }
        if (!real_done) {
            const Complex<double> t(hit.disc.re, hit.disc.im);
            Complex<double> z[3];
            for (int a = 0; a < 3; ++a) z[a] = Complex<double>(oo[a], 0.0) + mul_real(t, od[a]);
            gradient_flat(sob, z, gobj);
        }
        double n[3];
        if (ref) {
            mat_t_vec(s.linear, gobj, n);
        } else {
            linear_apply(s, sob.identity, true, gobj, n);
        }
        normalize3(n);
        if (dot3(n, d) > 0) for (double& v : n) v = -v;
        // Base colour, or hue by argument.
        double base[3] = {m.color[0], m.color[1], m.color[2]};
        if (plan_.params.hue_by_argument && s.complex_space) {
            const double theta =
                std::fabs(ref ? std::atan2(hit.disc.im, hit.disc.re) : argument_of(hit.disc.im, hit.disc.re));
            const double h = std::fmod(theta / kPi * 6.0 * 2.0, 6.0);  // hue sweep over [0, pi/2]
            const double x = 1 - std::fabs(std::fmod(h, 2.0) - 1);
            const double hues[6][3] = {{1, x, 0}, {x, 1, 0}, {0, 1, x}, {0, x, 1}, {x, 0, 1}, {1, 0, x}};
            const int i = std::min(5, static_cast<int>(h));
            for (int a = 0; a < 3; ++a) base[a] = 0.25 + 0.75 * hues[i][a];
        }
        double local[3] = {0, 0, 0};
        const double ambient = 0.12;
        for (int a = 0; a < 3; ++a) local[a] = ambient * base[a];
        const std::size_t n_lights = shading_.lights.size();
        for (std::size_t li = 0; li < n_lights; ++li) {
            const ShadePlan::LightRec& rec = shading_.lights[li];
            double L[3];
            if (rec.directional && !ref) {
                for (int a = 0; a < 3; ++a) L[a] = rec.dir[a];  // normalize3(vector), once
            } else if (rec.directional) {
                for (int a = 0; a < 3; ++a) L[a] = sc.lights[li].vector[a];
                normalize3(L);
            } else {
                for (int a = 0; a < 3; ++a) L[a] = sc.lights[li].vector[a] - p[a];
                normalize3(L);
            }
            const double ndl = dot3(n, L);
            if (ndl <= 0) continue;
            double R[3];
            for (int a = 0; a < 3; ++a) R[a] = 2 * ndl * n[a] - L[a];
            const double rv = std::max(0.0, -dot3(R, d));
            if (ref) {
                const Light& l = sc.lights[li];
                const double spec = m.specular * std::pow(rv, m.shininess);
                for (int a = 0; a < 3; ++a)
                    local[a] += l.intensity * l.color[a] * (m.diffuse * ndl * base[a] + spec);
                continue;
            }
            const double* ic = rec.ic;  // l.intensity * l.color[a], once
            // The diffuse terms m.diffuse * ndl * base[a], as parsed.
            const double dn = m.diffuse * ndl;
            const double diffuse[3] = {dn * base[0], dn * base[1], dn * base[2]};
            if (rv > 0.0 && rv <= 1.0 && rv <= sob.spec_rv_cut &&
                specular_negligible(sob.spec_k, rv, m.specular, diffuse)) {
                // diffuse[a] + spec == diffuse[a] for every a: no pow.
                for (int a = 0; a < 3; ++a) local[a] += ic[a] * diffuse[a];
                continue;
            }
            // pow(+0, y) = +0 for every y > 0 (C11 F.10.4.4): no call.
            const double spec = m.specular * (rv == 0.0 && m.shininess > 0 ? 0.0 : std::pow(rv, m.shininess));
            for (int a = 0; a < 3; ++a) local[a] += ic[a] * (diffuse[a] + spec);
        }
        // Depth cue from the modulus (the paper colours by the minimum
        // modulus): roots nearer than the scene's centre are brighter.
        // (exp(-0) = 1 exactly: no call for the near roots.)
        const double cue_arg = std::max(0.0, hit.modulus / plan_.scene_distance - 0.6);
        const double cue = !ref && cue_arg == 0.0 ? 1.0 : std::exp(-cue_arg);
        for (double& v : local) v *= 0.55 + 0.45 * cue;
        const bool bounces = !s.complex_space && depth < plan_.params.max_depth &&
                             (m.reflectivity > 0 || m.transparency > 0);
        if (!bounces) {
            for (int a = 0; a < 3; ++a) rgb[a] = local[a];
            return;
        }
        const double w_local = std::max(0.0, 1.0 - m.reflectivity - m.transparency);
        for (int a = 0; a < 3; ++a) rgb[a] = w_local * local[a];
        const double eps = 1e-6 * (1.0 + hit.modulus);
        const double cosi = -dot3(n, d);
        if (m.reflectivity > 0) {
            double rd[3], ro[3], col[3];
            for (int a = 0; a < 3; ++a) rd[a] = d[a] + 2 * cosi * n[a];
            normalize3(rd);
            for (int a = 0; a < 3; ++a) ro[a] = p[a] + eps * n[a];
            const HitInfo h2 = intersect(ro, rd, false, nullptr, depth + 1, nullptr);
            shade(ro, rd, h2, depth + 1, col);
            for (int a = 0; a < 3; ++a) rgb[a] += m.reflectivity * col[a];
        }
        if (m.transparency > 0) {
            // Entering or leaving: compare the original gradient's side.
            double gworld[3];
            mat_t_vec(s.linear, gobj, gworld);
            const bool entering = dot3(gworld, d) < 0;  // F grows outward
            const double eta = entering ? 1.0 / m.ior : m.ior;
            const double k = 1 - eta * eta * (1 - cosi * cosi);
            double td[3], to[3], col[3];
            if (k < 0) {  // total internal reflection
                for (int a = 0; a < 3; ++a) td[a] = d[a] + 2 * cosi * n[a];
            } else {
                for (int a = 0; a < 3; ++a) td[a] = eta * d[a] + (eta * cosi - std::sqrt(k)) * n[a];
            }
            normalize3(td);
            for (int a = 0; a < 3; ++a) to[a] = p[a] + eps * td[a];
            const HitInfo h2 = intersect(to, td, false, nullptr, depth + 1, nullptr);
            shade(to, td, h2, depth + 1, col);
            for (int a = 0; a < 3; ++a) rgb[a] += m.transparency * col[a] * (0.6 + 0.4 * base[a]);
        }
    }

    ShadePlan shading_;           // shade()'s per-frame data, built on its first hit
    bool shading_ready_ = false;


private:
    /// find_roots on the object's ray polynomial (with its coefficient radii).
    void solve(ObjectRoots& r, int degree, const Seeds* seed) {
        ++root_calls;
        r.outside_sphere = false;
        r.provisional = r.settled = false;
        if (!r.poly.finite) {
            r.set_non_finite();  // (not seeded: no seed was used, so no retry without)
            return;
        }
        r.seeded = seed != nullptr;
        r.status = find_roots(r.poly.c, degree + 1, plan_.params.method, r.own, seed ? seed->re : nullptr,
                              seed ? seed->im : nullptr, r.poly.r);
        r.res.bind(r.own);
        r.complete = r.status == Status::Ok;
        for (int i = 0; i < r.res.n_discs && r.complete; ++i) r.complete = r.res.discs[i].verified;
    }

    /// Level 3: double-double ray coefficients; a polynomial with a live
    /// cluster is re-isolated from scratch (isolate_dd), and every live
    /// verified count-1 disc is shrunk. True if any disc changed.
    bool refine(ObjectRoots* roots, const std::vector<DiscInfo>& infos) {
        bool changed = false;
        auto ensure_dd = [&](int obj) {
            ObjectRoots& r = roots[obj];
            if (!r.have_dd) {
                detail::primary_ray_polynomial_dd(plan_.scene.objects[obj], plan_.objects[obj], current_direction_,
                                                  r.poly_dd);
                r.have_dd = true;
            }
        };
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        std::vector<bool> isolated(n_obj, false);
        for (const DiscInfo& info : infos) {
            ObjectRoots& r = roots[info.object];
            if (!info.live || isolated[info.object] || !r.complete) continue;
            if (r.res.discs[info.index].count < 2) continue;
            ensure_dd(info.object);
            const bool done = detail::isolate_dd(r.poly_dd, r.writable());
            r.res.bind(r.own);  // (its header may have changed)
            if (done) {
                isolated[info.object] = true;
                changed = true;
            }
        }
        for (const DiscInfo& info : infos) {
            if (!info.live || info.at_origin || isolated[info.object]) continue;
            ObjectRoots& r = roots[info.object];
            if (!r.complete || r.res.discs[info.index].count != 1) continue;
            ensure_dd(info.object);
            RootDisc& disc = r.writable().discs[info.index];
            const bool real_before = info.real;
            if (detail::refine_disc_dd(r.poly_dd, real_before, disc)) {
                // A proven real root stays real: its disc is now centred on
                // the axis (Newton on the real line) and symmetric.
                if (real_before) disc.real = true;
                changed = true;
            }
        }
        return changed;
    }

    /// The pixel's decision from the current discs (see PixelStatus): the
    /// fast path when it decides, else the full one.
    HitInfo decide(ObjectRoots* roots, std::vector<DiscInfo>& infos) {
        HitInfo h;
        if (!recording_ && !full_only_ && decide_fast(roots, h)) return h;
        return decide_full(roots, infos);
    }

    /// The fast path of decide, for the common pixel: every object's roots
    /// complete (status Ok, every disc verified) and the result certified.
    /// It makes decide_full's decisions with the same predicates
    /// (detail::classify_discs_*: the *_fast forms of pixel_decision.h, four
    /// discs per vector where AVX2 runs, which return exactly what
    /// decide_full's references return), in the same order over the discs,
    /// but keeps only the live discs (in a fixed array), decides realness
    /// only where the band verdict depends on it, and uses moduli and the
    /// sphere only for discs not proven out of the band (as decide_full).
    /// True, with h (default-constructed by the caller) exactly
    /// decide_full's result, when the pixel is
    /// certified; false (h unspecified) for any other outcome (a blocked
    /// choice, a cluster chosen, more live discs than the array holds, an
    /// incomplete or degenerate object), which decide_full then decides
    /// (and fills `infos` for refine / record). (chosen_ is left alone: only
    /// record reads it, and record's pixels take the full path.)
    bool decide_fast(const ObjectRoots* roots, HitInfo& h) const {
        struct Live {
            double lo, hi;
            int object, index;
        };
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        if (n_obj == 1) return decide_one(roots, h);
        detail::DiscVerdicts v;
        constexpr int kLive = 2 * kMaxDegree;
        Live live[kLive];
        int n_live = 0, eligible = 0, best = -1;
        for (int obj = 0; obj < n_obj; ++obj) {
            const ObjectRoots& r = roots[obj];
            if (r.status != Status::Ok || !r.complete) return false;  // (degenerate or incomplete)
            // decide_full's verdicts: band (with proven_real, every disc
            // verified), then (not proven out of the band) moduli and sphere.
            classify_(r.res.discs, r.res.n_discs, classify_plans_[obj], r.ray, v);
            for (std::uint64_t m = v.live; m != 0; m &= m - 1) {
                const int i = __builtin_ctzll(m);
                if (n_live == kLive) return false;
                live[n_live] = Live{v.lo[i], v.hi[i], obj, i};
                if ((v.eligible >> i) & 1) {
                    eligible += r.res.discs[i].count;
                    if (best < 0 || v.hi[i] < live[best].hi) best = n_live;
                }
                ++n_live;
            }
        }
        // decide_full's proof of the choice; any blocking disc: not certified.
        if (best < 0) {
            if (n_live > 0) return false;
        } else {
            const Live& b = live[best];
            const ObjectRoots& rb = roots[b.object];
            if (rb.res.discs[b.index].count > 1) return false;  // a cluster chosen
            for (int i = 0; i < n_live; ++i) {
                if (i == best) continue;
                const Live& j = live[i];
                if (b.hi < j.lo) continue;
                if (j.object == b.object && detail::is_mirror_twin_fast(rb.res.discs, rb.res.n_discs, b.index, j.index))
                    continue;
                return false;
            }
        }
        // (h is decide's default HitInfo: no hit, certified, level first.)
        h.eligible = eligible;
        h.status = kCertified;
        if (best >= 0) set_hit(roots, live[best].object, live[best].index, h);
        return true;
    }

    /// decide_fast for a scene of one object: the same decisions from the
    /// discs' verdicts and choice (classify_discs_*, finish_choice).
    bool decide_one(const ObjectRoots* roots, HitInfo& h) const {
        const ObjectRoots& r = roots[0];
        if (r.status != Status::Ok || !r.complete) return false;  // (degenerate or incomplete)
        if (r.outside_sphere) {  // (no disc: a proven miss)
            h.eligible = 0;
            h.status = kCertified;
            return true;
        }
        const RootDisc* discs = r.res.discs;
        detail::DiscVerdicts v;
        classify_(discs, r.res.n_discs, classify_plans_[0], r.ray, v);
        if (v.best < 0) {
            if (v.live != 0) return false;  // (a live disc blocks the miss)
            h.eligible = 0;
            h.status = kCertified;
            return true;
        }
        if (discs[v.best].count > 1) return false;  // a cluster chosen
        if (v.blockers != 0 && !blockers_are_twins(discs, r.res.n_discs, v.best, v.blockers)) return false;
        h.eligible = v.count;
        h.status = kCertified;
        set_hit(roots, 0, v.best, h);
        return true;
    }

    /// Each disc of `blockers` holds exactly the conjugate of best's root
    /// (decide_full's proof for a disc not beyond best).
    __attribute__((noinline)) static bool blockers_are_twins(const RootDisc* discs, int n, int best,
                                                             std::uint64_t blockers) {
        for (; blockers != 0; blockers &= blockers - 1)
            if (!detail::is_mirror_twin_fast(discs, n, best, __builtin_ctzll(blockers))) return false;
        return true;
    }

    /// h shows disc `index` of object `object` (decide_fast and decide_full).
    static void set_hit(const ObjectRoots* roots, int object, int index, HitInfo& h) {
        h.hit = true;
        h.object = object;
        h.disc = roots[object].res.discs[index];
        // hypot(x, +-0) is |x| (C99 F.9.4.3); NaN keeps the call.
        h.modulus = h.disc.im == 0.0 && !std::isnan(h.disc.re) ? std::fabs(h.disc.re) : std::hypot(h.disc.re, h.disc.im);
    }

    /// The full decision, every disc's verdicts in `infos`.
    HitInfo decide_full(ObjectRoots* roots, std::vector<DiscInfo>& infos) {
        const FrameParams& fp = plan_.params;
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        infos.clear();
        bool incomplete = false, degenerate = false;
        for (int obj = 0; obj < n_obj; ++obj) {
            const ObjectRoots& r = roots[obj];
            const SurfaceSpec& s = plan_.scene.objects[obj];
            if (r.status == Status::ZeroPolynomial) {  // the ray lies in the surface
                degenerate = true;
                continue;
            }
            if (!r.complete) incomplete = true;
            if (r.status != Status::Ok) continue;
            for (int i = 0; i < r.res.n_discs; ++i) {
                const RootDisc& disc = r.res.discs[i];
                if (disc.count <= 0) continue;
                DiscInfo info{};
                info.object = obj;
                info.index = i;
                if (!disc.verified) {
                    detail::modulus_bounds(disc, info.lo, info.hi);
                    // Not enclosed: may be anywhere.
                    info.band = info.clip = Verdict::Unknown;
                    info.live = true;
                    infos.push_back(info);
                    continue;
                }
                // The exact root t = 0 (an exactly zero constant term): the
                // camera on the surface. Not a root the pixel shows.
                info.at_origin = disc.re == 0.0 && disc.im == 0.0 && disc.radius == 0.0;
                info.real = detail::proven_real(r.res.discs, r.res.n_discs, i, r.complete);
                info.band = detail::band_membership(disc, info.real, plan_, s.complex_space);
                // (Moduli and the sphere only matter for a root that may be in
                // the band.)
                if (info.band != Verdict::No) {
                    detail::modulus_bounds(disc, info.lo, info.hi);
                }
                info.clip = s.clip_radius <= 0.0 || info.band == Verdict::No
                                ? Verdict::Yes
                                : detail::inside_clip(r.ray, info.lo, info.hi, s.clip_radius);
                info.live = !info.at_origin && info.clip != Verdict::No && info.band != Verdict::No;
                info.eligible = info.live && info.clip == Verdict::Yes && info.band == Verdict::Yes;
                // (A disc proven out plays no further part; kept only for
                // --explain.)
                if (info.live || recording_) infos.push_back(info);
            }
        }
        HitInfo h;
        int best = -1;
        for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
            if (!infos[i].eligible) continue;
            h.eligible += roots[infos[i].object].res.discs[infos[i].index].count;
            if (best < 0 || infos[i].hi < infos[best].hi) best = i;
        }
        // Proof of the choice: every other live disc lies beyond the chosen
        // one, or holds exactly its conjugate.
        bool blocked = false, cluster_blocks = false;
        for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
            const DiscInfo& j = infos[i];
            if (!j.live || i == best) continue;
            if (best >= 0) {
                const DiscInfo& b = infos[best];
                if (b.hi < j.lo) continue;
                const ObjectRoots& r = roots[j.object];
                if (j.object == b.object &&
                    detail::is_mirror_twin(r.res.discs[b.index], r.res.discs[j.index], r.res.discs, r.res.n_discs, r.complete))
                    continue;
            }
            blocked = true;
            if (roots[j.object].res.discs[j.index].count > 1) cluster_blocks = true;
        }
        const bool best_cluster = best >= 0 && roots[infos[best].object].res.discs[infos[best].index].count > 1;
        if (degenerate) h.status = kCluster;
        else if (incomplete) h.status = kUnverified;
        else if (blocked) h.status = cluster_blocks ? kCluster : kUndecided;
        else if (best_cluster) h.status = kCluster;
        else h.status = kCertified;
        chosen_ = -1;
        if (!blocked && !incomplete && !degenerate) {
            chosen_ = best;
        } else {
            // Not proven: show the likeliest root (smallest centre modulus
            // among live discs whose centre looks eligible).
            double best_mod = kInf;
            for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
                const DiscInfo& j = infos[i];
                if (!j.live) continue;
                const RootDisc& disc = roots[j.object].res.discs[j.index];
                const SurfaceSpec& s = plan_.scene.objects[j.object];
                if (j.band == Verdict::Unknown && !centre_in_band(disc, fp.sigma, fp.delta, s.complex_space)) continue;
                if (j.clip == Verdict::Unknown && s.clip_radius > 0.0) {
                    const double m = std::hypot(disc.re, disc.im);
                    double p = 0.0;
                    for (int a = 0; a < 3; ++a) {
                        const double v = roots[j.object].ray.origin[a].mid + m * roots[j.object].ray.direction[a].mid;
                        p += v * v;
                    }
                    if (p > s.clip_radius * s.clip_radius) continue;
                }
                const double m = std::hypot(disc.re, disc.im);
                if (m < best_mod) {
                    best_mod = m;
                    chosen_ = i;
                }
            }
        }
        if (chosen_ >= 0) set_hit(roots, infos[chosen_].object, infos[chosen_].index, h);
        return h;
    }

    void record(const ObjectRoots* roots, const std::vector<DiscInfo>& infos, const HitInfo& h, PixelExplanation* t) const {
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        t->polynomials.clear();
        t->discs.clear();
        for (int obj = 0; obj < n_obj; ++obj) {
            const ObjectRoots& r = roots[obj];
            ExplainedPolynomial p;
            p.object = obj;
            p.coeffs.assign(r.poly.c, r.poly.c + plan_.scene.objects[obj].degree + 1);
            p.radius.assign(r.poly.r, r.poly.r + plan_.scene.objects[obj].degree + 1);
            p.roots_status = static_cast<int>(r.status);
            p.seeded = r.seeded;
            p.root_escalation = r.res.escalation;
            p.complete = r.complete && !r.outside_sphere;  // (no disc covers its roots: none was sought)
            p.outside_sphere = r.outside_sphere;
            p.provisional = r.provisional;
            p.settled = r.settled;
            t->polynomials.push_back(std::move(p));
        }
        for (const DiscInfo& i : infos) {
            ExplainedDisc e;
            e.object = i.object;
            e.disc = roots[i.object].res.discs[i.index];
            e.modulus_lo = i.lo;
            e.modulus_hi = i.hi;
            e.real = i.real;
            e.at_origin = i.at_origin;
            e.band = static_cast<std::uint8_t>(i.band);
            // (The sphere is not evaluated for a disc proven out of the band.)
            e.clip = i.band == Verdict::No ? 3 : static_cast<std::uint8_t>(i.clip);
            e.live = i.live;
            e.eligible = i.eligible;
            t->discs.push_back(e);
        }
        t->chosen = chosen_;
        t->hit = h.hit;
        t->status = h.status;
        t->level = h.level;
    }

public:
    double current_direction_[3] = {0, 0, 0};
    int pixel_x_ = 0, pixel_y_ = 0;  // the pixel being traced (for the exact tier)
    bool explaining_ = false;         // explain_pixel: the exact tier runs only for the traced pixel

private:
    const FramePlan& plan_;
    const ExactSolver* exact_ = nullptr;
    bool cull_ = true;  // ray_misses_sphere skips an object's roots (EngineOptions::cull)
    int exact_used_ = 0;  // pixels of this tile sent to the exact tier
    std::vector<ObjectRoots> scratch_;
    std::vector<std::vector<DiscInfo>> infos_;
    int chosen_ = -1;
    bool recording_ = false;  // keep every disc's decisions (explain_pixel)
    bool full_only_ = false;  // DecideMode::Full: decide_full for every pixel (the reference)
    std::vector<detail::ClassifyPlan> classify_plans_;  // per object: band and sphere constants of decide_fast
    detail::ClassifyDiscs classify_ = nullptr;  // decide_fast's verdicts (DecideMode::FastScalar: the scalar form)
    bool seed_objects_ = false;  // some object's Seeds are kept (degree > 4, seed_from_neighbour)
};

}  // namespace

bool band_rule_holds(double sigma, double delta) {
    if (!std::isfinite(sigma) || !std::isfinite(delta) || !(sigma >= 0.0) || !(delta >= 0.0)) return false;
    // Compare the exact sum s + err (TwoSum) with pi. kPiHi is the double
    // nearest pi; pi - kPiHi lies strictly between the double before kPiLo
    // and kPiLo (checked in core/tests/render_test.cpp with 60 digits). In
    // the binade of pi, s < kPiHi gives s + err <= s + ulp/2 < kPiHi, and
    // s > kPiHi gives s + err >= kPiHi + ulp/2 > pi.
    constexpr double kPiHi = 3.141592653589793116, kPiLo = 1.2246467991473532e-16;
    const double s = sigma + delta;
    if (s < kPiHi) return true;
    if (s > kPiHi) return false;
    const double bb = s - sigma;
    const double err = (sigma - (s - bb)) + (delta - bb);
    return err < kPiLo;
}

const char* decide_mode_name(DecideMode mode) {
    switch (mode) {
    case DecideMode::Fast: return "fast";
    case DecideMode::FastScalar: return "fast-scalar";
    case DecideMode::Full: return "full";
    }
    return "?";
}

const char* shade_mode_name(ShadeMode mode) { return mode == ShadeMode::Reference ? "reference" : "fast"; }

bool decide_mode_from_name(const std::string& name, DecideMode& out) {
    for (DecideMode m : {DecideMode::Fast, DecideMode::FastScalar, DecideMode::Full})
        if (name == decide_mode_name(m)) return out = m, true;
    return false;
}

bool shade_mode_from_name(const std::string& name, ShadeMode& out) {
    for (ShadeMode m : {ShadeMode::Fast, ShadeMode::Reference})
        if (name == shade_mode_name(m)) return out = m, true;
    return false;
}

FramePlan plan_frame(const SceneSpec& scene, const FrameParams& params) {
    if (scene.objects.empty()) throw std::invalid_argument("the scene has no objects");
    if (static_cast<int>(scene.objects.size()) > kMaxObjects)
        throw std::invalid_argument("the scene has " + std::to_string(scene.objects.size()) + " objects; at most " +
                                    std::to_string(kMaxObjects) + " are allowed");
    if (params.width < 1 || params.height < 1 || params.width > kMaxFrameSide || params.height > kMaxFrameSide)
        throw std::invalid_argument("frame size must be between 1x1 and " + std::to_string(kMaxFrameSide) + "x" +
                                    std::to_string(kMaxFrameSide));
    if (!band_rule_holds(params.sigma, params.delta))
        throw std::invalid_argument("the band (sigma = " + std::to_string(params.sigma) + ", delta = " +
                                    std::to_string(params.delta) + ") breaks the band rule: " + kBandRule);
    if (params.max_depth < 0 || params.max_depth > 16) throw std::invalid_argument("max_depth must be in 0..16");
    if (sample_side(params.samples) == 0)
        throw std::invalid_argument("samples must be a square from 1 to " + std::to_string(kMaxSamples) +
                                    " (1, 4, 9, 16, 25, 36, 49 or 64), got " + std::to_string(params.samples));
    if (params.exact_pixels_per_tile < 0)
        throw std::invalid_argument("exact_pixels_per_tile must be >= 0 (0: no exact tier)");
    if (params.exact_max_bits < 64 || params.exact_max_bits > kMaxExactBits)
        throw std::invalid_argument("exact_max_bits must be in 64.." + std::to_string(kMaxExactBits));
    if (!batch_isa_supported(params.engine.kernel))
        throw std::invalid_argument(std::string("kernel ") + batch_isa_name(params.engine.kernel) +
                                    ": this CPU does not run it (it runs " + batch_isa_name(BatchIsa::Auto) + ")");
    FramePlan plan;
    plan.scene = scene;
    plan.params = params;
    const CameraSpec& cam = scene.camera;
    for (int a = 0; a < 3; ++a) {
        plan.eye[a] = cam.position[a];
        plan.forward[a] = cam.look_at[a] - cam.position[a];
    }
    normalize3(plan.forward);
    cross3(plan.forward, cam.up, plan.right);
    if (dot3(plan.right, plan.right) < 1e-20) throw std::invalid_argument("camera up is parallel to the view direction");
    normalize3(plan.right);
    cross3(plan.right, plan.forward, plan.up);
    if (!(cam.fov_degrees > 0 && cam.fov_degrees < 180)) throw std::invalid_argument("fov must be in (0, 180) degrees");
    plan.tan_half_fov = std::tan(cam.fov_degrees * kPi / 360.0);
    double to_target[3];
    for (int a = 0; a < 3; ++a) to_target[a] = cam.look_at[a] - cam.position[a];
    plan.scene_distance = std::max(1e-9, std::sqrt(dot3(to_target, to_target)));
    plan.lower_edge = detail::band_edge(params.sigma, 0.0);
    plan.upper_edge = detail::band_edge(params.sigma, params.delta);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const SurfaceSpec& s = scene.objects[i];
        if (s.degree < 1 || s.degree > kMaxSurfaceDegree)
            throw std::invalid_argument("object " + std::to_string(i) + ": degree must be in 1.." +
                                        std::to_string(kMaxSurfaceDegree));
        FramePlan::ObjectPlan op;
        try {
            detail::plan_object(s, plan.eye, op);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("object " + std::to_string(i) + ": " + e.what());
        }
        plan.objects.push_back(std::move(op));
    }
    return plan;
}

int sample_side(int samples) {
    for (int side = 1; side * side <= kMaxSamples; ++side)
        if (side * side == samples) return side;
    return 0;
}

namespace {
Ray sample_ray(const FramePlan& plan, int sx_cell, int sy_cell, int side) {
    Ray r;
    for (int a = 0; a < 3; ++a) r.origin[a] = plan.eye[a];
    sample_direction(plan, sx_cell, sy_cell, side, r.direction);
    return r;
}
}  // namespace

Ray primary_ray(const FramePlan& plan, int x, int y, int sample) {
    const int side = sample_side(plan.params.samples);
    if (sample < 0 || sample >= plan.params.samples)
        throw std::invalid_argument("sample must be in 0.." + std::to_string(plan.params.samples - 1));
    return sample_ray(plan, side * x + sample % side, side * y + sample / side, side);
}

const char* render_kernel(const FramePlan& plan) { return batch_isa_name(resolved_kernel(plan.params.engine)); }

void ray_polynomial(const FramePlan& plan, int object, const double origin[3], const double direction[3], double* coeffs,
                    double* radius) {
    const SurfaceSpec& s = plan.scene.objects.at(object);
    RayCoefficients<double> p;
    ObjectRay ray;
    detail::general_ray_polynomial(s, origin, direction, p, ray);
    for (int k = 0; k <= s.degree; ++k) {
        coeffs[k] = p.c[k];
        if (radius) radius[k] = p.r[k];
    }
}

namespace {

/// One sample's outcome (a primary ray: traced and shaded).
struct SampleResult {
    HitInfo hit;
    float rgb[3];
};

/// Traces and shades the sample at cell (sx_cell, sy_cell) of the frame's
/// grid of samples.
/// `dir` (optional): the sample's direction, already made by
/// sample_direction for these cells (render_tile's batch): not made again.
/// (Inlined: render_tile's calls are specialised, trace and the rest
/// known; see PixelAccumulator::add for what that asks of add.)
[[gnu::always_inline]] inline SampleResult trace_sample(const FramePlan& plan, Tracer& tracer, int sx_cell, int sy_cell,
                                                       int side, Seeds* seeds, PixelExplanation* trace,
                                                       const BatchedCell* pre = nullptr, const double* dir = nullptr,
                                                       bool filled = false) {
    Ray ray;
    if (dir) {
        for (int a = 0; a < 3; ++a) {
            ray.origin[a] = plan.eye[a];
            ray.direction[a] = dir[a];
        }
    } else {
        ray = sample_ray(plan, sx_cell, sy_cell, side);
    }
    for (int a = 0; a < 3; ++a) tracer.current_direction_[a] = ray.direction[a];
    tracer.pixel_x_ = sx_cell / side;  // the pixel holding the sample (for the exact tier)
    tracer.pixel_y_ = sy_cell / side;
    SampleResult s;
    s.hit = tracer.intersect(ray.origin, ray.direction, true, seeds, 0, trace, pre, filled);
    if (trace) trace->ray = ray;
    double rgb[3];
    if (s.hit.hit) tracer.shade(ray.origin, ray.direction, s.hit, 0, rgb);
    else for (int a = 0; a < 3; ++a) rgb[a] = plan.scene.background[a];
    for (int a = 0; a < 3; ++a) s.rgb[a] = static_cast<float>(rgb[a]);
    return s;
}

/// A pixel's samples, folded in as they are traced (TileAOVs says what
/// each AOV of a sampled pixel is).
struct PixelAccumulator {
    double rgb[3] = {0, 0, 0};
    int hits = 0, certified = 0, seen = 0;
    std::uint8_t status = kCertified, level = kLevelFirst;
    bool shown_hit = false;
    HitInfo shown;   // the shown sample: the hitting sample of least |t|, else the first

    // (Not inlined: with trace_sample inlined into render_tile, GCC 12 -O2
    // compiled add()'s rgb[a] += s.rgb[a] for a = 0, 1 as one cvtpd2ps
    // for the store of s.rgb and an addpd of the unrounded doubles, i.e.
    // it dropped the float rounding of the sample's colour: the 4-sample
    // frames' rgba moved in the last bit. Reading s.rgb here, behind a
    // call, keeps the rounding.)
    [[gnu::noinline]] void add(const SampleResult& s) {
        for (int a = 0; a < 3; ++a) rgb[a] += s.rgb[a];
        hits += s.hit.hit;
        certified += s.hit.status == kCertified;
        status = std::max(status, s.hit.status);
        level = std::max(level, s.hit.level);
        if (seen == 0 || (s.hit.hit && (!shown_hit || s.hit.modulus < shown.modulus))) {
            shown = s.hit;
            shown_hit = s.hit.hit;
        }
        ++seen;
    }

    void write(TileView& out, std::size_t i) const {
        const double n = seen;
        const float rgb_mean[3] = {static_cast<float>(rgb[0] / n), static_cast<float>(rgb[1] / n),
                                   static_cast<float>(rgb[2] / n)};
        write_pixel(out, i, rgb_mean, static_cast<float>(hits / n), status, level, static_cast<float>(certified / n),
                    shown, shown_hit);
    }

    /// Writes pixel i (y * out.stride + x) of the tile's AOVs (the one
    /// place that does).
    static void write_pixel(TileView& out, std::size_t i, const float* rgb, float alpha, std::uint8_t status,
                            std::uint8_t level, float certified_share, const HitInfo& shown, bool shown_hit) {
        for (int a = 0; a < 3; ++a) out.rgba[4 * i + a] = rgb[a];
        out.rgba[4 * i + 3] = alpha;
        out.status[i] = status;
        out.escalation[i] = level;
        out.certified_share[i] = certified_share;
        out.count[i] = shown.eligible;
        if (level > kLevelFirst) ++out.escalations;
        ++out.by_status[status & 3];
        ++out.by_level[level & 7];
        out.hits += alpha > 0.0f;
        if (!shown_hit) {  // a miss (the planes come unset: every AOV is written here)
            out.modulus[i] = std::numeric_limits<float>::infinity();
            out.argument[i] = 0.0f;
            out.re[i] = 0.0f;
            out.im[i] = 0.0f;
            return;
        }
        out.modulus[i] = static_cast<float>(shown.modulus);
        out.argument[i] = static_cast<float>(argument_of(shown.disc.im, shown.disc.re));
        out.re[i] = static_cast<float>(shown.disc.re);
        out.im[i] = static_cast<float>(shown.disc.im);
    }

    /// A pixel of one sample, written as add() then write() would (the
    /// same values to the bit: a mean of one is the value), without the
    /// accumulator's copies.
    static void write_single(TileView& out, std::size_t i, const SampleResult& s) {
        const bool certified = s.hit.status == kCertified;
        write_pixel(out, i, s.rgb, s.hit.hit ? 1.0f : 0.0f, s.hit.status, s.hit.level, certified ? 1.0f : 0.0f,
                    s.hit, s.hit.hit);
    }
};

/// Sizes the tile's AOVs and returns the view of them render_tile writes
/// through. Their values are not set here: render_tile writes every pixel
/// through write_pixel, which writes every AOV (a miss included), so one
/// fill pass of nine (resize: a zeroing memset on fresh vectors) is all the
/// setup costs.
TileView allocate(TileAOVs& out, int w, int h) {
    out.width = w;
    out.height = h;
    const std::size_t np = static_cast<std::size_t>(w) * h;
    out.rgba.resize(4 * np);
    out.modulus.resize(np);
    out.argument.resize(np);
    out.re.resize(np);
    out.im.resize(np);
    out.count.resize(np);
    out.status.resize(np);
    out.escalation.resize(np);
    out.certified_share.resize(np);
    out.escalations = 0;
    out.root_calls = 0;
    TileView v;
    v.stride = w;
    v.rgba = out.rgba.data();
    v.modulus = out.modulus.data();
    v.argument = out.argument.data();
    v.re = out.re.data();
    v.im = out.im.data();
    v.count = out.count.data();
    v.status = out.status.data();
    v.escalation = out.escalation.data();
    v.certified_share = out.certified_share.data();
    return v;
}

/// A tile's AOVs in arrays of its own (render_tile's staging area when it
/// writes into a larger frame), one per thread, reused from tile to tile:
/// view() is a TileView of w x h pixels over them (allocate's); flush
/// copies its rows into another view's and adds its figures to that view's.
class TileStaging {
public:
    TileView& view(int w, int h) {
        view_ = allocate(aovs_, w, h);
        return view_;
    }

    /// Copies the staged tile into out (rows out.stride apart) and adds its
    /// figures.
    void flush(TileView& out) const {
        const std::size_t w = static_cast<std::size_t>(view_.width), stride = static_cast<std::size_t>(out.stride);
        for (int y = 0; y < view_.height; ++y) {
            const std::size_t from = static_cast<std::size_t>(y) * w, to = static_cast<std::size_t>(y) * stride;
            auto copy = [&](auto* dst, const auto* src, std::size_t k) {
                stream_copy(dst + k * to, src + k * from, sizeof(*src) * k * w);
            };
            copy(out.rgba, view_.rgba, 4);
            copy(out.modulus, view_.modulus, 1);
            copy(out.argument, view_.argument, 1);
            copy(out.re, view_.re, 1);
            copy(out.im, view_.im, 1);
            copy(out.count, view_.count, 1);
            copy(out.status, view_.status, 1);
            copy(out.escalation, view_.escalation, 1);
            copy(out.certified_share, view_.certified_share, 1);
        }
#if defined(__SSE2__)
        _mm_sfence();  // (the streaming stores ordered before anything after)
#endif
        out.escalations = view_.escalations;
        out.root_calls = view_.root_calls;
        out.hits = view_.hits;
        std::copy(std::begin(view_.by_status), std::end(view_.by_status), std::begin(out.by_status));
        std::copy(std::begin(view_.by_level), std::end(view_.by_level), std::begin(out.by_level));
    }

private:
    /// memcpy, with the 16-byte-aligned middle of dst written by streaming
    /// stores: the frame's lines are not read first (nor kept in the
    /// caches), as a plain store to a line not cached would.
    static void stream_copy(void* dst_v, const void* src_v, std::size_t bytes) {
        auto* dst = static_cast<unsigned char*>(dst_v);
        const auto* src = static_cast<const unsigned char*>(src_v);
#if defined(__SSE2__)
        const std::size_t head = std::min(bytes, (16 - reinterpret_cast<std::uintptr_t>(dst) % 16) % 16);
        std::memcpy(dst, src, head);
        std::size_t i = head;
        for (; i + 16 <= bytes; i += 16)
            _mm_stream_si128(reinterpret_cast<__m128i*>(dst + i),
                             _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i)));
        std::memcpy(dst + i, src + i, bytes - i);
#else
        std::memcpy(dst, src, bytes);
#endif
    }

    TileAOVs aovs_;
    TileView view_;
};

const char* status_reason(std::uint8_t status) {
    switch (status) {
        case kCertified: return "every decision proven";
        case kCluster: return "a deciding disc holds several roots (or the ray lies in the surface)";
        case kUnverified: return "a root of the ray polynomial is not enclosed (or a coefficient overflowed)";
        default: return "a band edge, the clipping sphere or another root's modulus lies within a deciding disc";
    }
}

}  // namespace

namespace {
TileRect clamp_rect(const FramePlan& plan, const TileRect& rect_in) {
    const FrameParams& fp = plan.params;
    return TileRect{std::max(0, rect_in.x0), std::max(0, rect_in.y0), std::min(fp.width, rect_in.x1),
                    std::min(fp.height, rect_in.y1)};
}
}  // namespace

void render_tile(const FramePlan& plan, const TileRect& rect_in, TileAOVs& out, const ExactSolver* exact) {
    const TileRect r = clamp_rect(plan, rect_in);
    TileView v = allocate(out, std::max(0, r.x1 - r.x0), std::max(0, r.y1 - r.y0));
    render_tile(plan, r, v, exact);
    out.escalations = v.escalations;
    out.root_calls = v.root_calls;
}

namespace {
void render_tile_view(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact);
}  // namespace

void render_tile(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact) {
    const TileRect r = clamp_rect(plan, rect_in);
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    if (out.stride <= w || h <= 1) {
        render_tile_view(plan, r, out, exact);
        return;
    }
    // Rows of out a frame's row apart: render into the thread's staging
    // tile and copy it over once done. (Written pixel by pixel at such
    // strides, the frame's cache lines were fetched while the tile was
    // traced, and the loads of the next run of samples waited behind those
    // pending stores: a 64x64 tile of a 1024x1024 frame took some 12% longer
    // than the same tile traced into arrays of its own.)
    static thread_local TileStaging staging;
    TileView& v = staging.view(w, h);
    render_tile_view(plan, r, v, exact);
    staging.flush(out);
    out.width = w;
    out.height = h;
}

namespace {
/// What one band of a tile keeps while the tile is traced: the band's plan,
/// its tracer (ladder, scratch, counters), its neighbour seeds, its row of
/// pixel accumulators and where its pixels go.
struct BandTrace {
    BandTrace(const FramePlan& plan, const ExactSolver* exact, TileView& out, int w)
        : plan(plan), tracer(plan, exact, plan.params.engine.cull), seeds(plan.scene.objects.size()),
          row(static_cast<std::size_t>(w)), out(out) {}
    const FramePlan& plan;
    Tracer tracer;
    std::vector<Seeds> seeds;
    std::vector<PixelAccumulator> row;
    TileView& out;
};

/// The colour the last band gave a sample's certified hit, and the root it
/// shaded (shade reads the hit's object, disc centre and modulus).
struct ShadeMemo {
    bool valid = false;
    int object = -1;
    double re = 0, im = 0, modulus = 0;
    float rgb[3] = {0, 0, 0};
    bool same(const HitInfo& h) const {
        return h.object == object && std::memcmp(&h.disc.re, &re, sizeof re) == 0 &&
               std::memcmp(&h.disc.im, &im, sizeof im) == 0 && std::memcmp(&h.modulus, &modulus, sizeof modulus) == 0;
    }
    void keep(const HitInfo& h, const float* colour) {
        valid = true;
        object = h.object;
        re = h.disc.re;
        im = h.disc.im;
        modulus = h.modulus;
        for (int a = 0; a < 3; ++a) rgb[a] = colour[a];
    }
};

/// FNV-1a over the bytes of v.
template <class T>
void mix(std::uint64_t& h, const T& v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (unsigned char c : b) h = (h ^ c) * 1099511628211ull;
}

/// A root field's header: its format, the rays it belongs to
/// (rays_fingerprint) and the tile (clamped) it holds.
void field_header(const FramePlan& plan, const TileRect& r, std::vector<std::uint8_t>& out) {
    const char magic[8] = {'A', 'R', 'G', 'F', 'I', 'E', 'L', '1'};
    out.insert(out.end(), magic, magic + 8);
    const std::uint64_t f = rays_fingerprint(plan);
    const std::int32_t rect[4] = {r.x0, r.y0, r.x1, r.y1};
    unsigned char b[8 + sizeof rect];
    std::memcpy(b, &f, 8);
    std::memcpy(b + 8, rect, sizeof rect);
    out.insert(out.end(), b, b + sizeof b);
}

void reset_figures(TileView& out, int w, int h) {
    out.width = w;
    out.height = h;
    out.escalations = 0;
    out.root_calls = 0;
    out.hits = 0;
    std::fill(std::begin(out.by_status), std::end(out.by_status), 0);
    std::fill(std::begin(out.by_level), std::end(out.by_level), 0);
}

/// Traces the tile r of every band of `plans` (same rays: same_rays) into
/// `outs`. The primary rays' batched roots do not depend on the band
/// (PrimaryBatch::solve reads the scene, the camera, the method and the
/// seeds of its own earlier solves, never sigma or delta): each run of
/// samples is solved once, then every band decides, climbs its own ladder
/// and shades from those discs with its own tracer and seeds, in the order
/// a tile of that band alone is traced. So each band's pixels are the bits
/// render_tile gives for its plan alone, by construction.
void render_tile_views(const std::vector<const FramePlan*>& plans, const TileRect& r,
                       const std::vector<TileView*>& outs, const ExactSolver* exact, RootField* record,
                       const RootField* replay) {
    const FramePlan& plan = *plans[0];
    const FrameParams& fp = plan.params;
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    const int side = sample_side(fp.samples);
    if (side == 0) throw std::invalid_argument("samples must be a square from 1 to " + std::to_string(kMaxSamples));
    std::vector<std::unique_ptr<BandTrace>> bands;
    bands.reserve(plans.size());
    for (std::size_t b = 0; b < plans.size(); ++b) {
        reset_figures(*outs[b], w, h);
        bands.push_back(std::make_unique<BandTrace>(*plans[b], exact, *outs[b], w));
    }
    PrimaryBatch batch(plan, resolved_kernel(plan.params.engine), plan.params.engine.cull);
    batch.begin_tile(side * w);
    // The root field: recorded as the batch solves, or replayed instead of
    // solving (its header names the rays and the tile it holds).
    std::size_t at = 0;
    if (record) field_header(plan, r, record->bytes);
    if (replay) {
        std::vector<std::uint8_t> want;
        field_header(plan, r, want);
        if (replay->bytes.size() < want.size() || std::memcmp(replay->bytes.data(), want.data(), want.size()) != 0)
            throw std::invalid_argument("root field: it holds another tile, scene, camera or set of parameters");
        at = want.size();
    }
    // Every object solved in the batch: a certified sample may take
    // Tracer::intersect_batched (intersect's result, the ladder unneeded).
    bool all_batched = batch.any();
    for (std::size_t obj = 0; obj < plan.scene.objects.size(); ++obj)
        all_batched = all_batched && batch.batched(static_cast<int>(obj));
    alignas(64) double dx[PrimaryBatch::kCells], dy[PrimaryBatch::kCells], dz[PrimaryBatch::kCells];
    // Per object: whether shading its root at depth 0 traces further rays
    // (shade's `bounces`), whose decisions would depend on the band.
    std::vector<char> bounces;
    for (const SurfaceSpec& s : plan.scene.objects)
        bounces.push_back(!s.complex_space && 0 < fp.max_depth &&
                          (s.material.reflectivity > 0 || s.material.transparency > 0));
    ShadeMemo memo[PrimaryBatch::kCells];
    const bool share_colours = bands.size() > 1;  // (a lone frame has no other band to share with)
    detail::SampleRowInput row_in;
    for (int a = 0; a < 3; ++a) {
        row_in.forward[a] = plan.forward[a];
        row_in.right[a] = plan.right[a];
        row_in.up[a] = plan.up[a];
    }
    // sample_direction's quantities, computed as there.
    row_in.tan_half_fov = plan.tan_half_fov;
    row_in.aspect = static_cast<double>(fp.width) / fp.height;
    row_in.cols = static_cast<double>(side) * fp.width;
    const double rows_total = static_cast<double>(side) * fp.height;
    // The samples are traced in the order of the (side W) x (side H) frame's
    // pixels: row of samples by row of samples, left to right, the
    // neighbour seeds flowing along each row of samples. With a batched
    // kernel, each run of PrimaryBatch::kCells samples of a row of samples
    // has its primary roots solved together first.
    // Seeds flow within blocks of kSeedBlock x kSeedBlock samples aligned
    // on the frame's grid of samples (FrameParams::seed_from_neighbour):
    // the batch's seeds from above restart at each block's first row of
    // samples, the scalar path's from the left at each block's first column.
    for (int y = r.y0; y < r.y1; ++y) {
        if (side > 1)
            for (auto& band : bands) std::fill(band->row.begin(), band->row.end(), PixelAccumulator{});
        for (int j = 0; j < side; ++j) {
            for (auto& band : bands)
                for (Seeds& s : band->seeds) s.valid = false;
            const int c0 = side * r.x0, c1 = side * r.x1, sy = side * y + j;
            if (sy != side * r.y0 && sy % kSeedBlock == 0 && batch.any()) batch.begin_tile(side * w);
            for (int b0 = c0; b0 < c1; b0 += PrimaryBatch::kCells) {
                const int cells = std::min(PrimaryBatch::kCells, c1 - b0);
                if (batch.any()) {
                    row_in.sy = (1.0 - 2.0 * (sy + 0.5) / rows_total) * plan.tan_half_fov;
                    detail::sample_direction_run(row_in, b0, cells, dx, dy, dz, batch.isa());
                    if (replay) {
                        batch.replay(dx, dy, dz, cells, replay->bytes.data(), replay->bytes.size(), at);
                    } else {
                        batch.solve(dx, dy, dz, cells, b0 - c0);
                        if (record) batch.record(record->bytes, cells);
                    }
                }
                for (int c = 0; c < cells; ++c) memo[c].valid = false;
                for (auto& band : bands) {
                    Tracer& tracer = band->tracer;
                    const std::size_t stride = static_cast<std::size_t>(band->out.stride);
                    for (int c = 0; c < cells; ++c) {
                        const BatchedCell pre{&batch, c};
                        const int sx = b0 + c;
                        if (sx % kSeedBlock == 0)
                            for (Seeds& s : band->seeds) s.valid = false;
                        // (The run's directions are sample_direction's, to the bit.)
                        const double dir[3] = {dx[c], dy[c], dz[c]};
                        SampleResult sample;
                        bool filled = false;
                        if (all_batched && tracer.intersect_batched(pre, sample.hit, filled)) {
                            // trace_sample's shading of the certified hit (the
                            // ray's origin is the eye's doubles). Shading a
                            // root that bounces no ray reads only the root,
                            // the ray and what the bands share: a band that
                            // chose the root an earlier band of this sample
                            // chose takes that band's colour, the same bits.
                            ShadeMemo& m = memo[c];
                            if (share_colours && sample.hit.hit && m.valid && m.same(sample.hit)) {
                                for (int a = 0; a < 3; ++a) sample.rgb[a] = m.rgb[a];
                            } else {
                                double rgb[3];
                                if (sample.hit.hit) tracer.shade(plan.eye, dir, sample.hit, 0, rgb);
                                else for (int a = 0; a < 3; ++a) rgb[a] = plan.scene.background[a];
                                for (int a = 0; a < 3; ++a) sample.rgb[a] = static_cast<float>(rgb[a]);
                                if (share_colours && sample.hit.hit && !bounces[sample.hit.object])
                                    m.keep(sample.hit, sample.rgb);
                            }
                        } else {
                            sample = trace_sample(band->plan, tracer, sx, sy, side, band->seeds.data(), nullptr,
                                                  batch.any() ? &pre : nullptr, batch.any() ? dir : nullptr, filled);
                        }
                        // One sample per pixel: straight to the AOVs (the same
                        // bits as add() then write(), without the copies).
                        if (side == 1)
                            PixelAccumulator::write_single(band->out, static_cast<std::size_t>(y - r.y0) * stride + (sx - r.x0),
                                                           sample);
                        else band->row[sx / side - r.x0].add(sample);
                    }
                }
            }
        }
        if (side > 1)
            for (auto& band : bands) {
                const std::size_t stride = static_cast<std::size_t>(band->out.stride);
                for (int x = 0; x < w; ++x) band->row[x].write(band->out, static_cast<std::size_t>(y - r.y0) * stride + x);
            }
    }
    for (auto& band : bands) band->out.root_calls = band->tracer.root_calls;
    if (replay && at != replay->bytes.size())
        throw std::invalid_argument("root field: it holds more than the tile's samples");
}

void render_tile_view(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact) {
    render_tile_views({&plan}, clamp_rect(plan, rect_in), {&out}, exact, nullptr, nullptr);
}
}  // namespace

std::uint64_t rays_fingerprint(const FramePlan& a) {
    // The fields same_rays compares, in its order.
    std::uint64_t h = 1469598103934665603ull;
    const FrameParams& p = a.params;
    mix(h, p.width), mix(h, p.height), mix(h, static_cast<int>(p.method)), mix(h, p.max_depth);
    mix(h, p.hue_by_argument), mix(h, p.seed_from_neighbour), mix(h, p.samples), mix(h, p.exact_pixels_per_tile);
    mix(h, p.exact_max_bits), mix(h, static_cast<int>(p.engine.kernel)), mix(h, p.engine.cull);
    mix(h, static_cast<int>(p.engine.decide)), mix(h, static_cast<int>(p.engine.shade));
    mix(h, a.tan_half_fov), mix(h, a.scene_distance);
    for (int k = 0; k < 3; ++k) mix(h, a.eye[k]), mix(h, a.forward[k]), mix(h, a.right[k]), mix(h, a.up[k]);
    const SceneSpec& s = a.scene;
    mix(h, s.objects.size()), mix(h, s.lights.size());
    for (int k = 0; k < 3; ++k) mix(h, s.background[k]);
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
        const SurfaceSpec& u = s.objects[i];
        mix(h, u.degree), mix(h, u.terms.size()), mix(h, u.complex_space), mix(h, u.clip_radius);
        mix(h, a.objects[i].origin);
        for (const Term& t : u.terms) mix(h, t.coeff), mix(h, t.ex), mix(h, t.ey), mix(h, t.ez);
    }
    return h;
}

bool same_rays(const FramePlan& a, const FramePlan& b) {
    const FrameParams &p = a.params, &q = b.params;
    if (p.width != q.width || p.height != q.height || p.method != q.method || p.max_depth != q.max_depth ||
        p.hue_by_argument != q.hue_by_argument || p.seed_from_neighbour != q.seed_from_neighbour ||
        p.samples != q.samples || p.exact_pixels_per_tile != q.exact_pixels_per_tile ||
        p.exact_max_bits != q.exact_max_bits || p.engine.kernel != q.engine.kernel || p.engine.cull != q.engine.cull ||
        p.engine.decide != q.engine.decide || p.engine.shade != q.engine.shade)
        return false;
    if (a.tan_half_fov != b.tan_half_fov || a.scene_distance != b.scene_distance) return false;
    for (int k = 0; k < 3; ++k)
        if (a.eye[k] != b.eye[k] || a.forward[k] != b.forward[k] || a.right[k] != b.right[k] || a.up[k] != b.up[k])
            return false;
    const SceneSpec &s = a.scene, &t = b.scene;
    if (s.objects.size() != t.objects.size() || s.lights.size() != t.lights.size()) return false;
    for (int k = 0; k < 3; ++k)
        if (s.background[k] != t.background[k]) return false;
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
        const SurfaceSpec &u = s.objects[i], &v = t.objects[i];
        if (u.degree != v.degree || u.terms.size() != v.terms.size() || u.complex_space != v.complex_space ||
            u.clip_radius != v.clip_radius || std::memcmp(&a.objects[i].origin, &b.objects[i].origin,
                                                          sizeof(a.objects[i].origin)) != 0)
            return false;
        for (std::size_t k = 0; k < u.terms.size(); ++k)
            if (u.terms[k].coeff != v.terms[k].coeff || u.terms[k].ex != v.terms[k].ex ||
                u.terms[k].ey != v.terms[k].ey || u.terms[k].ez != v.terms[k].ez)
                return false;
    }
    return true;
}

void render_tile_bands(const std::vector<const FramePlan*>& plans, const TileRect& rect_in,
                       const std::vector<TileView*>& outs, const ExactSolver* exact, RootField* record,
                       const RootField* replay) {
    if (record && replay) throw std::invalid_argument("render_tile_bands: record a root field or replay one, not both");
    if (record) record->bytes.clear();
    if (plans.empty() || plans.size() != outs.size())
        throw std::invalid_argument("render_tile_bands needs one output per plan, and at least one plan");
    for (std::size_t b = 1; b < plans.size(); ++b)
        if (!same_rays(*plans[0], *plans[b]))
            throw std::invalid_argument("render_tile_bands: plan " + std::to_string(b) +
                                        " does not share plan 0's scene, camera and parameters (only sigma and delta "
                                        "may differ)");
    const TileRect r = clamp_rect(*plans[0], rect_in);
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    // Bands whose rows lie a frame's row apart are traced into staging
    // tiles of their own and copied over once done (see render_tile).
    static thread_local std::vector<std::unique_ptr<TileStaging>> staging;
    std::vector<TileView*> views(outs.size());
    std::vector<int> staged(outs.size(), -1);
    int used = 0;
    for (std::size_t b = 0; b < outs.size(); ++b) {
        if (outs[b]->stride <= w || h <= 1) {
            views[b] = outs[b];
            continue;
        }
        if (static_cast<int>(staging.size()) <= used) staging.push_back(std::make_unique<TileStaging>());
        staged[b] = used;
        views[b] = &staging[used++]->view(w, h);
    }
    render_tile_views(plans, r, views, exact, record, replay);
    for (std::size_t b = 0; b < outs.size(); ++b) {
        if (staged[b] < 0) continue;
        staging[staged[b]]->flush(*outs[b]);
        outs[b]->width = w;
        outs[b]->height = h;
    }
}

PixelExplanation explain_pixel(const FramePlan& plan, int x, int y, int row_start, int sample,
                               const ExactSolver* exact, int column_start) {
    const FrameParams& fp = plan.params;
    if (x < 0 || x >= fp.width || y < 0 || y >= fp.height)
        throw std::invalid_argument("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is not inside the " +
                                    std::to_string(fp.width) + "x" + std::to_string(fp.height) + " frame");
    if (row_start < 0 || row_start > x) throw std::invalid_argument("row_start must be in 0..x");
    if (column_start < 0 || column_start > y) throw std::invalid_argument("column_start must be in 0..y");
    if (sample < 0 || sample >= fp.samples)
        throw std::invalid_argument("sample must be in 0.." + std::to_string(fp.samples - 1));
    // Replay the tile's row of samples from its first sample, or from the
    // first of the pixel's seed block (the neighbour seeds render_tile
    // would have), then trace the sample.
    const int side = sample_side(fp.samples);
    const int sx_cell = side * x + sample % side, sy_cell = side * y + sample / side;
    const int first_cell = std::max(side * row_start, sx_cell - sx_cell % kSeedBlock);
    const int first_row = std::max(side * column_start, sy_cell - sy_cell % kSeedBlock);
    const bool cull = plan.params.engine.cull;
    Tracer tracer(plan, exact, cull);
    tracer.explaining_ = true;
    PrimaryBatch batch(plan, resolved_kernel(plan.params.engine), cull);
    std::vector<Seeds> seeds(plan.scene.objects.size());
    PixelExplanation e;
    // A batched object's discs depend on its own ray and its seeds, the
    // roots of the samples above it in the tile (not on the other lanes):
    // replay that column from the tile's first row with batches of one,
    // then the row for the scalar objects' neighbour seeds.
    batch.begin_tile(1);
    double dir[3];
    if (batch.any())
        for (int sy = first_row; sy < sy_cell; ++sy) {
            sample_direction(plan, sx_cell, sy, side, dir);
            batch.solve(dir, dir + 1, dir + 2, 1, 0);
        }
    for (int c = first_cell; c <= sx_cell; ++c) {
        const BatchedCell pre{&batch, 0};
        const bool batched = batch.any() && c == sx_cell;
        if (batched) {
            sample_direction(plan, c, sy_cell, side, dir);
            batch.solve(dir, dir + 1, dir + 2, 1, 0);
        }
        trace_sample(plan, tracer, c, sy_cell, side, seeds.data(), c == sx_cell ? &e : nullptr,
                     batched ? &pre : nullptr);
    }
    e.reason = e.exact_ran && !e.exact.reason.empty() ? e.exact.reason : status_reason(e.status);
    return e;
}

}  // namespace argand
