// roots_real_test.cpp: real_roots_in and narrow_real_root (roots_real.h)
// on polynomials whose roots are known exactly: products of (t - r) with
// dyadic r and of (t - b)^2 + c^2 with dyadic b, c, built in exact double
// arithmetic (small dyadics, no rounding: checked). Every interval returned
// holds exactly one of the known real roots, every known root in the
// segment is in one, and a double root (a tangent ray) is never reported
// as one simple root or as none.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "check.h"
#include "roots_real.h"

using argand::detail::narrow_real_root;
using argand::detail::real_roots_in;
using argand::detail::RealIsolation;

namespace {

/// a b, and whether it is exact.
bool exact_product(double a, double b, double& out) {
    out = a * b;
    return std::fma(a, b, -out) == 0.0;
}

/// p *= (t^2 + b1 t + b0), exactly (every product and sum checked exact).
bool multiply(std::vector<double>& p, double b0, double b1, double b2) {
    std::vector<double> q(p.size() + 2, 0.0);
    for (std::size_t i = 0; i < p.size(); ++i) {
        double terms[3];
        if (!exact_product(p[i], b0, terms[0]) || !exact_product(p[i], b1, terms[1]) ||
            !exact_product(p[i], b2, terms[2]))
            return false;
        for (int k = 0; k < 3; ++k) {
            const double before = q[i + k];
            q[i + k] = before + terms[k];
            if (q[i + k] - terms[k] != before || q[i + k] - before != terms[k]) return false;  // (not exact)
        }
    }
    while (q.size() > 1 && q.back() == 0.0) q.pop_back();
    p = q;
    return true;
}

bool multiply_linear(std::vector<double>& p, double root) {
    std::vector<double> q(p.size() + 1, 0.0);
    for (std::size_t i = 0; i < p.size(); ++i) {
        double a;
        if (!exact_product(p[i], -root, a)) return false;
        const double before = q[i];
        q[i] = before + a;
        if (q[i] - a != before || q[i] - before != a) return false;
        const double b = q[i + 1];
        q[i + 1] = b + p[i];
        if (q[i + 1] - p[i] != b || q[i + 1] - b != p[i]) return false;
    }
    p = q;
    return true;
}

struct Case {
    std::vector<double> c;
    std::vector<double> real_roots;  // with multiplicity
};

/// A random product: `simple` distinct real roots j/8 in [0.5, 9.5] (at least
/// 1/4 apart), `pairs` complex pairs b +- c i (c in 1/8 .. 1), `doubles`
/// double real roots. False where a coefficient would round.
bool random_case(std::mt19937_64& rng, int simple, int pairs, int doubles, Case& out) {
    std::uniform_int_distribution<int> root8(4, 76), im8(1, 8);
    out.c = {1.0};
    out.real_roots.clear();
    std::vector<double> used;
    auto fresh = [&](double r) {
        for (double u : used)
            if (std::fabs(u - r) < 0.25) return false;
        used.push_back(r);
        return true;
    };
    for (int i = 0; i < simple; ++i) {
        double r;
        do r = root8(rng) / 8.0;
        while (!fresh(r));
        if (!multiply_linear(out.c, r)) return false;
        out.real_roots.push_back(r);
    }
    for (int i = 0; i < doubles; ++i) {
        double r;
        do r = root8(rng) / 8.0;
        while (!fresh(r));
        if (!multiply_linear(out.c, r) || !multiply_linear(out.c, r)) return false;
        out.real_roots.push_back(r);
        out.real_roots.push_back(r);
    }
    for (int i = 0; i < pairs; ++i) {
        const double b = root8(rng) / 8.0, c = im8(rng) / 8.0;
        if (!multiply(out.c, b * b + c * c, -2.0 * b, 1.0)) return false;
    }
    return true;
}

}  // namespace

