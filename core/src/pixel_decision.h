// pixel_decision.h: the proven decisions a pixel is made of (internal
// header of the renderer): where a root disc lies relative to the argument
// band, the clipping sphere and the other discs (the double-double
// refinement of a disc, root finding, is refine_dd.h's). Every predicate is
// certain-only: Yes and No are proofs, Unknown claims nothing.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "argand/arith.h"
#include "argand/render.h"
#include "ray_polynomial.h"

namespace argand::detail {

enum class Verdict : std::uint8_t { Yes = 0, No = 1, Unknown = 2 };

/// The band edge at the exact angle a + b (b may be 0): enclosures of its
/// cosine and sine.
FramePlan::BandEdge band_edge(double a, double b);

/// Lower / upper bounds of the moduli of the points of disc d (lo >= 0).
double modulus_down(const RootDisc& d);
double modulus_up(const RootDisc& d);
/// Both at once (lo = modulus_down(d), hi = modulus_up(d)).
void modulus_bounds(const RootDisc& d, double& lo, double& hi);

/// may_meet_mirror's final test: !(dist_down(a, conj b) > reach).
bool mirror_within(const RootDisc& a, const RootDisc& b, double reach);

/// True unless D(a) and D(b)'s mirror image are proven disjoint.
inline bool may_meet_mirror(const RootDisc& a, const RootDisc& b) {
    constexpr double kU = kUnitRoundoff;
    const double reach = add_up(a.radius, b.radius);
    // A cheap sufficient test first: the distance is at least the larger
    // component difference. A difference of doubles is correctly rounded
    // (exact where subnormal), so the exact one is at least the computed one
    // times (1 - u); (1 - 2u) and a step down cover that and the product's
    // rounding. (NaN and inf fail the comparison: the full test decides.)
    if (next_down(std::fabs(a.re - b.re) * (1.0 - 2.0 * kU)) > reach ||
        next_down(std::fabs(a.im + b.im) * (1.0 - 2.0 * kU)) > reach)
        return false;
    return mirror_within(a, b, reach);
}

/// proven_real's mirror test alone (d verified, count 1, meeting its mirror).
bool real_by_mirror(const RootDisc* all, int n_all, int self);

/// Flags real every one-root disc of `discs` (all verified: they hold every
/// root of a real polynomial) that meets its mirror image and no other
/// disc's (real_by_mirror): its root's conjugate is a root, so in it. After
/// a solve, once for every band (PrimaryBatch::solve, Tracer::solve), so
/// that a hit on it writes im = 0 whatever the kernel that found it.
void flag_real_by_mirror(RootDisc* discs, int n);

/// Is the root in disc all[self] (count 1, verified) real? True when the
/// disc says so, or when every other disc of the same polynomial (all
/// verified, so they cover every root) is proven disjoint from the mirror
/// image of all[self]: the conjugate of its root then lies in it, and it
/// holds one root. (Inline: most discs are decided by the first checks.)
inline bool proven_real(const RootDisc* all, int n_all, int self, bool all_verified) {
    const RootDisc& d = all[self];
    if (!d.verified || d.count != 1) return false;
    if (d.real) return true;
    // d meets its mirror image iff |im| <= radius (exact comparison).
    if (!all_verified || !(std::fabs(d.im) <= d.radius)) return false;
    return real_by_mirror(all, n_all, self);
}

/// Band membership of every root in disc d: Yes (all in the band), No (all
/// outside), Unknown. `real` says d's single root is proven real. For a real
/// object (complex_space false) the band is the positive real axis.
/// (band_verdict with edge_range.)
Verdict band_membership(const RootDisc& d, bool real, const FramePlan& plan, bool complex_space);

/// The clipping sphere |P| <= radius for every point P = o' + s d' with s
/// the modulus of a root in d: Yes (all inside, kept), No (all outside),
/// Unknown (straddling).
Verdict inside_clip(const ObjectRay& ray, double mod_lo, double mod_hi, double radius);

/// True only when the whole ray provably misses the clipping sphere:
/// |o' + s d'| > radius for every s >= 0 and every o', d' in the ray's
/// balls. Then inside_clip is No for every disc whatever its moduli, so no
/// root of the ray polynomial can be the pixel's, found or not: the object
/// is a proven miss along this ray without solving anything. False claims
/// nothing (the ray may still miss). Round-to-nearest operations only, no
/// branch but the last (the batched path calls it for a run of cells, the
/// scalar path for one ray: the same operations on the same balls, so the
/// same answer; primary_ray_polynomial_run's balls are
/// primary_ray_polynomial's bits).
///
/// Proof. With o, d the balls' centres (doubles), |o' - o| <= sum rad(o'_k)
/// and |d' - d| <= sum rad(d'_k) (1-norms bound 2-norms), so |o' + s d'| >=
/// |o + s d| - (L - radius) - s P for any reals L >= radius + sum
/// rad(o'_k), P >= sum rad(d'_k). L and P below are such: a sum of k nonnegative
/// doubles rounded to nearest is at least the exact sum times (1 - u)^k
/// (exact where subnormal), and fl(v (1 + 8u)) >= v (1 + 8u)(1 - u) >= v
/// (1 - u)^-3 for normal v (>= v for subnormal v, whose sums were exact). It
/// then suffices that |o + s d| > L + s P for s >= 0, i.e. Q(s) = A s^2 + 2
/// B s + C > 0 with A = |d|^2 - P^2, B = o.d - L P, C = |o|^2 - L^2.
/// Let T_A = |d|^2 + P^2, T_B = sum |o_k d_k| + L P, T_C = |o|^2 + L^2
/// (exact; T_B^2 <= T_A T_C by Cauchy-Schwarz). Each of A, B, C is
/// computed as a sum of four products whose terms pass at most four
/// roundings, so |fl(X) - X| <= gamma_4 T_X + 4 eta (gamma_4 = 4u / (1 -
/// 4u), eta = 2^-1074 for underflowing products); the computed T_X (the
/// same operations on the absolute values) is at least T_X (1 - u)^4.
/// The tests run only with T_A and T_C in [2^-400, 2^400] (which also
/// rejects inf and NaN), where the eta terms are below 2^-600 u T_A T_C and
/// no product overflows. Then fl(A) > 16u fl(T_A) gives A > 0, and
/// likewise C > 0, and B > 0 where also fl(T_B) >= 2^-400 (B > 0: Q >= C >
/// 0 on s >= 0). Otherwise the
/// rounded D = fl(A) fl(C) - fl(B)^2 is within (8.05 + 8.05 + 1.01 + 1.01 +
/// 2.03) u T_A T_C < 21u T_A T_C of A C - B^2 (the first two terms from
/// the errors of A, C and of B^2, the rest from the three roundings of D),
/// and D > fl(fl(128u fl(T_A)) fl(T_C)) >= 126u T_A T_C gives A C > B^2:
/// Q has no real zero and Q(0) = C > 0, so Q > 0 everywhere.
inline bool ray_misses_sphere(const ObjectRay& ray, double radius) {
    constexpr double kU = kUnitRoundoff;
    const Ball *o = ray.origin, *d = ray.direction;
    const double l = (radius + ((o[0].rad + o[1].rad) + o[2].rad)) * (1.0 + 8.0 * kU);
    const double p = ((d[0].rad + d[1].rad) + d[2].rad) * (1.0 + 8.0 * kU);
    const double d0 = d[0].mid * d[0].mid, d1 = d[1].mid * d[1].mid, d2 = d[2].mid * d[2].mid;
    const double o0 = o[0].mid * o[0].mid, o1 = o[1].mid * o[1].mid, o2 = o[2].mid * o[2].mid;
    const double b0 = o[0].mid * d[0].mid, b1 = o[1].mid * d[1].mid, b2 = o[2].mid * d[2].mid;
    const double pp = p * p, ll = l * l, lp = l * p;
    const double sa = (d0 + d1) + d2, sc = (o0 + o1) + o2, sb = (b0 + b1) + b2;
    const double big_a = sa - pp, t_a = sa + pp;
    const double big_c = sc - ll, t_c = sc + ll;
    const double big_b = sb - lp, t_b = ((std::fabs(b0) + std::fabs(b1)) + std::fabs(b2)) + lp;
    const double disc = big_a * big_c - big_b * big_b;
    constexpr double kLo = 0x1p-400, kHi = 0x1p400;
    const bool in_range = t_a >= kLo && t_a <= kHi && t_c >= kLo && t_c <= kHi;
    const bool signs = big_a > 16.0 * kU * t_a && big_c > 16.0 * kU * t_c;
    const bool away = t_b >= kLo && big_b > 16.0 * kU * t_b;
    const bool no_zero = disc > (128.0 * kU * t_a) * t_c;
    return in_range & signs & (away | no_zero);
}

/// True iff disc j (count 1, verified, of the polynomial whose discs are
/// all[0..n_all), all verified) holds exactly the conjugate of the root in
/// disc b: it is the only disc that may meet b's mirror image.
bool is_mirror_twin(const RootDisc& b, const RootDisc& j, const RootDisc* all, int n_all, bool all_verified);

// ---------------------------------------------------------------------------
// The fast decisions (Tracer::decide's fast path). Each returns EXACTLY what
// its reference above returns (band_fast == band_membership, modulus_fast ==
// modulus_bounds, clip_fast == inside_clip), for every input: either the
// reference's own floating-point operations in the same order (so the same
// roundings under -ffp-contract=off), or a cheaper sufficient test proven to
// imply the reference's outcome, falling back to the reference when it does
// not decide. core/tests/render_test.cpp compares them on random and edge
// discs; ARGAND_DECIDE=full renders with the reference path only.
// ---------------------------------------------------------------------------

/// Bounds of s(z) = Im(z e^{-i alpha}) = y cos(alpha) - x sin(alpha) over
/// the disc D((x, y), r), for the edge alpha enclosed by e (band_membership's
/// edge test; the error bound's argument is in pixel_decision.cpp).
__attribute__((always_inline)) inline void edge_range(const FramePlan::BandEdge& e, double x, double y, double r,
                                                      double& lo, double& hi) {
    constexpr double kU = kUnitRoundoff;
    const double s = y * e.cos_mid - x * e.sin_mid;
    const double mag = std::fabs(y) * std::fabs(e.cos_mid) + std::fabs(x) * std::fabs(e.sin_mid);
    const double err = next_up((mag * (4.0 * kU) + e.err * (std::fabs(x) + std::fabs(y))) * (1.0 + 8.0 * kU) +
                               8.0 * kDenormMin);
    const double reach = add_up(err, r);  // >= err + r
    lo = next_down(s - reach);
    hi = next_up(s + reach);
}

/// A band edge with the factor of edge_range_fast's quick test.
struct FastEdge {
    FramePlan::BandEdge e;
    double k = 0.0;  // >= (4u max(|cos_mid|, |sin_mid|) + err) (1 + 61u)
};
FastEdge fast_edge(const FramePlan::BandEdge& e);

/// edge_range for the sign tests band_membership makes (lo >= 0, lo > 0,
/// hi <= 0, hi < 0): when the disc is far from the edge, lo = hi = s (the
/// same computed s), whose four signs are those of edge_range's lo and hi;
/// otherwise edge_range itself.
///
/// Proof. Let a = |x| + |y|, M = max(|C|, |S|), E = e.err, u = 2^-53, eta =
/// 2^-1074. Every round-to-nearest operation on nonnegative operands returns
/// within a factor (1 +- u) of the exact result, or within eta / 2 of it
/// below the normal range (where sums are exact); next_up(v) <= v (1 + 2u) +
/// eta. Following edge_range's operations: mag <= a M (1 + u)^2 + eta, its
/// error term err <= a (4uM + E) (1 + 15u) + 12 eta, and reach = next_up(err
/// + r) <= a (4uM + E) (1 + 19u) + r (1 + 4u) + 14 eta. Here T = fl(fl(fl(fl(a)
/// k) + r) (1 + 16u)) + 64 eta (rounded) is at least (a k + r) (1 + 16u)
/// (1 - u)^6 + 60 eta >= a (4uM + E) (1 + 19u) + r (1 + 4u) + 60 eta >= reach
/// + 2 eta. If s > T, then s - reach >= 2 eta exactly, so fl(s - reach) >= 2
/// eta (rounding is monotone, 2 eta is a double) and lo = next_down(..) >= eta
/// > 0, and hi >= lo: both positive, as s. If -s > T, symmetrically hi <=
/// -eta < 0 and lo <= hi: both negative, as s. T = inf (overflow) or NaN
/// never passes the strict comparisons; s = +-inf with T finite gives the
/// reference's lo, hi = +-DBL_MAX or +-inf, of the same signs.
__attribute__((always_inline)) inline void edge_range_fast(const FastEdge& f, double x, double y, double r,
                                                           double& lo, double& hi) {
    constexpr double kU = kUnitRoundoff;
    const double s = y * f.e.cos_mid - x * f.e.sin_mid;
    const double t = ((std::fabs(x) + std::fabs(y)) * f.k + r) * (1.0 + 16.0 * kU) + 64.0 * kDenormMin;
    if (s > t || -s > t) {
        lo = hi = s;
        return;
    }
    edge_range(f.e, x, y, r, lo, hi);
}

/// The frame's band for one kind of object (band_membership's constants).
struct BandPlan {
    bool axis = true;        // the band is the positive real axis
    bool sigma_zero = true;  // sigma == 0
    bool lower = false;      // sigma > 0: the lower edge is tested
    FastEdge lower_edge, upper_edge;
};
BandPlan band_plan(const FramePlan& plan, bool complex_space);

/// Band membership (band_membership's logic, for band_membership and
/// band_fast alike): `axis`: the band is the positive real axis (a real
/// object, or sigma = delta = 0); `sigma_zero`: sigma == 0; `lower`: sigma >
/// 0 (the lower edge is tested). edge(upper, x, y, r, lo, hi) gives the
/// bounds of s(z) over the disc for the upper (true) or lower edge:
/// edge_range, or edge_range_fast (whose signs are edge_range's).
template <class Edge>
__attribute__((always_inline)) inline Verdict band_verdict(const RootDisc& d, bool real, bool axis, bool sigma_zero,
                                                           bool lower, Edge&& edge) {
    const double r = d.radius;
    // 0 is outside the disc (a sufficient test first, then the modulus).
    const bool misses_zero = std::fabs(d.re) > r || std::fabs(d.im) > r || modulus_down(d) > 0.0;
    if (axis) {
        // The band is the positive real axis (arg t = 0 exactly).
        if (real && misses_zero) return d.re > 0.0 ? Verdict::Yes : Verdict::No;
        // Points of the disc on the half-line [0, inf)?
        if (add_down(std::fabs(d.im), -r) > 0.0 || add_up(d.re, r) < 0.0) return Verdict::No;
        return Verdict::Unknown;
    }
    if (!misses_zero) return Verdict::Unknown;
    if (real) {
        // arg t = 0 (in the band iff sigma == 0) or pi (never: sigma + delta
        // <= pi, and the exact sum of two doubles is never pi).
        if (d.re > 0.0) return sigma_zero ? Verdict::Yes : Verdict::No;
        return Verdict::No;
    }
    // |arg z| over the disc equals arg z over the disc reflected into the
    // upper half-plane (centre (x, |y|)); there arg z <= alpha iff
    // s(z) <= 0, and arg z >= alpha iff s(z) >= 0 (alpha in (0, pi)).
    const double x = d.re, y = std::fabs(d.im);
    bool above_lower = true, below_lower = false;  // all >= sigma / all < sigma
    if (lower) {
        double lo, hi;
        edge(false, x, y, r, lo, hi);
        above_lower = lo >= 0.0;
        below_lower = hi < 0.0;
    }
    double lo, hi;
    edge(true, x, y, r, lo, hi);
    const bool below_upper = hi <= 0.0, above_upper = lo > 0.0;
    if (above_lower && below_upper) return Verdict::Yes;
    if (below_lower || above_upper) return Verdict::No;
    return Verdict::Unknown;
}

/// band_membership(d, real, plan, complex_space) for bp = band_plan(plan,
/// complex_space): band_verdict with edge_range_fast.
__attribute__((always_inline)) inline Verdict band_fast(const RootDisc& d, bool real, const BandPlan& bp) {
    return band_verdict(d, real, bp.axis, bp.sigma_zero, bp.lower,
                        [&bp](bool upper, double x, double y, double r, double& lo, double& hi) {
                            edge_range_fast(upper ? bp.upper_edge : bp.lower_edge, x, y, r, lo, hi);
                        });
}

/// band_membership(all[self], proven_real(all, n_all, self, true), ..) for a
/// polynomial whose discs are all verified: realness (the mirror test) is
/// decided only when the verdict depends on it.
__attribute__((always_inline)) inline Verdict band_fast_verified(const RootDisc* all, int n_all, int self,
                                                                 const BandPlan& bp) {
    const RootDisc& d = all[self];
    // proven_real: false unless count 1; true if d.real; else it needs
    // |im| <= radius and the mirror test.
    if (d.count != 1) return band_fast(d, false, bp);
    if (d.real) return band_fast(d, true, bp);
    const Verdict v0 = band_fast(d, false, bp);
    if (!(std::fabs(d.im) <= d.radius)) return v0;
    const Verdict v1 = band_fast(d, true, bp);
    if (v1 == v0) return v0;
    for (int j = 0; j < n_all; ++j)  // real_by_mirror, inline
        if (j != self && may_meet_mirror(all[j], d)) return v0;
    return v1;
}

/// b is a's mirror image to the bit (centre conjugated, same radius, count
/// and flags).
inline bool exact_mirrors(const RootDisc& a, const RootDisc& b) {
    std::uint64_t ar, ai, aq, br, bi, bq;
    std::memcpy(&ar, &a.re, 8);
    std::memcpy(&br, &b.re, 8);
    if (ar != br) return false;
    std::memcpy(&ai, &a.im, 8);
    std::memcpy(&bi, &b.im, 8);
    std::memcpy(&aq, &a.radius, 8);
    std::memcpy(&bq, &b.radius, 8);
    return bi == (ai ^ (std::uint64_t{1} << 63)) && aq == bq && a.count == b.count && a.real == b.real &&
           a.verified == b.verified;
}

/// is_mirror_twin(all[b], all[j], all, n_all, true) for discs all verified
/// (b != j): j meets b's mirror image, so "exactly one disc meets it" is
/// "no disc but j meets it".
__attribute__((always_inline)) inline bool is_mirror_twin_fast(const RootDisc* all, int n_all, int b, int j) {
    const RootDisc& db = all[b];
    if (db.count != 1 || all[j].count != 1) return false;
    // (j exactly b's mirror image meets it: distance 0.)
    if (!exact_mirrors(all[j], db) && !may_meet_mirror(all[j], db)) return false;
    for (int k = 0; k < n_all; ++k)
        if (k != j && may_meet_mirror(all[k], db)) return false;
    return true;
}

/// The double next to x > 0 (finite) upward / downward: its bits + 1 / - 1
/// (next_up / next_down there; next_down(2^-1074) = +0 both ways).
inline double successor_of_positive(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    ++b;
    std::memcpy(&x, &b, sizeof b);
    return x;
}
inline double predecessor_of_positive(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    --b;
    std::memcpy(&x, &b, sizeof b);
    return x;
}

/// modulus_bounds(d, lo, hi): the same operations, with next_up / next_down
/// of values known positive and finite as a step of their bits.
__attribute__((always_inline)) inline void modulus_fast(const RootDisc& d, double& lo, double& hi) {
    constexpr double kU = kUnitRoundoff;
    const double m = std::sqrt(d.re * d.re + d.im * d.im);
    if (!(m >= 0x1p-500 && m <= 0x1p500)) {
        modulus_bounds(d, lo, hi);
        return;
    }
    // m (1 -+ 4u) is a positive normal double (m in [2^-500, 2^500]).
    // Reference: l = next_down(next_down(m (1 - 4u)) - r), lo = l > 0 ? l : 0.
    // With a = next_down(m (1 - 4u)) - r: a > 0 (finite, <= m) gives l =
    // a's predecessor (0 for a = 2^-1074, then lo = 0 both ways); a <= 0
    // or NaN gives l <= -2^-1074 or NaN, lo = 0.
    const double a = predecessor_of_positive(m * (1.0 - 4.0 * kU)) - d.radius;
    lo = a > 0.0 ? predecessor_of_positive(a) : 0.0;
    // Reference: hi = next_up(next_up(m (1 + 4u)) + r).
    const double b = successor_of_positive(m * (1.0 + 4.0 * kU)) + d.radius;
    hi = b > 0.0 && b < INFINITY ? successor_of_positive(b) : next_up(b);
}

/// A ray's sums for clip_fast, over the axes a (round-to-nearest, in this
/// order): dabs = sum (|d'_a.mid| + d'_a.rad), orad = sum o'_a.rad, drad =
/// sum d'_a.rad, omid = sum |o'_a.mid|.
struct ClipSums {
    double dabs, orad, drad, omid;
};
inline ClipSums clip_sums(const ObjectRay& ray) {
    const Ball *o = ray.origin, *d = ray.direction;
    ClipSums c;
    c.dabs = ((std::fabs(d[0].mid) + d[0].rad) + (std::fabs(d[1].mid) + d[1].rad)) + (std::fabs(d[2].mid) + d[2].rad);
    c.orad = (o[0].rad + o[1].rad) + o[2].rad;
    c.drad = (d[0].rad + d[1].rad) + d[2].rad;
    c.omid = (std::fabs(o[0].mid) + std::fabs(o[1].mid)) + std::fabs(o[2].mid);
    return c;
}

/// clip_fast and clip_quick (sums = clip_sums(ray)).
///
/// inside_clip's first test (clip_verdict_fast) says Yes iff next_up(fl(norm
/// (1 + 4u)) + e) <= fl(radius (1 - 2u)) and No iff next_down(fl(norm (1 -
/// 4u)) - e) > fl(radius (1 + 2u)), with norm = sqrt(q), q the rounded sum of
/// the rounded squares of p_a = fl(o'_a.mid + fl(m d'_a.mid)) (computed here
/// with the same operations in the same order, so the same norm), and e its
/// rounded bound on the spread. Here e1 >= e: with X = w sum dabs_a + sum
/// orad_a + mod_hi sum drad_a + 8u (sum |o'_a.mid| + mod_hi sum dabs_a)
/// (exact, dabs_a = |d'_a.mid| + d'_a.rad; every term nonnegative), each
/// round-to-nearest operation on nonnegatives is within a factor (1 +- u)
/// of its exact result, or within eta / 2 (eta = 2^-1074) for a product
/// below the normal range (sums there are exact), and next_up(v) <= v (1 +
/// 2u) + eta. The reference's terms pass through at most ten roundings and
/// the final next_up: e <= X (1 + u)^10 (1 + 16u) (1 + 2u) + 80 eta <= X (1 +
/// 29u) + 80 eta. Ours pass through at most nine (three in the sums, six
/// below): e1 >= X (1 - u)^9 (1 + 64u) + 256 eta (1 - u) - 8 eta >= X (1 +
/// 54u) + 240 eta >= e. Rounding and next_up are monotone, so a Yes (No) of
/// the test with e1 is a Yes (No) of the test with e, which the reference
/// returns (before its exact test). Neither: the reference itself. (e1 inf
/// or NaN passes neither test.)
///
/// clip_quick is that first test alone: its Yes and No, Unknown where
/// clip_fast goes on to inside_clip (for a caller that would rather narrow
/// the disc first: the real-root path).
__attribute__((always_inline)) inline Verdict clip_quick(const ObjectRay& ray, const ClipSums& sums, double mod_lo,
                                                        double mod_hi, double radius) {
    constexpr double kU = kUnitRoundoff;
    const double m = 0.5 * (mod_lo + mod_hi);
    const double w = (mod_hi - m > m - mod_lo ? mod_hi - m : m - mod_lo) * (1.0 + 4.0 * kU);
    // (q: the reference's sum, 0 + p_0^2 + p_1^2 + p_2^2 in this order.)
    const double p0 = ray.origin[0].mid + m * ray.direction[0].mid;
    const double p1 = ray.origin[1].mid + m * ray.direction[1].mid;
    const double p2 = ray.origin[2].mid + m * ray.direction[2].mid;
    const double q = ((0.0 + p0 * p0) + p1 * p1) + p2 * p2;
    const double e1 = (w * sums.dabs + sums.orad + mod_hi * sums.drad + 8.0 * kU * (sums.omid + mod_hi * sums.dabs)) *
                          (1.0 + 64.0 * kU) +
                      256.0 * kDenormMin;
    const double norm = std::sqrt(q);
    // (next_up(v) <= c iff v < c for doubles v, c: next_up(v) is the least
    // double above v; NaN fails both. No such rewriting for next_down(v) > c,
    // which may fail where v > c holds.)
    if (norm * (1.0 + 4.0 * kU) + e1 < radius * (1.0 - 2.0 * kU)) return Verdict::Yes;
    if (next_down(norm * (1.0 - 4.0 * kU) - e1) > radius * (1.0 + 2.0 * kU)) return Verdict::No;
    return Verdict::Unknown;
}

/// inside_clip(ray, mod_lo, mod_hi, radius) (sums = clip_sums(ray)):
/// clip_quick, and the reference where it says Unknown (see above).
__attribute__((always_inline)) inline Verdict clip_fast(const ObjectRay& ray, const ClipSums& sums, double mod_lo,
                                                        double mod_hi, double radius) {
    const Verdict v = clip_quick(ray, sums, mod_lo, mod_hi, radius);
    return v != Verdict::Unknown ? v : inside_clip(ray, mod_lo, mod_hi, radius);
}

/// The decisions of one polynomial's discs (decide_fast's per-disc part):
/// bit i of `live` says disc i may hold the pixel's root (count > 0, not the
/// exact root 0, not proven out of the band, not proven outside the sphere),
/// bit i of `eligible` that it is proven in both; lo[i], hi[i] are its
/// modulus bounds (set for live discs only).
/// And decide_full's choice among them (finish_choice): best, the first
/// eligible disc of least hi (-1: none); count, the sum of the eligible
/// discs' counts; blockers, the live discs but best whose lo is not above
/// best's hi (0 without best).
struct DiscVerdicts {
    std::uint64_t live = 0, eligible = 0, blockers = 0;
    int best = -1, count = 0;
    double lo[kMaxDegree], hi[kMaxDegree];
};
static_assert(kMaxDegree <= 64, "DiscVerdicts: one bit per disc");

/// best, count and blockers of v from its live, eligible, lo and hi.
inline void finish_choice(const RootDisc* discs, DiscVerdicts& v) {
    v.best = -1;
    v.count = 0;
    v.blockers = 0;
    for (std::uint64_t m = v.eligible; m != 0; m &= m - 1) {
        const int i = __builtin_ctzll(m);
        v.count += discs[i].count;
        if (v.best < 0 || v.hi[i] < v.hi[v.best]) v.best = i;
    }
    if (v.best < 0) return;
    for (std::uint64_t m = v.live & ~(std::uint64_t{1} << v.best); m != 0; m &= m - 1) {
        const int j = __builtin_ctzll(m);
        if (!(v.hi[v.best] < v.lo[j])) v.blockers |= std::uint64_t{1} << j;
    }
}

/// An object's constants for classify_discs_*: its band, its clipping
/// sphere (clip: clip_radius > 0) and clip_fast's first-test bounds (Yes:
/// below clip_yes = fl(radius (1 - 2u)); No: above clip_no = next_up(fl(radius
/// (1 + 2u))), as next_down(v) > c iff v > next_up(c) for doubles).
struct ClassifyPlan {
    BandPlan band;
    double clip_radius = 0.0, clip_yes = 0.0, clip_no = 0.0;
    bool clip = false;
};
ClassifyPlan classify_plan(const FramePlan& plan, bool complex_space, double clip_radius);

/// What classify_discs_avx2 proved about one sample's discs that no band
/// changes: per group of four discs, the moduli's bounds (modulus_fast) and
/// the sphere's first test (clip_fast), with the lanes where those held
/// (mod_ok) as bits. The bands of a tile share their primary discs
/// (render_tile_bands): the first band that needs a group's moduli computes
/// them, the others read them back, the same bits. A memo belongs to one
/// set of discs, one ray and one ClassifyPlan's sphere (which the bands
/// share): whoever changes any of them clears `groups`.
struct ClassifyMemo {
    static constexpr int kDiscs = 12;  // (kBatchKernelMaxDegree: a batch's discs at most)
    /// In `groups`: twin_* hold a verdict of the twins test.
    static constexpr std::uint8_t kTwinsHeld = 0x80;
    std::uint8_t groups = 0;           // bit k: group k (discs 4k..4k+3) is held; kTwinsHeld
    std::uint8_t mod_ok[kDiscs / 4], c_in[kDiscs / 4], c_out[kDiscs / 4];
    double lo[kDiscs], hi[kDiscs];
    /// Whether every disc of twin_blockers holds exactly the conjugate of
    /// disc twin_best's root (Decider::blockers_are_twins: it reads the
    /// discs alone, and the bands of a sweep mostly ask it of the same pair).
    std::uint64_t twin_blockers = 0;
    std::int32_t twin_best = -1;
    bool twins = false;
    /// In `groups`: `band` holds the verdicts of four discs (n = 4) for the
    /// band verdicts `band_key` (each lane's band Yes, No and undecided, as
    /// three 4-bit masks). Past the band's own tests, classify_four reads
    /// only those masks and what this memo holds for every band, so a band
    /// of this sample with the same masks has the same verdicts, bit for
    /// bit: the bands of a sweep mostly share them (a root's argument moves
    /// in or out of a band at one band's edge, not at every band's).
    static constexpr std::uint8_t kBandHeld = 0x40;
    std::uint16_t band_key = 0;
    struct Band {
        std::uint64_t live, eligible, blockers;
        std::int32_t best, count;
        double lo[4], hi[4];
        /// Decider::decide_one_keyed's answer from these verdicts: -1 not
        /// made yet, 0 undecided, 1 a proven miss, 2 a proven hit.
        std::int8_t decision;
    } band;
};
static_assert(ClassifyMemo::kDiscs / 4 < 6 && ClassifyMemo::kTwinsHeld >> (ClassifyMemo::kDiscs / 4) != 0 &&
                  ClassifyMemo::kBandHeld >> (ClassifyMemo::kDiscs / 4) != 0 &&
                  (ClassifyMemo::kBandHeld & ClassifyMemo::kTwinsHeld) == 0,
              "ClassifyMemo: kTwinsHeld or kBandHeld is a group's bit");

/// The verdicts of discs[0..n) (n <= kMaxDegree), all verified and of a
/// complete polynomial: for each disc, exactly band_fast_verified, then
/// (band not No) modulus_fast and (clip_radius > 0) clip_fast, that is
/// exactly decide_full's band_membership (with proven_real), modulus_bounds
/// and inside_clip. Writes v.live, v.eligible, lo and hi of live discs, and
/// v's choice (finish_choice). `memo` (optional, n <= ClassifyMemo::kDiscs):
/// the sample's band-independent verdicts, read where held, kept where made
/// (the scalar form ignores it).
using ClassifyDiscs = void (*)(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray,
                               DiscVerdicts& v, ClassifyMemo* memo);
/// One disc at a time (the reference of the quick form below; a disc that
/// is its predecessor's exact mirror image takes its verdicts).
void classify_discs_scalar(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray, DiscVerdicts& v,
                           ClassifyMemo* memo = nullptr);
/// Four discs per AVX2 vector: every quick test of band_fast, modulus_fast
/// and clip_fast at once, with the same operations in the same order per
/// lane (so the same roundings), and the scalar reference for a disc any of
/// them leaves undecided (near an edge, a sphere, zero, a mirror test, outside
/// the safe range). Only where classify_discs_avx2_supported().
void classify_discs_avx2(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray, DiscVerdicts& v,
                         ClassifyMemo* memo = nullptr);
bool classify_discs_avx2_supported();
/// The band verdicts of four discs under the bands of plans[0..n) as
/// classify_discs_avx2 keys them in ClassifyMemo::band (the same tests, the
/// same bits): keys[k] for plans[k]. For a caller that asks whether a
/// band's verdicts are the memo's before classifying; the discs are read
/// once for every band. Only where classify_discs_avx2_supported().
void band_keys_four(const RootDisc* discs, const ClassifyPlan* const* plans, int n, std::uint16_t* keys);
/// The fastest supported form (`scalar`: the scalar one).
ClassifyDiscs classify_discs_best(bool scalar = false);

}  // namespace argand::detail
