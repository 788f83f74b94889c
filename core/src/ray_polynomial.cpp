// ray_polynomial.cpp: ray polynomials with proven coefficient errors.
//
// Per frame (plan_object): o' = linear (eye - translate) and the Taylor
// coefficients G_a of F(o' + v) in ball arithmetic (interval.h), in double
// and in double-double.
//
// Per pixel (primary_ray_polynomial): p_k = sum_{|a| = k} G_a d'^a with
// d' = linear d, in round-to-nearest, plus a running bound. Let A_c >= |d'_c|
// (exact) with |d'_c - computed| <= eps_d A_c (eps_d = 0 when linear is a
// signed permutation, else 5u), and let W_k = sum |g_a| A^a and
// R_k = sum rad(G_a) A^a (computed). Each monomial d'^a passes through at
// most k + 2 roundings, each term and the sum of the N_k terms through
// N_k + 1 more, so
//   |p_k - c_k| <= (phi_k + (N_k + 1) u)(1 + O(u)) W_k + (1 + O(u)) R_k,
//   phi_k = (1 + eps_d)^k (1 + u)^(k + 2) - 1 ~ k eps_d + (k + 2) u,
// which the factors weight_factor_k = 2 (k eps_d + (k + N_k + 6) u) and
// radius_factor_k = 1 + weight_factor_k cover (the factor 2 absorbs every
// second-order term for k, N_k <= 10^4). With u replaced by 2^-100 (a
// double-double operation's relative error, interval.h) the same argument
// bounds the double-double coefficients. This holds when no product
// underflows: every nonzero factor is then large enough that each nonzero
// product stays above 2^-900 (no_underflow_threshold); otherwise an
// absolute slack of 2^-1018 per operation, carried through the remaining
// factors, is added.
#include "ray_polynomial.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace argand::detail {
namespace {

constexpr double kU = kUnitRoundoff;
constexpr double kProductFloor = 0x1p-900;  // nonzero products stay above this without slack
constexpr double kSlackPerOp = 0x1p-1018;

/// max(floor, v), and floor when v is NaN (as std::fmax(floor, v)).
inline double floor_at(double floor, double v) { return v > floor ? v : floor; }

/// Exact binomial coefficients C(n, k), n <= kMaxDegree (C(64, 32) < 2^61).
const std::uint64_t* binomial_row(int n) {
    struct Table {
        std::uint64_t c[kMaxDegree + 1][kMaxDegree + 1] = {};
        Table() {
            for (int i = 0; i <= kMaxDegree; ++i) {
                c[i][0] = 1;
                for (int k = 1; k <= i; ++k) c[i][k] = c[i - 1][k - 1] + (k <= i - 1 ? c[i - 1][k] : 0);
            }
        }
    };
    static const Table table;
    return table.c[n];
}

/// The object-space direction d' = linear d: its computed value, a bound
/// A_c >= |d'_c| and A_c-relative error eps_d (see the file comment). A_c is
/// 0 only when d'_c is exactly 0; otherwise A_c >= 2^-900, so the absolute
/// part of the rounding error is below 2^-97 A_c.
template <class T>
void object_direction(const SurfaceSpec& s, bool exact, const double d[3], T mid[3], double mag[3], double rad[3]) {
    for (int r = 0; r < 3; ++r) {
        const double* L = s.linear + 3 * r;
        if (exact) {
            // A signed permutation's row: one entry +-1, two zeros, so the
            // dot product is exactly +-d_c (products by 0 and +-1 are exact,
            // and so are sums with zeros), without branches.
            const T v(L[0] * d[0] + L[1] * d[1] + L[2] * d[2]);
            mid[r] = v;
            mag[r] = std::fabs(to_double(v));
            rad[r] = 0.0;
            continue;
        }
        T v(0.0);
        double sum_abs = 0.0;
        bool all_zero = true;
        for (int c = 0; c < 3; ++c) {
            v = v + T(L[c]) * T(d[c]);
            sum_abs += std::fabs(L[c]) * std::fabs(d[c]);
            if (L[c] != 0.0 && d[c] != 0.0) all_zero = false;
        }
        mid[r] = v;
        if (all_zero) {
            mag[r] = rad[r] = 0.0;
            continue;
        }
        // sum_abs is within a factor (1 + u)^3 of the exact sum, up to 3
        // underflow losses: inflate and floor (see above).
        mag[r] = std::fmax(kProductFloor, next_up(next_up(sum_abs * (1.0 + 8.0 * kU)) + 4.0 * kDenormMin));
        rad[r] = mul_up(5.0 * kU, mag[r]);
    }
}

inline bool linear_is_signed_permutation(const double* L) {
    for (int r = 0; r < 3; ++r) {
        int nonzero = 0;
        for (int c = 0; c < 3; ++c) {
            const double v = L[3 * r + c];
            if (v == 0.0) continue;
            if (v != 1.0 && v != -1.0) return false;
            ++nonzero;
        }
        if (nonzero != 1) return false;
    }
    return true;
}

/// The per-pixel sum for T = double or DoubleDouble (see the file comment).
template <class T>
void primary_impl(const FramePlan::ObjectPlan& op, int n, const T* g, const double* g_rad, const double* weight_factor,
                  const double* radius_factor, const T dir[3], const double mag[3], RayCoefficients<T>& out) {
    const bool exact_direction = op.direction_exact;
    T px[kMaxDegree + 1], py[kMaxDegree + 1], pz[kMaxDegree + 1];
    double ax[kMaxDegree + 1], ay[kMaxDegree + 1], az[kMaxDegree + 1];
    px[0] = py[0] = pz[0] = T(1.0);
    ax[0] = ay[0] = az[0] = 1.0;
    for (int k = 1; k <= n; ++k) {
        px[k] = px[k - 1] * dir[0];
        py[k] = py[k - 1] * dir[1];
        pz[k] = pz[k - 1] * dir[2];
        if (!exact_direction) {
            ax[k] = ax[k - 1] * mag[0];
            ay[k] = ay[k - 1] * mag[1];
            az[k] = az[k - 1] * mag[2];
        }
    }
    out.n = n;
    bool finite = true;
    double check = 0.0;
    const int* ex = op.ex.data();
    const int* ey = op.ey.data();
    const int* ez = op.ez.data();
    for (int k = 0; k <= n; ++k) {
        T sum(0.0);
        double weight = 0.0, radius = 0.0;
        const int end = op.k_begin[k + 1];
        if (exact_direction) {
            // |d'| is exact: the magnitude of a monomial is |computed
            // monomial| (within its k + 2 roundings) and |g mono| that of the
            // computed term (within one more), both inside the factors.
            for (int i = op.k_begin[k]; i < end; ++i) {
                const T mono = px[ex[i]] * py[ey[i]] * pz[ez[i]];
                const T term = g[i] * mono;
                sum = sum + term;
                weight += std::fabs(to_double(term));
                radius += g_rad[i] * std::fabs(to_double(mono));
            }
        } else {
            for (int i = op.k_begin[k]; i < end; ++i) {
                sum = sum + g[i] * (px[ex[i]] * py[ey[i]] * pz[ez[i]]);
                const double mono_mag = ax[ex[i]] * ay[ey[i]] * az[ez[i]];
                weight += std::fabs(to_double(g[i])) * mono_mag;
                radius += g_rad[i] * mono_mag;
            }
        }
        out.c[k] = sum;
        // Two products and a sum of nonnegatives, each within a factor 1 + u:
        // (1 + u)^4 < 1 + 8u covers them and the product by 1 + 8u.
        out.r[k] = (weight == 0.0 && radius == 0.0)
                       ? 0.0
                       : next_up((weight_factor[k] * weight + radius_factor[k] * radius) * (1.0 + 8.0 * kU));
        check += std::fabs(to_double(sum)) + out.r[k];
    }
    finite = std::isfinite(check);  // (an inf or NaN anywhere makes the sum so)
    // Underflow slack (rare: a direction component below the threshold).
    double amin = 1.0, amax = 1.0;
    for (int a = 0; a < 3; ++a)
        if (mag[a] > 0.0) {
            amin = mag[a] < amin ? mag[a] : amin;
            amax = mag[a] > amax ? mag[a] : amax;
        }
    if (amin < op.no_underflow_threshold) {
        double grow = 1.0;
        for (int k = 0; k <= n; ++k) {
            const int terms = op.k_begin[k + 1] - op.k_begin[k];
            if (terms > 0) {
                const double slack = mul_up(mul_up(static_cast<double>(k + terms + 6) * kSlackPerOp, op.magnitude[k]), grow);
                out.r[k] = add_up(out.r[k], slack);
                finite = finite && std::isfinite(out.r[k]);
            }
            grow = mul_up(grow, amax);
        }
    }
    out.finite = finite;
}

/// general_ray_polynomial's expansion: the powers (o'_i + t d'_i)^a and
/// their magnitude twins (oa, da for o', d'), then every term's product of
/// three of them summed into sum and mag by degree (added counts summands).
template <int S>
void expand_terms(const SurfaceSpec& s, int n, const double* om, const double* oa, const double* dm, const double* da,
                  double (*pw)[S][S], double (*pm)[S][S], double* sum, double* mag, int* added, double& lowest,
                  double& highest) {
    for (int axis = 0; axis < 3; ++axis) {
        pw[axis][0][0] = pm[axis][0][0] = 1.0;
        for (int a = 1; a <= n; ++a) {
            pw[axis][a][0] = pw[axis][a - 1][0] * om[axis];
            pm[axis][a][0] = pm[axis][a - 1][0] * oa[axis];
            for (int k = 1; k < a; ++k) {
                pw[axis][a][k] = pw[axis][a - 1][k] * om[axis] + pw[axis][a - 1][k - 1] * dm[axis];
                pm[axis][a][k] = pm[axis][a - 1][k] * oa[axis] + pm[axis][a - 1][k - 1] * da[axis];
            }
            pw[axis][a][a] = pw[axis][a - 1][a - 1] * dm[axis];
            pm[axis][a][a] = pm[axis][a - 1][a - 1] * da[axis];
        }
    }
    for (int k = 0; k <= n; ++k) {
        sum[k] = mag[k] = 0.0;
        added[k] = 0;
    }
    for (const Term& term : s.terms) {
        if (term.coeff == 0.0) continue;
        const double ac = std::fabs(term.coeff);
        lowest = ac < lowest ? ac : lowest;
        highest = ac > highest ? ac : highest;
        const double* px = pw[0][term.ex];
        const double* py = pw[1][term.ey];
        const double* pz = pw[2][term.ez];
        const double* mx = pm[0][term.ex];
        const double* my = pm[1][term.ey];
        const double* mz = pm[2][term.ez];
        for (int i = 0; i <= term.ex; ++i)
            for (int j = 0; j <= term.ey; ++j) {
                const double xy = term.coeff * px[i] * py[j];
                const double xym = ac * mx[i] * my[j];
                if (xym == 0.0) continue;
                double* sk = sum + i + j;
                double* mk = mag + i + j;
                int* ak = added + i + j;
                for (int l = 0; l <= term.ez; ++l) {
                    sk[l] += xy * pz[l];
                    mk[l] += xym * mz[l];
                    ++ak[l];
                }
            }
    }
}

/// The direction of general_ray_polynomial (and rebased_ray_polynomial):
/// d' = linear d, computed (dm), its bound A (da) and radius (drad: 6u A;
/// the exact d' lies within 5u A of dm).
void general_direction(const SurfaceSpec& s, const double d[3], double dm[3], double da[3], double drad[3]) {
    for (int r = 0; r < 3; ++r) {
        const double* L = s.linear + 3 * r;
        double vd = 0.0, sd = 0.0;
        bool zero_d = true;
        for (int c = 0; c < 3; ++c) {
            vd += L[c] * d[c];
            sd += std::fabs(L[c]) * std::fabs(d[c]);
            if (L[c] != 0.0 && d[c] != 0.0) zero_d = false;
        }
        dm[r] = vd;
        da[r] = zero_d ? 0.0 : floor_at(kProductFloor, next_up(next_up(sd * (1.0 + 8.0 * kU)) + 8.0 * kDenormMin));
        drad[r] = da[r] == 0.0 ? 0.0 : mul_up(6.0 * kU, da[r]);
    }
}

/// A ball whose radius is summed in round-to-nearest (rebased_body): each
/// radius is an expression of + and * over nonnegative doubles, so its
/// computed value is at least the exact one times (1 - u)^depth, and one
/// inflation at the end makes it an upper bound. The products' and sums'
/// own rounding errors are taken exactly (FMA or Dekker's product, Knuth's
/// TwoSum): a ball radius near the actual error, not an a priori count.
struct RunBall {
    double m, r;
};

template <bool kFma>
__attribute__((always_inline)) inline double product_error(double a, double b, double p) {
    if constexpr (kFma) {
        return std::fabs(__builtin_fma(a, b, -p));
    } else {
        constexpr double kSplit = 134217729.0;  // 2^27 + 1 (Dekker; exact for |a|, |b| < 2^996)
        const double ta = kSplit * a, a_hi = ta - (ta - a), a_lo = a - a_hi;
        const double tb = kSplit * b, b_hi = tb - (tb - b), b_lo = b - b_hi;
        return std::fabs(((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo);
    }
}

template <bool kFma>
__attribute__((always_inline)) inline RunBall times(RunBall x, RunBall y) {
    const double p = x.m * y.m;
    return {p, product_error<kFma>(x.m, y.m, p) + std::fabs(x.m) * y.r + x.r * (std::fabs(y.m) + y.r)};
}

__attribute__((always_inline)) inline RunBall plus(RunBall x, RunBall y) {
    const double s = x.m + y.m;
    const double bb = s - x.m;
    return {s, x.r + y.r + std::fabs((x.m - (s - bb)) + (y.m - bb))};
}

/// The expansion of rebased_ray_polynomial about the enclosed point b along
/// the enclosed direction v. Returns the depth bound (the largest number of
/// round-to-nearest operations on any radius's path, for the inflation);
/// `ops` gets a bound on the number of operations in all and `highest` the
/// largest |coefficient| of F (for the underflow slack).
template <bool kFma>
__attribute__((always_inline)) inline int rebased_body(const SurfaceSpec& s, const RunBall b[3], const RunBall v[3],
                                                       RunBall* sum, double& ops, double& highest) {
    const int n = s.degree;
    RunBall pw[3][kMaxDegree + 1][kMaxDegree + 1];
    for (int axis = 0; axis < 3; ++axis) {
        pw[axis][0][0] = {1.0, 0.0};
        for (int a = 1; a <= n; ++a) {
            pw[axis][a][0] = times<kFma>(pw[axis][a - 1][0], b[axis]);
            for (int k = 1; k < a; ++k)
                pw[axis][a][k] = plus(times<kFma>(pw[axis][a - 1][k], b[axis]), times<kFma>(pw[axis][a - 1][k - 1], v[axis]));
            pw[axis][a][a] = times<kFma>(pw[axis][a - 1][a - 1], v[axis]);
        }
    }
    for (int k = 0; k <= n; ++k) sum[k] = {0.0, 0.0};
    int added = 0;  // summands in all, a bound on any coefficient's
    for (const Term& term : s.terms) {
        if (term.coeff == 0.0) continue;
        const RunBall coeff{term.coeff, 0.0};
        highest = std::fmax(highest, std::fabs(term.coeff));
        const RunBall* px = pw[0][term.ex];
        const RunBall* py = pw[1][term.ey];
        const RunBall* pz = pw[2][term.ez];
        for (int i = 0; i <= term.ex; ++i)
            for (int j = 0; j <= term.ey; ++j) {
                const RunBall xy = times<kFma>(times<kFma>(coeff, px[i]), py[j]);
                for (int l = 0; l <= term.ez; ++l) sum[i + j + l] = plus(sum[i + j + l], times<kFma>(xy, pz[l]));
                added += term.ez + 1;
            }
    }
    // (A power's radius: 6 operations per step, n steps; a term's product
    // 3 more (6 operations each); a sum one per summand, 3 for its error.
    // In all: 12 per power entry, 12 per summand and its product.)
    ops = 36.0 * (n + 1) * (n + 1) + 12.0 * added;
    return 6 * n + 18 + 4 * added;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("fma"))) int rebased_fma(const SurfaceSpec& s, const RunBall b[3], const RunBall v[3],
                                               RunBall* sum, double& ops, double& highest) {
    return rebased_body<true>(s, b, v, sum, ops, highest);
}
bool cpu_has_fma() {
    static const bool yes = __builtin_cpu_supports("fma");
    return yes;
}
#else
int rebased_fma(const SurfaceSpec& s, const RunBall b[3], const RunBall v[3], RunBall* sum, double& ops,
                double& highest) {
    return rebased_body<false>(s, b, v, sum, ops, highest);
}
bool cpu_has_fma() { return false; }
#endif

}  // namespace

void rebased_ray_polynomial(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3], double t0,
                            RayCoefficients<double>& out) {
    const int n = s.degree;
    out.n = n;
    out.finite = false;
    if (n < 0 || n > kMaxDegree || !std::isfinite(t0)) return;
    double dm[3], da[3], drad[3];
    general_direction(s, d, dm, da, drad);
    RunBall b[3], v[3];
    for (int r = 0; r < 3; ++r) {
        // b = o' + t0 d', enclosed in interval.h's balls (o' is the plan's
        // ball, d' lies within drad of dm).
        const Ball dv(dm[r], drad[r]);
        const Ball p = op.origin[r] + Ball(t0) * dv;
        if (!is_finite(p)) return;
        b[r] = {p.mid, p.rad};
        v[r] = {dm[r], drad[r]};
    }
    RunBall sum[kMaxDegree + 1];
    double ops = 0.0, highest = 0.0;
    const int depth = cpu_has_fma() ? rebased_fma(s, b, v, sum, ops, highest)
                                    : rebased_body<false>(s, b, v, sum, ops, highest);
    // Each radius: its computed value times (1 - u)^-depth <= 1 + 2 depth u
    // (depth u < 1/2), rounded up. Plus what gradual underflow may hide
    // from the exact product and sum errors (below 2^-1074 each, carried
    // by the coefficient and the remaining factors, as
    // general_ray_polynomial's slack): ops 2^-1018 (1 + highest)
    // max(1, A)^n, A the largest |b| or |v|; far below any radius unless
    // the ray is huge.
    double amax = 1.0;
    for (int r = 0; r < 3; ++r)
        amax = std::fmax(amax, std::fmax(add_up(std::fabs(b[r].m), b[r].r), add_up(std::fabs(v[r].m), v[r].r)));
    double grow_a = 1.0;
    for (int k = 0; k < n; ++k) grow_a = mul_up(grow_a, amax);
    const double grow = add_up(1.0, mul_up(2.0 * kU, static_cast<double>(depth)));
    const double slack = mul_up(mul_up(mul_up(ops, kSlackPerOp), add_up(1.0, highest)), grow_a);
    bool finite = depth < (1 << 20) && std::isfinite(slack);
    for (int k = 0; k <= n; ++k) {
        out.c[k] = sum[k].m;
        out.r[k] = add_up(mul_up(sum[k].r, grow), slack);
        finite = finite && std::isfinite(out.c[k]) && std::isfinite(out.r[k]);
    }
    out.finite = finite;
}

