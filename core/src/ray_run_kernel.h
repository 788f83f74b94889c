// ray_run_kernel.h: the lane-parallel part of primary_ray_polynomial_run
// and sample_direction_run (internal; included once per instruction set by
// ray_run_{generic,avx2,avx512}.cpp, each inside its own namespace
// ARGAND_RAY_NS, chosen at run time with the root kernels' BatchIsa).
//
// Bit-identity contract. Every lane (cell) performs exactly the IEEE-754
// binary64 operations of the scalar code it replaces, in the same order:
// primary_impl<double> (ray_polynomial.cpp) for the sums and radii, and
// render/camera.cpp's sample_direction for the directions. Only +, -, *, /, sqrt
// (correctly rounded in every instruction set), fabs and selects are used;
// the build pins -ffp-contract=off (no fused multiply-add) and no fast math,
// so the vector code computes the scalar code's bits lane by lane (the C++
// test ray_run_test and tests/render/test_kernel.py compare them bit for
// bit). Hence the rounding argument of ray_polynomial.cpp's file comment
// holds for every lane unchanged.
#ifndef ARGAND_RAY_NS
#error "define ARGAND_RAY_NS before including ray_run_kernel.h"
#endif

#include <cmath>
#include <cstdint>
#include <cstring>

#include "ray_polynomial.h"
#include "simd_width.h"

#if defined(__clang__)
#define ARGAND_RAY_LANES _Pragma("clang loop vectorize(enable)")
#else
#define ARGAND_RAY_LANES _Pragma("GCC ivdep")
#endif

