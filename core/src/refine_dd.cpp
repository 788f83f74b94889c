// refine_dd.cpp: double-double root refinement (refine_dd.h), all
// outward-rounded through arith.h/interval.h. (Moved from
// pixel_decision.cpp: it is root finding, not a pixel's decision.)
#include "refine_dd.h"

#include <cmath>

#include "root_kernels.h"

namespace argand::detail {
namespace {

/// Double-double products for the Aberth sweep, the error-free product
/// as one FMA where the CPU has it (kFma: the caller is compiled for it):
/// the product's error is exact either way (Dekker's split in arith.h), so
/// both give the same bits as arith.h's operator*, at about a third of the
/// split's cost. Sums are arith.h's.
template <bool kFma>
__attribute__((always_inline)) inline DoubleDouble dd_mul(DoubleDouble x, DoubleDouble y) {
    double ch, cl1;
    if constexpr (kFma) {
        ch = x.hi * y.hi;
        cl1 = __builtin_fma(x.hi, y.hi, -ch);
    } else {
        detail::two_prod(x.hi, y.hi, ch, cl1);
    }
    const double tl = x.hi * y.lo;
    const double cl2 = x.lo * y.hi + tl;
    const double cl3 = cl1 + cl2;
    double zh, zl;
    detail::fast_two_sum(ch, cl3, zh, zl);
    return {zh, zl};
}

template <bool kFma>
__attribute__((always_inline)) inline Complex<DoubleDouble> dd_cmul(Complex<DoubleDouble> a, Complex<DoubleDouble> b) {
    return {dd_mul<kFma>(a.re, b.re) - dd_mul<kFma>(a.im, b.im), dd_mul<kFma>(a.re, b.im) + dd_mul<kFma>(a.im, b.re)};
}

/// arith.h's DoubleDouble division with dd_mul.
template <bool kFma>
__attribute__((always_inline)) inline DoubleDouble dd_div(DoubleDouble x, DoubleDouble y) {
    const double q1 = x.hi / y.hi;
    DoubleDouble r = x - dd_mul<kFma>(y, DoubleDouble(q1));
    const double q2 = r.hi / y.hi;
    r = r - dd_mul<kFma>(y, DoubleDouble(q2));
    const double q3 = r.hi / y.hi;
    double s, e;
    detail::fast_two_sum(q1, q2, s, e);
    return DoubleDouble(s, e) + DoubleDouble(q3);
}

/// One Aberth-Ehrlich sweep in double-double over the approximations x of
/// the roots of c (degree n) that `which` selects (all: null), in place;
/// returns the largest relative correction. Approximations only: Smith's
/// radii prove whatever they are. p and p' are evaluated in double-double
/// (the fixed points are the roots of p at that precision); the sum
/// sum_j 1 / (x_i - x_j) only sets the rate, and is formed in double from
/// the double-double differences (a relative error of 2^-52 in it changes
/// the correction by that much of v times the sum, nothing at a root),
/// which spares n - 1 double-double divisions per root and sweep.
/// `noise` (optional): set true where p at every selected approximation
/// (before its correction) is within the rounding noise of its evaluation,
/// about n 2^-104 sum_k |c_k| |x|^k (an estimate, not a bound: the
/// approximations are then as good as this precision makes them, and
/// further sweeps only move them within that noise).
template <bool kFma>
__attribute__((always_inline)) inline double aberth_sweep_body(const DoubleDouble* c, int n, Complex<DoubleDouble>* x,
                                                               const bool* which, bool* noise) {
    double largest = 0.0;
    bool quiet = true;
    for (int i = 0; i < n; ++i) {
        if (which != nullptr && !which[i]) continue;
        Complex<DoubleDouble> v(c[n]), dv(DoubleDouble(0.0));
        const double ax = std::sqrt(x[i].re.hi * x[i].re.hi + x[i].im.hi * x[i].im.hi);
        double size = std::fabs(c[n].hi);
        for (int k = n - 1; k >= 0; --k) {
            dv = dd_cmul<kFma>(dv, x[i]) + v;
            v = add_real(dd_cmul<kFma>(v, x[i]), c[k]);
            size = size * ax + std::fabs(c[k].hi);
        }
        const double floor = n * 0x1p-102 * size;
        quiet = quiet && v.re.hi * v.re.hi + v.im.hi * v.im.hi <= floor * floor;
        double sre = 0.0, sim = 0.0;
        for (int j = 0; j < n; ++j) {
            if (j == i) continue;
            const Complex<DoubleDouble> d = x[i] - x[j];
            const double dre = d.re.hi + d.re.lo, dim = d.im.hi + d.im.lo;
            const double inv = 1.0 / (dre * dre + dim * dim);
            sre += dre * inv;
            sim -= dim * inv;
        }
        // w = v / (dv - v * sum).
        const Complex<DoubleDouble> vs(dd_mul<kFma>(v.re, DoubleDouble(sre)) - dd_mul<kFma>(v.im, DoubleDouble(sim)),
                                       dd_mul<kFma>(v.re, DoubleDouble(sim)) + dd_mul<kFma>(v.im, DoubleDouble(sre)));
        const Complex<DoubleDouble> den = dv - vs;
        const DoubleDouble inv = dd_div<kFma>(DoubleDouble(1.0), dd_mul<kFma>(den.re, den.re) + dd_mul<kFma>(den.im, den.im));
        const Complex<DoubleDouble> w(dd_mul<kFma>(dd_mul<kFma>(v.re, den.re) + dd_mul<kFma>(v.im, den.im), inv),
                                      dd_mul<kFma>(dd_mul<kFma>(v.im, den.re) - dd_mul<kFma>(v.re, den.im), inv));
        if (!is_finite(w)) continue;
        x[i] = x[i] - w;
        const double step = mag_approx(w) / (mag_approx(x[i]) + 1e-300);
        largest = step > largest ? step : largest;
    }
    if (noise != nullptr) *noise = quiet;
    return largest;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define ARGAND_DD_FMA 1
bool has_fma() {
    static const bool yes = __builtin_cpu_supports("fma");
    return yes;
}
#else
bool has_fma() { return false; }
#endif

/// Horner in double-double with a running error bound, as eval_bound
/// (root_kernels.h) but with double-double coefficients: |p(x) - value| <= err
/// for the exact dd coefficients c and the exact dd point x. (The products
/// as dd_mul: the same bits with or without FMA, so the same bound.)
template <bool kFma>
__attribute__((always_inline)) inline bool eval_dd_body(const DoubleDouble* c, int n, Complex<DoubleDouble> x,
                                                     Complex<DoubleDouble>& value, double& err) {
    using E = ErrorModel<DoubleDouble>;
    const double ax = mag_up(x);
    Complex<DoubleDouble> y(c[n]);
    double ay = abs_up(c[n]);
    double e = 0.0;
    for (int k = n - 1; k >= 0; --k) {
        const Complex<DoubleDouble> next = add_real(dd_cmul<kFma>(y, x), c[k]);
        // (|re| + |im| >= |next|, rounded up: an upper bound as the
        // error term needs, without mag_up's hypot, at most sqrt(2) above
        // it; the term stays far below the coefficients' radii.)
        const double a_next = add_up(abs_up(next.re), abs_up(next.im));
        e = add_up(add_up(mul_up(e, ax), mul_up(E::mul_rel, mul_up(ay, ax))), add_up(mul_up(E::add_rel, a_next), 2.0 * E::abs_err));
        y = next;
        ay = a_next;
    }
    value = y;
    err = e;
    return std::isfinite(e) && is_finite(y);
}

#ifdef ARGAND_DD_FMA
__attribute__((target("fma"))) bool eval_dd_fma(const DoubleDouble* c, int n, Complex<DoubleDouble> x,
                                                Complex<DoubleDouble>& value, double& err) {
    return eval_dd_body<true>(c, n, x, value, err);
}
#endif

bool eval_dd(const DoubleDouble* c, int n, Complex<DoubleDouble> x, Complex<DoubleDouble>& value, double& err) {
#ifdef ARGAND_DD_FMA
    if (has_fma()) return eval_dd_fma(c, n, x, value, err);
#endif
    return eval_dd_body<false>(c, n, x, value, err);
}

/// sum_k r_k a^k, rounded up.
double radius_sum(const double* r, int n, double a) {
    double s = r[n];
    for (int k = n - 1; k >= 0; --k) s = add_up0(mul_up0(s, a), r[k]);
    return s;
}


/// Starts for the two roots of a pair disc d (count 2) of p (degree n,
/// double-double coefficients): c + h for the roots h of p(c) + p'(c) h +
/// p''(c)/2 h^2, c the disc's centre, the Taylor coefficients in
/// double-double, the quadratic solved in double. Near a pair whose other
/// roots lie at a distance D, those are within about |h|^2 / D of the pair's
/// roots, against the disc's radius for the spread on a circle: Aberth's
/// sweeps start where they converge at once. False (x untouched) where the
/// quadratic gives no finite pair inside the disc. Approximations only.
template <bool kFma>
__attribute__((always_inline)) inline bool pair_start(const DoubleDouble* c, int n, const RootDisc& d,
                                                      Complex<DoubleDouble>* x) {
    const Complex<DoubleDouble> z(DoubleDouble(d.re), DoubleDouble(d.im));
    Complex<DoubleDouble> a0(c[n]), a1(DoubleDouble(0.0)), a2(DoubleDouble(0.0));
    for (int k = n - 1; k >= 0; --k) {
        a2 = dd_cmul<kFma>(a2, z) + a1;
        a1 = dd_cmul<kFma>(a1, z) + a0;
        a0 = add_real(dd_cmul<kFma>(a0, z), c[k]);
    }
    const Complex<double> q0 = to_double(a0), q1 = to_double(a1), q2 = to_double(a2);
    if (!(mag2_approx(q2) > 0.0)) return false;
    // h = (-q1 +- sqrt(q1^2 - 4 q2 q0)) / (2 q2), the larger one first (no
    // cancellation), the other from the product of the roots, q0 / q2.
    const Complex<double> disc = q1 * q1 - mul_real(q2 * q0, 4.0);
    const double r = std::sqrt(mag_approx(disc));
    const double ang = 0.5 * std::atan2(disc.im, disc.re);
    Complex<double> root(r * std::cos(ang), r * std::sin(ang));
    if (q1.re * root.re + q1.im * root.im < 0.0) root = -root;  // (-q1 - root: no cancellation)
    const Complex<double> big = mul_real(-(q1 + root), 1.0) / mul_real(q2, 2.0);
    if (!(mag2_approx(big) > 0.0)) return false;
    const Complex<double> small = (q0 / q2) / big;
    const double limit = d.radius * d.radius;
    if (!is_finite(big) || !is_finite(small) || !(mag2_approx(big) <= limit) || !(mag2_approx(small) <= limit)) return false;
    x[0] = Complex<DoubleDouble>(z.re + DoubleDouble(big.re), z.im + DoubleDouble(big.im));
    x[1] = Complex<DoubleDouble>(z.re + DoubleDouble(small.re), z.im + DoubleDouble(small.im));
    return true;
}

}  // namespace

#ifdef ARGAND_DD_FMA
__attribute__((target("fma"))) double aberth_sweep_fma(const DoubleDouble* c, int n, Complex<DoubleDouble>* x,
                                                       const bool* which, bool* noise) {
    return aberth_sweep_body<true>(c, n, x, which, noise);
}
#endif

double aberth_sweep_dd(const DoubleDouble* c, int n, Complex<DoubleDouble>* x, const bool* which, bool fma,
                       bool* noise) {
#ifdef ARGAND_DD_FMA
    if (fma && has_fma()) return aberth_sweep_fma(c, n, x, which, noise);
#endif
    return aberth_sweep_body<false>(c, n, x, which, noise);
}

bool refine_disc_dd(const RayCoefficients<DoubleDouble>& p, bool real, RootDisc& d) {
    if (!p.finite || !d.verified || d.count != 1) return false;
    int n = p.n;
    while (n > 0 && is_zero(p.c[n]) && p.r[n] == 0.0) --n;  // exact roots at infinity
    if (n < 1) return false;
    // Derivative coefficients as balls: (k + 1) c_{k+1}.
    DoubleDouble dc[kMaxDegree];
    double dr[kMaxDegree];
    for (int k = 0; k < n; ++k) {
        dc[k] = DoubleDouble(static_cast<double>(k + 1)) * p.c[k + 1];
        dr[k] = add_up0(mul_up0(static_cast<double>(k + 1), p.r[k + 1]),
                        is_zero(dc[k]) ? 0.0 : add_up(mul_up(kDoubleDoubleRel, abs_up(dc[k])), kDoubleDoubleAbs));
    }
    Complex<DoubleDouble> x(DoubleDouble(d.re), DoubleDouble(real ? 0.0 : d.im));
    for (int it = 0; it < 6; ++it) {
        Complex<DoubleDouble> v, dv;
        double e1, e2;
        if (!eval_dd(p.c, n, x, v, e1) || !eval_dd(dc, n - 1, x, dv, e2)) return false;
        if (mag_approx(dv) == 0.0) break;
        const Complex<DoubleDouble> step = v / dv;
        if (!is_finite(step)) break;
        x = x - step;
        if (real) x.im = DoubleDouble(0.0);
        if (mag_approx(step) <= 0x1p-100 * mag_approx(x)) break;
    }
    Complex<DoubleDouble> v, dv;
    double e1, e2;
    if (!eval_dd(p.c, n, x, v, e1) || !eval_dd(dc, n - 1, x, dv, e2)) return false;
    const double ax = mag_up(x);
    const double num = add_up(add_up(mag_up(v), e1), radius_sum(p.r, n, ax));
    const double den = add_down(add_down(mag_down(dv), -e2), -radius_sum(dr, n - 1, ax));
    if (!(den > 0.0) || !std::isfinite(num)) return false;
    // The centre as doubles; the distance to the dd point is its low parts.
    const double cre = x.re.hi, cim = x.im.hi;
    const double gap = hypot_up(std::fabs(x.re.lo), std::fabs(x.im.lo));
    const double rho = add_up(mul_up(static_cast<double>(n), div_up(num, den)), gap);
    if (!std::isfinite(rho) || !(rho < d.radius)) return false;
    // Inside d (then it holds d's single root).
    if (!(add_up(dist_up(cre, cim, d.re, d.im), rho) <= d.radius)) return false;
    d.re = cre;
    d.im = cim;
    d.radius = rho;
    return true;
}

namespace {

template <bool kFma>
__attribute__((always_inline)) inline bool isolate_dd_body(const RayCoefficients<DoubleDouble>& p, RootsResult& res) {
    if (!p.finite) return false;
    int n = p.n;
    while (n > 0 && is_zero(p.c[n]) && p.r[n] == 0.0) --n;  // exact roots at infinity
    if (n < 2 || n != p.n - res.n_infinite) return false;
    if (is_zero(p.c[0]) && p.r[0] == 0.0) return false;     // an exact root at 0: not here
    const double lead_lo = add_down(abs_down(p.c[n]), -p.r[n]);
    if (!(lead_lo > 0.0)) return false;
    // Starting points: each disc's centre, a cluster's spread on a circle;
    // a pair (count 2) at the roots of p's quadratic Taylor polynomial at
    // its centre (pair_start), where that is finite.
    Complex<DoubleDouble> x[kMaxDegree];
    bool in_cluster[kMaxDegree];
    int m = 0;
    for (int i = 0; i < res.n_discs && m < n; ++i) {
        const RootDisc& d = res.discs[i];
        if (d.count == 2 && m + 2 <= n && pair_start<kFma>(p.c, n, d, x + m)) {
            in_cluster[m] = in_cluster[m + 1] = true;
            m += 2;
            continue;
        }
        for (int k = 0; k < d.count && m < n; ++k) {
            const double a = 2.0 * 3.14159265358979323846 * k / d.count + 0.4;
            const double rho = d.count > 1 ? 0.5 * d.radius : 0.0;
            in_cluster[m] = d.count > 1;
            x[m++] = Complex<DoubleDouble>(DoubleDouble(d.re + rho * std::cos(a)), DoubleDouble(d.im + rho * std::sin(a)));
        }
    }
    if (m != n) return false;
    // Aberth-Ehrlich in double-double (approximations only): sweeps over
    // the roots a mask selects (aberth_sweep_body).
    // First the clusters' roots alone, the others held at their double
    // discs' centres: Aberth's fixed points are the roots of p whatever the
    // other approximations are (they set only the rate), and the roots
    // outside a cluster, already isolated in double, would cost as much per
    // sweep while the cluster converges (8 roots against 2 for a node of an
    // octic: a third of an Endrass octic frame was spent here). Near a
    // cluster the corrections of its roots bottom out at the rounding noise
    // of p there (about 2^-104 relative over the cluster's separation),
    // above the 2^-100 target, and would run all 60 sweeps: once the largest
    // relative correction is below 2^-64 and has failed twice in a row to
    // halve the smallest seen, or once p at every cluster root is within its
    // evaluation's rounding noise, the approximations are as good as this
    // precision makes them, and the sweeps stop. Then the other roots: one
    // sweep, a second only where its largest correction was above 2^-40 (a
    // centre not at double accuracy). From a double centre, Aberth's cubic
    // rate reaches the precision's end in one sweep (the error after it is
    // about the cube of the correction, 2^-120 relative to the roots'
    // separation for a correction of 2^-40): double-double accuracy for
    // every root, as when every root was swept from the start. (Speed only:
    // Smith's radii below prove whatever the approximations are.)
    double smallest = INFINITY;
    int stalled = 0;
    for (int it = 0; it < 60; ++it) {
        bool noise = false;
        const double largest = aberth_sweep_body<kFma>(p.c, n, x, in_cluster, &noise);
        if (largest < 0x1p-100 || noise) break;
        if (largest <= 0x1p-64) {
            stalled = largest > 0.5 * smallest ? stalled + 1 : 0;
            if (stalled >= 2) break;
        }
        smallest = largest < smallest ? largest : smallest;
    }
    bool outside[kMaxDegree];
    for (int i = 0; i < n; ++i) outside[i] = !in_cluster[i];
    if (aberth_sweep_body<kFma>(p.c, n, x, outside, nullptr) > 0x1p-40) aberth_sweep_body<kFma>(p.c, n, x, outside, nullptr);
    // Smith's radii over the coefficient balls, outward-rounded.
    using E = ErrorModel<DoubleDouble>;
    double cre[kMaxDegree], cim[kMaxDegree], rad[kMaxDegree];
    for (int i = 0; i < n; ++i) {
        if (!is_finite(x[i])) return false;
        Complex<DoubleDouble> v;
        double e;
        if (!eval_dd_body<kFma>(p.c, n, x[i], v, e)) return false;
        const double num = add_up(add_up(mag_up(v), e), radius_sum(p.r, n, mag_up(x[i])));
        double den = lead_lo;
        for (int j = 0; j < n; ++j) {
            if (j == i) continue;
            // |exact difference| >= |computed| (1 - add_rel) - abs_err.
            const double dist = add_down(mul_down(mag_down(x[i] - x[j]), 1.0 - 2.0 * E::add_rel), -E::abs_err);
            if (!(dist > 0.0)) return false;
            den = mul_down(den, dist);
        }
        if (!(den > 0.0)) return false;
        cre[i] = x[i].re.hi;
        cim[i] = x[i].im.hi;
        const double gap = hypot_up(std::fabs(x[i].re.lo), std::fabs(x[i].im.lo));
        rad[i] = add_up(mul_up(static_cast<double>(n), div_up(num, den)), gap);
        if (!std::isfinite(rad[i])) return false;
    }
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
            if (!(dist_down(cre[i], cim[i], cre[j], cim[j]) > add_up(rad[i], rad[j]))) return false;
    // Every disc isolated: Smith's theorem gives one root each.
    res.n_discs = n;
    for (int i = 0; i < n; ++i) res.discs[i] = RootDisc{cre[i], cim[i], rad[i], 1, true, false};
    res.wants_exact = false;
    return true;
}

#ifdef ARGAND_DD_FMA
__attribute__((target("fma"))) bool isolate_dd_fma(const RayCoefficients<DoubleDouble>& p, RootsResult& res) {
    return isolate_dd_body<true>(p, res);
}
#endif

}  // namespace

bool isolate_dd(const RayCoefficients<DoubleDouble>& p, RootsResult& res) {
#ifdef ARGAND_DD_FMA
    if (has_fma()) return isolate_dd_fma(p, res);
#endif
    return isolate_dd_body<false>(p, res);
}

}  // namespace argand::detail
