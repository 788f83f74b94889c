// roots_smith.cpp: simultaneous approximation (Aberth-Ehrlich) followed by
// Smith's inclusion discs; the "smith", "auto" and "unverified" methods.
#include <cmath>

#include "root_kernels.h"

namespace argand::detail {
namespace {

/// Distance from x (exact in T) to its double rounding, bounded above.
inline double rounding_gap(Complex<double>) { return 0.0; }
inline double rounding_gap(Complex<DoubleDouble> x) { return hypot_up(std::fabs(x.re.lo), std::fabs(x.im.lo)); }

template <class T>
inline void set_real(Complex<T>& x) { x.im = T(0.0); }

template <class T>
bool has_duplicate(const Complex<T>* x, int n) {
    for (int i = 1; i < n; ++i)
        for (int j = 0; j < i; ++j)
            if (exact_equal(x[i].re, x[j].re) && exact_equal(x[i].im, x[j].im)) return true;
    return false;
}

/// Smith discs for the approximations x (made distinct first), as members of
/// a covering family in double coordinates. Approximations of real roots are
/// snapped onto the real axis so that their discs are symmetric (p is real).
/// Returns false if Smith's bound could not be evaluated (nothing claimed).
template <class T>
bool smith_members(const double* c, const double* rad, int n, Complex<T>* x, MemberDisc* members) {
    if (!separate_duplicates(x, n)) return false;
    Complex<T> original[kMaxDegree];
    for (int i = 0; i < n; ++i) original[i] = x[i];

    // First pass: snap approximations that are real to working accuracy.
    const double snap_tol = 64.0 * working_epsilon<T>();
    for (int i = 0; i < n; ++i)
        if (std::fabs(to_double(x[i].im)) <= snap_tol * mag_approx(x[i])) set_real(x[i]);
    if (has_duplicate(x, n))
        for (int i = 0; i < n; ++i) x[i] = original[i];

    double r[kMaxDegree];
    if (!smith_radii(c, n, x, r, nullptr, rad)) return false;

    // Second pass: an approximation whose disc crosses the real axis by a
    // wide margin is also moved onto it (its true root may be real).
    Complex<T> first[kMaxDegree];
    double first_r[kMaxDegree];
    bool moved = false;
    for (int i = 0; i < n; ++i) {
        first[i] = x[i];
        first_r[i] = r[i];
        if (to_double(x[i].im) != 0.0 && std::fabs(to_double(x[i].im)) * (2.0 * n) <= r[i]) {
            set_real(x[i]);
            moved = true;
        }
    }
    // (Two approximations of a conjugate pair that are not exact mirror
    // images, as double-double ones often are not, land next to each other
    // on the axis: distinct, but their radii explode and merge every disc.
    // Keep the first discs then.)
    bool worse = false;
    if (moved && !has_duplicate(x, n) && smith_radii(c, n, x, r, nullptr, rad))
        for (int i = 0; i < n; ++i) worse = worse || !(r[i] <= 4.0 * first_r[i]);
    else
        worse = moved;
    if (worse) {
        for (int i = 0; i < n; ++i) {
            x[i] = first[i];
            r[i] = first_r[i];
        }
    }

    for (int i = 0; i < n; ++i) {
        const Complex<double> center = to_double(x[i]);
        members[i] = {center.re, center.im, add_up(r[i], rounding_gap(x[i])), 1};
    }
    return true;
}

/// Verified discs from approximations x, or 0 if Smith's bound failed.
template <class T>
int smith_discs(const double* c, const double* rad, int n, Complex<T>* x, RootDisc* out) {
    MemberDisc members[kMaxDegree];
    if (!smith_members(c, rad, n, x, members)) return 0;
    return enclose_and_merge(members, n, /*real_axis_centers=*/true, out);
}

/// Fast path in double: when every pair of Smith discs is proven disjoint
/// (with the pair distances Smith's bound already computed), each disc is its
/// own component and holds exactly one root. Falls back to the general
/// grouping otherwise.
template <>
int smith_discs<double>(const double* c, const double* rad, int n, Complex<double>* x, RootDisc* out) {
    if (has_duplicate(x, n) && !separate_duplicates(x, n)) return 0;
    // Snap approximations that are real to working accuracy (as
    // smith_members does); if that made two coincide, take the general path.
    const double snap_tol = 64.0 * working_epsilon<double>();
    Complex<double> original[kMaxDegree];
    bool any_snap = false;
    for (int i = 0; i < n; ++i) {
        original[i] = x[i];
        if (x[i].im != 0.0 && std::fabs(x[i].im) <= snap_tol * std::fabs(x[i].re)) {
            x[i].im = 0.0;
            any_snap = true;
        }
    }
    // (Distinct before, unchanged if nothing snapped: no new duplicates.)
    const bool snapped = any_snap && has_duplicate(x, n);
    if (snapped)
        for (int i = 0; i < n; ++i) x[i] = original[i];
    if (!snapped) {
        double r[kMaxDegree];
        double low[kMaxDegree * kMaxDegree];
        if (smith_radii_fast(c, n, x, r, low, rad) || smith_radii(c, n, x, r, low, rad)) {
            bool separated = true;
            for (int i = 0; i < n && separated; ++i)
                for (int j = i + 1; j < n && separated; ++j)
                    separated = low[i * n + j] > add_up(r[i], r[j]);
            if (separated) {
                for (int i = 0; i < n; ++i) {
                    out[i].re = x[i].re;
                    out[i].im = x[i].im;
                    out[i].radius = r[i];
                    out[i].count = 1;
                    out[i].verified = true;
                    out[i].real = x[i].im == 0.0;
                }
                return n;
            }
        }
    }
    MemberDisc members[kMaxDegree];
    if (!smith_members(c, rad, n, x, members)) return 0;
    return enclose_and_merge(members, n, /*real_axis_centers=*/true, out);
}

/// The paper's step 2(b): put the approximations that fell into a cluster
/// disc back on a circle around their centroid, so that the next sweeps can
/// pull them apart.
template <class T>
void respread_clusters(Complex<T>* x, int n, const RootDisc* discs, int n_discs) {
    for (int d = 0; d < n_discs; ++d) {
        if (discs[d].count < 2) continue;
        int idx[kMaxDegree];
        int m = 0;
        for (int i = 0; i < n; ++i) {
            const Complex<double> xi = to_double(x[i]);
            if (std::hypot(xi.re - discs[d].re, xi.im - discs[d].im) <= discs[d].radius) idx[m++] = i;
        }
        if (m < 2) continue;
        Complex<T> centroid(T(0.0));
        for (int k = 0; k < m; ++k) centroid = centroid + x[idx[k]];
        centroid = mul_real(centroid, T(1.0 / m));
        const double rho = 0.5 * discs[d].radius;
        for (int k = 0; k < m; ++k) {
            const double angle = 2.0 * kPi * k / m + 0.5;
            x[idx[k]] = centroid + Complex<T>(T(rho * std::cos(angle)), T(rho * std::sin(angle)));
        }
    }
}

void write_unverified(const double* c, int n, const Complex<double>* x, KernelResult& out) {
    for (int i = 0; i < n; ++i) {
        Complex<double> p, dp;
        eval_with_derivative(c, n, x[i], p, dp);
        RootDisc& d = out.discs[i];
        d.re = x[i].re;
        d.im = x[i].im;
        d.radius = n * mag_approx(p) / mag_approx(dp);  // an estimate, not a bound
        if (!std::isfinite(d.radius)) d.radius = std::numeric_limits<double>::infinity();
        d.count = 1;
        d.verified = false;
        d.real = false;
    }
    out.n_discs = n;
}

bool all_isolated(int n_discs, int n) { return n_discs == n && n > 0; }

/// Margin of family_limited: the discs that the coefficient radii alone
/// force are shrunk by this factor before the test, room for the
/// approximations to move (a pair whose family discs just touch may
/// separate once double-double places it better: over the frames of
/// /work/notes/frames.py, 1.0 skipped one rung that proved an extra disc,
/// 1.25 none, while it still skips 4 in 5 of the futile ones).
constexpr double kFamilyMargin = 1.25;

/// True when no sharper approximation can isolate more roots than
/// discs[0..nd) do (nd < n): Smith's radius of an approximation x_i is at
/// least its family term n sum_k rad_k |x_i|^k / (|c_n| prod_j |x_i - x_j|)
/// (the numerator's other terms, |p(x_i)| and the rounding bound, are >= 0,
/// and only they shrink in double-double), so if the discs D(x_i, family
/// term / kFamilyMargin) still group into at most nd components, the
/// double-double rung would prove no more discs, only cost (the coefficient
/// radii, not the working precision, hold the roots together). A heuristic
/// about speed only (approximate arithmetic; no claim rests on it: what is
/// proven is whatever smith_discs proved).
bool family_limited(const double* c, const double* rad, int n, const Complex<double>* x, int nd) {
    if (rad == nullptr || nd <= 0 || nd >= n) return false;
    MemberDisc members[kMaxDegree];
    const double lead = std::fabs(c[n]);
    for (int i = 0; i < n; ++i) {
        const double ax = std::fabs(x[i].re) + std::fabs(x[i].im);
        double fam = rad[n];
        for (int k = n - 1; k >= 0; --k) fam = fam * ax + rad[k];
        double den = lead;
        for (int j = 0; j < n; ++j)
            if (j != i) den *= std::hypot(x[i].re - x[j].re, x[i].im - x[j].im);
        const double rf = n * fam / (kFamilyMargin * den);
        if (!(rf <= 0x1p1000) || !is_finite(x[i])) return false;  // (NaN, or den 0: no opinion)
        members[i] = {x[i].re, x[i].im, rf, 1};
    }
    RootDisc groups[kMaxDegree];
    return enclose_and_merge(members, n, /*real_axis_centers=*/true, groups) <= nd;
}

}  // namespace

void solve_smith(const double* c, const double* rad, int n, Method method, const Complex<double>* seed,
                 KernelResult& out, bool seed_or_scratch) {
    Complex<double> x[kMaxDegree];
    if (seed) {
        for (int i = 0; i < n; ++i) x[i] = seed[i];
    } else if (!(n <= 4 && closed_form_guesses(c, n, x))) {
        initial_guesses(c, n, x);
    }
    aberth(c, n, x, 80);
    out.escalation = 0;
    if (method == Method::Unverified) {
        write_unverified(c, n, x, out);
        return;
    }

    // Double precision: Smith discs, then up to two re-spread rounds.
    Complex<double> work[kMaxDegree];
    for (int i = 0; i < n; ++i) work[i] = x[i];
    int nd = smith_discs(c, rad, n, work, out.discs);
    // From a batched lane's converged approximations (seed_or_scratch), the
    // double stage is kept only when it is done at once: every root
    // isolated, or all but one pair that the coefficient radii alone hold
    // together (family_limited: the re-spread rounds and the double-double
    // rung are skipped, a speed choice only). Otherwise the seeds may have
    // missed a root (two approximations stopped on one root of a cluster:
    // discs merge that the unseeded run keeps apart, even where the family
    // test holds at these approximations; over the frames of frames.py the
    // re-spread rounds from such seeds sometimes isolated more, and from
    // fewer discs sometimes fewer than from scratch) or would send the row
    // to double-double where the unseeded run does not: start again from
    // scratch, the unseeded run exactly.
    bool seeded_pair_limited = false;
    if (seed != nullptr && seed_or_scratch && !all_isolated(nd, n)) {
        seeded_pair_limited = nd == n - 1 && family_limited(c, rad, n, x, nd);
        if (!seeded_pair_limited) {
            solve_smith(c, rad, n, method, nullptr, out, false);
            return;
        }
    }
    for (int round = 0; round < 2 && !all_isolated(nd, n) && !seeded_pair_limited; ++round) {
        if (nd > 0) respread_clusters(x, n, out.discs, nd);
        aberth(c, n, x, 40);
        for (int i = 0; i < n; ++i) work[i] = x[i];
        RootDisc trial[kMaxDegree];
        const int nt = smith_discs(c, rad, n, work, trial);
        if (nt > nd) {
            nd = nt;
            for (int i = 0; i < nt; ++i) out.discs[i] = trial[i];
        }
    }

    // Double-double (section 2.6), only where double could not isolate and
    // the coefficient radii do not already forbid it.
    if (method == Method::Auto && !all_isolated(nd, n) && !seeded_pair_limited && !family_limited(c, rad, n, x, nd)) {
        out.escalation = 1;
        Complex<DoubleDouble> xd[kMaxDegree];
        for (int i = 0; i < n; ++i) xd[i] = Complex<DoubleDouble>(DoubleDouble(x[i].re), DoubleDouble(x[i].im));
        if (nd > 0) respread_clusters(xd, n, out.discs, nd);
        for (int round = 0; round < 2 && !all_isolated(nd, n); ++round) {
            aberth(c, n, xd, 60);
            Complex<DoubleDouble> wd[kMaxDegree];
            for (int i = 0; i < n; ++i) wd[i] = xd[i];
            RootDisc trial[kMaxDegree];
            const int nt = smith_discs(c, rad, n, wd, trial);
            if (nt > nd) {
                nd = nt;
                for (int i = 0; i < nt; ++i) out.discs[i] = trial[i];
            }
            if (all_isolated(nd, n) || nt == 0) continue;
            // The coefficient radii hold the rest together even at these
            // (double-double, converged) approximations: a re-spread round
            // would prove nothing more (over the frames of frames.py it never
            // did, and its Aberth sweeps often ran all 60 from the re-spread).
            Complex<double> xs[kMaxDegree];
            for (int i = 0; i < n; ++i) xs[i] = to_double(xd[i]);
            if (family_limited(c, rad, n, xs, nd)) break;
            respread_clusters(xd, n, trial, nt);
        }
        for (int i = 0; i < n; ++i) x[i] = to_double(xd[i]);
    }

    if (nd == 0) {
        write_unverified(c, n, x, out);
        out.wants_exact = true;
        return;
    }
    out.n_discs = nd;
    out.wants_exact = !all_isolated(nd, n);
}

}  // namespace argand::detail
