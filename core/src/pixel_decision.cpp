// pixel_decision.cpp: band, clipping sphere, realness and ordering, all
// outward-rounded through arith.h/interval.h (the double-double refinement
// of a disc is root finding: refine_dd.cpp).
#include "pixel_decision.h"

#include <cmath>
#include <cstddef>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

#include "root_kernels.h"

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

void flag_real_by_mirror(RootDisc* discs, int n) {
    for (int i = 0; i < n; ++i) {
        RootDisc& d = discs[i];
        if (d.count == 1 && !d.real && std::fabs(d.im) <= d.radius && real_by_mirror(discs, n, i)) d.real = true;
    }
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
    const double sigma = plan.params.sigma;
    return band_verdict(d, real, !complex_space || (sigma == 0.0 && plan.params.delta == 0.0), sigma == 0.0, sigma > 0.0,
                        [&plan](bool upper, double x, double y, double r, double& lo, double& hi) {
                            edge_range(upper ? plan.upper_edge : plan.lower_edge, x, y, r, lo, hi);
                        });
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

/// One disc's verdicts into v (the reference of classify_discs_*).
inline void classify_disc(const RootDisc* discs, int n, int i, const ClassifyPlan& cp, const ObjectRay& ray,
                          const ClipSums& sums, DiscVerdicts& v) {
    const BandPlan& bp = cp.band;
    const double clip_radius = cp.clip_radius;
    const RootDisc& d = discs[i];
    const std::uint64_t bit = std::uint64_t{1} << i;
    v.live &= ~bit;
    v.eligible &= ~bit;
    if (d.count <= 0 || (d.re == 0.0 && d.im == 0.0 && d.radius == 0.0)) return;  // (the exact root 0: not live)
    const Verdict band = band_fast_verified(discs, n, i, bp);
    if (band == Verdict::No) return;
    double lo, hi;
    modulus_fast(d, lo, hi);
    const Verdict clip = clip_radius > 0.0 ? clip_fast(ray, sums, lo, hi, clip_radius) : Verdict::Yes;
    if (clip == Verdict::No) return;
    v.lo[i] = lo;
    v.hi[i] = hi;
    v.live |= bit;
    if (band == Verdict::Yes && clip == Verdict::Yes) v.eligible |= bit;
}

}  // namespace

void classify_discs_scalar(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray,
                           DiscVerdicts& v, ClassifyMemo*) {
    v.live = v.eligible = 0;
    const ClipSums sums = cp.clip ? clip_sums(ray) : ClipSums{};
    // A disc that is the previous one's exact mirror image (the closed-form
    // starts of degree <= 4 list conjugate pairs so) takes its verdicts:
    // band, moduli and sphere are functions of (re, |im|, radius, count,
    // real) and the ray alone but for realness by the mirror test, which
    // proves neither of the two real (each meets the other's mirror image:
    // distance 0), so the mirror's verdicts are the previous disc's, bit for
    // bit. (Not twice in a row: the previous disc's own.)
    bool have_prev = false;
    for (int i = 0; i < n; ++i) {
        if (have_prev && exact_mirrors(discs[i - 1], discs[i])) {
            const std::uint64_t prev = std::uint64_t{1} << (i - 1);
            if (v.live & prev) {
                v.live |= prev << 1;
                v.eligible |= (v.eligible & prev) << 1;
                v.lo[i] = v.lo[i - 1];
                v.hi[i] = v.hi[i - 1];
            }
            have_prev = false;
            continue;
        }
        classify_disc(discs, n, i, cp, ray, sums, v);
        have_prev = true;
    }
    finish_choice(discs, v);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define ARGAND_CLASSIFY_AVX2 1
#define ARGAND_AVX2 __attribute__((target("avx2")))

namespace {

ARGAND_AVX2 inline __m256d v_abs(__m256d x) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x); }
/// The double whose bits are x's + k (the successor / predecessor of a
/// positive finite x for k = +1 / -1).
ARGAND_AVX2 inline __m256d v_step(__m256d x, long long k) {
    return _mm256_castsi256_pd(_mm256_add_epi64(_mm256_castpd_si256(x), _mm256_set1_epi64x(k)));
}
ARGAND_AVX2 inline __m256d v_gt(__m256d a, __m256d b) { return _mm256_cmp_pd(a, b, _CMP_GT_OQ); }
ARGAND_AVX2 inline __m256d v_lt(__m256d a, __m256d b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
ARGAND_AVX2 inline __m256d v_and(__m256d a, __m256d b) { return _mm256_and_pd(a, b); }
ARGAND_AVX2 inline __m256d v_or(__m256d a, __m256d b) { return _mm256_or_pd(a, b); }
ARGAND_AVX2 inline __m256d v_andnot(__m256d a, __m256d b) { return _mm256_andnot_pd(a, b); }  // ~a & b

/// edge_range_fast's quick test for four discs (x, y = |im|, r; ax = |x|):
/// `in` where s < -t (hi = lo = s < 0), `out` where s > t (lo = hi = s >
/// 0), the same s and t, the same operations in the same order.
ARGAND_AVX2 inline void v_edge(const FastEdge& f, __m256d x, __m256d y, __m256d ax, __m256d r, __m256d& in,
                               __m256d& out) {
    constexpr double kU = kUnitRoundoff;
    const __m256d s = _mm256_sub_pd(_mm256_mul_pd(y, _mm256_set1_pd(f.e.cos_mid)),
                                    _mm256_mul_pd(x, _mm256_set1_pd(f.e.sin_mid)));
    const __m256d t = _mm256_add_pd(
        _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(ax, y), _mm256_set1_pd(f.k)), r),
                      _mm256_set1_pd(1.0 + 16.0 * kU)),
        _mm256_set1_pd(64.0 * kDenormMin));
    out = v_gt(s, t);
    in = v_gt(_mm256_xor_pd(s, _mm256_set1_pd(-0.0)), t);
}

