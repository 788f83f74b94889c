// roots_real.h: the real roots of a ray polynomial in a segment, proven,
// without the complex ones.
//
// For the real surface (sigma = delta = 0, or an object with space: real)
// a pixel needs only the real roots t > 0 inside the clipping sphere, the
// first of them above all. real_roots_in isolates every real root of the
// polynomial in a segment [a, a + w] by Bernstein subdivision (the
// Vincent-Collins-Akritas family: Descartes' rule of signs on the Bernstein
// coefficients of each subinterval, de Casteljau halving), with every
// coefficient's rounding error bounded, so each verdict holds for every
// polynomial of the family c[k] +- r[k] (the ray polynomial's coefficient
// radii), the exact ray polynomial among them. It proves, or says it cannot:
// a double root (a tangent ray), a root on a subinterval's end that no
// sign settles, or a polynomial that vanishes everywhere within its radii
// is reported as not isolated (false), and the caller solves that ray the
// complex way (find_roots and its ladder). Internal header.
#pragma once

#include <cmath>

#include "argand/roots.h"

namespace argand::detail {

/// The real roots of a family in a segment: root i lies in the open
/// interval (lo[i], hi[i]) (doubles, ascending, disjoint), is simple, and is
/// the family member's only root in [lo[i], hi[i]]; the segment holds no
/// other root.
struct RealIsolation {
    int n = 0;
    double lo[kMaxDegree];
    double hi[kMaxDegree];
    double guess[kMaxDegree];  // in (lo, hi): where the control polygon crosses zero (proves nothing)
    int end_sign[kMaxDegree];  // the proven sign of p at the (exact, dyadic) right end of root i's subinterval
};

/// Isolates every real root in [a, a + w] (a, w finite doubles, w > 0; the
/// segment is the exact real interval, its right end not rounded) of every
/// polynomial p(t) = sum q_k t^k with |q_k - c[k]| <= r[k], k = 0..n (n <= 
/// kMaxDegree). True with `out` (RealIsolation's contract); false where it
/// cannot prove that (coefficients or bounds not finite, a root it cannot
/// separate or settle within its subdivision budget: a multiple or nearly
/// multiple root, a root on a subinterval's end, p's sign lost in its
/// rounding errors).
bool real_roots_in(const double* c, const double* r, int n, double a, double w, RealIsolation& out);

/// Narrows [lo, hi], an interval holding exactly one root of every family
/// member, simple (a RealIsolation interval), by Newton's iteration in
/// double from `start` (where it lies in (lo, hi); else the middle): kept
/// where the signs of p a few rounding errors either side of the iterate
/// are proven opposite for the whole family (the one root lies between).
/// Otherwise by bisection on proven signs. The interval never widens;
/// returns false (lo, hi as they were) where nothing narrower was proven.
/// `tight` (optional): set true only in the first case with Newton's
/// iteration settled (a step below 2^-26 of the iterate, or |p| at the
/// rounding noise of its evaluation on the centres c), false otherwise.
/// `value` (optional, set where tight): the settled iterate, in [lo, hi]:
/// the root of the centres' polynomial to about what a double evaluation
/// of it can tell, however wide the coefficients' radii keep the proven
/// interval (its middle may then be far from the root).
bool narrow_real_root(const double* c, const double* r, int n, double& lo, double& hi, bool* tight = nullptr,
                      double start = NAN, double* value = nullptr);

}  // namespace argand::detail