void plan_object(const SurfaceSpec& s, const double eye[3], FramePlan::ObjectPlan& op) {
    const int n = s.degree;
    // o' = linear (eye - translate), enclosed.
    for (int r = 0; r < 3; ++r) {
        Ball acc(0.0);
        BallDD acc_dd(0.0);
        for (int c = 0; c < 3; ++c) {
            acc += Ball(s.linear[3 * r + c]) * (Ball(eye[c]) - Ball(s.translate[c]));
            acc_dd += BallDD(s.linear[3 * r + c]) * (BallDD(eye[c]) + (-BallDD(s.translate[c])));
        }
        op.origin[r] = acc;
        op.origin_dd[r] = acc_dd;
    }
    op.direction_exact = linear_is_signed_permutation(s.linear);
    // Powers of o'.
    std::vector<Ball> pw(3 * (n + 1));
    std::vector<BallDD> pw_dd(3 * (n + 1));
    for (int a = 0; a < 3; ++a) {
        pw[a * (n + 1)] = Ball(1.0);
        pw_dd[a * (n + 1)] = BallDD(1.0);
        for (int k = 1; k <= n; ++k) {
            pw[a * (n + 1) + k] = pw[a * (n + 1) + k - 1] * op.origin[a];
            pw_dd[a * (n + 1) + k] = pw_dd[a * (n + 1) + k - 1] * op.origin_dd[a];
        }
    }
    // Taylor coefficients of F(o' + v): binomial expansion of each term, into
    // a dense (a, b, c) table, a, b, c <= n.
    const int side = n + 1;
    std::vector<Ball> dense(static_cast<std::size_t>(side) * side * side, Ball(0.0));
    std::vector<BallDD> dense_dd(static_cast<std::size_t>(side) * side * side, BallDD(0.0));
    Ball factor[3][kMaxDegree + 1];
    BallDD factor_dd[3][kMaxDegree + 1];
    for (const Term& t : s.terms) {
        if (t.ex < 0 || t.ey < 0 || t.ez < 0 || t.ex + t.ey + t.ez > n)
            throw std::invalid_argument("a term exceeds the declared degree");
        const int e[3] = {t.ex, t.ey, t.ez};
        for (int axis = 0; axis < 3; ++axis) {
            const std::uint64_t* row = binomial_row(e[axis]);
            for (int a = 0; a <= e[axis]; ++a) {
                factor[axis][a] = ball_from_integer(row[a]) * pw[axis * (n + 1) + e[axis] - a];
                factor_dd[axis][a] = ball_dd_from_integer(row[a]) * pw_dd[axis * (n + 1) + e[axis] - a];
            }
        }
        const Ball coeff(t.coeff);
        const BallDD coeff_dd(t.coeff);
        for (int a = 0; a <= t.ex; ++a)
            for (int b = 0; b <= t.ey; ++b) {
                const Ball xy = coeff * factor[0][a] * factor[1][b];
                const BallDD xy_dd = coeff_dd * factor_dd[0][a] * factor_dd[1][b];
                for (int c = 0; c <= t.ez; ++c) {
                    const std::size_t idx = (static_cast<std::size_t>(a) * side + b) * side + c;
                    dense[idx] += xy * factor[2][c];
                    dense_dd[idx] += xy_dd * factor_dd[2][c];
                }
            }
    }
    // Group by total degree, dropping exact zeros.
    const double eps_d = op.direction_exact ? 0.0 : 5.0 * kU;
    const double eps_d_dd = op.direction_exact ? 0.0 : 0x1p-97;
    op.k_begin.assign(n + 2, 0);
    op.weight_factor.assign(n + 1, 0.0);
    op.radius_factor.assign(n + 1, 0.0);
    op.weight_factor_dd.assign(n + 1, 0.0);
    op.radius_factor_dd.assign(n + 1, 0.0);
    op.magnitude.assign(n + 1, 0.0);
    double lowest = INFINITY;  // smallest nonzero magnitude of any g or radius
    auto note = [&](double v) {
        if (v != 0.0) lowest = std::fmin(lowest, std::fabs(v));
    };
    for (int k = 0; k <= n; ++k) {
        op.k_begin[k] = static_cast<int>(op.g.size());
        for (int a = 0; a <= k; ++a)
            for (int b = 0; a + b <= k; ++b) {
                const int c = k - a - b;
                const std::size_t idx = (static_cast<std::size_t>(a) * side + b) * side + c;
                const Ball& v = dense[idx];
                const BallDD& w = dense_dd[idx];
                if (v.mid == 0.0 && v.rad == 0.0 && is_zero(w.mid) && w.rad == 0.0) continue;
                if (!is_finite(v) || !is_finite(w))
                    throw std::invalid_argument("the surface's Taylor expansion at the camera overflows binary64");
                op.ex.push_back(a);
                op.ey.push_back(b);
                op.ez.push_back(c);
                op.g.push_back(v.mid);
                op.g_rad.push_back(v.rad);
                op.g_dd.push_back(w.mid);
                op.g_dd_rad.push_back(w.rad);
                note(v.mid);
                note(v.rad);
                note(w.mid.hi);
                note(w.rad);
                op.magnitude[k] = std::fmax(op.magnitude[k], add_up(abs_up(v), 1.0));
            }
        const double terms = static_cast<double>(op.g.size()) - op.k_begin[k];
        op.weight_factor[k] = mul_up(2.0, add_up(mul_up(k, eps_d), mul_up(k + terms + 6.0, kU)));
        op.radius_factor[k] = add_up(1.0, op.weight_factor[k]);
        op.weight_factor_dd[k] = mul_up(2.0, add_up(mul_up(k, eps_d_dd), mul_up(k + terms + 6.0, kDoubleDoubleRel)));
        op.radius_factor_dd[k] = add_up(1.0, op.weight_factor_dd[k]);
    }
    op.k_begin[n + 1] = static_cast<int>(op.g.size());
    // lowest * amin^n >= 2^-900 for amin >= threshold (amin clamped to <= 1).
    if (!(lowest < INFINITY)) {
        op.no_underflow_threshold = 0.0;
    } else if (lowest < kProductFloor) {
        op.no_underflow_threshold = INFINITY;
    } else {
        const double t = std::exp2((-900.0 - std::log2(lowest)) / n) * 1.01;
        op.no_underflow_threshold = t <= 1.0 ? t : INFINITY;
    }
}

