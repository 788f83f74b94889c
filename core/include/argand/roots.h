// roots.h: all complex roots of a real polynomial, with proven enclosures.
//
// Two tiers, as in FLINT (_acb_poly_x under acb_poly_x):
//  * find_roots(): the safe entry point. Validates input, strips exact zero
//    roots and roots at infinity, scales the polynomial by exact powers of
//    two, runs the chosen method and maps the discs back.
//  * detail::solve_smith() / detail::solve_paper() (core/src/root_kernels.h): the
//    kernels. Preconditions: degree >= 1, finite coefficients, nonzero p_0
//    and p_n. No allocation.
#pragma once

#include <cstdint>

namespace argand {

/// Largest degree handled (stack buffers are sized from it).
constexpr int kMaxDegree = 64;

enum class Method : int {
    Auto = 0,        // double Smith, escalating to double-double only where needed
    Paper = 1,       // the paper's AllCPolyZero (Hammer et al.), dd retry (sec. 2.6)
    Smith = 2,       // Aberth-Ehrlich + Smith's inclusion discs, in double
    Unverified = 3,  // the same approximations, no proof (speed reference)
};

/// One output entry. The closed disc D(center, radius).
///
/// If verified: the disc contains exactly `count` roots of p counted with
/// multiplicity (a proof, under IEEE-754 binary64 round-to-nearest), and it is
/// disjoint from every other verified disc of the same polynomial.
/// If real (only ever set together with verified): the disc contains at least
/// one real root (it is symmetric about the real axis and count is odd; the
/// renderer's batch also flags a count-1 disc that no other disc of its
/// polynomial can meet the mirror image of: its one root is real).
/// If not verified: center is the best approximation available, radius an
/// estimate of its error that is NOT proven, count the number of roots the
/// entry stands for (not proven).
/// (A trivial aggregate: arrays of it are not zeroed; find_roots writes
/// every field of every entry it reports.)
struct RootDisc {
    double re;
    double im;
    double radius;
    std::int32_t count;
    bool verified;
    bool real;
};

/// Result of one polynomial.
struct RootsResult {
    std::int32_t n_discs = 0;      // entries used in discs[]
    std::int32_t n_infinite = 0;   // roots at infinity: declared degree minus true degree
    // True when some entry is unverified, or a cluster (count > 1) remains;
    // Method::Auto callers may then ask for an exact fallback (the Python
    // layer uses python-flint on the exact rational coefficients).
    bool wants_exact = false;
    // How far the solver had to escalate: 0 = double, 1 = double-double.
    std::int32_t escalation = 0;
    RootDisc discs[kMaxDegree];
};

/// The method named "auto", "paper", "smith" or "unverified"; false (out
/// untouched) for any other name.
bool method_from_name(const char* name, Method& out);

enum class Status : int {
    Ok = 0,
    NonFinite = 1,     // a coefficient is NaN or infinite
    ZeroPolynomial = 2,// every coefficient is zero: every point is a root
    TooLarge = 3,      // degree > kMaxDegree
};

/// Finds all roots of p(t) = coeffs[0] + coeffs[1] t + ... + coeffs[n] t^n,
/// n = n_coeffs - 1 (the declared degree).
///
/// Guarantees (for every method but Unverified):
///  * every entry with verified = true is proven as documented on RootDisc;
///  * verified discs are pairwise disjoint;
///  * sum of count over all entries + n_infinite == n, and when every entry
///    is verified, the discs contain all roots of p.
/// Leading coefficients that are exactly zero are roots at infinity: they are
/// counted in n_infinite and produce no disc. A tiny nonzero leading
/// coefficient gives huge roots; those that overflow binary64 come back
/// unverified with an infinite center. Exact zero constant terms give one
/// exact verified disc D(0, 0) with their multiplicity.
/// Degree 0 (a nonzero constant) gives no disc.
/// `initial` (optional, length n) seeds the approximations (e.g. from a
/// neighbouring pixel); it never affects what is proven, only speed.
///
/// `coeff_radius` (optional, n_coeffs finite entries >= 0; NonFinite
/// otherwise) makes the input a family of polynomials: every guarantee above
/// (counts with multiplicity, disjointness, `real`) then holds for EVERY real
/// polynomial q with |q_k - coeffs[k]| <= coeff_radius[k] for all k. This is
/// how a caller whose coefficients carry a proven error bound (the ray
/// caster's) gets discs that are proven for the exact polynomial. A
/// coefficient counts as exactly zero (roots at infinity, exact roots at 0)
/// only when its radius is 0 too; if a stripped zero has a nonzero radius,
/// or the leading coefficient's interval contains 0, nothing is verified.
/// With radii, Method::Paper proves its roots with Smith's discs (its
/// Krawczyk test is not extended to coefficient intervals).
Status find_roots(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                  const double* initial_re = nullptr, const double* initial_im = nullptr,
                  const double* coeff_radius = nullptr);

}  // namespace argand
