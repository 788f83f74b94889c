// roots_batch_kernel.h: the lane-parallel root kernel (internal; included
// once per instruction set by roots_batch_generic.cpp, roots_batch_avx2.cpp
// and roots_batch_avx512.cpp, each inside its own namespace
// ARGAND_BATCH_NS so that no inline function compiled for one instruction
// set can be picked by the linker for another).
//
// A block holds kBatchLanes polynomials of one degree n <= kBatchMaxDegree in
// structure-of-arrays form (coefficient k of lane l at c[k][l]), already
// scaled by exact powers of two (roots of modulus ~1, largest coefficient in
// [1, 2)). Every step is a loop over the lanes with the same operations in
// every lane, written without branches (both sides computed, then a select),
// so that the compiler turns it into vector code (checked with objdump, see
// docs/roots.md). Rounding: the build pins -ffp-contract=off and no fast
// math for these files, and the driver refuses to run them under
// flush-to-zero / denormals-are-zero or a directed rounding mode, so every
// lane performs exactly the IEEE-754 binary64 operations written here, in
// this order: the same operations, in the same order, as the scalar
// smith_radii_lanes_reference (root_kernels.h), whose rounding argument therefore holds lane
// by lane (the C++ test compares the two bit for bit).
//
// What a lane proves: ok[l] = 1 iff Smith's discs D(x_i, r_i) (Smith 1970,
// Theorem 5, bound from smith_radii_lanes_reference) are pairwise proven disjoint, so
// each holds exactly one root. Every other lane claims nothing here and goes
// to the scalar path (find_roots) with its escalation ladder.
#ifndef ARGAND_BATCH_NS
#error "define ARGAND_BATCH_NS before including roots_batch_kernel.h"
#endif

#include <cmath>
#include <cstdint>
#include <cstring>

#include "roots_batch_block.h"
#include "simd_width.h"

// Masks are combined with & and | on bools on purpose: both sides are
// always evaluated, which keeps the lane loops free of branches.
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wunknown-warning-option"
#pragma clang diagnostic ignored "-Wbitwise-instead-of-logical"
#endif

// A loop over the lanes: its iterations are independent (no aliasing).
#if defined(__clang__)
#define ARGAND_LANES _Pragma("clang loop vectorize(enable)")
#else
#define ARGAND_LANES _Pragma("GCC ivdep")
#endif

