// refine_dd_test.cpp: isolate_dd's Aberth sweep gives the same bits with
// the products' error-free parts as FMA instructions and as Dekker's split
// (aberth_sweep_dd), and isolate_dd separates a cluster the double discs
// left, with every disc holding exactly one of the roots, known exactly.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "check.h"
#include "refine_dd.h"

using namespace argand;
using argand::detail::aberth_sweep_dd;
using argand::detail::isolate_dd;
using argand::detail::RayCoefficients;

namespace {
/// prod_i (t - roots[i]) in double-double, exact while the products fit
/// (dyadic roots of few bits).
RayCoefficients<DoubleDouble> from_roots(const double* roots, int n) {
    RayCoefficients<DoubleDouble> p;
    p.n = n;
    p.finite = true;
    for (int k = 0; k <= n; ++k) {
        p.c[k] = DoubleDouble(k == 0 ? 1.0 : 0.0);
        p.r[k] = 0.0;
    }
    for (int i = 0; i < n; ++i) {  // multiply by (t - roots[i]), degree i -> i + 1
        for (int k = i + 1; k >= 1; --k) p.c[k] = p.c[k - 1] - p.c[k] * DoubleDouble(roots[i]);
        p.c[0] = -(p.c[0] * DoubleDouble(roots[i]));
    }
    return p;
}

bool same_bits(const Complex<DoubleDouble>* a, const Complex<DoubleDouble>* b, int n) {
    return std::memcmp(a, b, sizeof(Complex<DoubleDouble>) * n) == 0;
}
}  // namespace

int main() {
    std::mt19937_64 rng(24);
    std::uniform_real_distribution<double> u(-1.0, 1.0);

    // 1. The sweep: FMA and split, the same bits, on random polynomials of
    // every degree and random approximations (sweeps repeated from where the
    // last left them, some over a subset of the roots).
    for (int trial = 0; trial < 400; ++trial) {
        const int n = 2 + trial % (kMaxDegree - 1);
        DoubleDouble c[kMaxDegree + 1];
        for (int k = 0; k <= n; ++k) c[k] = DoubleDouble(u(rng)) + DoubleDouble(u(rng) * 0x1p-60);
        Complex<DoubleDouble> a[kMaxDegree], b[kMaxDegree];
        bool which[kMaxDegree];
        for (int i = 0; i < n; ++i) {
            a[i] = b[i] = Complex<DoubleDouble>(DoubleDouble(1.5 * u(rng)), DoubleDouble(1.5 * u(rng)));
            which[i] = (trial + i) % 3 != 0;
        }
        for (int s = 0; s < 6; ++s) {
            const bool* sel = s % 2 ? which : nullptr;
            const double la = aberth_sweep_dd(c, n, a, sel, true), lb = aberth_sweep_dd(c, n, b, sel, false);
            CHECK(std::memcmp(&la, &lb, sizeof la) == 0);
            CHECK(same_bits(a, b, n));
        }
    }

    // 2. A cluster the double discs cannot split: roots 1 and 1 + 2^-40 (and
    // -3, 2, 0.5 + 0.75 i, 0.5 - 0.75 i written as a real quadratic), every
    // coefficient exact. One disc of count 2 around the pair, the others at
    // their roots. isolate_dd gives six disjoint discs, each holding its root.
    {
        const double pair = 1.0 + 0x1p-40;
        const double real_roots[] = {1.0, pair, -3.0, 2.0};
        RayCoefficients<DoubleDouble> p = from_roots(real_roots, 4);
        // times t^2 - t + (0.25 + 0.5625) = (t - 0.5)^2 + 0.75^2
        RayCoefficients<DoubleDouble> q;
        q.n = 6;
        q.finite = true;
        const DoubleDouble quad[3] = {DoubleDouble(0.8125), DoubleDouble(-1.0), DoubleDouble(1.0)};
        for (int k = 0; k <= 6; ++k) {
            q.c[k] = DoubleDouble(0.0);
            q.r[k] = 0.0;
        }
        for (int i = 0; i <= 4; ++i)
            for (int j = 0; j <= 2; ++j) q.c[i + j] = q.c[i + j] + p.c[i] * quad[j];
        RootsResult res;
        res.n_discs = 5;
        res.discs[0] = RootDisc{1.0 + 0x1p-41, 0.0, 1e-6, 2, true, false};
        res.discs[1] = RootDisc{-3.0 + 1e-13, 0.0, 1e-12, 1, true, false};
        res.discs[2] = RootDisc{2.0 - 1e-13, 0.0, 1e-12, 1, true, false};
        res.discs[3] = RootDisc{0.5, 0.75 + 1e-14, 1e-12, 1, true, false};
        res.discs[4] = RootDisc{0.5, -0.75 - 1e-14, 1e-12, 1, true, false};
        CHECK(isolate_dd(q, res));
        CHECK(res.n_discs == 6);
        const double want_re[] = {1.0, pair, -3.0, 2.0, 0.5, 0.5}, want_im[] = {0, 0, 0, 0, 0.75, -0.75};
        for (int w = 0; w < 6; ++w) {
            int holding = 0;
            for (int i = 0; i < res.n_discs; ++i)
                holding += std::hypot(res.discs[i].re - want_re[w], res.discs[i].im - want_im[w]) <= res.discs[i].radius;
            CHECK(holding == 1);  // (the discs are disjoint: one holds it)
        }
        for (int i = 0; i < res.n_discs; ++i) CHECK(res.discs[i].count == 1 && res.discs[i].verified);
    }
    return check_summary("refine_dd_test");
}
