// root_kernels.h: kernels shared by the root-finding methods (internal header).
//
// Preconditions for every kernel here unless stated otherwise: c[0..n] are
// finite doubles (exact values), n in [1, kMaxDegree], c[0] != 0, c[n] != 0.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "argand/arith.h"
#include "argand/roots.h"
#include "constants.h"

namespace argand::detail {

template <class T> constexpr double working_epsilon() { return kUnitRoundoff; }
template <> constexpr double working_epsilon<DoubleDouble>() { return 0x1p-104; }

// ---------------------------------------------------------------------------
// Evaluation
// ---------------------------------------------------------------------------

/// p(x) and p'(x) by Horner's rule (approximations, no bound).
template <class T>
inline void eval_with_derivative(const double* c, int n, Complex<T> x, Complex<T>& p, Complex<T>& dp) {
    p = Complex<T>(T(c[n]));
    dp = Complex<T>(T(0.0));
    for (int k = n - 1; k >= 0; --k) {
        dp = dp * x + p;
        p = add_real(p * x, T(c[k]));
    }
}

/// Sum of |c_k| |x|^k for a modulus ax (approximate scale of p's rounding noise).
inline double abs_poly(const double* c, int n, double ax) {
    double s = std::fabs(c[n]);
    for (int k = n - 1; k >= 0; --k) s = s * ax + std::fabs(c[k]);
    return s;
}

/// Rigorous Horner: on return, |p(x) - value| <= err, where x is the exact
/// value of the argument in T. Returns false (and nothing is claimed) if any
/// intermediate is not finite.
template <class T>
inline bool eval_bound(const double* c, int n, Complex<T> x, Complex<T>& value, double& err) {
    using E = ErrorModel<T>;
    const double ax = mag_up(x);
    Complex<T> y{T(c[n])};  // braces: y(T(c[n])) is a function declaration to Clang (vexing parse)
    double ay = std::fabs(c[n]);
    double e = 0.0;
    for (int k = n - 1; k >= 0; --k) {
        // Step k: y <- fl(fl(y * x) + c_k). The exact value moves by
        // (exact - computed) * x, plus this step's two roundings.
        Complex<T> y_next = add_real(y * x, T(c[k]));
        const double a_next = mag_up(y_next);
        e = add_up(add_up(mul_up(e, ax), mul_up(E::mul_rel, mul_up(ay, ax))),
                   add_up(mul_up(E::add_rel, a_next), 2.0 * E::abs_err));
        y = y_next;
        ay = a_next;
    }
    value = y;
    err = e;
    return std::isfinite(e) && is_finite(y);
}

/// Upper bound of sum_k rad_k |x|^k for a modulus bound ax >= |x| (rounded
/// upward: every step is a sum or product of nonnegatives, each rounded up).
/// With rad the radii of a family of polynomials {q : |q_k - c_k| <= rad_k},
/// |q(x)| <= |p(x)| + family_up(rad, n, |x|) for every member q. rad may be
/// null (a single polynomial): 0.
inline double family_up(const double* rad, int n, double ax) {
    if (rad == nullptr) return 0.0;
    double s = rad[n];
    for (int k = n - 1; k >= 0; --k) s = add_up(mul_up(s, ax), rad[k]);
    return s;
}

/// Lower bound of |q_n| over the family: |c_n| - rad_n rounded down (<= 0
/// when the family contains a polynomial of lower degree; nothing can then
/// be proven about n roots).
inline double lead_down(const double* c, const double* rad, int n) {
    return rad == nullptr ? std::fabs(c[n]) : add_down(std::fabs(c[n]), -rad[n]);
}

// ---------------------------------------------------------------------------
// Approximation: initial guesses and the Aberth-Ehrlich iteration
// ---------------------------------------------------------------------------

/// log2(v) to within 0.09 for finite v > 0 (exponent plus a linear mantissa).
inline double fast_log2(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    if (biased == 0 || biased == 0x7ff) return std::log2(v);  // subnormal (or not finite)
    bits = (bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL;  // mantissa in [1, 2)
    double m;
    std::memcpy(&m, &bits, sizeof m);
    return (biased - 1023) + (m - 1.0);
}

/// Initial approximations from the Newton polygon (upper convex hull of
/// (k, log|c_k|)), as in Bini's MPSolve: each hull edge of width m gives m
/// points on a circle of the radius it predicts. Spread by angle so that no
/// start is real and no two coincide.
inline void initial_guesses(const double* c, int n, Complex<double>* x) {
    // Unit roots e^{2 pi i / m}, m = 1..kMaxDegree, computed once.
    struct Table {
        Complex<double> step[kMaxDegree + 1];
        Table() {
            for (int m = 1; m <= kMaxDegree; ++m) step[m] = Complex<double>(std::cos(2 * kPi / m), std::sin(2 * kPi / m));
        }
    };
    static const Table table;
    static const Complex<double> twist(std::cos(0.4), std::sin(0.4));
    int hull[kMaxDegree + 1];
    double lg[kMaxDegree + 1];
    int h = 0;
    for (int k = 0; k <= n; ++k) {
        if (c[k] == 0.0) continue;
        lg[k] = fast_log2(std::fabs(c[k]));
        while (h >= 2) {
            const int a = hull[h - 2], b = hull[h - 1];
            // Drop b if it lies on or below the segment from a to k.
            if ((lg[b] - lg[a]) * (k - a) <= (lg[k] - lg[a]) * (b - a)) --h;
            else break;
        }
        hull[h++] = k;
    }
    int idx = 0;
    Complex<double> offset = twist;  // e^{i(2 pi a / n + 0.4)}, advanced per edge
    int advanced = 0;
    for (int s = 0; s + 1 < h; ++s) {
        const int a = hull[s], b = hull[s + 1], m = b - a;
        for (; advanced < a; ++advanced) offset = offset * table.step[n];
        const double r = std::exp2((lg[a] - lg[b]) / m);
        // Points r e^{i(2 pi j / m)} times the offset, by repeated rotation.
        Complex<double> z = mul_real(offset, r);
        for (int j = 0; j < m; ++j) {
            x[idx++] = z;
            z = z * table.step[m];
        }
    }
}

/// Principal square root (approximation).
inline Complex<double> complex_sqrt(Complex<double> z) {
    const double m = std::sqrt(z.re * z.re + z.im * z.im);
    const double re = std::sqrt(0.5 * (m + std::fabs(z.re)));
    if (re == 0.0) return Complex<double>(0.0, 0.0);
    const double other = z.im / (2.0 * re);
    return z.re >= 0.0 ? Complex<double>(re, other) : Complex<double>(std::fabs(other), z.im >= 0.0 ? re : -re);
}

/// Roots of the real monic quadratic t^2 + b t + c (approximation).
inline void real_quadratic_roots(double b, double c, Complex<double>* x) {
    const double disc = b * b - 4.0 * c;
    if (disc >= 0.0) {
        const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
        x[0] = Complex<double>(q, 0.0);
        x[1] = Complex<double>(q != 0.0 ? c / q : 0.0, 0.0);
    } else {
        const double im = 0.5 * std::sqrt(-disc);
        x[0] = Complex<double>(-0.5 * b, im);
        x[1] = Complex<double>(-0.5 * b, -im);
    }
}

/// Approximate roots of a real cubic or quartic (and lower) in closed form,
/// used only as starting points ("the surface's own degree"): a few ulps or
/// a few digits, Aberth and Smith do the rest. Returns false if the formula
/// broke down (NaN, a zero pivot); the caller then uses initial_guesses.
inline bool closed_form_guesses(const double* c, int n, Complex<double>* x) {
    if (n == 1) {
        x[0] = Complex<double>(-c[0] / c[1], 0.0);
    } else if (n == 2) {
        real_quadratic_roots(c[1] / c[2], c[0] / c[2], x);
    } else if (n == 3 || n == 4) {
        // Monic depressed form y^n + p y^(n-2) + q y^(n-3) [+ r] with
        // t = y - shift. (Approximations: constants multiply, not divide.)
        constexpr double third = 1.0 / 3.0, twenty_seventh = 1.0 / 27.0;
        const double inv_lead = 1.0 / c[n];
        const double a3 = c[n - 1] * inv_lead, a2 = c[n - 2] * inv_lead, a1 = c[n - 3] * inv_lead;
        if (n == 3) {
            const double shift = a3 * third;
            const double p = a2 - a3 * shift;
            const double q = 2.0 * twenty_seventh * a3 * a3 * a3 - a3 * a2 * third + a1;
            // Cardano for a real root, then the quadratic cofactor.
            const double disc = 0.25 * q * q + twenty_seventh * p * p * p;
            double y0;
            if (disc >= 0.0) {
                const double sq = std::sqrt(disc);
                const double u = std::cbrt(q >= 0.0 ? -0.5 * q - sq : -0.5 * q + sq);
                y0 = (u != 0.0) ? u - p * third / u : 0.0;
            } else {
                const double m = 2.0 * std::sqrt(-p * third);
                const double theta = std::acos(std::fmax(-1.0, std::fmin(1.0, 3.0 * q / (p * m)))) * third;
                y0 = m * std::cos(theta);
            }
            x[0] = Complex<double>(y0 - shift, 0.0);
            // y^3 + p y + q = (y - y0)(y^2 + y0 y + (p + y0^2)).
            Complex<double> y12[2];
            real_quadratic_roots(y0, p + y0 * y0, y12);
            x[1] = y12[0] - Complex<double>(shift);
            x[2] = y12[1] - Complex<double>(shift);
        } else {
            const double a0 = c[0] * inv_lead;
            const double shift = 0.25 * a3;
            const double s2 = shift * shift;
            const double p = a2 - 6.0 * s2;
            const double q = a1 - 2.0 * a2 * shift + 8.0 * s2 * shift;
            const double r = a0 - a1 * shift + a2 * s2 - 3.0 * s2 * s2;
            // Resolvent cubic z^3 + 2p z^2 + (p^2 - 4r) z - q^2: its largest
            // real root z >= 0 splits the quartic into two quadratics.
            const double rc[4] = {-q * q, p * p - 4.0 * r, 2.0 * p, 1.0};
            Complex<double> z3[3];
            closed_form_guesses(rc, 3, z3);
            double z = z3[0].re;
            for (int k = 1; k < 3; ++k)
                if (std::fabs(z3[k].im) <= 1e-8 * (1.0 + std::fabs(z3[k].re)) && z3[k].re > z) z = z3[k].re;
            Complex<double> y[4];
            if (z > 1e-14 * (1.0 + std::fabs(p))) {
                const double w = std::sqrt(z);
                const double half = 0.5 * (p + z);
                const double t = 0.5 * q / w;  // (one division)
                real_quadratic_roots(w, half - t, y);
                real_quadratic_roots(-w, half + t, y + 2);
            } else {
                // Biquadratic: y^4 + p y^2 + r.
                Complex<double> w2[2];
                real_quadratic_roots(p, r, w2);
                y[0] = complex_sqrt(w2[0]);
                y[1] = -y[0];
                y[2] = complex_sqrt(w2[1]);
                y[3] = -y[2];
            }
            for (int k = 0; k < 4; ++k) x[k] = y[k] - Complex<double>(shift);
        }
    } else {
        return false;
    }
    for (int k = 0; k < n; ++k)
        if (!is_finite(x[k])) return false;
    return true;
}

/// Aberth-Ehrlich iteration in T, Gauss-Seidel style. Stops a root when its
/// correction is below the working precision or |p| reaches rounding noise.
/// Returns the number of sweeps done. Approximations only: nothing is proven.
template <class T>
inline int aberth(const double* c, int n, Complex<T>* x, int max_iter, bool* converged_out = nullptr) {
    const double eps = working_epsilon<T>();
    const double noise = 4.0 * (n + 1) * eps;
    const double stop_rel = sizeof(T) == sizeof(double) ? 0x1p-20 : 0x1p-40;
    const double stop_rel2 = stop_rel * stop_rel;
    bool done[kMaxDegree] = {};
    int remaining = n;
    int it = 0;
    for (; it < max_iter && remaining > 0; ++it) {
        for (int i = 0; i < n; ++i) {
            if (done[i]) continue;
            // p first (the same Horner values eval_with_derivative gives):
            // from good starting points most roots stop here, and p' would
            // be wasted.
            Complex<T> p{T(c[n])};
            for (int k = n - 1; k >= 0; --k) p = add_real(p * x[i], T(c[k]));
            const double ax2 = mag2_approx(x[i]);
            const double floor = noise * abs_poly(c, n, std::sqrt(ax2));
            if (mag2_approx(p) <= floor * floor) {
                done[i] = true;  // |p| is at rounding noise: nothing to gain
                --remaining;
                continue;
            }
            Complex<T> dp;
            eval_with_derivative(c, n, x[i], p, dp);
            // Aberth correction w = p / (p' - p * sum_j 1/(x_i - x_j)).
            Complex<T> s(T(0.0));
            for (int j = 0; j < n; ++j)
                if (j != i) s = s + reciprocal(x[i] - x[j]);
            const Complex<T> w = p / (dp - p * s);
            if (!is_finite(w)) {
                // Derivative or denominator vanished: nudge and retry.
                const double a = std::sqrt(ax2);
                const double nudge = (a > 0 ? a : 1.0) * 1e-7 * (1 + i);
                x[i] = x[i] + Complex<T>(T(nudge), T(nudge * 0.7));
                continue;
            }
            x[i] = x[i] - w;
            // Near a simple root Aberth converges cubically: once a correction
            // is below stop_rel, the next would be below the working precision.
            if (mag2_approx(w) <= stop_rel2 * mag2_approx(x[i])) {
                done[i] = true;
                --remaining;
            }
        }
    }
    if (converged_out) *converged_out = (remaining == 0);
    return it;
}

inline bool exact_equal(double a, double b) { return a == b; }
inline bool exact_equal(DoubleDouble a, DoubleDouble b) { return a.hi == b.hi && a.lo == b.lo; }

/// Makes the approximations pairwise distinct (Smith's theorem needs it) by
/// moving later duplicates a little. Bounded work: returns false (and the
/// caller must claim nothing) if an approximation is not finite, or if the
/// duplicates could not be separated within 4 n^2 + 16 moves (e.g. after an
/// overflow made two of them (inf, inf), whose nudge is infinite).
template <class T>
inline bool separate_duplicates(Complex<T>* x, int n) {
    for (int i = 0; i < n; ++i)
        if (!is_finite(x[i])) return false;
    int budget = 4 * n * n + 16;
    for (int i = 1; i < n; ++i) {
        for (int j = 0; j < i; ++j) {
            if (exact_equal(x[i].re, x[j].re) && exact_equal(x[i].im, x[j].im)) {
                if (--budget < 0) return false;
                // A step of 1e-9 relative (max-norm: no overflow), at least
                // 2^-1000 so that it moves subnormal approximations too.
                const double a = std::fmax(std::fabs(to_double(x[i].re)), std::fabs(to_double(x[i].im)));
                const double step = std::fmax(a * 1e-9, 0x1p-1000);
                const double angle = 2.0 * kPi * i / n + 0.3;
                x[i] = x[i] + Complex<T>(T(step * std::cos(angle)), T(step * std::sin(angle)));
                if (!is_finite(x[i])) return false;
                j = -1;  // re-check against all earlier ones
            }
        }
    }
    return true;
}

// ---------------------------------------------------------------------------
// Smith's inclusion discs
// ---------------------------------------------------------------------------

/// Smith (1970), Theorem 5: for pairwise distinct x_1..x_n, the discs
/// |z - x_i| <= n |p(x_i) / (c_n prod_{j != i}(x_i - x_j))| cover all roots,
/// and every connected component of their union made of m discs holds
/// exactly m roots (with multiplicity).
/// On true, r[i] is an upper bound of that radius, computed with rigorous
/// error bounds; with rad (coefficient radii), an upper bound of the radius
/// for every polynomial of the family {q : |q_k - c_k| <= rad_k}, so the
/// discs and their counts hold for each member (larger radii keep Smith's
/// counts: each component of the larger discs is a union of components of
/// the smaller ones). On false nothing is claimed (non-finite intermediate or
/// coincident approximations).
template <class T>
inline bool smith_radii(const double* c, int n, const Complex<T>* x, double* r, double* pair_low = nullptr,
                        const double* rad = nullptr) {
    using E = ErrorModel<T>;
    // |exact difference| >= |computed difference| * (1 - add_rel) - abs_err.
    const double shrink = next_down(1.0 - 2.0 * E::add_rel);
    double local[kMaxDegree * kMaxDegree];
    double* low = pair_low ? pair_low : local;
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const double d = mag_down(x[i] - x[j]);
            low[i * n + j] = low[j * n + i] = std::fmax(0.0, add_down(mul_down(d, shrink), -E::abs_err));
        }
    const double lead = lead_down(c, rad, n);
    if (!(lead > 0.0)) return false;
    for (int i = 0; i < n; ++i) {
        Complex<T> v;
        double err;
        if (!eval_bound(c, n, x[i], v, err)) return false;
        const double numerator = add_up(add_up(mag_up(v), err), family_up(rad, n, mag_up(x[i])));
        double denominator = lead;
        for (int j = 0; j < n; ++j)
            if (j != i) denominator = mul_down(denominator, low[i * n + j]);
        if (!(denominator > 0.0)) return false;
        r[i] = mul_up(static_cast<double>(n), div_up(numerator, denominator));
        if (!std::isfinite(r[i])) return false;
    }
    return true;
}

/// The same bound as smith_radii<double>, an order of magnitude cheaper: the
/// error terms are computed in round-to-nearest and inflated once at the end
/// instead of rounding every operation outward. Returns false (and the caller
/// must use smith_radii) whenever a range guard that the argument below needs
/// does not hold.
///
/// Why the final factors suffice. Every error quantity is built from exact
/// nonnegative inputs by + and x in round-to-nearest. A sum of nonnegatives
/// is exact or within a factor (1 +- u); a product too, unless it underflows,
/// which costs at most eta = 2^-1075 absolutely. Along any path the Horner
/// error term passes through at most K = 4n + 8 roundings, so
/// exact <= computed / (1-u)^K + slack <= computed (1 + 2(K+2)u) + slack,
/// where slack (the underflow losses carried through the later
/// multiplications by |x| <= ax) is at most 8 n eta max(1, ax)^n. Moduli are
/// bounded above by |re| + |im| (>= the modulus). A pair distance computed as
/// sqrt(dr^2 + di^2) from the rounded difference is within (1+u)^3.5 of the
/// exact distance when nothing underflows (guard: >= 2^-450); a product of n-1
/// of them and the leading coefficient within (1+u)^(4.5n), covered by the
/// factor 1 - 2(5n+2)u (guard: product >= 2^-900).
inline bool smith_radii_fast(const double* c, int n, const Complex<double>* x, double* r, double* low,
                             const double* rad = nullptr) {
    constexpr double u = kUnitRoundoff;
    using E = ErrorModel<double>;
    const double relative_up = 1.0 + 2.0 * (4.0 * n + 10.0) * u;
    const double den_down = 1.0 - 2.0 * (5.0 * n + 2.0) * u;
    const double pair_down = 1.0 - 8.0 * u;
    double dist[kMaxDegree * kMaxDegree];
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const double dr = x[i].re - x[j].re, di = x[i].im - x[j].im;
            const double d = std::sqrt(dr * dr + di * di);
            if (!(d >= 0x1p-450) || !(d <= 0x1p450)) return false;
            dist[i * n + j] = dist[j * n + i] = d;
            low[i * n + j] = low[j * n + i] = d * pair_down;
        }
    const double lead = std::fabs(c[n]);
    // Horner with a running error bound (see eval_bound for the terms), all
    // n evaluations advanced together so their dependency chains overlap.
    double ax[kMaxDegree], yr[kMaxDegree], yi[kMaxDegree], ay[kMaxDegree], e[kMaxDegree];
    // The family's term sum_k rad_k |x|^k rides in the same recurrence: it is
    // the Horner sum s <- s ax + rad_k, whose multiplier ax is e's, so adding
    // rad_k to step k's additive term (and starting e at rad_n) gives e + s.
    // Each rad_k leaf passes through the roundings of one step (at most 3)
    // and 3 per later step, plus the n products by ax (>= |x| (1 - u)): at
    // most 4n, within K; the additions bring no underflow loss, so the slack
    // stays that of e's products.
    const double rad_n = rad == nullptr ? 0.0 : rad[n];
    double ax_max = 1.0;
    for (int i = 0; i < n; ++i) {
        ax[i] = std::fabs(x[i].re) + std::fabs(x[i].im);
        if (!(ax[i] <= 0x1p64)) return false;  // (NaN too)
        ax_max = ax[i] > ax_max ? ax[i] : ax_max;
        yr[i] = c[n];
        yi[i] = 0.0;
        ay[i] = lead;
        e[i] = rad_n;
    }
    for (int k = n - 1; k >= 0; --k) {
        const double constant = 2.0 * E::abs_err + (rad == nullptr ? 0.0 : rad[k]);
        for (int i = 0; i < n; ++i) {
            const double pr = yr[i] * x[i].re - yi[i] * x[i].im;
            const double pi = yr[i] * x[i].im + yi[i] * x[i].re;
            yr[i] = pr + c[k];
            yi[i] = pi;
            const double a_next = std::fabs(yr[i]) + std::fabs(yi[i]);
            e[i] = ax[i] * (e[i] + E::mul_rel * ay[i]) + (E::add_rel * a_next + constant);
            ay[i] = a_next;
        }
    }
    // Underflow slack 8 n eta max(1, ax)^n with every ax <= 2^L, L >= 8 the
    // bit length of the largest (a root far out of the unit circle, as the
    // far root of a ray that starts next to a surface, raises L):
    // 16 n 2^-1074 2^(nL) <= n 2^max(nL-1070, -1014), a normal power of two
    // (guard: nL <= 1070, so the slack stays below n).
    std::uint64_t ax_max_bits;
    std::memcpy(&ax_max_bits, &ax_max, sizeof ax_max_bits);
    const int ax_bits = static_cast<int>(ax_max_bits >> 52) - 1022;  // 1 <= ax_max < 2^ax_bits
    const int L = std::max(8, ax_bits);
    if (n * L > 1070) return false;
    const double slack = n * pow2(std::max(n * L - 1070, -1014));
    const double lead_low = lead_down(c, rad, n);
    if (!(lead_low > 0.0)) return false;
    for (int i = 0; i < n; ++i) {
        // |p(x)| <= |yr| + |yi| <= ay (1 + u); the error and family terms are
        // at most e relative_up + slack. The sum S of ay, e relative_up and
        // slack (nonnegatives, normal: S >= slack >= 2^-1014) is computed
        // with three roundings: ay (1 + u) + e relative_up + slack <=
        // (1 + u)^4 S, and RN(S (1 + 8u)) >= S (1 + 8u) / (1 + u) >= that.
        // (An underflow of e relative_up, at most 2^-1075, is far below the
        // final step up, an ulp of a number >= 2^-1014.)
        const double numerator = next_up((ay[i] + e[i] * relative_up + slack) * (1.0 + 8.0 * u));
        double denominator = lead_low;
        for (int j = 0; j < n; ++j)
            if (j != i) denominator *= dist[i * n + j];
        if (!(denominator >= 0x1p-900) || !std::isfinite(denominator) || !std::isfinite(numerator)) return false;
        denominator *= den_down;
        r[i] = next_up(n * next_up(numerator / denominator));
        if (!std::isfinite(r[i])) return false;
    }
    return true;
}

