// find_roots_fuzz.cpp: libFuzzer target for argand::find_roots.
//
// Input: one control byte (method, raw or structured coefficients, seeds,
// coefficient radii), a coefficient count, the coefficients, then optional
// seeds and optional coefficient radii (|structured double|, so NaN and
// infinity too). Checked on
// every input, beyond "no crash, no undefined behaviour, no hang" (the
// sanitizers and libFuzzer's -timeout watch those):
//  * the status is the documented one (NonFinite, ZeroPolynomial, TooLarge);
//  * on Ok: 0 <= n_discs <= n, sum(count) + n_infinite == n, every count
//    >= 1, real only with verified, verified discs have a finite center and a
//    finite radius >= 0, and verified discs are disjoint (judged only when
//    certain, with a relative slack far above the rounding of the check).
// Whether a verified disc really holds its roots needs exact arithmetic: the
// corpus is replayed against python-flint by tests/test_fuzz_corpus.py.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "argand/roots.h"
#include "fuzz_input.h"

using argand::Method;
using argand::RootsResult;
using argand::Status;

namespace {

[[noreturn]] void fail(const char* what, int i, int j) {
    std::fprintf(stderr, "find_roots_fuzz: contract violated: %s (entries %d, %d)\n", what, i, j);
    std::abort();
}

bool certainly_overlap(const argand::RootDisc& a, const argand::RootDisc& b) {
    if (a.re == b.re && a.im == b.im) return true;  // same centre: closed discs meet
    const double distance = std::hypot(a.re - b.re, a.im - b.im);
    const double reach = a.radius + b.radius;
    return distance * (1.0 + 0x1p-40) < reach * (1.0 - 0x1p-40);
}

void check(const double* coeffs, int n_coeffs, Method method, const double* seed_re, const double* seed_im,
           const double* radii) {
    RootsResult out;
    const Status status = argand::find_roots(coeffs, n_coeffs, method, out, seed_re, seed_im, radii);
    const int n = n_coeffs - 1;
    bool finite = true, all_zero = true;
    for (int i = 0; i < n_coeffs; ++i) {
        finite = finite && std::isfinite(coeffs[i]) && (!radii || (std::isfinite(radii[i]) && radii[i] >= 0.0));
        all_zero = all_zero && coeffs[i] == 0.0;
    }
    if (n > argand::kMaxDegree) {
        if (status != Status::TooLarge) fail("degree above kMaxDegree not refused", n, 0);
        return;
    }
    if (!finite) {
        if (status != Status::NonFinite) fail("non-finite coefficient not refused", n, 0);
        return;
    }
    if (all_zero) {
        if (status != Status::ZeroPolynomial) fail("zero polynomial not refused", n, 0);
        return;
    }
    if (status != Status::Ok) fail("valid polynomial refused", static_cast<int>(status), n);
    if (out.n_discs < 0 || out.n_discs > n) fail("n_discs out of range", out.n_discs, n);
    if (out.n_infinite < 0 || out.n_infinite > n) fail("n_infinite out of range", out.n_infinite, n);
    long total = out.n_infinite;
    for (int i = 0; i < out.n_discs; ++i) {
        const argand::RootDisc& d = out.discs[i];
        if (d.count < 1) fail("an entry with count < 1", i, d.count);
        total += d.count;
        if (d.real && !d.verified) fail("real without verified", i, 0);
        if (!d.verified) continue;
        if (method == Method::Unverified) fail("the unverified method claimed a proof", i, 0);
        if (!std::isfinite(d.re) || !std::isfinite(d.im)) fail("verified disc with a non-finite centre", i, 0);
        if (!(d.radius >= 0.0) || !std::isfinite(d.radius)) fail("verified disc with an invalid radius", i, 0);
        for (int j = 0; j < i; ++j)
            if (out.discs[j].verified && certainly_overlap(d, out.discs[j])) fail("verified discs overlap", j, i);
    }
    if (total != n) fail("sum(count) + n_infinite != degree", static_cast<int>(total), n);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    argand_fuzz::FuzzInput in(data, size);
    const std::uint8_t control = in.byte();
    const Method method = static_cast<Method>(control & 3);
    const bool structured = (control & 4) != 0;
    const bool seeded = (control & 8) != 0;
    // Mostly the renderer's degrees (1..12), sometimes up to one past the
    // limit (65 coefficients) to reach the TooLarge refusal.
    const int n_coeffs = (control & 16) ? in.in_range(1, argand::kMaxDegree + 2) : in.in_range(1, 13);
    double coeffs[argand::kMaxDegree + 2];
    for (int i = 0; i < n_coeffs; ++i) coeffs[i] = structured ? in.structured_double() : in.raw_double();
    double seed_re[argand::kMaxDegree + 1], seed_im[argand::kMaxDegree + 1];
    if (seeded) {
        for (int i = 0; i < n_coeffs - 1 && i <= argand::kMaxDegree; ++i) {
            seed_re[i] = in.structured_double();
            seed_im[i] = in.structured_double();
        }
    }
    const bool with_radii = (control & 32) != 0;
    double radii[argand::kMaxDegree + 2];
    if (with_radii)
        for (int i = 0; i < n_coeffs; ++i) radii[i] = std::fabs(in.structured_double());
    check(coeffs, n_coeffs, method, seeded ? seed_re : nullptr, seeded ? seed_im : nullptr,
          with_radii ? radii : nullptr);
    return 0;
}
