// refine_dd.h: root finding in double-double for the renderer's ladder
// (level 4, core/src/render/ladder.cpp): a verified disc of a ray
// polynomial shrunk, or a cluster re-isolated, with the double-double ray
// coefficients (ray_polynomial.h's primary_ray_polynomial_dd). Internal
// header; every disc it returns carries find_roots' contract.
#pragma once

#include "argand/arith.h"
#include "argand/roots.h"
#include "ray_polynomial.h"

namespace argand::detail {

/// Shrinks a verified count-1 disc d of p with the double-double
/// coefficients p (|p_k - c_k| <= r_k): Newton steps in double-double, then
/// the inclusion disc |z - x| <= n |p(x) / p'(x)| (it holds a root of every
/// polynomial of degree <= n in the coefficient balls), accepted only when it
/// lies inside d (so it holds d's root). Returns true and replaces d when the
/// result is smaller.
bool refine_disc_dd(const RayCoefficients<DoubleDouble>& p, bool real, RootDisc& d);

/// Re-isolates every root of p from scratch in double-double (for a
/// polynomial whose double discs left a cluster): Aberth-Ehrlich from the
/// current discs (a cluster's approximations spread inside it), then Smith's
/// discs with the double-double coefficient balls (each radius bounds the
/// Smith radius of every polynomial within them, so the counts hold for the
/// exact one). Replaces res's discs and returns true only when every root
/// gets its own verified disc, all pairwise disjoint (proven); otherwise
/// leaves res untouched. Not for polynomials with an exact root at 0 or an
/// uncertain leading coefficient.
bool isolate_dd(const RayCoefficients<DoubleDouble>& p, RootsResult& res);

/// isolate_dd's step: one Aberth-Ehrlich sweep in double-double over the
/// approximations x[i] of the roots of c (degree n) that `which` selects
/// (null: all), in place; returns the largest relative correction.
/// Approximations only. `fma`: the products' error-free parts as FMA
/// instructions where this CPU has them (else, and with false, Dekker's
/// split): the same bits either way, only faster. `noise` (optional): set
/// true where p at every selected approximation was within an estimate of
/// its evaluation's rounding noise (isolate_dd then stops sweeping).
double aberth_sweep_dd(const DoubleDouble* c, int n, Complex<DoubleDouble>* x, const bool* which, bool fma,
                       bool* noise = nullptr);

}  // namespace argand::detail
