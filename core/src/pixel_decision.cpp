// pixel_decision.cpp: band, clipping sphere, realness, ordering and the
// double-double refinement, all outward-rounded through arith.h/interval.h.
#include "pixel_decision.h"

#include <cmath>

#include "solver.h"

namespace argand::detail {
namespace {

constexpr double kU = kUnitRoundoff;

/// The C library's sin and cos are assumed within this of the exact value
/// for arguments in [0, pi] (glibc documents < 1 ulp, i.e. <= 2^-53 here;
/// core/tests/render_test.cpp checks the assumption against long double).
constexpr double kTrigAbsError = 0x1p-50;

// edge_range (pixel_decision.h), its error bound: |y C - x S - s| <= err
// (|x| + |y|) + 2u (|y C'| + |x S'|) (two roundings and the products'), plus
// underflow. The bound itself is computed in round-to-nearest from
// nonnegative terms (at most six roundings, each within a factor 1 + u) and
// inflated by 1 + 8u, then rounded up.
}  // namespace

FastEdge fast_edge(const FramePlan::BandEdge& e) {
    FastEdge f;
    f.e = e;
    // fl(4u M) is exact (a power-of-two scaling of a normal M >= 2^-1/2);
    // the sum and the product each lose at most a factor (1 - u):
    // k >= (4u M + E) (1 + 64u) (1 - u)^2 >= (4u M + E) (1 + 61u).
    const double m = std::fabs(e.cos_mid) > std::fabs(e.sin_mid) ? std::fabs(e.cos_mid) : std::fabs(e.sin_mid);
    f.k = (4.0 * kU * m + e.err) * (1.0 + 64.0 * kU);
    if (!(m >= 0.5)) f.k = INFINITY;  // (never for a real angle: then no quick test)
    return f;
}

BandPlan band_plan(const FramePlan& plan, bool complex_space) {
    BandPlan bp;
    bp.axis = !complex_space || (plan.params.sigma == 0.0 && plan.params.delta == 0.0);
    bp.sigma_zero = plan.params.sigma == 0.0;
    bp.lower = plan.params.sigma > 0.0;
    bp.lower_edge = fast_edge(plan.lower_edge);
    bp.upper_edge = fast_edge(plan.upper_edge);
    return bp;
}

FramePlan::BandEdge band_edge(double a, double b) {
    FramePlan::BandEdge e;
    double s = a + b;
    const double rounding = add_error(a, b, s);
    e.cos_mid = std::cos(s);
    e.sin_mid = std::sin(s);
    // cos and sin are 1-Lipschitz: the exact angle is within `rounding` of s.
    e.err = add_up0(kTrigAbsError, rounding);
    return e;
}

namespace {
/// |c| = sqrt(re^2 + im^2) computed in round-to-nearest is within a factor
/// (1 +- 3u) of the exact modulus when nothing underflows or overflows
/// (two squares, a sum, a square root: (1 + u)^2.5 < 1 + 3u), which holds
/// for moduli in [2^-500, 2^500]; outside, arith.h's directed mag_* are used.
constexpr double kModulusLow = 1.0 - 4.0 * kU, kModulusHigh = 1.0 + 4.0 * kU;
inline bool modulus_in_safe_range(double m) { return m >= 0x1p-500 && m <= 0x1p500; }
}  // namespace

double modulus_down(const RootDisc& d) {
    const double m = std::sqrt(d.re * d.re + d.im * d.im);
    const double lo = modulus_in_safe_range(m) ? next_down(next_down(m * kModulusLow) - d.radius)
                                               : add_down(mag_down(Complex<double>(d.re, d.im)), -d.radius);
    return lo > 0.0 ? lo : 0.0;
}
double modulus_up(const RootDisc& d) {
    const double m = std::sqrt(d.re * d.re + d.im * d.im);
    if (modulus_in_safe_range(m)) return next_up(next_up(m * kModulusHigh) + d.radius);
    return add_up0(mag_up(Complex<double>(d.re, d.im)), d.radius);
}
void modulus_bounds(const RootDisc& d, double& lo, double& hi) {
    const double m = std::sqrt(d.re * d.re + d.im * d.im);
    if (!modulus_in_safe_range(m)) {
        lo = modulus_down(d);
        hi = modulus_up(d);
        return;
    }
    // (modulus_down's and modulus_up's safe-range formulas, one square root.)
    const double l = next_down(next_down(m * kModulusLow) - d.radius);
    lo = l > 0.0 ? l : 0.0;
    hi = next_up(next_up(m * kModulusHigh) + d.radius);
}


bool mirror_within(const RootDisc& a, const RootDisc& b, double reach) {
    return !(dist_down(a.re, a.im, b.re, -b.im) > reach);
}

bool real_by_mirror(const RootDisc* all, int n_all, int self) {
    const RootDisc& d = all[self];
    for (int j = 0; j < n_all; ++j)
        if (j != self && may_meet_mirror(all[j], d)) return false;
    return true;
}

bool is_mirror_twin(const RootDisc& b, const RootDisc& j, const RootDisc* all, int n_all, bool all_verified) {
    if (!all_verified || !b.verified || b.count != 1 || !j.verified || j.count != 1) return false;
    if (!may_meet_mirror(j, b)) return false;
    int meeting = 0;
    for (int k = 0; k < n_all; ++k)
        if (may_meet_mirror(all[k], b)) ++meeting;
    return meeting == 1;
}

Verdict band_membership(const RootDisc& d, bool real, const FramePlan& plan, bool complex_space) {
    const double r = d.radius;
    // 0 is outside the disc (a sufficient test first, then the modulus).
    const bool misses_zero = std::fabs(d.re) > r || std::fabs(d.im) > r || modulus_down(d) > 0.0;
    if (!complex_space || (plan.params.sigma == 0.0 && plan.params.delta == 0.0)) {
        // The band is the positive real axis (arg t = 0 exactly).
        if (real && misses_zero) return d.re > 0.0 ? Verdict::Yes : Verdict::No;
        // Points of the disc on the half-line [0, inf)?
        if (add_down(std::fabs(d.im), -r) > 0.0 || add_up(d.re, r) < 0.0) return Verdict::No;
        return Verdict::Unknown;
    }
    if (!misses_zero) return Verdict::Unknown;
    const double sigma = plan.params.sigma;
    if (real) {
        // arg t = 0 (in the band iff sigma == 0) or pi (never: sigma + delta
        // <= pi, and the exact sum of two doubles is never pi).
        if (d.re > 0.0) return sigma == 0.0 ? Verdict::Yes : Verdict::No;
        return Verdict::No;
    }
    // |arg z| over the disc equals arg z over the disc reflected into the
    // upper half-plane (centre (x, |y|)); there arg z <= alpha iff
    // s(z) <= 0, and arg z >= alpha iff s(z) >= 0 (alpha in (0, pi)).
    const double x = d.re, y = std::fabs(d.im);
    bool above_lower = true, below_lower = false;  // all >= sigma / all < sigma
    if (sigma > 0.0) {
        double lo, hi;
        edge_range(plan.lower_edge, x, y, r, lo, hi);
        above_lower = lo >= 0.0;
        below_lower = hi < 0.0;
    }
    double lo, hi;
    edge_range(plan.upper_edge, x, y, r, lo, hi);
    const bool below_upper = hi <= 0.0, above_upper = lo > 0.0;
    if (above_lower && below_upper) return Verdict::Yes;
    if (below_lower || above_upper) return Verdict::No;
    return Verdict::Unknown;
}

namespace {

/// |o' + s d'|^2 over s in [mod_lo, mod_hi], per axis in intervals. Exact:
/// step outward only after a rounding (slower; decides points exactly on
/// the sphere); otherwise always step.
/// |o' + s d'|^2 over s in [mod_lo, mod_hi], per axis in intervals, exact
/// (outward steps only after a rounding: decides points exactly on the
/// sphere).
Verdict clip_verdict_exact(const ObjectRay& ray, double mod_lo, double mod_hi, double radius) {
    double qlo = 0.0, qhi = 0.0;
    for (int a = 0; a < 3; ++a) {
        const Interval o = to_interval(ray.origin[a]), d = to_interval(ray.direction[a]);
        // d * [mod_lo, mod_hi] with mod_lo >= 0, then + o.
        const double dlo = d.lo >= 0 ? product_down(d.lo, mod_lo) : product_down(d.lo, mod_hi);
        const double dhi = d.hi >= 0 ? product_up(d.hi, mod_hi) : product_up(d.hi, mod_lo);
        const double plo = sum_down(o.lo, dlo), phi = sum_up(o.hi, dhi);
        double slo, shi;
        if (plo >= 0) {
            slo = product_down(plo, plo);
            shi = product_up(phi, phi);
        } else if (phi <= 0) {
            slo = product_down(phi, phi);
            shi = product_up(plo, plo);
        } else {
            const double m = -plo > phi ? -plo : phi;
            slo = 0.0;
            shi = product_up(m, m);
        }
        qlo = sum_down(qlo, slo > 0.0 ? slo : 0.0);
        qhi = sum_up(qhi, shi);
    }
    if (qhi <= product_down(radius, radius)) return Verdict::Yes;
    if (qlo > product_up(radius, radius)) return Verdict::No;
    return Verdict::Unknown;
}

/// A cheaper first test: the point P_c = o' + m d' at the middle modulus m,
/// computed in round-to-nearest, and a bound e on the distance from P_c to
/// every P(s) = o' + s d' (s in [mod_lo, mod_hi], o' and d' anywhere in
/// their balls): |s - m| |d'| + rad(o') + m rad(d') + the roundings of P_c
/// (at most 4u (|o'| + m |d'|) per axis), with 1-norms bounding 2-norms.
/// Then every |P(s)| lies in [|P_c| - e, |P_c| + e], |P_c| within 3u.
Verdict clip_verdict_fast(const ObjectRay& ray, double mod_lo, double mod_hi, double radius) {
    const double m = 0.5 * (mod_lo + mod_hi);
    const double w = (mod_hi - m > m - mod_lo ? mod_hi - m : m - mod_lo) * (1.0 + 4.0 * kU);
    double q = 0.0, spread = 0.0, size = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double om = ray.origin[a].mid, dm = ray.direction[a].mid;
        const double p = om + m * dm;
        q += p * p;
        const double dabs = std::fabs(dm) + ray.direction[a].rad;
        spread += w * dabs + ray.origin[a].rad + mod_hi * ray.direction[a].rad;
        size += std::fabs(om) + mod_hi * dabs;
    }
    // Each sum/product above of nonnegatives is within 1 + u: inflate by
    // 1 + 16u, then round up.
    const double e = next_up((spread + 8.0 * kU * size) * (1.0 + 16.0 * kU) + 64.0 * kDenormMin);
    const double norm = std::sqrt(q);
    if (!(e < INFINITY) || !(norm < INFINITY)) return Verdict::Unknown;
    if (next_up(norm * (1.0 + 4.0 * kU) + e) <= radius * (1.0 - 2.0 * kU)) return Verdict::Yes;
    if (next_down(norm * (1.0 - 4.0 * kU) - e) > radius * (1.0 + 2.0 * kU)) return Verdict::No;
    return Verdict::Unknown;
}

}  // namespace