/// The batched kernel's scalar twin (core/src/roots_batch_kernel.h performs
/// these operations, in this order, lane by lane; core/tests/roots_batch_test
/// compares the two bit for bit): smith_radii_fast as it was before its cost
/// pass (which folded the family term into the Horner recurrence and moved
/// the underflow guard; the lanes keep this form, whose argument follows).
///
/// The same bound as smith_radii<double>, an order of magnitude cheaper: the
/// error terms are computed in round-to-nearest and inflated once at the end
/// instead of rounding every operation outward. Returns false (and the caller
/// must use smith_radii) whenever a range guard that the argument below needs
/// does not hold.
///
/// Why the final factors suffice. Every error quantity is built from exact
/// nonnegative inputs by + and x in round-to-nearest. A sum of nonnegatives
/// is exact or within a factor (1 +- u); a product too, unless it underflows,
/// which costs at most eta = 2^-1075 absolutely. Along any path the Horner
/// error term passes through at most K = 4n + 8 roundings, so
/// exact <= computed / (1-u)^K + slack <= computed (1 + 2(K+2)u) + slack,
/// where slack (the underflow losses carried through the later
/// multiplications by |x| <= ax) is at most 8 n eta max(1, ax)^n. Moduli are
/// bounded above by |re| + |im| (>= the modulus). A pair distance computed as
/// sqrt(dr^2 + di^2) from the rounded difference is within (1+u)^3.5 of the
/// exact distance when nothing underflows (guard: >= 2^-450); a product of n-1
/// of them and the leading coefficient within (1+u)^(4.5n), covered by the
/// factor 1 - 2(5n+2)u (guard: product >= 2^-900).
inline bool smith_radii_lanes_reference(const double* c, int n, const Complex<double>* x, double* r, double* low,
                             const double* rad = nullptr) {
    constexpr double u = kUnitRoundoff;
    using E = ErrorModel<double>;
    const double relative_up = 1.0 + 2.0 * (4.0 * n + 10.0) * u;
    const double den_down = 1.0 - 2.0 * (5.0 * n + 2.0) * u;
    const double pair_down = 1.0 - 8.0 * u;
    // Underflow slack 8 n eta max(1, ax)^n with ax <= 2^8 (guarded below).
    // (16 n 2^-1074 2^(8n) <= n 2^max(8n-1070, -1014), a normal power of two.)
    const double slack = n * pow2(std::max(8 * n - 1070, -1014));
    double dist[kMaxDegree * kMaxDegree];
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const double dr = x[i].re - x[j].re, di = x[i].im - x[j].im;
            const double d = std::sqrt(dr * dr + di * di);
            if (!(d >= 0x1p-450) || !(d <= 0x1p450)) return false;
            dist[i * n + j] = dist[j * n + i] = d;
            low[i * n + j] = low[j * n + i] = d * pair_down;
        }
    const double lead = std::fabs(c[n]);
    // Horner with a running error bound (see eval_bound for the terms), all
    // n evaluations advanced together so their dependency chains overlap.
    double ax[kMaxDegree], yr[kMaxDegree], yi[kMaxDegree], ay[kMaxDegree], e[kMaxDegree];
    for (int i = 0; i < n; ++i) {
        ax[i] = std::fabs(x[i].re) + std::fabs(x[i].im);
        if (!(ax[i] <= 0x1p8)) return false;  // keeps the slack below tiny
        yr[i] = c[n];
        yi[i] = 0.0;
        ay[i] = lead;
        e[i] = 0.0;
    }
    for (int k = n - 1; k >= 0; --k) {
        for (int i = 0; i < n; ++i) {
            const double pr = yr[i] * x[i].re - yi[i] * x[i].im;
            const double pi = yr[i] * x[i].im + yi[i] * x[i].re;
            yr[i] = pr + c[k];
            yi[i] = pi;
            const double a_next = std::fabs(yr[i]) + std::fabs(yi[i]);
            e[i] = ax[i] * (e[i] + E::mul_rel * ay[i]) + (E::add_rel * a_next + 2.0 * E::abs_err);
            ay[i] = a_next;
        }
    }
    // The family's term sum_k rad_k |x|^k, in round-to-nearest on ax >= |x|
    // (1 - u): the same argument as for e bounds it by relative_up and slack.
    double fam[kMaxDegree];
    const double lead_low = lead_down(c, rad, n);
    if (!(lead_low > 0.0)) return false;
    for (int i = 0; i < n; ++i) {
        fam[i] = 0.0;
        if (rad == nullptr) continue;
        double s = rad[n];
        for (int k = n - 1; k >= 0; --k) s = s * ax[i] + rad[k];
        fam[i] = add_up(next_up(s * relative_up), slack);
    }
    for (int i = 0; i < n; ++i) {
        const double numerator =
            add_up(add_up(next_up(ay[i]), next_up(e[i] * relative_up)), add_up(slack, fam[i]));
        double denominator = lead_low;
        for (int j = 0; j < n; ++j)
            if (j != i) denominator *= dist[i * n + j];
        if (!(denominator >= 0x1p-900) || !std::isfinite(denominator) || !std::isfinite(numerator)) return false;
        denominator *= den_down;
        r[i] = next_up(n * next_up(numerator / denominator));
        if (!std::isfinite(r[i])) return false;
    }
    return true;
}