// The vector helpers below are inlined and internal to this file: the ABI
// of passing wide vectors between translation units does not concern them.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace argand::detail::ARGAND_RAY_NS {
namespace {

// One native vector of V lanes (AVX-512: 8, AVX2: 4, SSE2: 2), U of them
// side by side: W = U V = 8 lanes per chunk of the monomial loop, whose
// accumulators stay in registers.
constexpr int V = kSimdDoubles;
constexpr int W = 8;
constexpr int U = W / V;
typedef double vd __attribute__((vector_size(V * sizeof(double))));
typedef std::int64_t vi __attribute__((vector_size(V * sizeof(double))));

inline vd load(const double* p) {
    vd v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(double* p, vd v) { std::memcpy(p, &v, sizeof v); }
inline vd vabs(vd v) {
    vi b;
    std::memcpy(&b, &v, sizeof b);
    b &= std::int64_t(0x7fffffffffffffffLL);
    std::memcpy(&v, &b, sizeof v);
    return v;
}
inline vd splat(double x) {
    vd v;
    for (int l = 0; l < V; ++l) v[l] = x;
    return v;
}

/// next_up (arith.h) lane by lane: the same result for every input.
inline double next_up_bits(double x) {
    x += 0.0;
    // In unsigned arithmetic: the step is taken before the +inf/NaN test
    // (branch-free lanes), and a NaN's bits + 1 may wrap (defined here, an
    // overflow in int64_t). +1 on the bits of a value >= +0, -1 on a negative.
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const std::uint64_t stepped = bits + 1 - ((bits >> 63) << 1);
    double y;
    std::memcpy(&y, &stepped, sizeof y);
    return x < INFINITY ? y : x;  // +inf and NaN stay
}

}  // namespace

void primary_run_sums(const PrimaryRunInput& in, PrimaryRun& out) {
    const int n = in.n;
    const bool exact = in.exact_direction;
    // Powers of the lanes' d' (and of A for an inexact direction), as
    // primary_impl: p[0] = 1, p[k] = p[k - 1] * d'.
    alignas(64) double px[kRunMaxDegree + 1][kRunCells], py[kRunMaxDegree + 1][kRunCells],
        pz[kRunMaxDegree + 1][kRunCells];
    alignas(64) double ax[kRunMaxDegree + 1][kRunCells], ay[kRunMaxDegree + 1][kRunCells],
        az[kRunMaxDegree + 1][kRunCells];
    const int lanes = (out.cells + W - 1) / W * W;
    if (exact) {
        // d' = linear d for a signed permutation, object_direction's
        // operations: (L0 d0 + L1 d1) + L2 d2, exact; A = |d'|. Padding
        // lanes repeat cell 0 (finite; never read back).
        alignas(64) double wx[kRunCells], wy[kRunCells], wz[kRunCells];
        if (out.cells == kRunCells) {
            // (A full run's copies have a fixed size: no library calls.)
            std::memcpy(wx, in.dx, sizeof wx);
            std::memcpy(wy, in.dy, sizeof wy);
            std::memcpy(wz, in.dz, sizeof wz);
        } else {
            for (int l = 0; l < out.cells; ++l) {
                wx[l] = in.dx[l];
                wy[l] = in.dy[l];
                wz[l] = in.dz[l];
            }
            for (int l = out.cells; l < kRunCells; ++l) {
                wx[l] = in.dx[0];
                wy[l] = in.dy[0];
                wz[l] = in.dz[0];
            }
        }
        for (int r = 0; r < 3; ++r) {
            const double L0 = in.linear[3 * r], L1 = in.linear[3 * r + 1], L2 = in.linear[3 * r + 2];
            ARGAND_RAY_LANES
            for (int l = 0; l < kRunCells; ++l) {
                const double v = L0 * wx[l] + L1 * wy[l] + L2 * wz[l];
                out.dir[r][l] = v;
                out.mag[r][l] = std::fabs(v);
                out.dir_rad[r][l] = 0.0;
            }
        }
    }
    // The underflow test of primary_impl per lane: amin, amax over the
    // nonzero A_a (1 when none is smaller / larger).
    // (In native vectors: the same selects lane by lane.)
    {
        const vd threshold = splat(in.no_underflow_threshold), zero = splat(0.0);
        for (int l0 = 0; l0 < kRunCells; l0 += V) {
            vd amin = splat(1.0), amax = splat(1.0);
            for (int a = 0; a < 3; ++a) {
                const vd m = load(out.mag[a] + l0);
                amin = (m > zero) & (m < amin) ? m : amin;
                amax = (m > zero) & (m > amax) ? m : amax;
            }
            store(out.amax + l0, amax);
            const vi low = amin < threshold;
            for (int l = 0; l < V; ++l) out.slack[l0 + l] = low[l] != 0 ? 1 : 0;
        }
    }
    ARGAND_RAY_LANES
    for (int l = 0; l < kRunCells; ++l) {
        px[0][l] = py[0][l] = pz[0][l] = 1.0;
        ax[0][l] = ay[0][l] = az[0][l] = 1.0;
    }
    for (int k = 1; k <= n; ++k) {
        ARGAND_RAY_LANES
        for (int l = 0; l < kRunCells; ++l) {
            px[k][l] = px[k - 1][l] * out.dir[0][l];
            py[k][l] = py[k - 1][l] * out.dir[1][l];
            pz[k][l] = pz[k - 1][l] * out.dir[2][l];
        }
        if (!exact) {
            ARGAND_RAY_LANES
            for (int l = 0; l < kRunCells; ++l) {
                ax[k][l] = ax[k - 1][l] * out.mag[0][l];
                ay[k][l] = ay[k - 1][l] * out.mag[1][l];
                az[k][l] = az[k - 1][l] * out.mag[2][l];
            }
        }
    }
    alignas(64) double check[kRunCells];
    for (int l = 0; l < kRunCells; ++l) check[l] = 0.0;
    const int* ex = in.ex;
    const int* ey = in.ey;
    const int* ez = in.ez;
    for (int k = 0; k <= n; ++k) {
        const int begin = in.k_begin[k], end = in.k_begin[k + 1];
        alignas(64) double weight_all[kRunCells], radius_all[kRunCells];
        for (int l0 = 0; l0 < lanes; l0 += W) {
            // The monomial loop with the lanes' accumulators in registers;
            // each lane adds its terms in primary_impl's order.
            vd sum[U], weight[U], radius[U];
#pragma GCC unroll 8
            for (int u = 0; u < U; ++u) sum[u] = weight[u] = radius[u] = splat(0.0);
            if (exact) {
                for (int i = begin; i < end; ++i) {
                    const double* X = px[ex[i]] + l0;
                    const double* Y = py[ey[i]] + l0;
                    const double* Z = pz[ez[i]] + l0;
                    const double g = in.g[i], gr = in.g_rad[i];
#pragma GCC unroll 8
                    for (int u = 0; u < U; ++u) {
                        const vd mono = load(X + u * V) * load(Y + u * V) * load(Z + u * V);
                        const vd term = g * mono;
                        sum[u] = sum[u] + term;
                        weight[u] += vabs(term);
                        radius[u] += gr * vabs(mono);
                    }
                }
            } else {
                for (int i = begin; i < end; ++i) {
                    const double* X = px[ex[i]] + l0;
                    const double* Y = py[ey[i]] + l0;
                    const double* Z = pz[ez[i]] + l0;
                    const double* AX = ax[ex[i]] + l0;
                    const double* AY = ay[ey[i]] + l0;
                    const double* AZ = az[ez[i]] + l0;
                    const double g = in.g[i], ag = std::fabs(in.g[i]), gr = in.g_rad[i];
#pragma GCC unroll 8
                    for (int u = 0; u < U; ++u) {
                        sum[u] = sum[u] + g * (load(X + u * V) * load(Y + u * V) * load(Z + u * V));
                        const vd mono_mag = load(AX + u * V) * load(AY + u * V) * load(AZ + u * V);
                        weight[u] += ag * mono_mag;
                        radius[u] += gr * mono_mag;
                    }
                }
            }
#pragma GCC unroll 8
            for (int u = 0; u < U; ++u) {
                store(out.c[k] + l0 + u * V, sum[u]);
                store(weight_all + l0 + u * V, weight[u]);
                store(radius_all + l0 + u * V, radius[u]);
            }
        }
        const double wf = in.weight_factor[k], rf = in.radius_factor[k];
        ARGAND_RAY_LANES
        for (int l = 0; l < kRunCells; ++l) {
            const double w = weight_all[l], r = radius_all[l];
            const double v = next_up_bits((wf * w + rf * r) * (1.0 + 8.0 * 0x1p-53));
            const double rk = (w == 0.0 && r == 0.0) ? 0.0 : v;
            out.r[k][l] = rk;
            check[l] += std::fabs(out.c[k][l]) + rk;
        }
    }
    ARGAND_RAY_LANES
    for (int l = 0; l < kRunCells; ++l) out.finite[l] = std::fabs(check[l]) <= 1.7976931348623157e308 ? 1 : 0;
}

void sample_direction_run(const SampleRowInput& in, int first_cell, int cells, double* dx, double* dy, double* dz) {
    ARGAND_RAY_LANES
    for (int c = 0; c < cells; ++c) {
        const double sx = (2.0 * (static_cast<double>(first_cell + c) + 0.5) / in.cols - 1.0) * in.tan_half_fov * in.aspect;
        double d0 = in.forward[0] + sx * in.right[0] + in.sy * in.up[0];
        double d1 = in.forward[1] + sx * in.right[1] + in.sy * in.up[1];
        double d2 = in.forward[2] + sx * in.right[2] + in.sy * in.up[2];
        const double nn = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        const bool pos = nn > 0;
        const double q = pos ? nn : 1.0;
        const double e0 = d0 / q, e1 = d1 / q, e2 = d2 / q;
        dx[c] = pos ? e0 : d0;
        dy[c] = pos ? e1 : d1;
        dz[c] = pos ? e2 : d2;
    }
}

}  // namespace argand::detail::ARGAND_RAY_NS