namespace argand::ARGAND_BATCH_NS {
namespace {

constexpr int L = kBatchLanes;
constexpr double kU = 0x1p-53;             // unit roundoff (kUnitRoundoff)
constexpr double kMulRel = 2.25 * kU;      // ErrorModel<double>::mul_rel
constexpr double kAddRel = 1.0000001 * kU; // ErrorModel<double>::add_rel
constexpr double kAbsErr = 8.0 * 0x1p-1074;// ErrorModel<double>::abs_err
constexpr double kHuge = 1.7976931348623157e308;

inline std::uint64_t bits_of(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
}
inline double from_bits(std::uint64_t b) {
    double v;
    std::memcpy(&v, &b, sizeof v);
    return v;
}
/// next_up for v >= 0 (also 0 -> smallest subnormal); +inf and NaN stay.
inline double up(double v) { return v < __builtin_inf() ? from_bits(bits_of(v) + 1) : v; }
inline bool finite(double v) { return std::fabs(v) <= kHuge; }

/// Cube root for the starting points only (a few ulps): exponent split by
/// bits, a cubic on [1, 8), two Halley steps. 0 gives 0; subnormal or huge
/// arguments give garbage (finite or not); the caller replaces non-finite
/// starts.
inline double cbrt_approx(double a) {
    const double x = std::fabs(a);
    const double biased = from_bits((bits_of(x) >> 52) | 0x4330000000000000ULL) - 0x1p52;  // exponent field
    const double t = (biased - 1023.0 + 1200.0) * (1.0 / 3.0);
    double k = (t + 0x1p52) - 0x1p52;
    k = k > t ? k - 1.0 : k;  // floor(t)
    const double j = (biased - 1023.0 + 1200.0) - 3.0 * k;  // 0, 1 or 2
    const double mant = from_bits((bits_of(x) & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL);
    const double m = mant * (j == 0.0 ? 1.0 : (j == 1.0 ? 2.0 : 4.0));  // in [1, 8)
    double u = 0.7214687145987767 + m * (0.32889523423265293 + m * (-0.03472546820473445 + m * 0.0017137144084611797));
    for (int s = 0; s < 2; ++s) {
        const double u3 = u * u * u;
        u = u * (u3 + 2.0 * m) / (2.0 * u3 + m);
    }
    const double scale = from_bits((bits_of((k - 400.0 + 1023.0) + 0x1p52) - bits_of(0x1p52)) << 52);
    const double r = u * scale;
    return x == 0.0 ? 0.0 : (a < 0.0 ? -r : r);
}

/// 2^m for an integer-valued double m, built from bits; valid (and then
/// exact) for m in [-1022, 1023], which the caller checks.
inline double pow2_of(double m) {
    return from_bits((bits_of((m + 1023.0) + 0x1p52) - bits_of(0x1p52)) << 52);
}
inline bool exponent_ok(double m) { return (m >= -1022.0) & (m <= 1023.0); }

/// cos(acos(t) / 3) for t in [-1, 1], as h(sqrt((1 + t) / 2)) with
/// h(s) = cos(2/3 acos s) analytic on [0, 1]: a degree-8 fit, |error| < 4e-9.
inline double cos_third_acos(double t) {
    const double s = std::sqrt(0.5 * (1.0 + t));
    return 0.5000000032511468 +
           s * (0.5773497201111664 +
                s * (-0.11109568692096883 +
                     s * (0.05328867622501659 +
                          s * (-0.03196135433598694 +
                               s * (0.019675813400088206 +
                                    s * (-0.010325578211612447 +
                                         s * (0.0037077251982862163 + s * -0.0006393211418758642)))))));
}

/// A real root of the depressed cubic y^3 + p y + q in every lane (the
/// largest when all three are real), as closed_form_guesses finds it
/// (approximation): Cardano where the discriminant is >= 0, the
/// trigonometric form elsewhere. Each form is computed only if some lane
/// needs it (both cost divisions and square roots).
inline void depressed_cubic_roots(const double* p, const double* q, double* y) {
    constexpr double third = 1.0 / 3.0, twenty_seventh = 1.0 / 27.0;
    double disc[L];
    int n_one = 0;
    for (int l = 0; l < L; ++l) {
        disc[l] = 0.25 * q[l] * q[l] + twenty_seventh * p[l] * p[l] * p[l];
        n_one += disc[l] >= 0.0;
    }
    if (n_one > 0) {
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double sq = std::sqrt(disc[l] > 0.0 ? disc[l] : 0.0);
            const double u = cbrt_approx(q[l] >= 0.0 ? -0.5 * q[l] - sq : -0.5 * q[l] + sq);
            const double p3u = p[l] * third / u;
            y[l] = u != 0.0 ? u - p3u : 0.0;
        }
    }
    if (n_one < L) {
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double mp = -p[l] * third;
            const double m = 2.0 * std::sqrt(mp > 0.0 ? mp : 0.0);
            const double ratio = 3.0 * q[l] / (p[l] * m);
            const double tc = ratio >= 1.0 ? 1.0 : (ratio >= -1.0 ? ratio : (ratio < -1.0 ? -1.0 : 1.0));
            const double y_three = m * cos_third_acos(tc);
            y[l] = disc[l] >= 0.0 ? y[l] : y_three;
        }
    }
}

/// Roots of t^2 + b t + c (real_quadratic_roots, without branches).
inline void quadratic(double b, double c, double& r0, double& i0, double& r1, double& i1) {
    const double disc = b * b - 4.0 * c;
    const double sq = std::sqrt(std::fabs(disc));
    const double q = -0.5 * (b + std::copysign(sq, b));
    const bool real = disc >= 0.0;
    const double other = c / q;
    r0 = real ? q : -0.5 * b;
    i0 = real ? 0.0 : 0.5 * sq;
    r1 = real ? (q != 0.0 ? other : 0.0) : -0.5 * b;
    i1 = real ? 0.0 : -0.5 * sq;
}

/// Principal square root of re + i im (complex_sqrt, without branches).
inline void csqrt(double re, double im, double& sr, double& si) {
    const double m = std::sqrt(re * re + im * im);
    const double a = std::sqrt(0.5 * (m + std::fabs(re)));
    const double other = im / (2.0 * a);
    const bool zero = a == 0.0;
    sr = zero ? 0.0 : (re >= 0.0 ? a : std::fabs(other));
    si = zero ? 0.0 : (re >= 0.0 ? other : (im >= 0.0 ? a : -a));
}

/// Closed-form starting points for degree N <= 4, lane by lane (the
/// formulas of closed_form_guesses with the transcendental functions
/// replaced by the approximations above), in phases so that a branch no
/// lane takes is skipped. Non-finite starts are replaced by the circle
/// starts.
template <int N>
void closed_form_starts(BatchBlock& b) {
    constexpr double third = 1.0 / 3.0, twenty_seventh = 1.0 / 27.0;
    if constexpr (N == 1) {
        for (int l = 0; l < L; ++l) {
            b.xr[0][l] = -b.c[0][l] / b.c[1][l];
            b.xi[0][l] = 0.0;
        }
    } else if constexpr (N == 2) {
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double inv = 1.0 / b.c[2][l];
            quadratic(b.c[1][l] * inv, b.c[0][l] * inv, b.xr[0][l], b.xi[0][l], b.xr[1][l], b.xi[1][l]);
        }
    } else if constexpr (N == 3) {
        double p[L], q[L], shift[L], y0[L];
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double inv_lead = 1.0 / b.c[3][l];
            const double a3 = b.c[2][l] * inv_lead, a2 = b.c[1][l] * inv_lead, a1 = b.c[0][l] * inv_lead;
            shift[l] = a3 * third;
            p[l] = a2 - a3 * shift[l];
            q[l] = 2.0 * twenty_seventh * a3 * a3 * a3 - a3 * a2 * third + a1;
        }
        depressed_cubic_roots(p, q, y0);
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            double r1, i1, r2, i2;
            quadratic(y0[l], p[l] + y0[l] * y0[l], r1, i1, r2, i2);
            b.xr[0][l] = y0[l] - shift[l];
            b.xi[0][l] = 0.0;
            b.xr[1][l] = r1 - shift[l];
            b.xi[1][l] = i1;
            b.xr[2][l] = r2 - shift[l];
            b.xi[2][l] = i2;
        }
    } else {
        double p[L], q[L], r[L], shift[L], P[L], Q[L], zs[L], y0[L];
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double inv_lead = 1.0 / b.c[4][l];
            const double a3 = b.c[3][l] * inv_lead, a2 = b.c[2][l] * inv_lead, a1 = b.c[1][l] * inv_lead;
            const double a0 = b.c[0][l] * inv_lead;
            const double sh = 0.25 * a3;
            const double s2 = sh * sh;
            shift[l] = sh;
            p[l] = a2 - 6.0 * s2;
            q[l] = a1 - 2.0 * a2 * sh + 8.0 * s2 * sh;
            r[l] = a0 - a1 * sh + a2 * s2 - 3.0 * s2 * s2;
            // Resolvent z^3 + 2p z^2 + (p^2 - 4r) z - q^2 (depressed by z = y - A/3).
            const double A = 2.0 * p[l], B = p[l] * p[l] - 4.0 * r[l], C = -q[l] * q[l];
            zs[l] = A * third;
            P[l] = B - A * zs[l];
            Q[l] = 2.0 * twenty_seventh * A * A * A - A * B * third + C;
        }
        depressed_cubic_roots(P, Q, y0);
        double split[L];
        int n_split = 0;
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            // The resolvent's largest real root z.
            double q0r, q0i, q1r, q1i;
            quadratic(y0[l], P[l] + y0[l] * y0[l], q0r, q0i, q1r, q1i);
            double z = y0[l] - zs[l];
            const double z1 = q0r - zs[l], z2 = q1r - zs[l];
            z = ((std::fabs(q0i) <= 1e-8 * (1.0 + std::fabs(z1))) & (z1 > z)) ? z1 : z;
            z = ((std::fabs(q1i) <= 1e-8 * (1.0 + std::fabs(z2))) & (z2 > z)) ? z2 : z;
            // Split into two quadratics.
            const double w = std::sqrt(z > 0.0 ? z : 0.0);
            const double half = 0.5 * (p[l] + z);
            const double t = 0.5 * q[l] / w;
            double yr[4], yi[4];
            quadratic(w, half - t, yr[0], yi[0], yr[1], yi[1]);
            quadratic(-w, half + t, yr[2], yi[2], yr[3], yi[3]);