/// The lanes of a 4-bit movemask as an all-ones / all-zeros mask (lane k:
/// bit k), so that v_lanes(_mm256_movemask_pd(x)) is x for any mask x.
ARGAND_AVX2 __attribute__((always_inline)) inline __m256d v_lanes(unsigned bits) {
    const __m256i lane_bit = _mm256_set_epi64x(8, 4, 2, 1);
    const __m256i b = _mm256_and_si256(_mm256_set1_epi64x(static_cast<long long>(bits)), lane_bit);
    return _mm256_castsi256_pd(_mm256_cmpeq_epi64(b, lane_bit));
}

/// clip_sums(ray) as [omid, orad, dabs, drad]: per axis a the lanes [|o'_a.mid|,
/// o'_a.rad, |d'_a.mid| + d'_a.rad, d'_a.rad], summed lane by lane as ((a = 0)
/// + (a = 1)) + (a = 2): clip_sums' operations in its order.
ARGAND_AVX2 __attribute__((always_inline)) inline __m256d v_clip_sums(const ObjectRay& ray) {
    // (Loaded double by double: the tracer has just written the ray's balls
    // (PrimaryBatch::fill) with 8-byte stores, and a 32-byte load spanning
    // several of them cannot be forwarded from the store buffer; it waited
    // for the stores to retire, some 5% of a Bicube frame.)
    const Ball *o = ray.origin, *d = ray.direction;
    const __m256d x0 = _mm256_set_pd(d[0].rad, std::fabs(d[0].mid), o[0].rad, std::fabs(o[0].mid));
    const __m256d x1 = _mm256_set_pd(d[1].rad, std::fabs(d[1].mid), o[1].rad, std::fabs(o[1].mid));
    const __m256d x2 = _mm256_set_pd(d[2].rad, std::fabs(d[2].mid), o[2].rad, std::fabs(o[2].mid));
    // Per axis [|om|, or, |dm|, dr], then lane 2: |dm| + dr (the others as
    // they are).
    const __m256d y0 = _mm256_blend_pd(x0, _mm256_add_pd(x0, _mm256_permute_pd(x0, 0xF)), 0x4);
    const __m256d y1 = _mm256_blend_pd(x1, _mm256_add_pd(x1, _mm256_permute_pd(x1, 0xF)), 0x4);
    const __m256d y2 = _mm256_blend_pd(x2, _mm256_add_pd(x2, _mm256_permute_pd(x2, 0xF)), 0x4);
    return _mm256_add_pd(_mm256_add_pd(y0, y1), y2);
}

}  // namespace

bool classify_discs_avx2_supported() { return __builtin_cpu_supports("avx2"); }