void primary_ray_polynomial(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3],
                            RayCoefficients<double>& out, ObjectRay& ray) {
    double dir[3], mag[3], rad[3];
    object_direction(s, op.direction_exact, d, dir, mag, rad);
    primary_impl(op, s.degree, op.g.data(), op.g_rad.data(), op.weight_factor.data(), op.radius_factor.data(), dir, mag,
                 out);
    for (int a = 0; a < 3; ++a) {
        ray.origin[a] = op.origin[a];
        ray.direction[a] = Ball(dir[a], rad[a]);
    }
}

namespace {

/// One instruction set's lane-parallel functions (ray_run_kernel.h).
struct RunKernels {
    void (*sums)(const PrimaryRunInput&, PrimaryRun&);
    void (*dirs)(const SampleRowInput&, int, int, double*, double*, double*);
};

constexpr RunKernels kRunGeneric{&ray_generic::primary_run_sums, &ray_generic::sample_direction_run};
#if defined(__x86_64__) || defined(_M_X64)
constexpr RunKernels kRunAvx2{&ray_avx2::primary_run_sums, &ray_avx2::sample_direction_run};
constexpr RunKernels kRunAvx512{&ray_avx512::primary_run_sums, &ray_avx512::sample_direction_run};
#endif

/// The functions for isa: Auto, Scalar or one this CPU does not run picks
/// the widest it runs (batch_isa_best); SSE2 is the generic build.
const RunKernels& run_kernels(BatchIsa isa) {
    if (isa == BatchIsa::Auto || isa == BatchIsa::Scalar || !batch_isa_supported(isa)) isa = batch_isa_best();
    switch (isa) {
#if defined(__x86_64__) || defined(_M_X64)
        case BatchIsa::Avx2: return kRunAvx2;
        case BatchIsa::Avx512: return kRunAvx512;
#endif
        default: return kRunGeneric;
    }
}

}  // namespace