#pragma GCC unroll 4
            for (int i = 0; i < 4; ++i) {
                b.xr[i][l] = yr[i] - shift[l];
                b.xi[i][l] = yi[i];
            }
            const bool s = z > 1e-14 * (1.0 + std::fabs(p[l]));
            split[l] = s ? 1.0 : 0.0;
            n_split += s;
        }
        if (n_split < L) {
            // The biquadratic y^4 + p y^2 + r where the split degenerates.
ARGAND_LANES
            for (int l = 0; l < L; ++l) {
                double w0r, w0i, w1r, w1i, s0r, s0i, s1r, s1i;
                quadratic(p[l], r[l], w0r, w0i, w1r, w1i);
                csqrt(w0r, w0i, s0r, s0i);
                csqrt(w1r, w1i, s1r, s1i);
                const bool s = split[l] != 0.0;
                b.xr[0][l] = s ? b.xr[0][l] : s0r - shift[l];
                b.xi[0][l] = s ? b.xi[0][l] : s0i;
                b.xr[1][l] = s ? b.xr[1][l] : -s0r - shift[l];
                b.xi[1][l] = s ? b.xi[1][l] : -s0i;
                b.xr[2][l] = s ? b.xr[2][l] : s1r - shift[l];
                b.xi[2][l] = s ? b.xi[2][l] : s1i;
                b.xr[3][l] = s ? b.xr[3][l] : -s1r - shift[l];
                b.xi[3][l] = s ? b.xi[3][l] : -s1i;
            }
        }
    }
    double circle_re[N], circle_im[N];
    for (int i = 0; i < N; ++i) {
        circle_re[i] = b.circle_re[i];
        circle_im[i] = b.circle_im[i];
    }
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        // x - x is 0 for finite x and NaN otherwise (no fast math: not folded).
        double probe = 0.0;
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) probe += (b.xr[i][l] - b.xr[i][l]) + (b.xi[i][l] - b.xi[i][l]);
        const bool good = probe == 0.0;
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            b.xr[i][l] = good ? b.xr[i][l] : circle_re[i];
            b.xi[i][l] = good ? b.xi[i][l] : circle_im[i];
        }
    }
}