// Each lane follows the scalar code's branches as masks; a lane is sent to
// classify_disc (the reference) wherever the scalar code would leave its
// quick tests: misses_zero's sufficient test failing (band_fast then needs
// modulus_down), the mirror test (count 1, not flagged real, |im| <= r),
// either band edge's quick test undecided with no edge proving it out,
// moduli outside [2^-500, 2^500] or a non-finite upper bound, the sphere's
// first test undecided. Identities used (doubles v, c, eta = 2^-1074):
// next_down(v) > 0 iff v > eta; next_up(v) < 0 iff v < -eta; next_down(v) >
// c iff v > next_up(c) (next_down(v) is the largest double below v; NaN
// fails each side); 0 + p^2 = p^2 (p^2 is never -0).
namespace {

/// What band_of reads of four discs besides the band (group_discs):
/// their centres' re and |im|, radii, and the band-independent masks.
struct GroupDiscs {
    __m256d re, im, r, are, aim, valid, real, single_unflagged, positive, misses_zero, mirror;
};

ARGAND_AVX2 __attribute__((always_inline)) inline void group_discs(const RootDisc* p0, const RootDisc* p1,
                                                                  const RootDisc* p2, const RootDisc* p3,
                                                                  GroupDiscs& g) {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    // Four discs, transposed.
    const __m256d D0 = _mm256_loadu_pd(&p0->re), D1 = _mm256_loadu_pd(&p1->re), D2 = _mm256_loadu_pd(&p2->re),
                  D3 = _mm256_loadu_pd(&p3->re);
    const __m256d t0 = _mm256_unpacklo_pd(D0, D1), t1 = _mm256_unpackhi_pd(D0, D1);
    const __m256d t2 = _mm256_unpacklo_pd(D2, D3), t3 = _mm256_unpackhi_pd(D2, D3);
    g.re = _mm256_permute2f128_pd(t0, t2, 0x20);
    g.r = _mm256_permute2f128_pd(t0, t2, 0x31);
    g.im = _mm256_permute2f128_pd(t1, t3, 0x20);
    const __m256i fl = _mm256_castpd_si256(_mm256_permute2f128_pd(t1, t3, 0x31));
    // count (the low 32 bits) > 0; count 1 and real (byte 5) set; count 1
    // and real clear (bytes 4, verified, and 6-7, padding, masked).
    const __m256d counted =
        _mm256_castsi256_pd(_mm256_shuffle_epi32(_mm256_cmpgt_epi32(fl, _mm256_setzero_si256()), 0xA0));
    const __m256i count_real = _mm256_and_si256(fl, _mm256_set1_epi64x(0x0000FF00FFFFFFFFLL));
    g.real = _mm256_castsi256_pd(_mm256_cmpeq_epi64(count_real, _mm256_set1_epi64x(0x0000010000000001LL)));
    g.single_unflagged = _mm256_castsi256_pd(_mm256_cmpeq_epi64(count_real, _mm256_set1_epi64x(1)));
    g.are = _mm256_andnot_pd(sign, g.re);
    g.aim = _mm256_andnot_pd(sign, g.im);
    // The exact root 0: re, im and radius all +-0 (their bits or'ed, the
    // signs of re and im cleared, is +-0 exactly then).
    const __m256d at_origin = _mm256_cmp_pd(v_or(v_or(g.are, g.aim), g.r), zero, _CMP_EQ_OQ);
    g.valid = v_andnot(at_origin, counted);
    // band_fast_verified: count 1 and flagged real: band_fast(real); count
    // 1, not flagged, |im| <= r: the mirror test (the reference); otherwise
    // band_fast(not real).
    g.mirror = v_and(g.single_unflagged, _mm256_cmp_pd(g.aim, g.r, _CMP_LE_OQ));
    g.misses_zero = v_or(v_gt(g.are, g.r), v_gt(g.aim, g.r));  // (else: modulus_down, the reference)
    g.positive = v_gt(g.re, zero);
}

/// The band part of classify_group: each lane's band verdicts (yes, no,
/// band_fb: the reference's band test needed) from group_discs; nothing
/// else of classify_group reads the band.
ARGAND_AVX2 __attribute__((always_inline)) inline void band_of(const GroupDiscs& g, const BandPlan& bp, __m256d& yes,
                                                               __m256d& no, __m256d& band_fb) {
    const __m256d zero = _mm256_setzero_pd(), all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256d re = g.re, r = g.r, are = g.are, aim = g.aim, real = g.real, misses_zero = g.misses_zero,
                  positive = g.positive;
    band_fb = g.mirror;
    if (bp.axis) {
        const __m256d real_decided = v_and(real, misses_zero);
        band_fb = v_or(band_fb, v_andnot(misses_zero, real));
        yes = v_and(real_decided, positive);
        // add_down(|im|, -r) > 0 || add_up(re, r) < 0.
        const __m256d off_axis = v_or(v_gt(_mm256_add_pd(aim, _mm256_xor_pd(r, sign)), _mm256_set1_pd(kDenormMin)),
                                      v_lt(_mm256_add_pd(re, r), _mm256_set1_pd(-kDenormMin)));
        no = v_or(v_andnot(positive, real_decided), v_andnot(real, off_axis));
    } else {
        band_fb = v_or(band_fb, v_andnot(misses_zero, all));
        yes = bp.sigma_zero ? v_and(real, positive) : zero;
        no = v_andnot(yes, real);
        __m256d in, out;
        v_edge(bp.upper_edge, re, aim, are, r, in, out);
        if (bp.lower) {
            __m256d below, above;
            v_edge(bp.lower_edge, re, aim, are, r, below, above);
            in = v_and(in, above);
            out = v_or(out, below);
        }
        yes = v_or(yes, v_andnot(real, in));
        no = v_or(no, v_andnot(real, out));
        band_fb = v_or(band_fb, v_andnot(real, v_andnot(v_or(in, out), all)));
    }
}

/// A group's band verdicts as a key of ClassifyMemo::band.
ARGAND_AVX2 __attribute__((always_inline)) inline std::uint16_t band_key_of(__m256d yes, __m256d no, __m256d band_fb) {
    return static_cast<std::uint16_t>(_mm256_movemask_pd(yes) | _mm256_movemask_pd(no) << 4 |
                                      _mm256_movemask_pd(band_fb) << 8);
}

/// One group of four discs (p[0..3], discs g..g+3; kNone past the end).
/// `band_key` (classify_four's): the lanes' band verdicts as a key of
/// ClassifyMemo::band; true, with nothing written, where `memo` holds the
/// verdicts of that key already.
ARGAND_AVX2 __attribute__((always_inline)) inline bool classify_group(const RootDisc* p0, const RootDisc* p1,
                                                                     const RootDisc* p2, const RootDisc* p3, int g,
                                                                     const ClassifyPlan& cp, const ObjectRay& ray,
                                                                     DiscVerdicts& v, ClassifyMemo* memo,
                                                                     std::uint64_t& fallback, __m256d& lo_out,
                                                                     __m256d& hi_out, __m256d& live_out,
                                                                     __m256d& eligible_out, int& ones_out,
                                                                     std::uint16_t* band_key = nullptr) {
    constexpr double kU = kUnitRoundoff;
    const __m256d zero = _mm256_setzero_pd(), all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    GroupDiscs gd;
    group_discs(p0, p1, p2, p3, gd);
    __m256d yes, no, band_fb;
    band_of(gd, cp.band, yes, no, band_fb);
    const __m256d re = gd.re, im = gd.im, r = gd.r, valid = gd.valid, real = gd.real,
                  single_unflagged = gd.single_unflagged;
    // Below, the band enters only through yes, no and band_fb.
    if (band_key != nullptr) {
        *band_key = band_key_of(yes, no, band_fb);
        if (memo && (memo->groups & ClassifyMemo::kBandHeld) && memo->band_key == *band_key) return true;
    }
    // A lane not proven out of the band needs its moduli and sphere.
    const __m256d needs = v_and(valid, v_andnot(v_or(no, band_fb), all));
    if (_mm256_movemask_pd(needs) == 0) {
        fallback |= static_cast<std::uint64_t>(_mm256_movemask_pd(v_and(valid, band_fb))) << g;
        lo_out = hi_out = live_out = eligible_out = zero;
        ones_out = 0;
        return false;
    }
    // The moduli and the sphere's first test read only the discs, the ray
    // and the sphere (no band): held in the memo where another band of
    // this sample made them already (the same bits), kept there otherwise.
    __m256d lo, hi, mod_ok, c_in, c_out;
    const int group = g / 4;
    if (memo && (memo->groups >> group & 1)) {
        lo = _mm256_loadu_pd(memo->lo + g);
        hi = _mm256_loadu_pd(memo->hi + g);
        mod_ok = v_lanes(memo->mod_ok[group]);
        c_in = v_lanes(memo->c_in[group]);
        c_out = v_lanes(memo->c_out[group]);
    } else {
        // modulus_fast.
        const __m256d m = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(re, re), _mm256_mul_pd(im, im)));
        const __m256d a = _mm256_sub_pd(v_step(_mm256_mul_pd(m, _mm256_set1_pd(1.0 - 4.0 * kU)), -1), r);
        lo = _mm256_blendv_pd(zero, v_step(a, -1), v_gt(a, zero));
        const __m256d b = _mm256_add_pd(v_step(_mm256_mul_pd(m, _mm256_set1_pd(1.0 + 4.0 * kU)), 1), r);
        hi = v_step(b, 1);
        mod_ok = v_and(v_and(_mm256_cmp_pd(m, _mm256_set1_pd(0x1p-500), _CMP_GE_OQ),
                             _mm256_cmp_pd(m, _mm256_set1_pd(0x1p500), _CMP_LE_OQ)),
                       v_and(v_gt(b, zero), v_lt(b, _mm256_set1_pd(INFINITY))));
        // clip_fast's first test.
        c_in = all;
        c_out = zero;
        if (cp.clip) {
            const __m256d sums = v_clip_sums(ray);
            const __m256d mid = _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(lo, hi));
            const __m256d w = _mm256_mul_pd(_mm256_max_pd(_mm256_sub_pd(hi, mid), _mm256_sub_pd(mid, lo)),
                                            _mm256_set1_pd(1.0 + 4.0 * kU));
            const __m256d q0 = _mm256_add_pd(_mm256_set1_pd(ray.origin[0].mid), _mm256_mul_pd(mid, _mm256_set1_pd(ray.direction[0].mid)));
            const __m256d q1 = _mm256_add_pd(_mm256_set1_pd(ray.origin[1].mid), _mm256_mul_pd(mid, _mm256_set1_pd(ray.direction[1].mid)));
            const __m256d q2 = _mm256_add_pd(_mm256_set1_pd(ray.origin[2].mid), _mm256_mul_pd(mid, _mm256_set1_pd(ray.direction[2].mid)));
            const __m256d q = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(q0, q0), _mm256_mul_pd(q1, q1)), _mm256_mul_pd(q2, q2));
            // (sums: [omid, orad, dabs, drad].)
            const __m256d dabs = _mm256_permute4x64_pd(sums, 0xAA);
            const __m256d spread = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(w, dabs), _mm256_permute4x64_pd(sums, 0x55)),
                                                 _mm256_mul_pd(hi, _mm256_permute4x64_pd(sums, 0xFF)));
            const __m256d size = _mm256_mul_pd(_mm256_set1_pd(8.0 * kU),
                                               _mm256_add_pd(_mm256_permute4x64_pd(sums, 0x00), _mm256_mul_pd(hi, dabs)));
            const __m256d e1 = _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(spread, size), _mm256_set1_pd(1.0 + 64.0 * kU)),
                                             _mm256_set1_pd(256.0 * kDenormMin));
            const __m256d norm = _mm256_sqrt_pd(q);
            c_in = v_lt(_mm256_add_pd(_mm256_mul_pd(norm, _mm256_set1_pd(1.0 + 4.0 * kU)), e1), _mm256_set1_pd(cp.clip_yes));
            c_out = v_gt(_mm256_sub_pd(_mm256_mul_pd(norm, _mm256_set1_pd(1.0 - 4.0 * kU)), e1), _mm256_set1_pd(cp.clip_no));
        }
        if (memo) {
            _mm256_storeu_pd(memo->lo + g, lo);
            _mm256_storeu_pd(memo->hi + g, hi);
            memo->mod_ok[group] = static_cast<std::uint8_t>(_mm256_movemask_pd(mod_ok));
            memo->c_in[group] = static_cast<std::uint8_t>(_mm256_movemask_pd(c_in));
            memo->c_out[group] = static_cast<std::uint8_t>(_mm256_movemask_pd(c_out));
            memo->groups |= static_cast<std::uint8_t>(1u << group);
        }
    }
    const __m256d fb = v_or(v_and(valid, band_fb), v_andnot(v_and(mod_ok, v_or(c_in, c_out)), needs));
    const __m256d live = v_andnot(v_or(fb, c_out), needs);
    const __m256d eligible = v_and(live, v_and(yes, c_in));
    ones_out = _mm256_movemask_pd(v_or(real, single_unflagged));  // (count 1)
    lo_out = lo;
    hi_out = hi;
    live_out = live;
    eligible_out = eligible;
    _mm256_storeu_pd(v.lo + g, lo);
    _mm256_storeu_pd(v.hi + g, hi);
    v.live |= static_cast<std::uint64_t>(_mm256_movemask_pd(live)) << g;
    v.eligible |= static_cast<std::uint64_t>(_mm256_movemask_pd(eligible)) << g;
    fallback |= static_cast<std::uint64_t>(_mm256_movemask_pd(fb)) << g;
    return false;
}

}  // namespace

