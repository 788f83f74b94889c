// refine_dd.cpp: double-double root refinement (refine_dd.h), all
// outward-rounded through arith.h/interval.h. (Moved from
// pixel_decision.cpp: it is root finding, not a pixel's decision.)
#include "refine_dd.h"

#include <cmath>

#include "root_kernels.h"

namespace argand::detail {
namespace {

/// Horner in double-double with a running error bound, as eval_bound
/// (root_kernels.h) but with double-double coefficients: |p(x) - value| <= err
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
    bool in_cluster[kMaxDegree];
    int m = 0;
    for (int i = 0; i < res.n_discs && m < n; ++i) {
        const RootDisc& d = res.discs[i];
        for (int k = 0; k < d.count && m < n; ++k) {
            const double a = 2.0 * 3.14159265358979323846 * k / d.count + 0.4;
            const double rho = d.count > 1 ? 0.5 * d.radius : 0.0;
            in_cluster[m] = d.count > 1;
            x[m++] = Complex<DoubleDouble>(DoubleDouble(d.re + rho * std::cos(a)), DoubleDouble(d.im + rho * std::sin(a)));
        }
    }
    if (m != n) return false;
    // Aberth-Ehrlich in double-double (approximations only), one sweep over
    // the roots `which` selects; returns the largest relative correction.
    auto sweep = [&](const bool* which) {
        double largest = 0.0;
        for (int i = 0; i < n; ++i) {
            if (which != nullptr && !which[i]) continue;
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
        return largest;
    };
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
    // halve the smallest seen, the approximations are as good as this
    // precision makes them, and the sweeps stop. Then the other roots, at
    // most two sweeps (Aberth's cubic rate takes a double centre to the
    // precision's end in one): double-double accuracy for every root, as
    // when every root was swept from the start. (Speed only: Smith's radii
    // below prove whatever the approximations are.)
    double smallest = INFINITY;
    int stalled = 0;
    for (int it = 0; it < 60; ++it) {
        const double largest = sweep(in_cluster);
        if (largest < 0x1p-100) break;
        if (largest <= 0x1p-64) {
            stalled = largest > 0.5 * smallest ? stalled + 1 : 0;
            if (stalled >= 2) break;
        }
        smallest = largest < smallest ? largest : smallest;
    }
    bool outside[kMaxDegree];
    for (int i = 0; i < n; ++i) outside[i] = !in_cluster[i];
    for (int it = 0; it < 2; ++it)
        if (sweep(outside) < 0x1p-100) break;
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
