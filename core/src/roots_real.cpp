// roots_real.cpp: see roots_real.h.
//
// Error bounds. u = 2^-53; every operation below rounds once (no
// contraction: ARGAND_FP_FLAGS), and gamma(k) = k u / (1 - k u). Products
// that underflow add at most 2^-1074 each, covered by kTiny per operation.
//
// 1. Taylor shift to a: t_k = sum_j C(j, k) c_j a^(j-k) by repeated
//    synthetic division. Each term reaches t_k through at most 2n roundings,
//    so |fl(t_k) - t_k| <= gamma(2n) sum_j C(j, k) |c_j| |a|^(j-k); a family
//    member's coefficients q_j = c_j + e_j (|e_j| <= r_j) move t_k by at most
//    sum_j C(j, k) r_j |a|^(j-k). Both are the Taylor shift at |a| of f_j =
//    gamma(2n+2) |c_j| + r_j, nonnegative terms computed through at most 2n+2
//    roundings each: the computed shift F~_k is at least (1 - u)^(2n+2) times
//    the exact one, so the exact one is at most F~_k (1 + gamma(2n+3)).
// 2. Scaling to s in [0, 1] (t = a + w s): g_k = t_k w^k, with w^k computed
//    by k - 1 products: |fl(g_k) - t~_k w^k| <= gamma(n+1) |t~_k| w^k <=
//    gamma(n+2) |g~_k|, and the errors of step 1 scale by w^k (bounded by
//    the computed power times (1 + gamma(n))).
// 3. Bernstein coefficients b_i = sum_{k<=i} beta(i, k) g_k with beta(i, k)
//    = C(i, k) / C(n, k) in [0, 1] (a correctly rounded quotient of exact
//    integers): the sum of at most n+1 products errs by gamma(n+2) sum |g~|,
//    the rounded betas by u sum |g~|, and the g errors enter with weights
//    beta <= 1. One bound E for every i: E = sum_k G_k + gamma(n+3) sum_k
//    |g~_k|, G_k the bound of step 2, computed with a (1 + gamma(2n+4))
//    margin for its own roundings.
// 4. de Casteljau halving: each new coefficient is fl(x + y) * 0.5 of two
//    older ones (the * 0.5 exact above the subnormals), a convex combination
//    whose own rounding adds at most u |x + y| / 2 <= u M (1 + u)^n, M the
//    largest |b~| of the parent: after n levels a child's bound is E + n u M
//    (1 + u)^n, which E + gamma(n+1) M (1 + gamma(n+1)) covers.
//
// A coefficient b~ with b~ > E is positive for every family member (b~ < -E
// negative). Descartes' rule for the Bernstein basis: the number of roots in
// the open subinterval is at most the number of sign changes of its
// coefficients, and of the same parity. All of one proven sign: no root.
// Exactly one change whatever the one unproven coefficient (at most one,
// where the change is) with both ends proven: exactly one root, simple.
#include "roots_real.h"

#include <algorithm>
#include <cmath>

#include "argand/arith.h"

