// solver.h: kernels shared by the root-finding methods (internal header).
//
// Preconditions for every kernel here unless stated otherwise: c[0..n] are
// finite doubles (exact values), n in [1, kMaxDegree], c[0] != 0, c[n] != 0.
#pragma once

#include <algorithm>
#include <cmath>

#include "argand/arith.h"
#include "argand/roots.h"

namespace argand::detail {

constexpr double kPi = 3.14159265358979323846;

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
    Complex<T> y(T(c[n]));
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

// ---------------------------------------------------------------------------
// Approximation: initial guesses and the Aberth-Ehrlich iteration
// ---------------------------------------------------------------------------

/// Initial approximations from the Newton polygon (upper convex hull of
/// (k, log|c_k|)), as in Bini's MPSolve: each hull edge of width m gives m
/// points on a circle of the radius it predicts. Spread by angle so that no
/// start is real and no two coincide.
inline void initial_guesses(const double* c, int n, Complex<double>* x) {
    int hull[kMaxDegree + 1];
    double lg[kMaxDegree + 1];
    int h = 0;
    for (int k = 0; k <= n; ++k) {
        if (c[k] == 0.0) continue;
        lg[k] = std::log(std::fabs(c[k]));
        while (h >= 2) {
            const int a = hull[h - 2], b = hull[h - 1];
            // Drop b if it lies on or below the segment from a to k.
            if ((lg[b] - lg[a]) * (k - a) <= (lg[k] - lg[a]) * (b - a)) --h;
            else break;
        }
        hull[h++] = k;
    }
    int idx = 0;
    for (int s = 0; s + 1 < h; ++s) {
        const int a = hull[s], b = hull[s + 1], m = b - a;
        const double r = std::exp((lg[a] - lg[b]) / m);
        for (int j = 0; j < m; ++j) {
            const double angle = 2.0 * kPi * j / m + 2.0 * kPi * a / n + 0.4;
            x[idx++] = Complex<double>(r * std::cos(angle), r * std::sin(angle));
        }
    }
}

/// Aberth-Ehrlich iteration in T, Gauss-Seidel style. Stops a root when its
/// correction is below the working precision or |p| reaches rounding noise.
/// Returns the number of sweeps done. Approximations only: nothing is proven.
template <class T>
inline int aberth(const double* c, int n, Complex<T>* x, int max_iter, bool* converged_out = nullptr) {
    const double eps = working_epsilon<T>();
    bool done[kMaxDegree] = {};
    int remaining = n;
    int it = 0;
    for (; it < max_iter && remaining > 0; ++it) {
        for (int i = 0; i < n; ++i) {
            if (done[i]) continue;
            Complex<T> p, dp;
            eval_with_derivative(c, n, x[i], p, dp);
            const double ax = mag_approx(x[i]);
            if (mag_approx(p) <= 4.0 * (n + 1) * eps * abs_poly(c, n, ax)) {
                done[i] = true;
                --remaining;
                continue;
            }
            Complex<T> s(T(0.0));
            for (int j = 0; j < n; ++j) {
                if (j == i) continue;
                Complex<T> d = x[i] - x[j];
                T d2 = d.re * d.re + d.im * d.im;
                s = s + Complex<T>(d.re / d2, -(d.im / d2));
            }
            Complex<T> ratio = p / dp;
            Complex<T> w = ratio / (Complex<T>(T(1.0)) - ratio * s);
            if (!is_finite(w)) {
                // Derivative or denominator vanished: nudge and retry.
                const double nudge = (ax > 0 ? ax : 1.0) * 1e-7 * (1 + i);
                x[i] = x[i] + Complex<T>(T(nudge), T(nudge * 0.7));
                continue;
            }
            x[i] = x[i] - w;
            if (mag_approx(w) <= 2.0 * eps * mag_approx(x[i])) {
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
/// moving later duplicates a little. Returns true if anything moved.
template <class T>
inline bool separate_duplicates(Complex<T>* x, int n) {
    bool moved = false;
    for (int i = 1; i < n; ++i) {
        for (int j = 0; j < i; ++j) {
            if (exact_equal(x[i].re, x[j].re) && exact_equal(x[i].im, x[j].im)) {
                const double a = mag_approx(x[i]);
                const double step = (a > 0 ? a : 1.0) * 1e-9;
                const double angle = 2.0 * kPi * i / n + 0.3;
                x[i] = x[i] + Complex<T>(T(step * std::cos(angle)), T(step * std::sin(angle)));
                moved = true;
                j = -1;  // re-check against all earlier ones
            }
        }
    }
    return moved;
}

// ---------------------------------------------------------------------------
// Smith's inclusion discs
// ---------------------------------------------------------------------------

/// Smith (1970), Theorem 5: for pairwise distinct x_1..x_n, the discs
/// |z - x_i| <= n |p(x_i) / (c_n prod_{j != i}(x_i - x_j))| cover all roots,
/// and every connected component of their union made of m discs holds
/// exactly m roots (with multiplicity).
/// On true, r[i] is an upper bound of that radius, computed with rigorous
/// error bounds. On false nothing is claimed (non-finite intermediate or
/// coincident approximations).
template <class T>
inline bool smith_radii(const double* c, int n, const Complex<T>* x, double* r) {
    using E = ErrorModel<T>;
    // |exact difference| >= |computed difference| * (1 - add_rel) - abs_err.
    const double shrink = next_down(1.0 - 2.0 * E::add_rel);
    const double lead = std::fabs(c[n]);
    for (int i = 0; i < n; ++i) {
        Complex<T> v;
        double err;
        if (!eval_bound(c, n, x[i], v, err)) return false;
        const double numerator = add_up(mag_up(v), err);
        double denominator = lead;
        for (int j = 0; j < n; ++j) {
            if (j == i) continue;
            const double d = mag_down(x[i] - x[j]);
            const double d_low = std::fmax(0.0, add_down(mul_down(d, shrink), -E::abs_err));
            denominator = mul_down(denominator, d_low);
        }
        if (!(denominator > 0.0)) return false;
        r[i] = mul_up(static_cast<double>(n), div_up(numerator, denominator));
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
/// |exact| is within a factor (1 +- u) of the computed one.
inline double dist_down(double ar, double ai, double br, double bi) {
    return mul_down(hypot_down(std::fabs(ar - br), std::fabs(ai - bi)), 1.0 - 2.0 * kUnitRoundoff);
}
inline double dist_up(double ar, double ai, double br, double bi) {
    return mul_up(hypot_up(std::fabs(ar - br), std::fabs(ai - bi)), 1.0 + 2.0 * kUnitRoundoff);
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

void solve_smith(const double* c, int n, Method method, const Complex<double>* seed, KernelResult& out);
void solve_paper(const double* c, int n, KernelResult& out);

}  // namespace argand::detail