namespace {

/// The discs that classify_group left undecided, by the reference.
__attribute__((noinline)) void classify_fallback(const RootDisc* discs, int n, const ClassifyPlan& cp,
                                                 const ObjectRay& ray, DiscVerdicts& v, std::uint64_t fallback) {
    const ClipSums sums = cp.clip ? clip_sums(ray) : ClipSums{};
    for (; fallback != 0; fallback &= fallback - 1)
        classify_disc(discs, n, __builtin_ctzll(fallback), cp, ray, sums, v);
}

/// classify_four's verdicts `v` (lanes lo, hi) of band verdicts `key`, kept
/// in `memo` for the sample's other bands.
ARGAND_AVX2 inline void keep_band(ClassifyMemo* memo, std::uint16_t key, const DiscVerdicts& v, __m256d lo,
                                  __m256d hi) {
    if (memo == nullptr) return;
    ClassifyMemo::Band& b = memo->band;
    b.live = v.live;
    b.eligible = v.eligible;
    b.blockers = v.blockers;
    b.best = v.best;
    b.count = v.count;
    _mm256_storeu_pd(b.lo, lo);
    _mm256_storeu_pd(b.hi, hi);
    b.decision = -1;
    memo->band_key = key;
    memo->groups |= ClassifyMemo::kBandHeld;
}

/// Four discs (the common case: every degree-4 polynomial), straight.
ARGAND_AVX2 __attribute__((noinline)) void classify_four(const RootDisc* discs, const ClassifyPlan& cp,
                                                         const ObjectRay& ray, DiscVerdicts& v, ClassifyMemo* memo) {
    v.live = v.eligible = 0;
    std::uint64_t fallback = 0;
    __m256d lo, hi, live, eligible;
    int ones;
    std::uint16_t key;
    if (classify_group(discs, discs + 1, discs + 2, discs + 3, 0, cp, ray, v, memo, fallback, lo, hi, live, eligible,
                       ones, &key)) {
        // Another band of this sample had these band verdicts: its verdicts.
        const ClassifyMemo::Band& b = memo->band;
        v.live = b.live;
        v.eligible = b.eligible;
        v.blockers = b.blockers;
        v.best = b.best;
        v.count = b.count;
        _mm256_storeu_pd(v.lo, _mm256_loadu_pd(b.lo));
        _mm256_storeu_pd(v.hi, _mm256_loadu_pd(b.hi));
        return;
    }
    if (fallback != 0) {  // (the reference's verdicts read the band itself: not kept)
        if (memo) memo->groups &= static_cast<std::uint8_t>(~ClassifyMemo::kBandHeld);  // (held: this band's)
        classify_fallback(discs, 4, cp, ray, v, fallback);
        finish_choice(discs, v);
        return;
    }
    // finish_choice in the lanes: the least hi of the eligible discs (inf
    // elsewhere; an eligible inf ties with it, and the first eligible lane
    // holding the least is chosen either way), then the live discs whose lo
    // is not above it.
    v.best = -1;
    v.count = 0;
    v.blockers = 0;
    std::uint64_t m = v.eligible;
    if (m == 0) {
        keep_band(memo, key, v, lo, hi);
        return;
    }
    __m256d least = _mm256_blendv_pd(_mm256_set1_pd(INFINITY), hi, eligible);
    least = _mm256_min_pd(least, _mm256_permute2f128_pd(least, least, 1));
    least = _mm256_min_pd(least, _mm256_permute_pd(least, 0x5));
    const int best = __builtin_ctz(static_cast<unsigned>(_mm256_movemask_pd(v_and(_mm256_cmp_pd(hi, least, _CMP_EQ_OQ), eligible))));
    v.best = best;
    v.blockers = static_cast<std::uint64_t>(_mm256_movemask_pd(v_andnot(v_lt(least, lo), live))) &
                 ~(std::uint64_t{1} << best);
    if ((m & ~static_cast<std::uint64_t>(ones)) == 0) {
        v.count = __builtin_popcountll(m);  // (every eligible disc holds one root)
    } else {
        int count = 0;
        for (; m != 0; m &= m - 1) count += discs[__builtin_ctzll(m)].count;
        v.count = count;
    }
    keep_band(memo, key, v, lo, hi);
}

}  // namespace