template <int N>
void circle_starts(BatchBlock& b) {
    if (b.has_start == 0) {
        for (int i = 0; i < N; ++i)
            for (int l = 0; l < L; ++l) {
                b.xr[i][l] = b.circle_re[i];
                b.xi[i][l] = b.circle_im[i];
            }
        return;
    }
    // The given starts, scaled by 2^-e like the lane (not necessarily
    // exactly: they are approximations); the circle where a lane has none.
    double circle_re[N], circle_im[N];
    for (int i = 0; i < N; ++i) {
        circle_re[i] = b.circle_re[i];
        circle_im[i] = b.circle_im[i];
    }
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        const double me = -b.e[l];
        const double f = pow2_of(exponent_ok(me) ? me : 0.0);
        double sr[N], si[N], probe = 0.0;
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            sr[i] = b.start_re[i][l] * f;
            si[i] = b.start_im[i][l] * f;
            probe += (sr[i] - sr[i]) + (si[i] - si[i]);  // NaN unless all finite
        }
        const bool good = (b.start_ok[l] != 0.0) & exponent_ok(me) & (probe == 0.0);
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            b.xr[i][l] = good ? sr[i] : circle_re[i];
            b.xi[i][l] = good ? si[i] : circle_im[i];
        }
    }
}

/// Lanes per vector register of this instruction set: the lane loops of the
/// Aberth sweeps run chunk by chunk, W lanes (one vector) at a time, and a
/// chunk in which root i has stopped in every lane skips root i.
constexpr int W = detail::kSimdDoubles;
static_assert(L % W == 0, "a block is whole vectors");
/// From this sweep on (0-based), a real approximation whose correction is
/// still large steps off the real axis (see aberth_lanes).
constexpr int kRealNudgeSweep = 2;

/// One sweep's update of root i in lanes [l0, l1) (see aberth_lanes). With
/// Newton set (n <= 4, first sweep from the closed-form starts) the Aberth
/// sum is left out: the correction is Newton's p / p' (M = 1, S = 0 in the
/// formula below). From starts this close (the closed form's error is a few
/// ulps, or about 1e-9 where the cubic's trigonometric form is used) the two
/// corrections agree to second order, and the pairwise sums cost n^2 per
/// lane; a lane Newton does not settle goes on with Aberth sweeps.
template <int N, bool Newton, int CW>
inline void sweep_root(BatchBlock& b, int i, int l0, double (*done)[L], bool nudge_now) {
    constexpr double eps = kU;
    constexpr double noise = 4.0 * (N + 1) * eps;
    constexpr double stop_rel2 = 0x1p-20 * 0x1p-20;
ARGAND_LANES
    for (int l = l0; l < l0 + CW; ++l) {
        const double xr = b.xr[i][l], xi = b.xi[i][l];
        double pr = b.c[N][l], pi = 0.0, dr = 0.0, di = 0.0, ap = std::fabs(b.c[N][l]);
        const double ax2 = xr * xr + xi * xi;
        const double ax = std::sqrt(ax2);
#pragma GCC unroll 12
        for (int k = N - 1; k >= 0; --k) {
            const double ndr = dr * xr - di * xi + pr;
            const double ndi = dr * xi + di * xr + pi;
            dr = ndr;
            di = ndi;
            const double npr = pr * xr - pi * xi + b.c[k][l];
            const double npi = pr * xi + pi * xr;
            pr = npr;
            pi = npi;
            ap = ap * ax + std::fabs(b.c[k][l]);
        }
        const double floor = noise * ap;
        const bool small = pr * pr + pi * pi <= floor * floor;
        double wr, wi;
        if constexpr (Newton) {
            // w = p / p' = p conj(p') / |p'|^2.
            const double inv = 1.0 / (dr * dr + di * di);
            wr = (pr * dr + pi * di) * inv;
            wi = (pi * dr - pr * di) * inv;
        } else {
            // Aberth sum over j != i with a single division.
            double mprod = 1.0, sr = 0.0, si = 0.0;
#pragma GCC unroll 12
            for (int j = 0; j < N; ++j) {
                if (j == i) continue;
                const double er = xr - b.xr[j][l], ei = xi - b.xi[j][l];
                const double m = er * er + ei * ei;
                // S <- S m + conj(d) M (keeps S = sum conj(d_j) M / m_j).
                sr = sr * m + er * mprod;
                si = si * m - ei * mprod;
                mprod *= m;
            }
            // den = p' M - p S; w = p M / den.
            const double denr = dr * mprod - (pr * sr - pi * si);
            const double deni = di * mprod - (pr * si + pi * sr);
            const double numr = pr * mprod, numi = pi * mprod;
            const double inv = 1.0 / (denr * denr + deni * deni);
            wr = (numr * denr + numi * deni) * inv;
            wi = (numi * denr - numr * deni) * inv;
        }
        const bool ok_w = finite(wr) & finite(wi);
        const double nudge = (ax > 0.0 ? ax : 1.0) * 1e-7 * (1 + i);
        const double nr = ok_w ? xr - wr : xr + nudge;
        const double ni = ok_w ? xi - wi : xi + 0.7 * nudge;
        // Real arithmetic keeps a real approximation of a real
        // polynomial real: two real seeds of roots that have
        // become a complex pair (the ray left the surface
        // between neighbouring samples) would never converge.
        // A real approximation whose correction is still above
        // 2^-8 relative from sweep kRealNudgeSweep on steps off
        // the axis by 2^-6 relative (alternating sides); one
        // converging from a seed is far below that by then.
        // (Only degrees 5 to 12 ever nudge: nudge_now is false below.)
        bool stray = false;
        if constexpr (N >= 5) stray = nudge_now & (ni == 0.0) & (wr * wr + wi * wi > 0x1p-16 * (nr * nr));
        const double side = i % 2 == 0 ? 0x1p-6 : -0x1p-6;
        const double ni2 = stray ? side * (nr != 0.0 ? std::fabs(nr) : 1.0) : ni;
        const bool act = done[i][l] == 0.0;
        const bool move = act & !small;
        b.xr[i][l] = move ? nr : xr;
        b.xi[i][l] = move ? ni2 : xi;
        const bool conv = small | (ok_w & (wr * wr + wi * wi <= stop_rel2 * (nr * nr + ni * ni)));
        done[i][l] = (!act | conv) ? 1.0 : 0.0;
    }
}