// ---------------------------------------------------------------------------
// Geometry of discs (binary64, outward rounding)
// ---------------------------------------------------------------------------

/// A disc that holds exactly `count` roots as a member of a covering family
/// (a Smith disc, or an exact root point with its multiplicity).
struct MemberDisc {
    double re, im, r;
    int count;
};

/// Lower / upper bounds of |a - b| for points given in doubles. A difference
/// of doubles is correctly rounded (exact when subnormal), so per component
/// |exact| is within a factor (1 +- u) of the computed one (overflow gives
/// inf: still an upper bound, and next_down(inf) is a lower one). The modulus
/// is taken on components rescaled by an exact power of two when they are
/// tiny or huge, so that squaring neither underflows (which made the lower
/// bound 0 and the upper bound 2^-537 for subnormal distances) nor overflows.
inline double scaled_hypot(double dr, double di, bool up) {
    const double big = std::fmax(dr, di);
    if (big > 0.0 && big < 0x1p-500) {
        // Exact: no overflow, and a product by 2^600 of a double this small is a normal double.
        const double h = up ? hypot_up(dr * 0x1p600, di * 0x1p600) : hypot_down(dr * 0x1p600, di * 0x1p600);
        return up ? mul_up(h, 0x1p-600) : mul_down(h, 0x1p-600);
    }
    if (big > 0x1p500 && std::isfinite(big)) {
        // The smaller component may lose bits when scaled down: round it the safe way.
        const double sr = up ? mul_up(dr, 0x1p-600) : mul_down(dr, 0x1p-600);
        const double si = up ? mul_up(di, 0x1p-600) : mul_down(di, 0x1p-600);
        const double h = up ? hypot_up(std::fmax(sr, 0.0), std::fmax(si, 0.0)) : hypot_down(std::fmax(sr, 0.0), std::fmax(si, 0.0));
        return up ? mul_up(h, 0x1p600) : mul_down(h, 0x1p600);
    }
    return up ? hypot_up(dr, di) : hypot_down(dr, di);
}
inline double dist_down(double ar, double ai, double br, double bi) {
    return std::fmax(0.0, mul_down(scaled_hypot(std::fabs(ar - br), std::fabs(ai - bi), false), 1.0 - 2.0 * kUnitRoundoff));
}
inline double dist_up(double ar, double ai, double br, double bi) {
    return mul_up(scaled_hypot(std::fabs(ar - br), std::fabs(ai - bi), true), 1.0 + 2.0 * kUnitRoundoff);
}

