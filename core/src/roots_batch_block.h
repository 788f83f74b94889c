// roots_batch_block.h: the structure-of-arrays block that the batched root
// kernels work on (internal; plain data, shared by the driver
// roots_batch.cpp and the per-instruction-set kernels).
#pragma once

namespace argand {

/// Polynomials per block (lanes). 16 doubles fill two AVX-512 registers or
/// four AVX2 registers per quantity: independent vectors that the core can
/// overlap while one of them waits on a division.
constexpr int kBatchLanes = 16;
/// Largest degree with a batched kernel (higher degrees use find_roots).
constexpr int kBatchMaxDegree = 12;

struct alignas(64) BatchBlock {
    int n = 0;                 // degree of every lane
    int max_sweeps_closed = 12;  // Aberth sweeps from closed-form starts (n <= 4)
    int max_sweeps_circle = 40;  // ... from circle starts (n >= 5)
    double slack = 0.0;        // smith_radii_lanes_reference's underflow slack for degree n
    double circle_re[kBatchMaxDegree];  // starts on the unit circle, twisted
    double circle_im[kBatchMaxDegree];
    // In: coefficients, c[k][l] = coefficient k of lane l (finite, c[0] and
    // c[n] nonzero). The kernel scales them in place by exact powers of two
    // (t = 2^e u: roots of modulus ~1, largest coefficient in [1, 2)).
    alignas(64) double c[kBatchMaxDegree + 1][kBatchLanes];
    // Out: the root scaling exponent e of each lane (a small integer).
    alignas(64) double e[kBatchLanes];
    alignas(64) double scale_top[kBatchLanes];  // (the factor 2^-top of the scaling)
    // In (when has_radius): coefficient radii rad[k][l] >= 0, finite; the
    // discs are then proven for every real polynomial q of the family
    // |q_k - c_k| <= rad_k (smith_radii_lanes_reference's family term). Scaled in place
    // with the coefficients (rounded up where inexact).
    int has_radius = 0;
    alignas(64) double rad[kBatchMaxDegree + 1][kBatchLanes];
    // In (when has_start, degree >= 5): starting approximations in the
    // input's coordinates, start_ok[l] = 1.0 for a lane that has them (the
    // kernel scales them with the lane; a lane without, or whose scaled
    // starts are not finite, starts on the circle). Approximations only:
    // nothing proven depends on them.
    int has_start = 0;
    alignas(64) double start_re[kBatchMaxDegree][kBatchLanes];
    alignas(64) double start_im[kBatchMaxDegree][kBatchLanes];
    alignas(64) double start_ok[kBatchLanes];
    // In: 1.0 for lanes that hold a polynomial, 0.0 for padding.
    alignas(64) double active[kBatchLanes];
    // Out: centres and radii in the coordinates of the input (mapped back
    // from the scaled ones exactly), and per lane ok = 1.0 iff the scaling
    // and the mapping back were exact and every disc D(x_i, r_i) is proven
    // to hold exactly one root (verify) or the estimates were written (no
    // verify).
    alignas(64) double xr[kBatchMaxDegree][kBatchLanes];
    alignas(64) double xi[kBatchMaxDegree][kBatchLanes];
    alignas(64) double r[kBatchMaxDegree][kBatchLanes];
    alignas(64) double ok[kBatchLanes];
    alignas(64) double converged[kBatchLanes];  // Aberth stopped every root (diagnostic)
    // Out (verify): 1.0 iff every r_i is Smith's radius for x_i (distinct
    // approximations, every guard of the radii passed, the mapping back
    // exact), whether or not the discs are pairwise disjoint: then the
    // union of the D(x_i, r_i) holds every root of every member of the
    // family and each connected component of m discs holds exactly m
    // (Smith's theorem), so they may be merged into cluster discs
    // (enclose_and_merge). ok implies discs_ok.
    alignas(64) double discs_ok[kBatchLanes];
};

// One kernel per instruction set (roots_batch_{generic,avx2,avx512}.cpp):
// solve_block, and admit_block (the driver's admission test over the block:
// active[l] on entry = row present, on exit = admitted; returns the count).
namespace batch_generic { int solve_block(BatchBlock& b, bool verify); int admit_block(BatchBlock& b); }
namespace batch_avx2 { int solve_block(BatchBlock& b, bool verify); int admit_block(BatchBlock& b); }
namespace batch_avx512 { int solve_block(BatchBlock& b, bool verify); int admit_block(BatchBlock& b); }

}  // namespace argand