namespace {

/// Any number of discs, four at a time (kNone past the end: count 0, not
/// live).
ARGAND_AVX2 __attribute__((noinline)) void classify_any(const RootDisc* discs, int n, const ClassifyPlan& cp,
                                                        const ObjectRay& ray, DiscVerdicts& v, ClassifyMemo* memo) {
    // (The padding disc's lanes are masked out by its count 0, whatever its
    // centre; centred at 1, their moduli and bounds stay normal numbers. At
    // 0, the outward steps of the moduli made subnormals, and each
    // arithmetic operation on one took a microcode assist: a quarter of a
    // sextic frame's time.)
    static const RootDisc kNone{1.0, 0.0, 0.0, 0, false, false};
    v.live = v.eligible = 0;
    std::uint64_t fallback = 0;
    for (int g = 0; g < n; g += 4) {
        const RootDisc* p1 = g + 1 < n ? discs + g + 1 : &kNone;
        const RootDisc* p2 = g + 2 < n ? discs + g + 2 : &kNone;
        const RootDisc* p3 = g + 3 < n ? discs + g + 3 : &kNone;
        __m256d lo, hi, live, eligible;
        int ones;
        classify_group(discs + g, p1, p2, p3, g, cp, ray, v, memo, fallback, lo, hi, live, eligible, ones);
    }
    if (fallback != 0) classify_fallback(discs, n, cp, ray, v, fallback);
    finish_choice(discs, v);
}

}  // namespace