void primary_ray_polynomial_run(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double* dx,
                                const double* dy, const double* dz, int cells, PrimaryRun& out, BatchIsa isa) {
    if (s.degree > kRunMaxDegree || cells < 1 || cells > kRunCells)
        throw std::invalid_argument("primary_ray_polynomial_run: degree above 12 or cells outside 1..32");
    out.n = s.degree;
    out.cells = cells;
    // d' and A per cell: object_direction's operations, lane by lane (a
    // signed permutation's rows in the kernel's lane loops; a general linear
    // part cell by cell with the scalar function). Padding lanes repeat
    // cell 0 (finite; never read back).
    if (!op.direction_exact) {
        for (int l = 0; l < kRunCells; ++l) {
            const int c = l < cells ? l : 0;
            const double d[3] = {dx[c], dy[c], dz[c]};
            double dir[3], mag[3], rad[3];
            object_direction(s, false, d, dir, mag, rad);
            for (int r = 0; r < 3; ++r) {
                out.dir[r][l] = dir[r];
                out.mag[r][l] = mag[r];
                out.dir_rad[r][l] = rad[r];
            }
        }
    }
    PrimaryRunInput in;
    in.n = s.degree;
    in.exact_direction = op.direction_exact;
    in.linear = s.linear;
    in.dx = dx;
    in.dy = dy;
    in.dz = dz;
    in.no_underflow_threshold = op.no_underflow_threshold;
    in.k_begin = op.k_begin.data();
    in.ex = op.ex.data();
    in.ey = op.ey.data();
    in.ez = op.ez.data();
    in.g = op.g.data();
    in.g_rad = op.g_rad.data();
    in.weight_factor = op.weight_factor.data();
    in.radius_factor = op.radius_factor.data();
    run_kernels(isa).sums(in, out);
    // Underflow slack, lane by lane as primary_impl, for the lanes whose
    // smallest nonzero A is below the threshold (rare).
    const int n = s.degree;
    for (int l = 0; l < cells; ++l) {
        if (out.slack[l] == 0) continue;
        const double amax = out.amax[l];
        bool finite = out.finite[l] != 0;
        double grow = 1.0;
        for (int k = 0; k <= n; ++k) {
            const int terms = op.k_begin[k + 1] - op.k_begin[k];
            if (terms > 0) {
                const double slack = mul_up(mul_up(static_cast<double>(k + terms + 6) * kSlackPerOp, op.magnitude[k]), grow);
                out.r[k][l] = add_up(out.r[k][l], slack);
                finite = finite && std::isfinite(out.r[k][l]);
            }
            grow = mul_up(grow, amax);
        }
        out.finite[l] = finite ? 1 : 0;
    }
}

