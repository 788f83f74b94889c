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

#include "argand/render.h"

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
/// Any ray (secondary rays), by direct expansion of each term in balls.
void general_ray_polynomial(const SurfaceSpec& s, const double o[3], const double d[3], RayCoefficients<double>& out,
                            ObjectRay& ray);

}  // namespace argand::detail