/// Nonzero iff some of done[0..CW) is 0.0 (open); done holds 0.0 or 1.0
/// only. An OR of integers, which vectorises (a count of doubles did not).
template <int CW>
inline std::uint64_t open_bits(const double* done) {
    std::uint64_t acc = 0;
    for (int l = 0; l < CW; ++l) acc |= bits_of(done[l]) ^ 0x3ff0000000000000ULL;
    return acc;
}

/// Aberth-Ehrlich sweeps (Gauss-Seidel over the roots, all lanes at once),
/// with the scalar aberth's stopping rules per root and lane; a converged
/// root is frozen. The Aberth sum uses one division per root: with
/// d_j = x_i - x_j, m_j = |d_j|^2, M = prod m_j and S = sum conj(d_j) M / m_j,
/// the correction p / (p' - p S / M) is p M / (p' M - p S). Approximations
/// only: nothing here is proven. Returns the sweeps done.
///
/// Freezing pays per vector: root i of a chunk of W lanes is updated only
/// while it has not stopped in some lane of the chunk (a stopped root is
/// never moved, so skipping the chunk gives the same bits as computing it
/// and discarding the result).
template <int N>
int aberth_lanes(BatchBlock& b, int max_iter) {
    double done[N][L];
    for (int i = 0; i < N; ++i)
        for (int l = 0; l < L; ++l) done[i][l] = b.active[l] ? 0.0 : 1.0;
    int it = 0;
    for (; it < max_iter; ++it) {
        std::uint64_t left = 0;  // nonzero while some root of some lane is open
        // (Degrees 5 to 12 only: those take the ray caster's seeds; the
        // closed-form starts of n <= 4 put a complex pair off the axis.)
        const bool nudge_now = (N >= 5) & (it >= kRealNudgeSweep);
        if ((N <= 4) & (it == 0)) {
            // n <= 4, first sweep from the closed-form starts: Newton's,
            // over the whole block without per-chunk tests (nearly every
            // lane stops here, and the tests would cost more than they
            // skip).
#pragma GCC unroll 12
            for (int i = 0; i < N; ++i) {
                sweep_root<N, true, L>(b, i, 0, done, nudge_now);
                left |= open_bits<L>(done[i]);
            }
        } else {
            // Chunk by chunk (one vector of W lanes); a chunk where root i
            // has stopped in every lane skips it (for n <= 4 these sweeps
            // only finish the few lanes Newton did not settle).
#pragma GCC unroll 12
            for (int i = 0; i < N; ++i) {
                for (int l0 = 0; l0 < L; l0 += W) {
                    if (open_bits<W>(done[i] + l0) == 0) continue;
                    sweep_root<N, false, W>(b, i, l0, done, nudge_now);
                    left |= open_bits<W>(done[i] + l0);
                }
            }
        }
        if (left == 0) {
            ++it;
            break;
        }
    }
    // converged: 1.0 iff every root of the lane stopped (a product of 0.0s
    // and 1.0s, exact).
    for (int l = 0; l < L; ++l) b.converged[l] = done[0][l];
    for (int i = 1; i < N; ++i)
        for (int l = 0; l < L; ++l) b.converged[l] *= done[i][l];
    return it;
}

