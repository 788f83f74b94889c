// polish.h: a proven simple root's value, refined to what a double holds.
//
// A verified disc with count 1 proves that one root lies in it; its centre
// is only the solver's approximation, as good as the iteration that found
// it (a batched lane may stop with a disc of radius 1e-2 around a centre
// 1e-3 off). The renderer writes the root's value into the AOVs (Z, re,
// im, arg) and shades at it, so a wide disc is polished first: Newton's
// iteration in double-double on the double coefficients the disc was
// proven for, from the centre, kept only where it settles inside the disc
// (then it is that disc's one root, to about 2^-100 relative, rounded to
// double). Nothing proven changes: the disc, its count and every decision
// made from it stay as they are.
#pragma once

#include "argand/render.h"
#include "argand/roots.h"

namespace argand::detail {

/// Relative distance below which a simple root's value is left as it is:
/// a centre that close to its root (or a disc that narrow) is closer than
/// a float32 AOV (Z, re, im: 24 bits) can tell.
constexpr double kPolishRelativeRadius = 0x1p-26;

/// True iff a verified disc of one root may be worth polishing: its radius
/// exceeds kPolishRelativeRadius times its centre's modulus.
bool wants_polish(const RootDisc& d);

/// The root of p(t) = c[0] + c[1] t + ... + c[n] t^n in the verified,
/// count-1 disc d, by Newton's iteration in double-double from d's centre
/// (real iteration when d.real or `real`: the root is real), rounded to
/// double into
/// (re, im). Returns false (re, im untouched) where the centre is already
/// within kPolishRelativeRadius of the root by Newton's step in double, or
/// the iteration does not converge, leaves the disc, or meets a zero
/// derivative.
/// `real`: the caller holds a proof that d's root is real (a certified hit
/// in a band that is the positive real axis: band_verdict says Yes there
/// only for a disc proven real), so the iteration stays on the real line,
/// some four times cheaper than the complex one, and writes im = 0 (also
/// where the centre is kept: its real part then, true).
bool polish_root(const double* c, int n, const RootDisc& d, double& re, double& im, bool real = false);

/// The root in d (verified, count 1) by Newton's iteration in double from
/// a start that does not depend on d's centre to within d's width: the
/// centre rounded to a grid of 2^-20 of its modulus (on the real line
/// where `real` or d.real; off it, on the upper half-plane, the conjugate
/// of a disc below the axis taken; a disc across the axis is tried on it
/// first), then steps until one is below 2^-30 of the root (the next
/// error about its square: far below a float32's step).
/// Two discs around one root (another kernel's, another seed's) give the
/// same double, bit for bit, unless their centres round to different
/// grid points. True with the root in (re, im) (im >= 0 off the real
/// line); false (untouched) where the iteration does not settle, its end
/// lies outside d (or its conjugate; the iterates on the way may leave it),
/// or it meets a zero or non-finite derivative.
/// `slope` (optional): |p'| near the root, where it settles.
bool canonical_root(const double* c, int n, const RootDisc& d, double& re, double& im, bool real = false,
                    double* slope = nullptr);

/// Every point of [x - r, x + r] rounds to the same float32 (to nearest;
/// false where the interval holds a rounding step, or is not finite).
/// Rounding is monotone, so its two ends decide.
bool one_float(double x, double r);

/// x rounded to float32 (to nearest), as a double. Out of line on purpose:
/// GCC 12.2 at -O2/-O3 (its SLP vectorizer) stored the unrounded doubles for
/// an inlined pair (double)(float)re, (double)(float)im written to a struct,
/// rounding only the copy it compared.
double round_to_float(double x);

/// Newton's iteration in double on c from d's centre (polish_root's first
/// phase: to about a double's last place where it converges inside d):
/// (re, im), a start for polish_root_at_point. On the real line where
/// `real` or d.real (im = 0).
void polish_start(const double* c, int n, const RootDisc& d, double& re, double& im, bool real = false);

/// Whether a root at (re, im) (d's centre, or polish_root's root) may be
/// farther than 2^-24 of |z| (a float32 AOV's resolution) from the root of
/// the exact polynomial: the double coefficients c carry radii r (the exact
/// coefficients lie within them), which move a root by about
/// sum_k r_k |z|^k / |p'(z)| (to first order: an estimate that selects the
/// ill-conditioned roots, not a bound, and proves nothing). True also where
/// that is not finite.
bool polish_ill_conditioned(const double* c, const double* r, int n, double re, double im);

/// polish_ill_conditioned at (re, im) with |p'| there given (`slope`).
bool polish_ill_conditioned_at(const double* r, int n, double re, double im, double slope);

/// A ray in an object's space: F(origin + t direction) is its polynomial.
struct RayPoint {
    const SurfaceSpec* surface = nullptr;
    double origin[3] = {0, 0, 0};
    double direction[3] = {0, 0, 0};
};

/// The root in d of F along the ray, by Newton's iteration in double with
/// F evaluated at the point o' + t d' (from its terms), not from the ray
/// polynomial's coefficients: those are F's Taylor expansion at the eye,
/// whose rounding grows with the eye's distance to the power of the
/// degree, while F at a point near the surface rounds at the surface's own
/// scale. The derivative comes from the double coefficients c (degree n),
/// which only slows the iteration by their relative error. From (re, im)
/// (polish_start's root, or d's centre) to a step below 2^-30 relative
/// inside d: then (re, im) holds it. Returns false (re, im untouched)
/// otherwise. Proves nothing: only the value written moves, within d.
/// `real` as polish_root's.
bool polish_root_at_point(const RayPoint& ray, const double* c, int n, const RootDisc& d, double& re, double& im,
                          bool real = false);

}  // namespace argand::detail