/// Given a covering family (every root of p lies in some member, and every
/// connected component of the union holds as many roots as its members'
/// counts add up to), groups the members into enclosing discs that are
/// pairwise disjoint (proven), each holding exactly the sum of its members'
/// counts. real_axis_centers: the polynomial is real, so an enclosure that
/// meets the real axis is centred on it (symmetric discs prove real roots).
/// Writes verified RootDisc entries to out; returns how many.
inline int enclose_and_merge(const MemberDisc* members, int m, bool real_axis_centers, RootDisc* out) {
    int group[kMaxDegree];
    for (int i = 0; i < m; ++i) group[i] = i;
    struct Enclosure { double re, im, r; int count; };
    Enclosure enc[kMaxDegree];
    int n_groups = 0;
    for (;;) {
        // Compute one enclosure per group.
        int label[kMaxDegree];
        n_groups = 0;
        for (int i = 0; i < m; ++i) label[i] = -1;
        for (int i = 0; i < m; ++i) {
            if (label[i] >= 0) continue;
            const int g = group[i];
            // Members of group g: centroid as the centre.
            double sr = 0, si = 0, w = 0;
            int count = 0, size = 0, last = i;
            for (int j = i; j < m; ++j) {
                if (group[j] != g) continue;
                label[j] = n_groups;
                sr += members[j].re;
                si += members[j].im;
                w += 1.0;
                count += members[j].count;
                ++size;
                last = j;
            }
            Enclosure e;
            if (size == 1) {
                e = {members[last].re, members[last].im, members[last].r, count};
            } else {
                e.re = sr / w;
                e.im = si / w;
                e.count = count;
                double rmax = 0.0;
                bool meets_axis = false;
                for (int j = i; j < m; ++j) {
                    if (group[j] != g) continue;
                    if (std::fabs(members[j].im) <= members[j].r) meets_axis = true;
                    rmax = std::fmax(rmax, add_up(dist_up(e.re, e.im, members[j].re, members[j].im), members[j].r));
                }
                if (real_axis_centers && (meets_axis || std::fabs(e.im) <= rmax)) {
                    e.im = 0.0;
                    rmax = 0.0;
                    for (int j = i; j < m; ++j) {
                        if (group[j] != g) continue;
                        rmax = std::fmax(rmax, add_up(dist_up(e.re, 0.0, members[j].re, members[j].im), members[j].r));
                    }
                }
                e.r = rmax;
            }
            enc[n_groups++] = e;
        }
        // Merge groups whose enclosures are not proven disjoint.
        bool merged = false;
        for (int a = 0; a < n_groups && !merged; ++a) {
            for (int b = a + 1; b < n_groups && !merged; ++b) {
                if (dist_down(enc[a].re, enc[a].im, enc[b].re, enc[b].im) <= add_up(enc[a].r, enc[b].r)) {
                    // Relabel every member of enclosure b into a's group.
                    int ga = -1, gb = -1;
                    for (int i = 0; i < m; ++i) {
                        if (label[i] == a) ga = group[i];
                        if (label[i] == b) gb = group[i];
                    }
                    for (int i = 0; i < m; ++i)
                        if (group[i] == gb) group[i] = ga;
                    merged = true;
                }
            }
        }
        if (!merged) break;
    }
    for (int g = 0; g < n_groups; ++g) {
        RootDisc& d = out[g];
        d.re = enc[g].re;
        d.im = enc[g].im;
        d.radius = enc[g].r;
        d.count = enc[g].count;
        d.verified = true;
        d.real = real_axis_centers && enc[g].im == 0.0 && (enc[g].count % 2 == 1);
    }
    return n_groups;
}