namespace argand::detail {

namespace {

constexpr double kU = kUnitRoundoff;
constexpr double kTiny = 0x1p-1000;  // per operation: covers the absolute errors of underflowing products
constexpr int kMaxN = 12;            // degrees the real path takes (the batched kernel's)
constexpr int kMaxDepth = 44;        // halvings of the segment
constexpr int kMaxNodes = 160;       // subintervals examined per segment

/// gamma(k) = k u / (1 - k u), tabled for k < 64 (the callers' k <= 2n + 4 <= 28).
struct Gammas {
    double v[64];
    constexpr Gammas() : v() {
        for (int k = 0; k < 64; ++k) v[k] = k * kU / (1.0 - k * kU);
    }
};
constexpr Gammas kGammas{};
inline double gamma(int k) { return kGammas.v[k]; }

/// beta(n, i, k) = C(i, k) / C(n, k), rounded to nearest, for n <= kMaxN.
struct Betas {
    double v[kMaxN + 1][kMaxN + 1][kMaxN + 1] = {};
    Betas() {
        double binom[kMaxN + 1][kMaxN + 1] = {};
        for (int i = 0; i <= kMaxN; ++i) {
            binom[i][0] = 1.0;
            for (int k = 1; k <= i; ++k) binom[i][k] = binom[i - 1][k - 1] + (k < i ? binom[i - 1][k] : 0.0);
        }
        for (int n = 0; n <= kMaxN; ++n)
            for (int i = 0; i <= n; ++i)
                for (int k = 0; k <= i; ++k) v[n][i][k] = binom[i][k] / binom[n][k];
    }
};

const Betas& betas() {
    static const Betas b;
    return b;
}

struct Node {
    double s0;   // the subinterval is s in [s0, s0 + 2^-depth]
    int depth;
    double e;    // error bound of every coefficient
    double b[kMaxN + 1];
};

/// -1, 0 (not proven), +1: the sign of x for every family member.
inline int proven_sign(double x, double e) { return x > e ? 1 : (x < -e ? -1 : 0); }

/// p(t) and a bound of |p~(t) - q(t)| for every family member q.
inline void eval_bounded(const double* c, const double* r, int n, double t, double& value, double& bound) {
    const double at = std::fabs(t), g = gamma(2 * n + 2);
    double p = c[n], s = g * std::fabs(c[n]) + r[n];
    for (int k = n - 1; k >= 0; --k) {
        p = p * t + c[k];
        s = s * at + (g * std::fabs(c[k]) + r[k]);
    }
    value = p;
    bound = s * (1.0 + gamma(2 * n + 4)) + (2 * n + 2) * kTiny;
}

inline int sign_at(const double* c, const double* r, int n, double t) {
    double v, b;
    eval_bounded(c, r, n, t, v, b);
    if (!std::isfinite(v) || !std::isfinite(b)) return 0;
    return proven_sign(v, b);
}

}  // namespace

bool real_roots_in(const double* c, const double* r, int n, double a, double w, RealIsolation& out) {
    out.n = 0;
    if (n < 1 || n > kMaxN || !std::isfinite(a) || !std::isfinite(w) || !(w > 0.0)) return false;
    for (int k = 0; k <= n; ++k)
        if (!std::isfinite(c[k]) || !std::isfinite(r[k]) || r[k] < 0.0) return false;
    // Steps 1-3 (see the top of the file).
    double t[kMaxN + 1], f[kMaxN + 1];
    const double g2 = gamma(2 * n + 2), aa = std::fabs(a);
    for (int k = 0; k <= n; ++k) {
        t[k] = c[k];
        f[k] = g2 * std::fabs(c[k]) + r[k];
    }
    for (int i = 0; i < n; ++i)
        for (int j = n - 1; j >= i; --j) {
            t[j] = t[j] + a * t[j + 1];
            f[j] = f[j] + aa * f[j + 1];
        }
    double g[kMaxN + 1], sum_err = 0.0, sum_abs = 0.0, pw = 1.0;
    const double grow_f = 1.0 + gamma(2 * n + 3), grow_pw = 1.0 + gamma(n + 1), g_n2 = gamma(n + 2);
    for (int k = 0; k <= n; ++k) {
        g[k] = t[k] * pw;
        sum_err += f[k] * grow_f * (pw * grow_pw) + g_n2 * std::fabs(g[k]);
        sum_abs += std::fabs(g[k]);
        pw = pw * w;
    }
    Node stack[kMaxDepth + 2];
    int top = 0;
    Node& root = stack[top++];
    root.s0 = 0.0;
    root.depth = 0;
    root.e = (sum_err + gamma(n + 3) * sum_abs) * (1.0 + gamma(2 * n + 4)) + (n + 1) * (n + 1) * kTiny;
    if (!std::isfinite(root.e)) return false;
    const Betas& bt = betas();
    for (int i = 0; i <= n; ++i) {
        double s = 0.0;
        for (int k = 0; k <= i; ++k) s += bt.v[n][i][k] * g[k];
        root.b[i] = s;
        if (!std::isfinite(s)) return false;
    }
    int nodes = 0;
    const double split_growth = gamma(n + 1) * (1.0 + gamma(n + 1));
    while (top > 0) {
        const Node& nd = stack[--top];  // (its slot is reused by its halves below, after the last read)
        if (++nodes > kMaxNodes) return false;
        int sg[kMaxN + 1];
        bool all_pos = true, all_neg = true;
        for (int i = 0; i <= n; ++i) {
            sg[i] = proven_sign(nd.b[i], nd.e);
            all_pos &= sg[i] > 0;
            all_neg &= sg[i] < 0;
        }
        if (all_pos || all_neg) continue;  // no root here
        if (sg[0] != 0 && sg[n] == -sg[0]) {
            int k = 1;
            while (k < n && sg[k] == sg[0]) ++k;
            bool one = true;
            for (int j = k + 1; j <= n; ++j) one &= sg[j] == sg[n];
            if (one) {  // exactly one root, simple, in the open subinterval
                if (out.n >= kMaxDegree) return false;
                const double h = std::ldexp(1.0, -nd.depth), s1 = nd.s0 + h;
                // t = a + w s, s exact (dyadic): one rounding each end, then outward.
                out.lo[out.n] = next_down(std::fma(w, nd.s0, a));
                out.hi[out.n] = next_up(std::fma(w, s1, a));
                // Newton's start: where the control polygon crosses zero
                // (between b_(k-1) and b_k, or at b_k where it is unproven).
                const double bl = nd.b[k - 1], br = nd.b[k];
                const double f = (k - 1 + (bl != br ? bl / (bl - br) : 0.5)) / n;
                out.guess[out.n] = std::fma(w, nd.s0 + h * std::min(1.0, std::max(0.0, f)), a);
                out.end_sign[out.n] = sg[n];
                ++out.n;
                continue;
            }
        }
        if (nd.depth >= kMaxDepth) return false;
        // Halve (step 4): the right half is pushed first, so the left one
        // (the nearer roots) is examined first and the roots come ascending.
        double m = 0.0;
        for (int i = 0; i <= n; ++i) m = std::max(m, std::fabs(nd.b[i]));
        const double e = nd.e + split_growth * m + (n + 1) * kTiny;
        double tmp[kMaxN + 1];
        for (int i = 0; i <= n; ++i) tmp[i] = nd.b[i];
        const double s0 = nd.s0;
        const int depth = nd.depth;
        Node& right = stack[top++];  // (nd's slot: nd is not read below)
        Node& left = stack[top++];
        left.b[0] = tmp[0];
        right.b[n] = tmp[n];
        for (int j = 1; j <= n; ++j) {
            for (int i = 0; i <= n - j; ++i) tmp[i] = (tmp[i] + tmp[i + 1]) * 0.5;
            left.b[j] = tmp[0];
            right.b[n - j] = tmp[n - j];
        }
        left.depth = right.depth = depth + 1;
        left.s0 = s0;
        right.s0 = s0 + std::ldexp(1.0, -(depth + 1));
        left.e = right.e = e;
    }
    // Adjacent subintervals share an end T (a dyadic point, not a double),
    // widened outward by a step each: the roots' intervals must not meet.
    // m1 < T < m2 are the doubles either side of T's rounding. p's sign s
    // at T is proven (the left subinterval's last coefficient, p(T)): where
    // p has sign s at m1 too, the left root (the only root in its
    // subinterval, simple) is not in [m1, T] (it would change the sign
    // once), so it lies below m1; likewise, with sign s at m2, the right root
    // above m2. Otherwise narrow both apart, or give up.
    for (int i = 0; i + 1 < out.n; ++i) {
        if (out.hi[i] < out.lo[i + 1]) continue;
        const double m = next_up(out.lo[i + 1]);  // fl(T) (lo = next_down(fl(T)))
        const double m1 = next_down(m), m2 = next_up(m);
        const int s = out.end_sign[i];
        if (m == next_down(out.hi[i]) && s != 0 && sign_at(c, r, n, m1) == s && sign_at(c, r, n, m2) == s &&
            out.lo[i] < m1 && m2 < out.hi[i + 1]) {
            out.hi[i] = m1;
            out.lo[i + 1] = m2;
            continue;
        }
        if (!narrow_real_root(c, r, n, out.lo[i], out.hi[i]) ||
            !narrow_real_root(c, r, n, out.lo[i + 1], out.hi[i + 1]) || !(out.hi[i] < out.lo[i + 1]))
            return false;
    }
    return true;
}

bool narrow_real_root(const double* c, const double* r, int n, double& lo, double& hi, bool* tight, double start,
                      double* value) {
    if (tight) *tight = false;
    if (n < 1 || n > kMaxN || !(lo < hi)) return false;
    // Newton in double from `start` (or the middle), kept inside (lo, hi),
    // with eval_bounded's error bound computed alongside, for the family
    // (f: with the radii) and for the centres alone (e: the rounding noise
    // of p's evaluation); independent chains, no extra latency.
    const double g = gamma(2 * n + 2);
    double f[kMaxN + 1], e[kMaxN + 1];
    for (int k = 0; k <= n; ++k) {
        e[k] = g * std::fabs(c[k]);
        f[k] = e[k] + r[k];
    }
    double x = start > lo && start < hi ? start : 0.5 * (lo + hi);
    double dp = 0.0, bound = INFINITY;
    const double grow = 1.0 + gamma(2 * n + 4);
    bool settled = false;
    for (int step = 0; step < 48; ++step) {
        const double ax = std::fabs(x);
        double p = c[n], s = f[n], q = e[n];
        dp = 0.0;
        for (int k = n - 1; k >= 0; --k) {
            dp = dp * x + p;
            p = p * x + c[k];
            s = s * ax + f[k];
            q = q * ax + e[k];
        }
        bound = s * grow + (2 * n + 2) * kTiny;
        if (!(dp != 0.0) || !std::isfinite(p) || !std::isfinite(dp)) break;
        // At the noise, |p| below its evaluation's error: this last step
        // (within that error over |p'|) is as far as p's computed values can
        // lead.
        const bool at_noise = std::fabs(p) <= q * grow + (2 * n + 2) * kTiny;
        double nx = x - p / dp;
        if (!(nx > lo && nx < hi)) nx = 0.5 * (x + (nx <= lo ? lo : hi));
        const double size = std::fabs(nx - x);
        x = nx;
        // A step below 2^-26 of the root: the next error is of its square.
        // (Steps that shrink slowly, far from the root or near a double
        // one, go on: 48 steps at most.)
        if (at_noise || size <= 0x1p-26 * std::fabs(x)) {
            settled = true;
            break;
        }
    }
    // Proven opposite signs a few rounding errors either side of x (the
    // interval's only root lies between).
    double eps = 4.0 * kU * std::fabs(x);
    if (std::isfinite(bound) && std::fabs(dp) > 0.0 && std::isfinite(dp)) eps = std::max(eps, 2.0 * bound / std::fabs(dp));
    for (int tries = 0; tries < 4; ++tries, eps *= 8.0) {
        const double l = x - eps, h = x + eps;
        if (!(l >= lo && h <= hi)) break;  // (equal: an interval this narrowed before)
        const int sl = sign_at(c, r, n, l);
        if (sl != 0 && sign_at(c, r, n, h) == -sl) {
            lo = l;
            hi = h;
            if (tight) *tight = settled;
            if (value && settled) *value = x;
            return true;
        }
    }
    // Bisection on proven signs.
    const int sl = sign_at(c, r, n, lo), sh = sign_at(c, r, n, hi);
    if (sl == 0 || sh != -sl) return false;
    bool narrowed = false;
    for (int step = 0; step < 12; ++step) {
        const double m = 0.5 * (lo + hi);
        if (!(m > lo && m < hi)) break;
        const int sm = sign_at(c, r, n, m);
        if (sm == 0) break;
        (sm == sl ? lo : hi) = m;
        narrowed = true;
    }
    return narrowed;
}

}  // namespace argand::detail
