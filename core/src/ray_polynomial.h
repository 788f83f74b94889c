// ray_polynomial.h: the ray polynomial p(t) = F(o' + t d') of a surface
// along a ray, with a proven bound on the error of every coefficient
// (internal header of the renderer).
//
// What is proven. The ray is given by its exact double world origin o and
// direction d; the surface by its exact double coefficients and its exact
// double transform (object = linear (world - translate)). The exact ray
// polynomial p has |p_k - c[k]| <= r[k] for every k, where c and r are
// what these functions return. r[k] == 0 only where c[k] is exact (in
// particular a coefficient all of whose monomials vanish exactly stays an
// exact zero). finite == false: something overflowed, nothing is claimed.
#pragma once

#include <cstdint>

#include "argand/render.h"
#include "argand/roots_batch.h"

namespace argand::detail {

template <class T>
struct RayCoefficients {
    int n = 0;
    T c[kMaxDegree + 1];
    double r[kMaxDegree + 1];
    bool finite = false;
};

/// The object-space ray as balls (the exact o' and d' lie in them), for the
/// clipping sphere.
struct ObjectRay {
    Ball origin[3];
    Ball direction[3];
};

/// The per-frame part of an object: o' and the Taylor coefficients of
/// F(o' + v), as balls, and the factors of the per-pixel bound.
void plan_object(const SurfaceSpec& s, const double eye[3], FramePlan::ObjectPlan& op);

/// A primary ray (origin: the plan's eye) along the world direction d.
void primary_ray_polynomial(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3],
                            RayCoefficients<double>& out, ObjectRay& ray);
/// The same in double-double (coefficients within ~2^-100 relative).
void primary_ray_polynomial_dd(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3],
                               RayCoefficients<DoubleDouble>& out);
/// A primary ray's polynomial about the point at t0 on it: q(s) = p(t0 + s)
/// for the exact p of primary_ray_polynomial (|q_k - c[k]| <= r[k]), by
/// expansion of each term of F in double about the enclosed point
/// o' + t0 d', every product's and sum's rounding error carried exactly
/// into a running radius (inflated once at the end for its own rounding),
/// out.finite false where it overflows or t0 is not finite.
/// About a point near the surface the terms are of the surface's own size,
/// not of the camera's distance to the power of the degree: clusters that
/// the eye's expansion merges (its coefficients are sums of terms up to 10^9
/// on an octic seen from 10 units) separate in double. Some ten times primary_ray_polynomial's cost: for the ladder's
/// pixels only.
void rebased_ray_polynomial(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double d[3], double t0,
                            RayCoefficients<double>& out);
/// Any ray (secondary rays), by direct expansion of each term in balls.
void general_ray_polynomial(const SurfaceSpec& s, const double o[3], const double d[3], RayCoefficients<double>& out,
                            ObjectRay& ray);

/// A run of up to kRunCells primary rays of one object, in structure of
/// arrays (cells innermost): what primary_ray_polynomial gives for cell l,
/// bit for bit, at [.][l].
constexpr int kRunCells = 32;
constexpr int kRunMaxDegree = 12;
struct alignas(64) PrimaryRun {
    int n = 0;      // degree
    int cells = 0;  // cells 0..cells-1 hold rays (the rest is padding)
    // RayCoefficients<double>::c and r of each cell (k <= n).
    alignas(64) double c[kRunMaxDegree + 1][kRunCells];
    alignas(64) double r[kRunMaxDegree + 1][kRunCells];
    // The computed object-space direction d' (ObjectRay::direction[a] is
    // Ball(dir[a][l], dir_rad[a][l]); the origin is the plan's), and the
    // bound A on |d'| of the rounding argument.
    alignas(64) double dir[3][kRunCells];
    alignas(64) double dir_rad[3][kRunCells];
    alignas(64) double mag[3][kRunCells];
    alignas(64) std::uint8_t finite[kRunCells];  // RayCoefficients::finite
    // (Internal: the lanes that take primary_impl's underflow slack, and
    // their largest A, 1 at least.)
    alignas(64) std::uint8_t slack[kRunCells];
    alignas(64) double amax[kRunCells];
};

/// primary_ray_polynomial for the cells 0..cells-1 (cells <= kRunCells) of
/// a run whose unit world directions are (dx[l], dy[l], dz[l]): out gets,
/// for every cell, exactly the bits primary_ray_polynomial computes (the
/// same operations in the same order, lane by lane; see ray_run_kernel.h).
/// Degree <= kRunMaxDegree. isa: the instruction set of the lane loops
/// (BatchIsa::Scalar or Auto: the widest this CPU runs).
void primary_ray_polynomial_run(const SurfaceSpec& s, const FramePlan::ObjectPlan& op, const double* dx,
                                const double* dy, const double* dz, int cells, PrimaryRun& out,
                                BatchIsa isa = BatchIsa::Auto);

/// One row of samples of render/camera.cpp's sample_direction: the camera and the
/// row's sy (computed there).
struct SampleRowInput {
    double forward[3], right[3], up[3];
    double tan_half_fov, aspect, cols, sy;
};
/// The unit world directions of the cells first_cell..first_cell+cells-1
/// of a row (sample_direction's operations, lane by lane).
void sample_direction_run(const SampleRowInput& in, int first_cell, int cells, double* dx, double* dy, double* dz,
                          BatchIsa isa = BatchIsa::Auto);

/// The lane-parallel kernels, once per instruction set (ray_run_kernel.h).
struct PrimaryRunInput {
    int n;
    bool exact_direction;  // (then the kernel computes dir, mag and dir_rad from dx, dy, dz)
    const double* linear;
    const double *dx, *dy, *dz;
    double no_underflow_threshold;
    const int* k_begin;
    const int *ex, *ey, *ez;
    const double *g, *g_rad, *weight_factor, *radius_factor;
};
#define ARGAND_RAY_DECLARE(ns)                                                                                   \
    namespace ns {                                                                                               \
    void primary_run_sums(const PrimaryRunInput& in, PrimaryRun& out);                                           \
    void sample_direction_run(const SampleRowInput& in, int first_cell, int cells, double* dx, double* dy, double* dz); \
    }
ARGAND_RAY_DECLARE(ray_generic)
ARGAND_RAY_DECLARE(ray_avx2)
ARGAND_RAY_DECLARE(ray_avx512)
#undef ARGAND_RAY_DECLARE

}  // namespace argand::detail