// ---------------------------------------------------------------------------
// Kernels (implemented in roots_smith.cpp and roots_paper.cpp). Each writes
// discs in the coordinates of the (scaled) polynomial it was given.
// ---------------------------------------------------------------------------

/// Kernel outcome; discs are in the scaled coordinates.
struct KernelResult {
    int n_discs = 0;
    int escalation = 0;
    bool wants_exact = false;
    RootDisc discs[kMaxDegree];
};

/// rad (nullable): coefficient radii; the discs then hold for every member of
/// the family {q : |q_k - c_k| <= rad_k} (see smith_radii).
/// seed_or_scratch (with seed): the seeds are a batched lane's converged
/// approximations of this polynomial; they are kept only when their first
/// Smith discs isolate every root, or all but one pair that the coefficient
/// radii alone hold together (no re-spread, no double-double then);
/// otherwise the kernel starts again from scratch, as without seeds (seeds
/// never affect what is proven, only speed).
void solve_smith(const double* c, const double* rad, int n, Method method, const Complex<double>* seed,
                 KernelResult& out, bool seed_or_scratch = false);
void solve_paper(const double* c, int n, KernelResult& out);

/// find_roots (roots.cpp) for a row that a batched lane did not prove:
/// seeded with the lane's converged approximations (in the input's
/// coordinates), kept only where their first Smith discs isolate every
/// root or all but one family-limited pair, from scratch otherwise
/// (solve_smith's seed_or_scratch). The same contract as find_roots.
Status find_roots_lane_seeded(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                              const double* seed_re, const double* seed_im, const double* coeff_radius);

}  // namespace argand::detail