void sample_direction_run(const SampleRowInput& in, int first_cell, int cells, double* dx, double* dy, double* dz,
                          BatchIsa isa) {
    run_kernels(isa).dirs(in, first_cell, cells, dx, dy, dz);
}

void primary_ray_polynomial_dd(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3],
                               RayCoefficients<DoubleDouble>& out) {
    DoubleDouble dir[3];
    double mag[3], rad[3];
    object_direction(s, op.direction_exact, d, dir, mag, rad);
    primary_impl(op, s.degree, op.g_dd.data(), op.g_dd_rad.data(), op.weight_factor_dd.data(),
                 op.radius_factor_dd.data(), dir, mag, out);
}

void general_ray_polynomial(const SurfaceSpec& s, const double o[3], const double d[3], RayCoefficients<double>& out,
                            ObjectRay& ray) {
    // Direct expansion of each term in round-to-nearest, with a magnitude
    // expansion beside it (the same recurrences on bounds A of |o'_a|,
    // |d'_a|): every coefficient's error is at most
    //   factor_k * M_k,  factor_k = 2 (n eps + (2n + 6 + N_k) u),
    // where M_k is the magnitude expansion's coefficient, eps = 5u (6u
    // charged) the A-relative error of o' and d' (as object_direction), 2n
    // the roundings of the powers on any path, 6 those of the triple
    // products, and N_k the number of summands added into coefficient k.
    const int n = s.degree;
    double om[3], oa[3], orad[3], dm[3], da[3], drad[3];
    general_direction(s, d, dm, da, drad);
    const double diff[3] = {o[0] - s.translate[0], o[1] - s.translate[1], o[2] - s.translate[2]};
    double diff_abs[3];
    for (int c = 0; c < 3; ++c) {
        // |exact o - T| <= |computed| (1 + u) (+ underflow, below the floor).
        diff_abs[c] = std::fabs(diff[c]) * (1.0 + 2.0 * kU);
    }
    for (int r = 0; r < 3; ++r) {
        const double* L = s.linear + 3 * r;
        double vo = 0.0, so = 0.0;
        bool zero_o = true;
        for (int c = 0; c < 3; ++c) {
            vo += L[c] * diff[c];
            so += std::fabs(L[c]) * diff_abs[c];
            if (L[c] != 0.0 && o[c] != s.translate[c]) zero_o = false;
        }
        om[r] = vo;
        // (floor_at: std::fmax's NaN rule without its libm call.)
        oa[r] = zero_o ? 0.0 : floor_at(kProductFloor, next_up(next_up(so * (1.0 + 8.0 * kU)) + 8.0 * kDenormMin));
        orad[r] = oa[r] == 0.0 ? 0.0 : mul_up(6.0 * kU, oa[r]);
        ray.origin[r] = Ball(om[r], orad[r]);
        ray.direction[r] = Ball(dm[r], drad[r]);
    }
    // Powers (o'_i + t d'_i)^a as polynomials in t, and their magnitudes:
    // on the stack for the usual degrees; thread-local above (200 KB on the
    // stack per secondary ray would be probed page by page on every call).
    double sum[kMaxDegree + 1], mag[kMaxDegree + 1];
    int added[kMaxDegree + 1];  // summands of each coefficient (roundings of its sum)
    double lowest = INFINITY, highest = 0.0;
    constexpr int kSmall = 12;
    if (n < kSmall) {
        double pw[3][kSmall][kSmall], pm[3][kSmall][kSmall];
        expand_terms<kSmall>(s, n, om, oa, dm, da, pw, pm, sum, mag, added, lowest, highest);
    } else {
        using Table = double[kMaxDegree + 1][kMaxDegree + 1];
        static thread_local Table tls_pw[3], tls_pm[3];
        expand_terms<kMaxDegree + 1>(s, n, om, oa, dm, da, tls_pw, tls_pm, sum, mag, added, lowest, highest);
    }
    // No product underflows when every nonzero factor is large enough.
    double amin = 1.0, amax = 1.0;
    for (int a = 0; a < 3; ++a)
        for (double v : {oa[a], da[a]})
            if (v > 0.0) {
                amin = v < amin ? v : amin;
                amax = v > amax ? v : amax;
            }
    bool slack = !(lowest >= kProductFloor);
    if (!slack && lowest < INFINITY) {
        double p = lowest;
        for (int k = 0; k < n; ++k) p *= amin;
        slack = !(p >= kProductFloor);
    }
    const double terms = static_cast<double>(s.terms.size());
    double grow = 1.0;
    if (slack)
        for (int k = 0; k <= n; ++k) grow = mul_up(grow, amax);
    out.n = n;
    out.finite = true;
    for (int k = 0; k <= n; ++k) {
        out.c[k] = sum[k];
        // factor_k = 2 (5n + 2n + 6 + N_k) u, an integer times 2^-52 below
        // 2^-40: exact in round-to-nearest, and so is 1 + factor_k.
        const double factor = 2.0 * (5.0 * n + (2.0 * n + 6.0 + added[k])) * kU;
        double r = mag[k] == 0.0 ? 0.0 : next_up(next_up((1.0 + factor) * mag[k]) * factor);
        // (An absolute loss in one product is carried by the coefficient and
        // the remaining factors: at most max(1, |coeff|) max(1, A)^n.)
        if (slack) r = add_up(r, mul_up(mul_up((3.0 * n + terms + 8.0) * kSlackPerOp, 1.0 + highest), grow));
        out.r[k] = r;
        out.finite = out.finite && std::isfinite(sum[k]) && std::isfinite(r);
    }
}

}  // namespace argand::detail