/// Smith's discs, lane by lane, exactly as smith_radii_lanes_reference (root_kernels.h) with
/// no coefficient radii, after the same snapping of real approximations;
/// then the pairwise separation test of smith_discs<double>. Sets ok[l] and
/// r[i][l]; real roots are those with xi == 0 (a disc centred on the real
/// axis holding one root of a real polynomial holds a real root).
template <int N, bool has_radius>
void smith_lanes_impl(BatchBlock& b) {
    constexpr double u = kU;
    constexpr double relative_up = 1.0 + 2.0 * (4.0 * N + 10.0) * u;
    constexpr double den_down = 1.0 - 2.0 * (5.0 * N + 2.0) * u;
    constexpr double pair_down = 1.0 - 8.0 * u;
    constexpr double snap_tol = 64.0 * u;
    // The denominator's guard (>= 2^-900, as the reference's) also rules out
    // an underflow inside the product: a lane is ok only if every |x_i| is
    // below 2^8 (|re| + |im|), so every distance is below 2^9 (1 + 4u), and a
    // partial product below 2^-1022 grows by less than 2^(9 (N - 1) + 1)
    // <= 2^100 over the N - 1 factors: it ends below 2^-900. That holds for
    // N <= 14.
    static_assert(N <= 14, "the denominator's underflow guard needs N <= 14");
    const double slack = b.slack;  // N pow2(max(8N - 1070, -1014)), from the driver
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        double xr[N], xi[N];
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            xr[i] = b.xr[i][l];
            const double v = b.xi[i][l];
            xi[i] = ((v != 0.0) & (std::fabs(v) <= snap_tol * std::fabs(xr[i]))) ? 0.0 : v;
            b.xi[i][l] = xi[i];
        }
        bool ok = b.active[l] != 0.0;
        double dist[N][N];
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i)
#pragma GCC unroll 12
            for (int j = i + 1; j < N; ++j) {
                const double dr = xr[i] - xr[j], di = xi[i] - xi[j];
                const double d = std::sqrt(dr * dr + di * di);
                ok = ok & (d >= 0x1p-450) & (d <= 0x1p450);
                dist[i][j] = dist[j][i] = d;
            }
        const double lead = std::fabs(b.c[N][l]);
        // lead_down(c, rad, n): |c_n| - rad_n rounded down (must be > 0).
        const double lead_diff = lead - b.rad[N][l];
        // (For lead_diff <= 0 this is negative or NaN: the denominator test
        // below then fails, as lead_down's "must be > 0" asks; no select, so
        // that the lane loop vectorises.)
        const double lead_low = from_bits(bits_of(lead_diff) - 1);
        double r[N];
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            const double ax = std::fabs(xr[i]) + std::fabs(xi[i]);
            ok = ok & (ax <= 0x1p8);
            double yr = b.c[N][l], yi = 0.0, ay = lead, e = 0.0;
#pragma GCC unroll 12
            for (int k = N - 1; k >= 0; --k) {
                const double pr = yr * xr[i] - yi * xi[i];
                const double pi = yr * xi[i] + yi * xr[i];
                yr = pr + b.c[k][l];
                yi = pi;
                const double a_next = std::fabs(yr) + std::fabs(yi);
                e = ax * (e + kMulRel * ay) + (kAddRel * a_next + 2.0 * kAbsErr);
                ay = a_next;
            }
            // The family's term sum_k rad_k |x|^k on ax (0 without radii).
            double fam = 0.0;
            if constexpr (has_radius) {
                double fs = b.rad[N][l];
#pragma GCC unroll 12
                for (int k = N - 1; k >= 0; --k) fs = fs * ax + b.rad[k][l];
                fam = up(up(fs * relative_up) + slack);
            }
            // add_up(add_up(next_up(ay), next_up(e relative_up)), add_up(slack, fam)).
            const double numerator = up(up(up(ay) + up(e * relative_up)) + up(slack + fam));
            double denominator = has_radius ? lead_low : lead;
#pragma GCC unroll 12
            for (int j = 0; j < N; ++j)
                if (j != i) denominator *= dist[i][j];
            ok = ok & (denominator >= 0x1p-900) & finite(denominator) & finite(numerator);
            denominator *= den_down;
            r[i] = up(N * up(numerator / denominator));
            ok = ok & finite(r[i]);
        }
        // (Every radius is Smith's here; disjoint is the test below.)
        b.discs_ok[l] = ok ? 1.0 : 0.0;
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i)
#pragma GCC unroll 12
            for (int j = i + 1; j < N; ++j) ok = ok & (dist[i][j] * pair_down > up(r[i] + r[j]));
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) b.r[i][l] = r[i];
        b.ok[l] = ok ? 1.0 : 0.0;
    }
}