Verdict inside_clip(const ObjectRay& ray, double mod_lo, double mod_hi, double radius) {
    const Verdict v = clip_verdict_fast(ray, mod_lo, mod_hi, radius);
    return v != Verdict::Unknown ? v : clip_verdict_exact(ray, mod_lo, mod_hi, radius);
}

namespace {

/// Horner in double-double with a running error bound, as eval_bound
/// (solver.h) but with double-double coefficients: |p(x) - value| <= err
/// for the exact dd coefficients c and the exact dd point x.
bool eval_dd(const DoubleDouble* c, int n, Complex<DoubleDouble> x, Complex<DoubleDouble>& value, double& err) {
    using E = ErrorModel<DoubleDouble>;
    const double ax = mag_up(x);
    Complex<DoubleDouble> y(c[n]);
    double ay = abs_up(c[n]);
    double e = 0.0;
    for (int k = n - 1; k >= 0; --k) {
        const Complex<DoubleDouble> next = add_real(y * x, c[k]);
        const double a_next = mag_up(next);
        e = add_up(add_up(mul_up(e, ax), mul_up(E::mul_rel, mul_up(ay, ax))), add_up(mul_up(E::add_rel, a_next), 2.0 * E::abs_err));
        y = next;
        ay = a_next;
    }
    value = y;
    err = e;
    return std::isfinite(e) && is_finite(y);
}

/// sum_k r_k a^k, rounded up.
double radius_sum(const double* r, int n, double a) {
    double s = r[n];
    for (int k = n - 1; k >= 0; --k) s = add_up0(mul_up0(s, a), r[k]);
    return s;
}

}  // namespace

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