ARGAND_AVX2 void band_keys_four(const RootDisc* discs, const ClassifyPlan* const* plans, int n, std::uint16_t* keys) {
    GroupDiscs g;
    group_discs(discs, discs + 1, discs + 2, discs + 3, g);
    for (int k = 0; k < n; ++k) {
        __m256d yes, no, band_fb;
        band_of(g, plans[k]->band, yes, no, band_fb);
        keys[k] = band_key_of(yes, no, band_fb);
    }
}

void classify_discs_avx2(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray, DiscVerdicts& v,
                         ClassifyMemo* memo) {
    static_assert(sizeof(RootDisc) == 32 && offsetof(RootDisc, re) == 0 && offsetof(RootDisc, im) == 8 &&
                      offsetof(RootDisc, radius) == 16 && offsetof(RootDisc, count) == 24 &&
                      offsetof(RootDisc, real) == 29,
                  "classify_discs_avx2 loads a disc as four doubles");
    if (n > ClassifyMemo::kDiscs) memo = nullptr;
    if (n == 4) classify_four(discs, cp, ray, v, memo);
    else classify_any(discs, n, cp, ray, v, memo);
}

#else
bool classify_discs_avx2_supported() { return false; }
void band_keys_four(const RootDisc*, const ClassifyPlan* const*, int n, std::uint16_t* keys) {
    for (int k = 0; k < n; ++k) keys[k] = 0;
}
void classify_discs_avx2(const RootDisc* discs, int n, const ClassifyPlan& cp, const ObjectRay& ray, DiscVerdicts& v,
                         ClassifyMemo*) {
    classify_discs_scalar(discs, n, cp, ray, v);
}
#endif

ClassifyPlan classify_plan(const FramePlan& plan, bool complex_space, double clip_radius) {
    ClassifyPlan cp;
    cp.band = band_plan(plan, complex_space);
    cp.clip_radius = clip_radius;
    cp.clip = clip_radius > 0.0;
    cp.clip_yes = clip_radius * (1.0 - 2.0 * kU);
    cp.clip_no = next_up(clip_radius * (1.0 + 2.0 * kU));
    return cp;
}

ClassifyDiscs classify_discs_best(bool scalar) {
    return !scalar && classify_discs_avx2_supported() ? classify_discs_avx2 : classify_discs_scalar;
}

}  // namespace argand::detail