template <int N>
void smith_lanes(BatchBlock& b) {
    if (b.has_radius != 0) smith_lanes_impl<N, true>(b);
    else smith_lanes_impl<N, false>(b);
}

/// The unverified method's radius estimate n |p| / |p'| (no claim).
template <int N>
void estimate_lanes(BatchBlock& b) {
    for (int i = 0; i < N; ++i)
ARGAND_LANES
        for (int l = 0; l < L; ++l) {
            const double xr = b.xr[i][l], xi = b.xi[i][l];
            double pr = b.c[N][l], pi = 0.0, dr = 0.0, di = 0.0;
#pragma GCC unroll 12
            for (int k = N - 1; k >= 0; --k) {
                const double ndr = dr * xr - di * xi + pr;
                const double ndi = dr * xi + di * xr + pi;
                dr = ndr;
                di = ndi;
                const double npr = pr * xr - pi * xi + b.c[k][l];
                const double npi = pr * xi + pi * xr;
                pr = npr;
                pi = npi;
            }
            const double est = N * std::sqrt(pr * pr + pi * pi) / std::sqrt(dr * dr + di * di);
            b.r[i][l] = finite(est) ? est : __builtin_inf();
            b.ok[l] = b.active[l];
            b.discs_ok[l] = 0.0;  // (estimates: nothing proven)
        }
}


/// Scales every lane exactly, as scale_polynomial does: t = 2^e u with
/// e = round((E_0 - E_n) / n) from the coefficients' exponents, and the
/// factor 2^f that puts the largest coefficient in [1, 2). A product by a
/// power of two is exact when the result is normal (or the input zero):
/// lanes where some scaled coefficient is not are marked inactive (the
/// driver sends them to find_roots). Exponents are small integers held in
/// doubles (exact).
template <int N>
void scale_lanes(BatchBlock& b) {
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        double ex[N + 1];
#pragma GCC unroll 13
        for (int k = 0; k <= N; ++k)
            ex[k] = from_bits((bits_of(b.c[k][l]) >> 52 & 0x7ff) | 0x4330000000000000ULL) - 0x1p52 - 1023.0;
        const double t = (ex[0] - ex[N]) * (1.0 / N);
        const double e = (t + 0x1.8p52) - 0x1.8p52;  // nearest integer
        double top = -1e9;
#pragma GCC unroll 13
        for (int k = 0; k <= N; ++k) {
            const double v = ex[k] + e * k;
            top = ((b.c[k][l] != 0.0) & (v > top)) ? v : top;
        }
        bool ok = b.active[l] != 0.0;
#pragma GCC unroll 13
        for (int k = 0; k <= N; ++k) {
            const double m = e * k - top;
            const double v = b.c[k][l];
            const double s = v * pow2_of(exponent_ok(m) ? m : 0.0);
            ok = ok & exponent_ok(m) & ((v == 0.0) | ((std::fabs(s) >= 0x1p-1022) & (std::fabs(s) <= kHuge)));
            b.c[k][l] = s;
        }
        ok = ok & exponent_ok(e);
        b.e[l] = e;
        b.scale_top[l] = top;
        b.active[l] = ok ? 1.0 : 0.0;
    }
    if (b.has_radius == 0) return;
    // The radii by the same factors, rounded up where the product is not
    // exact (a subnormal or zero result): still upper bounds.
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        const double e = b.e[l], top = b.scale_top[l];
        // (The largest scaled radius decides finiteness after the loop, and
        // the rounding up is a select of doubles: no bool chain, so that
        // the lane loop vectorises.)
        double largest = 0.0;
#pragma GCC unroll 13
        for (int k = 0; k <= N; ++k) {
            const double m = e * k - top;
            const double rv = b.rad[k][l];
            const double rs = rv * pow2_of(exponent_ok(m) ? m : 0.0);
            // rs below 2^-1022 (subnormal or zero) from rv > 0 is inexact:
            // its successor bounds the exact product from above.
            const double bumped = from_bits(bits_of(rs) + 1);
            const double rr = (rs < 0x1p-1022) & (rv != 0.0) ? bumped : rs;
            b.rad[k][l] = rr;
            largest = rr > largest ? rr : largest;
        }
        b.active[l] = (b.active[l] != 0.0) & (largest <= kHuge) ? 1.0 : 0.0;
    }
}