bool isolate_dd(const RayCoefficients<DoubleDouble>& p, RootsResult& res) {
    if (!p.finite) return false;
    int n = p.n;
    while (n > 0 && is_zero(p.c[n]) && p.r[n] == 0.0) --n;  // exact roots at infinity
    if (n < 2 || n != p.n - res.n_infinite) return false;
    if (is_zero(p.c[0]) && p.r[0] == 0.0) return false;     // an exact root at 0: not here
    const double lead_lo = add_down(abs_down(p.c[n]), -p.r[n]);
    if (!(lead_lo > 0.0)) return false;
    // Starting points: each disc's centre, a cluster's spread on a circle.
    Complex<DoubleDouble> x[kMaxDegree];
    int m = 0;
    for (int i = 0; i < res.n_discs && m < n; ++i) {
        const RootDisc& d = res.discs[i];
        for (int k = 0; k < d.count && m < n; ++k) {
            const double a = 2.0 * 3.14159265358979323846 * k / d.count + 0.4;
            const double rho = d.count > 1 ? 0.5 * d.radius : 0.0;
            x[m++] = Complex<DoubleDouble>(DoubleDouble(d.re + rho * std::cos(a)), DoubleDouble(d.im + rho * std::sin(a)));
        }
    }
    if (m != n) return false;
    // Aberth-Ehrlich in double-double (approximations only). Near a cluster
    // the corrections of its roots bottom out at the rounding noise of p
    // there (about 2^-104 relative over the cluster's separation), above the
    // 2^-100 target, and would run all 60 sweeps: once the largest relative
    // correction is below 2^-64 and has failed twice in a row to halve the
    // smallest seen, the approximations are as good as this precision makes
    // them, and the sweeps stop (speed only: Smith's radii below prove
    // whatever they are).
    double smallest = INFINITY;
    int stalled = 0;
    for (int it = 0; it < 60; ++it) {
        double largest = 0.0;
        for (int i = 0; i < n; ++i) {
            Complex<DoubleDouble> v(p.c[n]), dv(DoubleDouble(0.0));
            for (int k = n - 1; k >= 0; --k) {
                dv = dv * x[i] + v;
                v = add_real(v * x[i], p.c[k]);
            }
            Complex<DoubleDouble> sum(DoubleDouble(0.0));
            for (int j = 0; j < n; ++j)
                if (j != i) sum = sum + reciprocal(x[i] - x[j]);
            const Complex<DoubleDouble> w = v / (dv - v * sum);
            if (!is_finite(w)) continue;
            x[i] = x[i] - w;
            const double step = mag_approx(w) / (mag_approx(x[i]) + 1e-300);
            largest = step > largest ? step : largest;
        }
        if (largest < 0x1p-100) break;
        if (largest <= 0x1p-64) {
            stalled = largest > 0.5 * smallest ? stalled + 1 : 0;
            if (stalled >= 2) break;
        }
        smallest = largest < smallest ? largest : smallest;
    }
    // Smith's radii over the coefficient balls, outward-rounded.
    using E = ErrorModel<DoubleDouble>;
    double cre[kMaxDegree], cim[kMaxDegree], rad[kMaxDegree];
    for (int i = 0; i < n; ++i) {
        if (!is_finite(x[i])) return false;
        Complex<DoubleDouble> v;
        double e;
        if (!eval_dd(p.c, n, x[i], v, e)) return false;
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

}  // namespace argand::detail
