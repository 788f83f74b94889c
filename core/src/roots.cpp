// roots.cpp: the safe entry point find_roots (input checks, exact zero roots,
// roots at infinity, exact power-of-two scaling, dispatch, mapping back).
#include "argand/roots.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "solver.h"

namespace argand {
namespace {

/// True iff ldexp(v, e) is exact (no overflow, no loss in the subnormal range).
inline bool exact_ldexp(double v, int e, double& out) {
    out = std::ldexp(v, e);
    return std::isfinite(out) && std::ldexp(out, -e) == v;
}

/// Exponent of a finite nonzero double (floor(log2|v|)), without libm.
inline int exponent_of(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    return biased == 0 ? std::ilogb(v) : biased - 1023;
}

/// v * 2^k when that is exact: the result is a normal double (a product by a
/// power of two then only changes the exponent). Otherwise false.
inline bool exact_scale(double v, int k, double& out) {
    if (v == 0.0) { out = 0.0; return true; }
    if (k < -1022 || k > 1023) return exact_ldexp(v, k, out);
    out = v * pow2(k);
    return std::fabs(out) >= 0x1p-1022 && std::fabs(out) <= std::numeric_limits<double>::max();
}

/// Chooses t = 2^e u and an overall factor 2^f so that the scaled polynomial
/// has roots of modulus ~1 and coefficients of modulus <= ~1, and writes its
/// coefficients. Only exact scalings are accepted (the scaled polynomial must
/// have exactly the roots of the original divided by 2^e); otherwise falls
/// back to e = 0, then to no scaling at all.
int scale_polynomial(const double* c, int n, double* s) {
    const int lo_exp = exponent_of(c[0]);
    const int hi_exp = exponent_of(c[n]);
    const int e_guess = static_cast<int>(std::lround(static_cast<double>(lo_exp - hi_exp) / n));
    for (int attempt = 0; attempt < 2; ++attempt) {
        const int e = attempt == 0 ? e_guess : 0;
        // Largest exponent after the root scaling, to normalise by.
        int top = -100000;
        for (int k = 0; k <= n; ++k)
            if (c[k] != 0.0) top = std::max(top, exponent_of(c[k]) + e * k);
        const int f = -top;
        bool ok = true;
        for (int k = 0; k <= n && ok; ++k) {
            ok = exact_scale(c[k], e * k + f, s[k]);
        }
        if (ok) return e;
    }
    for (int k = 0; k <= n; ++k) s[k] = c[k];
    return 0;
}

/// Maps a disc from scaled coordinates (u) back to t = 2^e u, keeping the
/// enclosure: centres are exact unless they underflow, and any loss is added
/// to the radius; radii are rounded up.
void unscale_disc(RootDisc& d, int e) {
    if (e == 0) return;
    double re, im;
    double slack = 0.0;
    if (!exact_scale(d.re, e, re)) { re = std::ldexp(d.re, e); slack = add_up(slack, kDenormMin); }
    if (!exact_scale(d.im, e, im)) { im = std::ldexp(d.im, e); slack = add_up(slack, kDenormMin); }
    double r;
    if (!exact_scale(d.radius, e, r)) {
        r = std::ldexp(d.radius, e);
        if (std::ldexp(r, -e) < d.radius) r = next_up(r);
    }
    d.re = re;
    d.im = im;
    d.radius = slack > 0.0 ? add_up(r, slack) : r;
    if (!std::isfinite(d.re) || !std::isfinite(d.im)) {
        d.verified = false;
        d.real = false;
    }
    if (d.verified && !std::isfinite(d.radius)) {
        d.verified = false;
        d.real = false;
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
    if (exact_scale(rad, k, out)) return out;
    out = std::ldexp(rad, k);
    if (out == 0.0) return kDenormMin;
    if (std::isfinite(out) && std::ldexp(out, -k) < rad) out = next_up(out);
    return out;
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

Status find_roots(const double* coeffs, int n_coeffs, Method method, RootsResult& out,
                  const double* initial_re, const double* initial_im, const double* coeff_radius) {
    out.n_discs = 0;
    out.n_infinite = 0;
    out.wants_exact = false;
    out.escalation = 0;
    if (n_coeffs < 1) return Status::ZeroPolynomial;
    if (n_coeffs - 1 > kMaxDegree) return Status::TooLarge;
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
        e = scale_polynomial(coeffs + low, n, scaled);
        // The same exact scaling of the radii (rounded up where inexact):
        // scaled coefficient k is c_{low+k} 2^(e k + f), f read off the
        // leading coefficient's scaling.
        double scaled_radius[kMaxDegree + 1];
        if (radius_in != nullptr) {
            const int f = exponent_of(scaled[n]) - exponent_of(coeffs[top]) - e * n;
            for (int k = 0; k <= n; ++k) scaled_radius[k] = scale_radius_up(radius_in[low + k], e * k + f);
        }
        const double* rad = radius_in != nullptr ? scaled_radius : nullptr;
        Complex<double> seed[kMaxDegree];
        const bool use_seed = initial_re != nullptr && initial_im != nullptr;
        if (use_seed) {
            for (int i = 0; i < n; ++i) {
                seed[i] = Complex<double>(std::ldexp(initial_re[i], -e), std::ldexp(initial_im[i], -e));
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
            detail::solve_smith(scaled, rad, n, kernel, use_seed ? seed : nullptr, kr);
        }
        for (int i = 0; i < kr.n_discs; ++i) unscale_disc(kr.discs[i], e);
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

}  // namespace argand