/// Maps centres and radii back by 2^e; a lane stays ok only if every value
/// maps exactly (zero from zero, or a normal result).
template <int N>
void unscale_lanes(BatchBlock& b) {
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        const double e = b.e[l];
        const double f = pow2_of(exponent_ok(e) ? e : 0.0);
        bool exact = true;
#pragma GCC unroll 12
        for (int i = 0; i < N; ++i) {
            const double vr = b.xr[i][l] * f, vi = b.xi[i][l] * f, vd = b.r[i][l] * f;
            exact = exact & ((b.xr[i][l] == 0.0) | ((std::fabs(vr) >= 0x1p-1022) & (std::fabs(vr) <= kHuge)));
            exact = exact & ((b.xi[i][l] == 0.0) | ((std::fabs(vi) >= 0x1p-1022) & (std::fabs(vi) <= kHuge)));
            exact = exact & ((b.r[i][l] == 0.0) | ((std::fabs(vd) >= 0x1p-1022) & (std::fabs(vd) <= kHuge)));
            b.xr[i][l] = vr;
            b.xi[i][l] = vi;
            b.r[i][l] = vd;
        }
        b.ok[l] = (b.ok[l] != 0.0) & exact ? 1.0 : 0.0;
        b.discs_ok[l] = (b.discs_ok[l] != 0.0) & exact ? 1.0 : 0.0;
    }
}

template <int N>
int solve_block_n(BatchBlock& b, bool verify) {
    scale_lanes<N>(b);
    if constexpr (N <= 4) closed_form_starts<N>(b);
    else circle_starts<N>(b);
    const int sweeps = aberth_lanes<N>(b, N <= 4 ? b.max_sweeps_closed : b.max_sweeps_circle);
    if (verify) smith_lanes<N>(b);
    else estimate_lanes<N>(b);
    unscale_lanes<N>(b);
    return sweeps;
}

/// The driver's admission rule (roots_batch.cpp), lane by lane over the
/// whole block: a lane stays active (active[l] = 1.0 on entry: a row that
/// is there and not skipped) iff every coefficient is finite, c_0 and c_n
/// are nonzero and, with radii, every radius is finite and >= 0. z = sum_k
/// 0 c_k (+ sum_k 0 rad_k) is 0 iff every one is finite (0 inf and 0 NaN
/// are NaN, and NaN stays); low = min(0, rad_k) (a NaN radius already makes
/// z NaN). Returns the lanes admitted.
template <int N, bool has_radius>
int admit_lanes(BatchBlock& b) {
ARGAND_LANES
    for (int l = 0; l < L; ++l) {
        double z = 0.0, low = 0.0;
#pragma GCC unroll 13
        for (int k = 0; k <= N; ++k) z += 0.0 * b.c[k][l];
        if constexpr (has_radius) {
#pragma GCC unroll 13
            for (int k = 0; k <= N; ++k) {
                const double v = b.rad[k][l];
                z += 0.0 * v;
                low = v < low ? v : low;
            }
        }
        const bool ok = (b.active[l] != 0.0) & (z == 0.0) & (low >= 0.0) & (b.c[0][l] != 0.0) & (b.c[N][l] != 0.0);
        b.active[l] = ok ? 1.0 : 0.0;
    }
    std::uint64_t count = 0;
    for (int l = 0; l < L; ++l) count += bits_of(b.active[l]) >> 61;  // (1.0 is 0x3ff0...: 1; 0.0: 0)
    return static_cast<int>(count);
}

template <int N>
int admit_n(BatchBlock& b) {
    return b.has_radius != 0 ? admit_lanes<N, true>(b) : admit_lanes<N, false>(b);
}

}  // namespace

/// Admission (see admit_lanes) for the block's degree; returns the lanes
/// admitted.
int admit_block(BatchBlock& b) {
    switch (b.n) {
        case 1: return admit_n<1>(b);
        case 2: return admit_n<2>(b);
        case 3: return admit_n<3>(b);
        case 4: return admit_n<4>(b);
        case 5: return admit_n<5>(b);
        case 6: return admit_n<6>(b);
        case 7: return admit_n<7>(b);
        case 8: return admit_n<8>(b);
        case 9: return admit_n<9>(b);
        case 10: return admit_n<10>(b);
        case 11: return admit_n<11>(b);
        case 12: return admit_n<12>(b);
        default: return 0;
    }
}

/// The entry point of this instruction set's kernel: solves the block in
/// place (see BatchBlock); returns the Aberth sweeps done.
int solve_block(BatchBlock& b, bool verify) {
    switch (b.n) {
        case 1: return solve_block_n<1>(b, verify);
        case 2: return solve_block_n<2>(b, verify);
        case 3: return solve_block_n<3>(b, verify);
        case 4: return solve_block_n<4>(b, verify);
        case 5: return solve_block_n<5>(b, verify);
        case 6: return solve_block_n<6>(b, verify);
        case 7: return solve_block_n<7>(b, verify);
        case 8: return solve_block_n<8>(b, verify);
        case 9: return solve_block_n<9>(b, verify);
        case 10: return solve_block_n<10>(b, verify);
        case 11: return solve_block_n<11>(b, verify);
        case 12: return solve_block_n<12>(b, verify);
        default: return -1;
    }
}

}  // namespace argand::ARGAND_BATCH_NS
