// pixel_decision.h: the proven decisions a pixel is made of (internal
// header of the renderer): where a root disc lies relative to the argument
// band, the clipping sphere and the other discs, and the double-double
// refinement of a disc. Every predicate is certain-only: Yes and No are
// proofs, Unknown claims nothing.
#pragma once

#include <cmath>
#include <cstdint>

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

/// proven_real's mirror test alone (d verified, count 1, meeting its mirror).
bool real_by_mirror(const RootDisc* all, int n_all, int self);

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
Verdict band_membership(const RootDisc& d, bool real, const FramePlan& plan, bool complex_space);

/// The clipping sphere |P| <= radius for every point P = o' + s d' with s
/// the modulus of a root in d: Yes (all inside, kept), No (all outside),
/// Unknown (straddling).
Verdict inside_clip(const ObjectRay& ray, double mod_lo, double mod_hi, double radius);

/// True iff disc j (count 1, verified, of the polynomial whose discs are
/// all[0..n_all), all verified) holds exactly the conjugate of the root in
/// disc b: it is the only disc that may meet b's mirror image.
bool is_mirror_twin(const RootDisc& b, const RootDisc& j, const RootDisc* all, int n_all, bool all_verified);

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

}  // namespace argand::detail
