// roots.cpp: the safe entry point find_roots (input checks, exact zero roots,
// roots at infinity, exact power-of-two scaling, dispatch, mapping back).
#include "argand/roots.h"

#include <cmath>
#include <cstdint>
#include <algorithm>
#include <cstring>
#include <limits>

#include "root_kernels.h"

namespace argand {
namespace {

/// Exponent of a finite nonzero double (floor(log2|v|)), without libm.
inline int exponent_of(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    return biased == 0 ? std::ilogb(v) : biased - 1023;
}

/// Writes s[k] = c[k] 2^(e k + f) for all k and returns true iff every one
/// is exact (finite, and nothing lost in the subnormal range).
inline bool scale_exactly(const double* c, int n, int e, int f, double* s) {
    for (int k = 0; k <= n; ++k)
        if (!exact_ldexp(c[k], e * k + f, s[k]) && c[k] != 0.0) return false;
    return true;
}

/// Chooses t = 2^e u and an overall factor 2^f so that the scaled polynomial
/// has roots of modulus ~1 and coefficients of modulus <= ~1, and writes its
/// coefficients. Only exact scalings are accepted (the scaled polynomial must
/// have exactly the roots of the original divided by 2^e). When putting the
/// largest coefficient at ~1 would lose bits of a tiny one, the factor is
/// raised just enough to keep every coefficient exact, as long as the largest
/// stays below 2^(1023 - 64 - 8) (headroom for Horner at |u| ~ 1). Tries the
/// root scaling from the end coefficients, then e = 0; otherwise no scaling.
int scale_polynomial(const double* c, int n, double* s, int& f_out) {
    const int lo_exp = exponent_of(c[0]);
    const int hi_exp = exponent_of(c[n]);
    // lround((lo_exp - hi_exp) / n) in integers (halves away from zero; a
    // quotient of such small integers is never within rounding of a half
    // without being one, so this is the same e as the double formula).
    const int diff = lo_exp - hi_exp;
    const int q = (2 * (diff < 0 ? -diff : diff) + n) / (2 * n);
    const int e_guess = diff < 0 ? -q : q;
    {
        // Fast path (the usual case): every nonzero coefficient is normal and
        // the scaled exponents span at most 1022 binades. Then the general
        // path below takes f = -top (a normal c has its lowest bit at or
        // above exponent - 52, so -1074 - low <= -1022 - min <= -top), and
        // every scaled coefficient c_k 2^(e k + f) has its exponent in
        // [min - top, 0], inside the normal range: the scaling only moves
        // exponent fields, exactly. Same e, f and s as the general path.
        std::uint64_t bits[kMaxDegree + 1];
        int top = -100000, bottom = 100000;
        bool fast = true;
        for (int k = 0; k <= n; ++k) {
            std::memcpy(&bits[k], &c[k], sizeof bits[k]);
            if (c[k] == 0.0) continue;
            const int biased = static_cast<int>((bits[k] >> 52) & 0x7ff);
            fast = fast && biased != 0;
            const int ex = biased + e_guess * k;
            top = std::max(top, ex);
            bottom = std::min(bottom, ex);
        }
        if (fast && top - bottom <= 1022) {
            const int f = 1023 - top;  // (biased exponents: top - 1023 is the true one)
            for (int k = 0; k <= n; ++k) {
                if (c[k] == 0.0) {
                    s[k] = c[k];
                    continue;
                }
                const std::uint64_t moved =
                    bits[k] + (static_cast<std::uint64_t>(static_cast<std::int64_t>(e_guess * k + f)) << 52);
                std::memcpy(&s[k], &moved, sizeof moved);
            }
            f_out = f;
            return e_guess;
        }
    }
    for (int attempt = 0; attempt < 2; ++attempt) {
        const int e = attempt == 0 ? e_guess : 0;
        // Largest exponent and lowest bit after the root scaling.
        int top = -100000, low = 100000;
        for (int k = 0; k <= n; ++k)
            if (c[k] != 0.0) {
                top = std::max(top, exponent_of(c[k]) + e * k);
                low = std::min(low, lowest_bit(c[k]) + e * k);
            }
        const int f = std::max(-top, -1074 - low);
        if (top + f > 1023 - kMaxDegree - 8) continue;
        if (scale_exactly(c, n, e, f, s)) {
            f_out = f;
            return e;
        }
    }
    for (int k = 0; k <= n; ++k) s[k] = c[k];
    f_out = 0;
    return 0;
}

/// Maps a disc from scaled coordinates (u) back to t = 2^e u, keeping the
/// enclosure: where a centre component lands in the subnormal range it is
/// rounded (an error of at most half the smallest subnormal, the absolute
/// term that relative bounds miss) and a smallest subnormal per component is
/// added to the radius; radii are rounded up. Returns true iff the mapping
/// was exact (then every claim carries over unchanged); false means the disc
/// was enlarged, so its count and its disjointness from the others must be
/// proven again (see reconcile_enlarged).
bool unscale_disc(RootDisc& d, int e) {
    if (e == 0) return true;
    double re, im;
    double slack = 0.0;
    bool exact = true;
    if (!exact_ldexp(d.re, e, re)) { exact = false; slack = add_up(slack, kDenormMin); }
    if (!exact_ldexp(d.im, e, im)) { exact = false; slack = add_up(slack, kDenormMin); }
    double r;
    if (!exact_ldexp(d.radius, e, r)) {
        exact = false;
        if (std::ldexp(r, -e) < d.radius) r = next_up(r);
    }
    d.re = re;
    d.im = im;
    d.radius = slack > 0.0 ? add_up(r, slack) : r;
    if (!std::isfinite(d.re) || !std::isfinite(d.im) || !std::isfinite(d.radius)) {
        d.verified = false;
        d.real = false;
    }
    return exact;
}

/// After some discs were enlarged by the back-mapping, restores the contract.
/// If the verified discs account for every root (all verified, counts adding
/// up to n: a covering family), enlarging members keeps Smith's component
/// property (a component of the enlarged family is a union of components of
/// the old one), so the discs are regrouped by enclose_and_merge into proven
/// disjoint enclosures. Otherwise an enlarged disc may have reached a root
/// that no verified disc accounts for, or another disc: it is unverified
/// (exactly mapped discs keep their claims, and their disjointness).
void reconcile_enlarged(detail::KernelResult& kr, const bool* enlarged, int n) {
    int total = 0;
    bool all_verified = true;
    for (int i = 0; i < kr.n_discs; ++i) {
        all_verified = all_verified && kr.discs[i].verified;
        total += kr.discs[i].count;
    }
    if (all_verified && total == n && kr.n_discs > 0) {
        detail::MemberDisc members[kMaxDegree];
        for (int i = 0; i < kr.n_discs; ++i)
            members[i] = {kr.discs[i].re, kr.discs[i].im, kr.discs[i].radius, kr.discs[i].count};
        kr.n_discs = detail::enclose_and_merge(members, kr.n_discs, true, kr.discs);
        kr.wants_exact = false;
        for (int i = 0; i < kr.n_discs; ++i) kr.wants_exact = kr.wants_exact || kr.discs[i].count > 1;
        return;
    }
    for (int i = 0; i < kr.n_discs; ++i)
        if (enlarged[i] && kr.discs[i].verified) {
            kr.discs[i].verified = false;
            kr.discs[i].real = false;
            kr.wants_exact = true;
        }
}

}  // namespace

bool method_from_name(const char* name, Method& out) {
    static const struct { const char* name; Method method; } table[] = {
        {"auto", Method::Auto}, {"paper", Method::Paper}, {"smith", Method::Smith}, {"unverified", Method::Unverified}};
    for (const auto& entry : table)
        if (std::strcmp(name, entry.name) == 0) {
            out = entry.method;
            return true;
        }
    return false;
}

namespace {

/// rad * 2^k rounded up (a radius in scaled coordinates); 0 stays 0.
double scale_radius_up(double rad, int k) {
    if (rad == 0.0) return 0.0;
    double out;
    if (exact_ldexp(rad, k, out)) return out;
    out = std::ldexp(rad, k);
    if (out == 0.0) return kDenormMin;
    if (std::isfinite(out) && std::ldexp(out, -k) < rad) out = next_up(out);
    return out;
}

/// out = v 2^s when that is exact without leaving the normal range (v zero,
/// or v normal with v 2^s normal): only the exponent field moves. False
/// (out untouched) otherwise; the caller then takes the general path.
inline bool shift_exponent(double v, int s, double& out) {
    if (v == 0.0) {
        out = v;
        return true;
    }
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    if (static_cast<unsigned>(biased - 1) >= 0x7feu || static_cast<unsigned>(biased + s - 1) >= 0x7feu) return false;
    bits += static_cast<std::uint64_t>(static_cast<std::int64_t>(s)) << 52;
    std::memcpy(&out, &bits, sizeof out);
    return true;
}

/// out = v p for a power of two p, true iff that is exact: the product is
/// normal (a product by a power of two with a normal result loses nothing),
/// or v is zero. NaN and infinities fail.
inline bool times_power_exact(double v, double p, double& out) {
    out = v * p;
    const double a = std::fabs(out);
    return (a >= 0x1p-1022 && a <= std::numeric_limits<double>::max()) || v == 0.0;
}

/// The kernel on the scaled polynomial, with its discs mapped back to t and
/// the contract restored where the mapping enlarged one (shared by the fast
/// and the general entry).
void solve_scaled(const double* scaled, const double* rad, int n, int e, Method method, const double* initial_re,
                  const double* initial_im, detail::KernelResult& kr, bool seed_or_scratch) {
    Complex<double> seed[kMaxDegree];
    const bool use_seed = initial_re != nullptr && initial_im != nullptr;
    if (use_seed) {
        for (int i = 0; i < n; ++i) {
            double sr, si;
            exact_ldexp(initial_re[i], -e, sr);
            exact_ldexp(initial_im[i], -e, si);
            seed[i] = Complex<double>(sr, si);
            if (!is_finite(seed[i])) seed[i] = Complex<double>(0.5 + 0.1 * i, 0.3 + 0.05 * i);
        }
    }
    if (method == Method::Paper && rad == nullptr) {
        detail::solve_paper(scaled, n, kr);
    } else {
        // (With coefficient radii the paper's per-root Krawczyk test is
        // not extended to the family: Smith's discs, with the paper's
        // double-double retry, prove the roots instead.)
        const Method kernel = method == Method::Paper ? Method::Auto : method;
        detail::solve_smith(scaled, rad, n, kernel, use_seed ? seed : nullptr, kr, seed_or_scratch);
    }
    if (e == 0) return;
    bool enlarged[kMaxDegree];
    bool any_enlarged = false;
    // 2^e as a double (the fast entry's e is within [-1022, 1023]; otherwise
    // 0, and every product below fails its check).
    const double scale = e >= -1022 && e <= 1023 ? pow2(e) : 0.0;
    for (int i = 0; i < kr.n_discs; ++i) {
        RootDisc& d = kr.discs[i];
        double re, im, r;
        // Exact (the product by a power of two lands in the normal range, or
        // is of a zero): every claim carries over.
        if (times_power_exact(d.re, scale, re) && times_power_exact(d.im, scale, im) &&
            times_power_exact(d.radius, scale, r)) {
            d.re = re;
            d.im = im;
            d.radius = r;
            enlarged[i] = false;
            continue;
        }
        enlarged[i] = !unscale_disc(d, e);
        any_enlarged = any_enlarged || enlarged[i];
    }
    if (any_enlarged && method != Method::Unverified) reconcile_enlarged(kr, enlarged, n);
}

/// find_roots's usual case in one pass over the input: nonzero end
/// coefficients (no root at 0 or at infinity), every coefficient zero or
/// normal, every radius zero or normal, and the fast exact scaling of
/// scale_polynomial applicable to the coefficients and the radii alike
/// (every scaled radius normal: exact, so equal to scale_radius_up's). Then
/// the result is the general path's, computed with less bookkeeping. Returns
/// false, having written nothing, when the input is not of that kind.
bool find_roots_fast(const double* c, int n_coeffs, Method method, RootsResult& out, const double* initial_re,
                     const double* initial_im, const double* coeff_radius, bool seed_or_scratch) {
    const int n = n_coeffs - 1;
    if (n < 1 || c[0] == 0.0 || c[n] == 0.0) return false;
    std::uint64_t bits[kMaxDegree + 1];
    std::memcpy(&bits[0], &c[0], sizeof bits[0]);
    std::memcpy(&bits[n], &c[n], sizeof bits[n]);
    // scale_polynomial's fast path (see there): the same e and f.
    const int diff = static_cast<int>((bits[0] >> 52) & 0x7ff) - static_cast<int>((bits[n] >> 52) & 0x7ff);
    const int q = (2 * (diff < 0 ? -diff : diff) + n) / (2 * n);
    const int e = diff < 0 ? -q : q;
    int top = -100000, bottom = 100000;
    for (int k = 0; k <= n; ++k) {
        std::memcpy(&bits[k], &c[k], sizeof bits[k]);
        const int biased = static_cast<int>((bits[k] >> 52) & 0x7ff);
        // Not finite, or subnormal (a zero is fine: its exponent is not used).
        // (The end coefficients are nonzero; if one is not finite or
        // subnormal, e above is meaningless but this returns first.)
        if (biased == 0x7ff || (biased == 0 && c[k] != 0.0)) return false;
        if (c[k] == 0.0) continue;
        const int ex = biased + e * k;
        top = std::max(top, ex);
        bottom = std::min(bottom, ex);
    }
    if (top - bottom > 1022) return false;
    const int f = 1023 - top;
    double scaled[kMaxDegree + 1], scaled_radius[kMaxDegree + 1];
    bool has_radius = false;
    for (int k = 0; k <= n; ++k) {
        if (c[k] == 0.0) {
            scaled[k] = c[k];
        } else {
            const std::uint64_t moved = bits[k] + (static_cast<std::uint64_t>(static_cast<std::int64_t>(e * k + f)) << 52);
            std::memcpy(&scaled[k], &moved, sizeof moved);
        }
        if (coeff_radius == nullptr) continue;
        const double r = coeff_radius[k];
        if (r == 0.0) {
            scaled_radius[k] = 0.0;
            continue;
        }
        // Positive and normal, and so after the scaling (NaN, negative,
        // infinite, subnormal, or an inexact scaling: the general path).
        if (!(r >= 0x1p-1022) || !shift_exponent(r, e * k + f, scaled_radius[k])) return false;
        has_radius = true;
    }
    out.n_discs = 0;
    out.n_infinite = 0;
    detail::KernelResult kr;
    solve_scaled(scaled, has_radius ? scaled_radius : nullptr, n, e, method, initial_re, initial_im, kr, seed_or_scratch);
    out.escalation = kr.escalation;
    out.wants_exact = kr.wants_exact;
    out.n_discs = kr.n_discs;
    for (int i = 0; i < kr.n_discs; ++i) out.discs[i] = kr.discs[i];
    return true;
}

/// Every disc becomes an unverified estimate (nothing is claimed).
void unverify_all(RootsResult& out) {
    for (int i = 0; i < out.n_discs; ++i) {
        out.discs[i].verified = false;
        out.discs[i].real = false;
    }
    out.wants_exact = true;
}

}  // namespace

namespace {
Status find_roots_impl(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                       const double* initial_re, const double* initial_im, const double* coeff_radius,
                       bool seed_or_scratch);
}  // namespace

Status find_roots(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                  const double* initial_re, const double* initial_im, const double* coeff_radius) {
    return find_roots_impl(coeffs, n_coeffs, method, out, initial_re, initial_im, coeff_radius, false);
}

namespace detail {
Status find_roots_lane_seeded(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                              const double* seed_re, const double* seed_im, const double* coeff_radius) {
    return find_roots_impl(coeffs, n_coeffs, method, out, seed_re, seed_im, coeff_radius, true);
}
}  // namespace detail

namespace {
Status find_roots_impl(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                       const double* initial_re, const double* initial_im, const double* coeff_radius,
                       bool seed_or_scratch) {
    out.n_discs = 0;
    out.n_infinite = 0;
    out.wants_exact = false;
    out.escalation = 0;
    if (n_coeffs < 1) return Status::ZeroPolynomial;
    if (n_coeffs - 1 > kMaxDegree) return Status::TooLarge;
    if (find_roots_fast(coeffs, n_coeffs, method, out, initial_re, initial_im, coeff_radius, seed_or_scratch))
        return Status::Ok;
    for (int k = 0; k < n_coeffs; ++k)
        if (!std::isfinite(coeffs[k])) return Status::NonFinite;
    bool has_radius = false;
    if (coeff_radius != nullptr)
        for (int k = 0; k < n_coeffs; ++k) {
            if (!(coeff_radius[k] >= 0.0) || !std::isfinite(coeff_radius[k])) return Status::NonFinite;
            has_radius = has_radius || coeff_radius[k] > 0.0;
        }
    const double* radius_in = has_radius ? coeff_radius : nullptr;

    // Roots at infinity: exactly zero leading coefficients.
    int top = n_coeffs - 1;
    while (top >= 0 && coeffs[top] == 0.0) --top;
    if (top < 0) return Status::ZeroPolynomial;
    out.n_infinite = (n_coeffs - 1) - top;

    // Exact roots at zero: exactly zero constant terms.
    int low = 0;
    while (coeffs[low] == 0.0) ++low;
    const int n = top - low;
    // A stripped zero that is not exactly zero over the whole family (the
    // family holds polynomials of another degree, or without the root 0):
    // the discs below would be about another family; claim nothing.
    bool family_degenerate = false;
    if (radius_in != nullptr) {
        for (int k = top + 1; k < n_coeffs; ++k) family_degenerate = family_degenerate || radius_in[k] > 0.0;
        for (int k = 0; k < low; ++k) family_degenerate = family_degenerate || radius_in[k] > 0.0;
    }

    detail::KernelResult kr;
    int e = 0;
    if (n >= 1) {
        double scaled[kMaxDegree + 1];
        int f = 0;
        e = scale_polynomial(coeffs + low, n, scaled, f);
        // The same exact scaling of the radii (rounded up where inexact):
        // scaled coefficient k is c_{low+k} 2^(e k + f).
        double scaled_radius[kMaxDegree + 1];
        if (radius_in != nullptr)
            for (int k = 0; k <= n; ++k) scaled_radius[k] = scale_radius_up(radius_in[low + k], e * k + f);
        const double* rad = radius_in != nullptr ? scaled_radius : nullptr;
        solve_scaled(scaled, rad, n, e, method, initial_re, initial_im, kr, seed_or_scratch);
    }
    out.escalation = kr.escalation;
    out.wants_exact = kr.wants_exact;

    if (low == 0 || method == Method::Unverified) {
        // (The unverified method claims nothing, not even exact zeros.)
        out.n_discs = kr.n_discs;
        for (int i = 0; i < kr.n_discs; ++i) out.discs[i] = kr.discs[i];
        if (low > 0) out.discs[out.n_discs++] = RootDisc{0.0, 0.0, 0.0, low, false, false};
        if (family_degenerate) unverify_all(out);
        return Status::Ok;
    }

    // Combine with the exact zero disc D(0, 0) of multiplicity `low`.
    RootDisc zero;
    zero.re = zero.im = zero.radius = 0.0;
    zero.count = low;
    zero.verified = true;
    zero.real = true;
    bool all_verified = true;
    for (int i = 0; i < kr.n_discs; ++i) all_verified = all_verified && kr.discs[i].verified;
    if (all_verified) {
        // Every disc (and the point 0) is a member of a covering family.
        detail::MemberDisc members[kMaxDegree + 1];
        for (int i = 0; i < kr.n_discs; ++i)
            members[i] = {kr.discs[i].re, kr.discs[i].im, kr.discs[i].radius, kr.discs[i].count};
        members[kr.n_discs] = {0.0, 0.0, 0.0, low};
        out.n_discs = detail::enclose_and_merge(members, kr.n_discs + 1, true, out.discs);
        // Keep the "real" proof of discs that were not merged (a merged disc
        // is symmetric with an odd count, or keeps real = false).
        if (family_degenerate) unverify_all(out);
        return Status::Ok;
    }
    // Some discs unverified: a verified disc holds its roots of p / t^low;
    // if it also contains 0 it holds the zeros too; if undecided, no proof.
    bool zero_absorbed = false;
    int k = 0;
    for (int i = 0; i < kr.n_discs; ++i) {
        RootDisc d = kr.discs[i];
        if (d.verified) {
            const double lo = detail::dist_down(d.re, d.im, 0.0, 0.0);
            const double hi = detail::dist_up(d.re, d.im, 0.0, 0.0);
            if (hi <= d.radius && !zero_absorbed) {
                d.count += low;
                d.real = d.im == 0.0 && (d.count % 2 == 1);
                zero_absorbed = true;
            } else if (!(lo > d.radius)) {
                d.verified = false;
                d.real = false;
            }
        }
        out.discs[k++] = d;
    }
    if (!zero_absorbed) out.discs[k++] = zero;
    out.n_discs = k;
    if (family_degenerate) unverify_all(out);
    return Status::Ok;
}

}  // namespace

}  // namespace argand