int main() {
    std::mt19937_64 rng(20261206);
    const std::vector<double> zeros(64, 0.0);
    int isolated = 0, refused = 0, cases = 0;
    double worst = 0.0;  // largest tight width over its limit
    int wide_tight = 0;  // tight roots of the coefficients with radii
    // Simple real roots and complex pairs: isolated exactly.
    for (int trial = 0; trial < 3000; ++trial) {
        const int simple = 1 + static_cast<int>(rng() % 5), pairs = static_cast<int>(rng() % 3);
        Case k;
        if (!random_case(rng, simple, pairs, 0, k)) continue;
        const int n = static_cast<int>(k.c.size()) - 1;
        if (n > 12) continue;
        ++cases;
        // A segment that holds some of the roots (ends at odd sixteenths:
        // never a root).
        const double a = (2 * static_cast<int>(rng() % 80) + 1) / 16.0;
        const double w = (2 * static_cast<int>(rng() % 80) + 1) / 16.0;
        RealIsolation iso;
        if (!real_roots_in(k.c.data(), zeros.data(), n, a, w, iso)) {
            ++refused;
            continue;
        }
        ++isolated;
        std::vector<double> inside;
        for (double r : k.real_roots)
            if (r >= a && r <= a + w) inside.push_back(r);
        std::sort(inside.begin(), inside.end());
        CHECK(iso.n == static_cast<int>(inside.size()));
        for (int i = 0; i < iso.n && i < static_cast<int>(inside.size()); ++i) {
            CHECK(iso.lo[i] < inside[i] && inside[i] < iso.hi[i]);
            if (i > 0) CHECK(iso.hi[i - 1] < iso.lo[i]);
            for (double r : k.real_roots)  // no other root in the interval
                CHECK(r == inside[i] || r < iso.lo[i] || r > iso.hi[i]);
            CHECK(iso.lo[i] < iso.guess[i] && iso.guess[i] < iso.hi[i]);
            // Narrowed: still around the root; tight means within a few
            // rounding errors of it.
            double lo = iso.lo[i], hi = iso.hi[i], value = NAN;
            bool tight = false;
            // The same root with every coefficient known to a relative
            // 2^-30 only (radii): the proven interval may stay wide, but
            // where it is tight its value is the centres' root all the same
            // (not the middle of the interval).
            {
                std::vector<double> radii(k.c.size());
                for (std::size_t j = 0; j < k.c.size(); ++j) radii[j] = std::ldexp(std::fabs(k.c[j]), -30);
                double wlo = iso.lo[i], whi = iso.hi[i], wvalue = NAN;
                bool wtight = false;
                if (narrow_real_root(k.c.data(), radii.data(), n, wlo, whi, &wtight, iso.guess[i], &wvalue)) {
                    CHECK(wlo <= inside[i] && inside[i] <= whi);
                    if (wtight) {
                        CHECK(wlo <= wvalue && wvalue <= whi);
                        const double r = inside[i];
                        double mag = 0.0, slope = 0.0, pw = 1.0;
                        for (int j = 0; j <= n; ++j, pw *= r) mag += std::fabs(k.c[j]) * pw;
                        pw = 1.0;
                        for (int j = 1; j <= n; ++j, pw *= r) slope += j * k.c[j] * pw;
                        CHECK(std::fabs(wvalue - r) <= 0x1p-53 * mag / std::fabs(slope) * (64.0 * n) + 16.0 * 0x1p-53 * r);
                        ++wide_tight;
                    }
                }
            }
            if (narrow_real_root(k.c.data(), zeros.data(), n, lo, hi, &tight, iso.guess[i], &value)) {
                CHECK(lo <= inside[i] && inside[i] <= hi);
                CHECK(lo >= iso.lo[i] && hi <= iso.hi[i]);
                if (tight) {
                    // Tight: within what a double evaluation of p can tell,
                    // u sum |c_k| r^k / |p'(r)| (the root's condition), times
                    // the evaluation's error constant (about 2n) and some slack,
                    // or a few units of r.
                    const double r = inside[i];
                    double mag = 0.0, slope = 0.0, pw = 1.0;
                    for (int j = 0; j <= n; ++j, pw *= r) mag += std::fabs(k.c[j]) * pw;
                    pw = 1.0;
                    for (int j = 1; j <= n; ++j, pw *= r) slope += j * k.c[j] * pw;
                    const double limit = 0x1p-53 * mag / std::fabs(slope) * (64.0 * n) + 16.0 * 0x1p-53 * r;
                    CHECK(hi - lo <= limit);
                    CHECK(lo <= value && value <= hi);
                    worst = std::max(worst, (hi - lo) / limit);
                }
            }
        }
    }
    CHECK(cases > 2000);
    CHECK(wide_tight > cases / 4);  // (not vacuous)
    std::printf("narrow_real_root: %d tight values with coefficient radii\n", wide_tight);
    CHECK(isolated > cases * 9 / 10);  // (not vacuous: nearly all proven)
    // Double roots (a tangent ray): never claimed as one simple root, or as
    // none, inside the segment.
    int double_cases = 0;
    for (int trial = 0; trial < 600; ++trial) {
        Case k;
        if (!random_case(rng, static_cast<int>(rng() % 3), static_cast<int>(rng() % 2), 1, k)) continue;
        const int n = static_cast<int>(k.c.size()) - 1;
        if (n > 12) continue;
        ++double_cases;
        RealIsolation iso;
        if (!real_roots_in(k.c.data(), zeros.data(), n, 1.0 / 16.0, 10.0, iso)) continue;
        // Proven: then the double root must not be inside (it always is: the
        // roots lie in [0.5, 9.5]).
        CHECK(false);
    }
    CHECK(double_cases > 300);
    // A family: coefficients with radii. (t - 2)(t - 3) with radius 1e-3 on
    // every coefficient still has two roots near 2 and 3 for every member;
    // with radius 0.3 a member has none (t^2 - 5t + 6.3 > 0 nowhere? it has
    // discriminant 25 - 25.2 < 0): the family cannot be proven either way.
    {
        const double c[] = {6.0, -5.0, 1.0};
        const double small[] = {1e-3, 1e-3, 1e-3}, large[] = {0.3, 0.3, 0.3};
        RealIsolation iso;
        CHECK(real_roots_in(c, small, 2, 1.0, 3.0, iso) && iso.n == 2);
        CHECK(iso.lo[0] < 2.0 && 2.0 < iso.hi[0] && iso.lo[1] < 3.0 && 3.0 < iso.hi[1]);
        CHECK(!real_roots_in(c, large, 2, 1.0, 3.0, iso));
    }
    // Bad input: refused, not guessed.
    {
        const double c[] = {6.0, NAN, 1.0}, ok[] = {6.0, -5.0, 1.0};
        RealIsolation iso;
        CHECK(!real_roots_in(c, zeros.data(), 2, 1.0, 3.0, iso));
        CHECK(!real_roots_in(ok, zeros.data(), 2, 1.0, 0.0, iso));
        CHECK(!real_roots_in(ok, zeros.data(), 13, 1.0, 3.0, iso));
        // The zero polynomial within its radii: nothing proven.
        const double zero[] = {0.0, 0.0, 0.0};
        CHECK(!real_roots_in(zero, zeros.data(), 2, 1.0, 3.0, iso));
    }
    std::printf("roots_real_test: %d cases, %d isolated, %d refused; %d with a double root; tight widths up to %.3g "
                "of their limit\n", cases, isolated, refused, double_cases, worst);
    return check_summary("roots_real_test");
}
