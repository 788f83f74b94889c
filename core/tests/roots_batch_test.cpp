// roots_batch_test.cpp: the batched root kernels (roots_batch_kernel.h)
// against the scalar reference, lane by lane:
//  * every lane a kernel proves has exactly the radii smith_radii_lanes_reference
//    computes for the same scaled polynomial and approximations, bit for
//    bit, and passes the same separation test (so the scalar rounding
//    argument is the one that holds in the lanes);
//  * every instruction set this CPU runs gives bit-identical lanes;
//  * find_roots_rows on batches mixing easy and hard rows (exact multiple
//    roots, clusters, subnormal and zero coefficients, huge ranges) claims
//    only what holds for polynomials with known exact roots (dyadic roots,
//    expansion exact), and agrees with find_roots row by row (same counts,
//    verified discs overlap);
//  * under flush-to-zero / denormals-are-zero nothing enters a lane.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "../src/roots_batch_block.h"
#include "../src/root_kernels.h"
#include "argand/roots.h"
#include "argand/roots_batch.h"

#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

using namespace argand;

static int failures = 0;
#define CHECK(cond, ...)                                                  \
    do {                                                                  \
        if (!(cond)) {                                                    \
            if (++failures <= 30) {                                       \
                std::printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
                std::printf(__VA_ARGS__);                                 \
                std::printf("\n");                                        \
            }                                                             \
        }                                                                 \
    } while (0)

static bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

using KernelFn = int (*)(BatchBlock&, bool);

// ---------------------------------------------------------------------------
// The kernel against smith_radii_lanes_reference, and the instruction sets against
// each other.
// ---------------------------------------------------------------------------

static void fill_block(BatchBlock& b, int n, std::mt19937_64& rng, int kind, bool family) {
    std::normal_distribution<double> normal;
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    b.n = n;
    b.slack = n * std::ldexp(1.0, std::max(8 * n - 1070, -1014));
    for (int i = 0; i < n; ++i) {
        b.circle_re[i] = std::cos(2.0 * detail::kPi * i / n + 0.4);
        b.circle_im[i] = std::sin(2.0 * detail::kPi * i / n + 0.4);
    }
    for (int l = 0; l < kBatchLanes; ++l) {
        b.active[l] = 1.0;
        for (int k = 0; k <= n; ++k) {
            double v = kind == 0 ? normal(rng) : uni(rng);
            if (kind == 2 && l % 3 == 0 && k > 0 && k < n) v = 0.0;  // sparse rows
            if (kind == 3 && l % 4 == 1) v = std::ldexp(1.0, (int)(rng() % 3)) * (k % 2 ? -1 : 1);  // clusters / multiples
            b.c[k][l] = v;
        }
        if (b.c[0][l] == 0.0) b.c[0][l] = 0.5;
        if (b.c[n][l] == 0.0) b.c[n][l] = 1.0;
        // Roots and coefficients at other scales (exact): t -> 2^s t, times 2^g.
        const int sh = (int)(rng() % 41) - 20, g = (int)(rng() % 201) - 100;
        for (int k = 0; k <= n; ++k) b.c[k][l] = std::ldexp(b.c[k][l], g - sh * k);
        // Coefficient radii (a family), sometimes zero, sometimes tiny
        // enough to round when scaled.
        for (int k = 0; k <= n; ++k)
            b.rad[k][l] = family && rng() % 4 ? std::fabs(b.c[k][l]) * std::ldexp(1.0, -(int)(rng() % 40) - 20) : 0.0;
    }
    b.has_radius = family ? 1 : 0;
}

static void kernel_matches_scalar_bound() {
    std::vector<std::pair<const char*, KernelFn>> kernels = {{"sse2", &batch_generic::solve_block}};
#if defined(__x86_64__)
    if (batch_isa_supported(BatchIsa::Avx2)) kernels.push_back({"avx2", &batch_avx2::solve_block});
    if (batch_isa_supported(BatchIsa::Avx512)) kernels.push_back({"avx512", &batch_avx512::solve_block});
#endif
    std::mt19937_64 rng(15);
    long lanes = 0, proven = 0;
    for (int n = 1; n <= kBatchMaxDegree; ++n)
        for (int rep = 0; rep < 200; ++rep) {
            BatchBlock input;
            const bool family = rep % 3 == 2;
            fill_block(input, n, rng, rep % 4, family);
            if (rep % 5 == 4) input.active[rep % kBatchLanes] = 0.0;  // padding lane
            BatchBlock first;
            for (std::size_t kk = 0; kk < kernels.size(); ++kk) {
                BatchBlock b = input;
                kernels[kk].second(b, true);
                if (kk == 0) {
                    first = b;
                    continue;
                }
                for (int l = 0; l < kBatchLanes; ++l) {
                    bool same = same_bits(b.ok[l], first.ok[l]);
                    for (int i = 0; i < n; ++i)
                        same = same && same_bits(b.xr[i][l], first.xr[i][l]) && same_bits(b.xi[i][l], first.xi[i][l]) &&
                               same_bits(b.r[i][l], first.r[i][l]);
                    CHECK(same, "%s and %s differ: degree %d lane %d", kernels[kk].first, kernels[0].first, n, l);
                }
            }
            for (int l = 0; l < kBatchLanes; ++l) {
                ++lanes;
                if (input.active[l] == 0.0) {
                    CHECK(first.ok[l] == 0.0, "padding lane %d proven", l);
                    continue;
                }
                if (first.ok[l] == 0.0) continue;
                ++proven;
                // The kernel scaled the lane in place (t = 2^e u) and mapped
                // its discs back exactly: compare in the scaled coordinates.
                const int e = (int)first.e[l];
                double c[kBatchMaxDegree + 1];
                for (int k = 0; k <= n; ++k) c[k] = first.c[k][l];
                Complex<double> x[kBatchMaxDegree];
                for (int i = 0; i < n; ++i)
                    x[i] = Complex<double>(std::ldexp(first.xr[i][l], -e), std::ldexp(first.xi[i][l], -e));
                double r[kBatchMaxDegree], low[kBatchMaxDegree * kBatchMaxDegree];
                double rad[kBatchMaxDegree + 1];
                for (int k = 0; k <= n; ++k) rad[k] = first.rad[k][l];  // scaled by the kernel (rounded up)
                for (int k = 0; k <= n; ++k)
                    CHECK(first.rad[k][l] >= std::ldexp(input.rad[k][l], (int)(std::ilogb(first.c[k][l]) - std::ilogb(input.c[k][l]))) || input.c[k][l] == 0.0,
                          "degree %d lane %d: radius %d scaled down", n, l, k);
                const double* rp = family ? rad : nullptr;
                const bool ok = detail::smith_radii_lanes_reference(c, n, x, r, low, rp);
                CHECK(ok, "degree %d lane %d: the kernel proved what smith_radii_lanes_reference refuses", n, l);
                if (!ok) continue;
                for (int i = 0; i < n; ++i) {
                    CHECK(same_bits(std::ldexp(r[i], e), first.r[i][l]), "degree %d lane %d root %d: radius %.17g, scalar %.17g",
                          n, l, i, first.r[i][l], std::ldexp(r[i], e));
                    for (int j = i + 1; j < n; ++j)
                        CHECK(low[i * n + j] > add_up(r[i], r[j]), "degree %d lane %d: discs %d, %d not separated", n, l,
                              i, j);
                }
                // The proven radius (rigorous, independent of the kernel's
                // own loop): the slow smith_radii with outward rounding
                // everywhere gives radii the fast ones must not undercut by
                // more than the final inflation factors.
                double slow[kBatchMaxDegree];
                if (detail::smith_radii(c, n, x, slow, nullptr, rp))
                    for (int i = 0; i < n; ++i)
                        CHECK(std::ldexp(first.r[i][l], -e) >= slow[i] * (1.0 - 1e-12), "degree %d lane %d root %d: %.17g < slow %.17g", n,
                              l, i, first.r[i][l], slow[i]);
            }
        }
    std::printf("kernel vs smith_radii_lanes_reference (a third of the blocks with coefficient radii): %ld lanes, %ld proven, %zu instruction sets\n", lanes, proven,
                kernels.size());
    CHECK(proven > lanes / 2, "only %ld of %ld lanes proven", proven, lanes);
}

// ---------------------------------------------------------------------------
// find_roots_rows on mixed batches, against known roots and find_roots.
// ---------------------------------------------------------------------------

struct Known {
    std::vector<double> coeffs;  // lowest degree first
    std::vector<long double> re, im;  // the exact roots (with multiplicity), when known
    bool exact;
};

// prod (t - root) with dyadic roots (k/8, pairs a +- bi with a, b in k/8):
// every coefficient is a small dyadic rational, exact in double.
static Known from_dyadic_roots(std::mt19937_64& rng, int n, double scale_pow2) {
    Known out;
    std::vector<double> c = {1.0};
    // The same expansion in long double (x87: a 64-bit significand, exact
    // for these degrees where long double is wider): a coefficient that
    // double rounded (degrees 9 to 12 can exceed 53 bits) makes the row
    // inexact.
    std::vector<long double> cl = {1.0L};
    auto mul = [&](std::vector<double> f) {
        std::vector<double> r(c.size() + f.size() - 1, 0.0);
        std::vector<long double> rl(r.size(), 0.0L);
        for (std::size_t a = 0; a < c.size(); ++a)
            for (std::size_t b = 0; b < f.size(); ++b) {
                r[a + b] += c[a] * f[b];
                rl[a + b] += cl[a] * (long double)f[b];
            }
        c = r;
        cl = rl;
    };
    int deg = 0;
    double prev_re = 0.5;
    while (deg < n) {
        const double a = (double)((long)(rng() % 33) - 16) / 8.0;
        const double bb = (double)(rng() % 16 + 1) / 8.0;
        const bool repeat = deg > 0 && rng() % 4 == 0;
        if (deg + 2 <= n && rng() % 2) {
            mul({a * a + bb * bb, -2.0 * a, 1.0});
            out.re.push_back(a); out.im.push_back(bb);
            out.re.push_back(a); out.im.push_back(-bb);
            deg += 2;
        } else {
            const double root = repeat ? prev_re : a;
            mul({-root, 1.0});
            out.re.push_back(root); out.im.push_back(0.0);
            prev_re = root;
            deg += 1;
        }
    }
    bool exact = std::numeric_limits<long double>::digits >= 64;
    for (std::size_t k = 0; k < c.size(); ++k) exact = exact && (long double)c[k] == cl[k];
    for (double& v : c) v = std::ldexp(v, (int)scale_pow2);
    out.coeffs = c;
    out.exact = exact;
    return out;
}

static bool inside(long double re, long double im, const RootDisc& d, bool& sure) {
    const long double dr = re - d.re, di = im - d.im;
    const long double lhs = dr * dr + di * di, rhs = (long double)d.radius * d.radius;
    sure = std::fabs((double)(lhs - rhs)) > 1e-12 * (double)(lhs + rhs);
    return lhs <= rhs;
}

static bool overlaps(const RootDisc& a, const RootDisc& b) {
    const long double dr = (long double)a.re - b.re, di = (long double)a.im - b.im;
    const long double s = (long double)a.radius + b.radius;
    return dr * dr + di * di <= s * s * (1 + 1e-12L);
}

static void mixed_batches() {
    std::mt19937_64 rng(1515);
    std::normal_distribution<double> normal;
    long total_rows = 0, total_lanes = 0, total_kept = 0, checked_discs = 0;
    for (int n = 1; n <= kBatchMaxDegree + 1; ++n) {
        const int nc = n + 1;
        std::vector<Known> rows;
        for (int r = 0; r < 400; ++r) {
            Known k;
            k.exact = false;
            switch (r % 10) {
                case 0: case 1: case 2: case 3:  // easy: standard normal
                    for (int j = 0; j <= n; ++j) k.coeffs.push_back(normal(rng));
                    break;
                case 4: case 5:  // known dyadic roots, some multiple, exact expansion
                    k = from_dyadic_roots(rng, n, (double)((long)(rng() % 41) - 20));
                    break;
                case 6:  // a subnormal coefficient (or several)
                    for (int j = 0; j <= n; ++j) k.coeffs.push_back(normal(rng));
                    k.coeffs[rng() % nc] = 4.9406564584124654e-324 * (double)(rng() % 1000 + 1);
                    break;
                case 7:  // exact zero constant term / zero leading coefficient
                    for (int j = 0; j <= n; ++j) k.coeffs.push_back(normal(rng));
                    k.coeffs[(r / 10) % 2 ? 0 : n] = 0.0;
                    break;
                case 8:  // huge ranges
                    for (int j = 0; j <= n; ++j)
                        k.coeffs.push_back((rng() % 2 ? -1.0 : 1.0) * std::pow(10.0, (double)((long)(rng() % 601) - 300)));
                    break;
                default:  // a tight cluster: (t - 1)^n perturbed in the last bits
                    k.coeffs.assign(nc, 0.0);
                    {
                        std::vector<double> c = {1.0};
                        for (int j = 0; j < n; ++j) {
                            std::vector<double> nx(c.size() + 1, 0.0);
                            for (std::size_t a = 0; a < c.size(); ++a) { nx[a] -= c[a]; nx[a + 1] += c[a]; }
                            c = nx;
                        }
                        k.coeffs = c;
                        k.coeffs[0] *= 1.0 + 0x1p-50 * (double)(r % 7);
                    }
            }
            rows.push_back(k);
        }
        std::vector<double> matrix;
        for (const Known& k : rows) matrix.insert(matrix.end(), k.coeffs.begin(), k.coeffs.end());
        for (Method m : {Method::Auto, Method::Smith, Method::Unverified}) {
            std::vector<RootsResult> out(rows.size());
            BatchCounters cnt;
            std::int64_t bad = -2;
            const Status s = find_roots_rows(matrix.data(), (std::int64_t)rows.size(), nc, m, out.data(), &bad, BatchIsa::Auto, &cnt);
            CHECK(s == Status::Ok && bad == -1, "degree %d method %d: status %d bad row %ld", n, (int)m, (int)s, (long)bad);
            CHECK(cnt.rows == (std::int64_t)rows.size() && cnt.kept + cnt.scalar == cnt.rows, "degree %d: counters", n);
            if (n <= kBatchMaxDegree) CHECK(cnt.kept > 0, "degree %d method %d: no lane kept", n, (int)m);
            else CHECK(cnt.lanes == 0, "degree %d above the kernels' range entered a lane", n);
            total_rows += cnt.rows;
            total_lanes += cnt.lanes;
            total_kept += cnt.kept;
            for (std::size_t r = 0; r < rows.size(); ++r) {
                const RootsResult& b = out[r];
                RootsResult ref;
                find_roots(rows[r].coeffs.data(), nc, m, ref);
                int sum_b = b.n_infinite, sum_s = ref.n_infinite;
                for (int i = 0; i < b.n_discs; ++i) sum_b += b.discs[i].count;
                for (int i = 0; i < ref.n_discs; ++i) sum_s += ref.discs[i].count;
                CHECK(sum_b == n && sum_s == n, "degree %d row %zu: counts %d (batch) %d (scalar)", n, r, sum_b, sum_s);
                CHECK(b.n_infinite == ref.n_infinite, "degree %d row %zu: n_infinite", n, r);
                for (int i = 0; i < b.n_discs; ++i) {
                    const RootDisc& d = b.discs[i];
                    if (m == Method::Unverified) {
                        CHECK(!d.verified && !d.real, "unverified method claimed a disc");
                        continue;
                    }
                    if (!d.verified) continue;
                    for (int j = 0; j < i; ++j)
                        if (b.discs[j].verified) CHECK(!overlaps(d, b.discs[j]), "degree %d row %zu: discs overlap", n, r);
                    // A verified batch disc holding single roots meets the
                    // scalar answer's verified discs with the same total.
                    int met = 0;
                    bool all_verified = true;
                    for (int j = 0; j < ref.n_discs; ++j) {
                        all_verified = all_verified && ref.discs[j].verified;
                        if (ref.discs[j].verified && overlaps(d, ref.discs[j])) met += ref.discs[j].count;
                    }
                    if (all_verified) CHECK(met >= d.count, "degree %d row %zu disc %d: meets %d scalar roots", n, r, i, met);
                    if (rows[r].exact) {
                        int held = 0;
                        bool sure_all = true;
                        for (std::size_t q = 0; q < rows[r].re.size(); ++q) {
                            bool sure;
                            const long double sc = std::ldexp(1.0L, 0);
                            held += inside(rows[r].re[q] * sc, rows[r].im[q] * sc, d, sure) ? 1 : 0;
                            sure_all = sure_all && sure;
                        }
                        (void)sure_all;
                        ++checked_discs;
                        CHECK(held == d.count, "degree %d row %zu disc %d D(%g%+gi, %g) claims %d, holds %d", n, r, i,
                              d.re, d.im, d.radius, d.count, held);
                    }
                }
            }
        }
    }
    std::printf("find_roots_rows: %ld rows, %ld entered lanes, %ld kept; %ld discs checked against known roots\n",
                total_rows, total_lanes, total_kept, checked_discs);
}

static void flush_to_zero_refused() {
#if defined(__x86_64__)
    std::vector<double> m;
    std::mt19937_64 rng(3);
    std::normal_distribution<double> normal;
    for (int r = 0; r < 64; ++r)
        for (int k = 0; k < 5; ++k) m.push_back(normal(rng));
    std::vector<RootsResult> out(64);
    const unsigned csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040u);
    BatchCounters cnt;
    find_roots_rows(m.data(), 64, 5, Method::Auto, out.data(), nullptr, BatchIsa::Auto, &cnt);
    _mm_setcsr(csr);
    CHECK(cnt.lanes == 0 && cnt.scalar == 64, "lanes ran under FTZ/DAZ: %ld", (long)cnt.lanes);
    BatchCounters again;
    find_roots_rows(m.data(), 64, 5, Method::Auto, out.data(), nullptr, BatchIsa::Auto, &again);
    CHECK(again.lanes == 64, "lanes after restoring MXCSR: %ld", (long)again.lanes);
#endif
}

// Starting approximations (the ray caster's seeds) change only the work:
// rows of degree 5 to 12 with known dyadic roots, started near their roots,
// far from them, at NaN, or on top of each other, all give discs that hold
// their exact roots (one each where proven), with fewer sweeps from near starts.
static void starts_change_only_the_work() {
    std::mt19937_64 rng(2915);
    std::normal_distribution<double> normal;
    for (int n = 5; n <= kBatchMaxDegree; ++n) {
        const int rows = 64;
        std::vector<Known> known;
        std::vector<double> m, sr(rows * n), si(rows * n);
        for (int r = 0; r < rows; ++r) {
            Known k = from_dyadic_roots(rng, n, (double)(r % 7) - 3.0);
            while (!k.exact) k = from_dyadic_roots(rng, n, (double)(r % 7) - 3.0);  // (degrees 9 to 12, rarely)
            known.push_back(k);
            m.insert(m.end(), known.back().coeffs.begin(), known.back().coeffs.end());
            for (int i = 0; i < n; ++i) {
                const int kind = r % 4;  // near, far, NaN, all equal
                const double re = (double)known.back().re[i], im = (double)known.back().im[i];
                sr[r * n + i] = kind == 0 ? re * (1 + 1e-3 * normal(rng)) : kind == 1 ? 40.0 * normal(rng)
                                : kind == 2 ? std::nan("") : 0.5;
                si[r * n + i] = kind == 0 ? im * (1 + 1e-3 * normal(rng)) : kind == 1 ? 40.0 * normal(rng)
                                : kind == 2 ? 0.0 : 0.25;
            }
        }
        // (from_dyadic_roots scales the coefficients, not the roots.)
        std::vector<RootsResult> with(rows), without(rows);
        BatchCounters cw, co;
        const Status a = find_roots_rows(m.data(), rows, n + 1, Method::Auto, with.data(), nullptr, BatchIsa::Auto,
                                         &cw, nullptr, sr.data(), si.data());
        const Status b = find_roots_rows(m.data(), rows, n + 1, Method::Auto, without.data(), nullptr, BatchIsa::Auto,
                                         &co);
        CHECK(a == Status::Ok && b == Status::Ok, "degree %d: status", n);
        for (int r = 0; r < rows; ++r) {
            const RootsResult& res = with[r];
            int counted = 0;
            for (int i = 0; i < res.n_discs; ++i) counted += res.discs[i].count;
            CHECK(counted + res.n_infinite == n, "degree %d row %d: counts", n, r);
            for (int i = 0; i < res.n_discs; ++i) {
                if (!res.discs[i].verified) continue;
                int in = 0;
                for (int j = 0; j < n; ++j) {
                    bool sure = true;
                    in += inside(known[r].re[j], known[r].im[j], res.discs[i], sure);
                }
                CHECK(in == res.discs[i].count, "degree %d row %d disc %d: holds %d roots, claims %d", n, r, i, in,
                      res.discs[i].count);
            }
        }
        CHECK(cw.kept > 0, "degree %d: no lane kept with starts", n);
        std::printf("starts, degree %d: kept %ld of %ld lanes (%ld without starts), sweeps %ld (%ld without)\n", n,
                    (long)cw.kept, (long)cw.lanes, (long)co.kept, (long)cw.sweeps, (long)co.sweeps);
    }
}

// ---------------------------------------------------------------------------
// Blocks that mix easy and hard lanes, with seeds good, bad and NaN, against
// exact roots; every instruction set gives the same bits.
// ---------------------------------------------------------------------------

// prod (t - root) for roots given as (re, im) numerators over 2^q (an im
// numerator > 0 stands for the pair re +- i im), expanded in integers
// (s = 2^q t) and converted exactly: false if a coefficient needs more than
// 53 bits.
static bool exact_poly(const std::vector<std::pair<long, long>>& roots, int q, Known& out) {
    std::vector<__int128> c = {1};
    auto mul = [&](std::vector<__int128> f) {
        std::vector<__int128> r(c.size() + f.size() - 1, 0);
        for (std::size_t a = 0; a < c.size(); ++a)
            for (std::size_t b = 0; b < f.size(); ++b) r[a + b] += c[a] * f[b];
        c = r;
    };
    out.re.clear();
    out.im.clear();
    for (const auto& rt : roots) {
        const __int128 a = rt.first, b = rt.second;
        if (b > 0) {
            mul({a * a + b * b, -2 * a, 1});
            out.re.push_back(std::ldexp((long double)rt.first, -q));
            out.im.push_back(std::ldexp((long double)rt.second, -q));
            out.re.push_back(out.re.back());
            out.im.push_back(-out.im.back());
        } else {
            mul({-a, 1});
            out.re.push_back(std::ldexp((long double)rt.first, -q));
            out.im.push_back(0.0L);
        }
    }
    const int n = (int)c.size() - 1;
    out.coeffs.assign(c.size(), 0.0);
    for (int k = 0; k <= n; ++k) {
        const __int128 v = c[k] < 0 ? -c[k] : c[k];
        if (v >= ((__int128)1 << 53)) return false;
        out.coeffs[k] = std::ldexp((double)c[k], q * (k - n));  // exact: 53 bits, a power of two
    }
    out.exact = true;
    return true;
}

// Lane kinds of the mixed blocks (a block of 16 rows holds all of them).
static bool mixed_lane(std::mt19937_64& rng, int n, int kind, Known& out) {
    std::vector<std::pair<long, long>> roots;
    int deg = 0;
    // (Exact expansion needs |coefficients| < 2^53 in units of 2^-qn: the
    // finer grid of the near-multiple rows shrinks with the degree.)
    const int q = kind == 3 || kind == 4 ? (n <= 5 ? 9 : n == 6 ? 7 : n == 7 ? 6 : n == 8 ? 5 : n <= 10 ? 4 : 3) : 3;
    const long unit = 1L << q;  // 1 in numerators over 2^q
    auto add_real = [&](long num) { roots.push_back({num, 0}); ++deg; };
    auto add_pair = [&](long a, long b) { roots.push_back({a, b}); deg += 2; };
    switch (kind) {
        case 0: case 1:  // well separated (pairs and reals in k/8)
            break;
        case 2:  // an exact double root next to well-separated ones
            add_real(5);
            add_real(5);
            break;
        case 3:  // a near-multiple pair: 1 and 1 + 2^-q
            add_real(unit);
            add_real(unit + 1);
            break;
        case 4:  // a cluster of three around 3/4 (spacing 2^-q)
            add_real(3 * unit / 4);
            add_real(3 * unit / 4 + 1);
            add_real(3 * unit / 4 - 1);
            break;
        default:  // a complex pair next to a real root of nearly its modulus
            add_pair(unit / 2, unit);
            add_real(-(long)(1.118 * unit));
            break;
    }
    std::vector<long> used;
    for (int guard = 0; deg < n && guard < 100; ++guard) {
        const long a = ((long)(rng() % 17) - 8) * unit / 8, b = ((long)(rng() % 10) + 2) * unit / 8;
        bool clash = false;
        for (long u : used) clash = clash || std::labs(u - a) < unit / 4;
        if (clash) continue;
        used.push_back(a);
        if (deg + 2 <= n && rng() % 2) add_pair(a, b);
        else add_real(a);
    }
    return deg == n && exact_poly(roots, q, out);
}

// find_roots_rows (Method::Auto) on rows polynomials of degree n, row-major
// in m, with seeds sr, si (n per row) or none, with every instruction set
// this CPU runs: each keeps some lane, and all give the same bits. Returns
// the first set's (generic) results; adds its lanes and kept lanes to
// lanes and kept.
static std::vector<RootsResult> rows_on_every_isa(const std::vector<double>& m, int rows, int n, const double* sr,
                                                  const double* si, long& kept, long& lanes) {
    std::vector<BatchIsa> isas = {BatchIsa::Generic};
    if (batch_isa_supported(BatchIsa::Avx2)) isas.push_back(BatchIsa::Avx2);
    if (batch_isa_supported(BatchIsa::Avx512)) isas.push_back(BatchIsa::Avx512);
    std::vector<std::vector<RootsResult>> per_isa;
    for (BatchIsa isa : isas) {
        std::vector<RootsResult> out(rows);
        BatchCounters cnt;
        const Status st = find_roots_rows(m.data(), rows, n + 1, Method::Auto, out.data(), nullptr, isa, &cnt, nullptr,
                                          sr, si);
        CHECK(st == Status::Ok, "degree %d %s: status", n, batch_isa_name(isa));
        CHECK(cnt.kept > 0, "degree %d %s: no lane kept", n, batch_isa_name(isa));
        if (per_isa.empty()) {
            kept += cnt.kept;
            lanes += cnt.lanes;
        }
        per_isa.push_back(out);
    }
    for (std::size_t a = 1; a < per_isa.size(); ++a)
        for (int r = 0; r < rows; ++r) {
            const RootsResult &x = per_isa[0][r], &y = per_isa[a][r];
            bool same = x.n_discs == y.n_discs && x.n_infinite == y.n_infinite;
            for (int i = 0; same && i < x.n_discs; ++i)
                same = same_bits(x.discs[i].re, y.discs[i].re) && same_bits(x.discs[i].im, y.discs[i].im) &&
                       same_bits(x.discs[i].radius, y.discs[i].radius) && x.discs[i].count == y.discs[i].count &&
                       x.discs[i].verified == y.discs[i].verified && x.discs[i].real == y.discs[i].real;
            CHECK(same, "degree %d row %d: %s and %s differ", n, r, batch_isa_name(isas[0]), batch_isa_name(isas[a]));
        }
    return per_isa[0];
}

// Every verified disc of res (row r, lane kind `kind`, degree n) holds
// exactly as many of k's exact roots as it claims. Returns the discs
// checked.
static long check_verified_discs(const RootsResult& res, const Known& k, int n, int r, int kind) {
    long checked = 0;
    for (int i = 0; i < res.n_discs; ++i) {
        const RootDisc& d = res.discs[i];
        if (!d.verified) continue;
        int in = 0;
        for (int j = 0; j < n; ++j) {
            bool sure = true;
            in += inside(k.re[j], k.im[j], d, sure);
        }
        ++checked;
        CHECK(in == d.count, "degree %d row %d (kind %d) disc %d D(%g%+gi, %g): holds %d roots, claims %d", n, r, kind, i,
              d.re, d.im, d.radius, in, d.count);
    }
    return checked;
}

static void mixed_blocks_with_seeds() {
    std::mt19937_64 rng(1529);
    std::normal_distribution<double> normal;
    long checked = 0, kept = 0, lanes = 0;
    for (int n = 5; n <= kBatchMaxDegree; ++n) {
        const int rows = 96;  // six blocks; each block holds every lane kind and seed kind
        std::vector<Known> known;
        std::vector<double> m, sr(rows * n), si(rows * n);
        for (int r = 0; r < rows; ++r) {
            Known k;
            int tries = 0;
            while (!mixed_lane(rng, n, r % 6, k) && ++tries < 10000) {
            }
            CHECK(tries < 10000, "degree %d kind %d: no exact polynomial", n, r % 6);
            known.push_back(k);
            m.insert(m.end(), k.coeffs.begin(), k.coeffs.end());
            // Seeds: near the roots, far, NaN, infinite, all equal, complex
            // pairs seeded on the real axis (the trap of real seeds), and
            // real roots seeded as conjugate pairs.
            const int seed = (r / 6 + r) % 7;
            for (int i = 0; i < n; ++i) {
                const double re = (double)k.re[i], im = (double)k.im[i];
                double a, b;
                switch (seed) {
                    case 0: a = re * (1 + 1e-3 * normal(rng)); b = im * (1 + 1e-3 * normal(rng)); break;
                    case 1: a = 40.0 * normal(rng); b = 40.0 * normal(rng); break;
                    case 2: a = std::nan(""); b = 0.0; break;
                    case 3: a = re; b = i == n - 1 ? HUGE_VAL : im; break;
                    case 4: a = 0.5; b = 0.25; break;
                    case 5: a = re + 0.5 * im; b = 0.0; break;
                    default: a = re; b = 0.05 * (i % 2 ? 1 : -1); break;
                }
                sr[r * n + i] = a;
                si[r * n + i] = b;
            }
        }
        const std::vector<RootsResult> got = rows_on_every_isa(m, rows, n, sr.data(), si.data(), kept, lanes);
        for (int r = 0; r < rows; ++r) {
            const RootsResult& res = got[r];
            RootsResult ref;
            find_roots(known[r].coeffs.data(), n + 1, Method::Auto, ref);
            int counted = 0, counted_ref = 0;
            for (int i = 0; i < res.n_discs; ++i) counted += res.discs[i].count;
            for (int i = 0; i < ref.n_discs; ++i) counted_ref += ref.discs[i].count;
            CHECK(counted + res.n_infinite == n && counted_ref + ref.n_infinite == n, "degree %d row %d: counts", n, r);
            checked += check_verified_discs(res, known[r], n, r, r % 6);
        }
    }
    std::printf("mixed blocks with seeds: %ld lanes, %ld kept, %ld verified discs checked against exact roots\n", lanes,
                kept, checked);
}

// Complex pairs seeded on the real axis (the sample above hit the surface
// twice where this one misses it): real arithmetic would keep those seeds
// real; the lanes step them off the axis, converge within the sweep cap,
// and prove every well-separated row.
static void real_seeds_of_complex_pairs_converge() {
    std::mt19937_64 rng(1530);
    for (int n = 5; n <= kBatchMaxDegree; ++n) {
        const int rows = 32;
        std::vector<Known> known;
        std::vector<double> m, sr(rows * n), si(rows * n);
        for (int r = 0; r < rows; ++r) {
            Known k;
            int tries = 0;
            while ((!mixed_lane(rng, n, 0, k) ||
                    std::none_of(k.im.begin(), k.im.end(), [](long double v) { return v != 0; })) &&
                   ++tries < 10000) {
            }
            CHECK(tries < 10000, "degree %d: no exact polynomial", n);
            known.push_back(k);
            m.insert(m.end(), k.coeffs.begin(), k.coeffs.end());
            for (int i = 0; i < n; ++i) {
                const double re = (double)k.re[i], im = (double)k.im[i];
                sr[r * n + i] = re + 0.1 * im;  // a pair a +- bi: two real seeds a +- b/10
                si[r * n + i] = 0.0;
            }
        }
        std::vector<RootsResult> out(rows);
        BatchCounters cnt;
        const Status st = find_roots_rows(m.data(), rows, n + 1, Method::Auto, out.data(), nullptr, BatchIsa::Auto, &cnt,
                                          nullptr, sr.data(), si.data());
        CHECK(st == Status::Ok, "degree %d: status", n);
        // (Rows with an exact zero root, c_0 = 0, never enter a lane: the
        // share is of the rows that do.)
        CHECK(cnt.lanes >= rows / 2 && cnt.kept >= cnt.lanes * 3 / 4,
              "degree %d: %ld of %ld lanes (of %d rows) with real seeds of complex pairs kept", n, (long)cnt.kept,
              (long)cnt.lanes, rows);
        CHECK(cnt.sweeps < 40 * cnt.blocks, "degree %d: %ld sweeps in %ld blocks (the cap is 40)", n, (long)cnt.sweeps,
              (long)cnt.blocks);
        for (int r = 0; r < rows; ++r)
            for (int i = 0; i < out[r].n_discs; ++i) {
                const RootDisc& d = out[r].discs[i];
                int in = 0;
                for (int j = 0; j < n; ++j) {
                    bool sure = true;
                    in += d.verified && inside(known[r].re[j], known[r].im[j], d, sure);
                }
                CHECK(!d.verified || in == d.count, "degree %d row %d disc %d: holds %d, claims %d", n, r, i, in, d.count);
            }
        std::printf("real seeds of complex pairs, degree %d: %ld of %ld lanes (%d rows) kept, %.1f sweeps per block\n", n,
                    (long)cnt.kept, (long)cnt.lanes, rows, (double)cnt.sweeps / (double)cnt.blocks);
    }
}

// Degrees 2 to 4 (closed-form starts, a first Newton sweep, then Aberth
// sweeps chunk by chunk for the lanes Newton did not settle): blocks whose
// lanes mix well-separated rows with exact double roots, near-multiple
// pairs, clusters of three and complex pairs beside a real root of nearly
// their modulus. Every verified claim holds against the exact roots, every
// instruction set gives the same bits, and the well-separated rows are
// fully verified.
static void closed_form_blocks_mixed() {
    std::mt19937_64 rng(2718);
    long checked = 0, kept = 0, lanes = 0;
    for (int n = 2; n <= 4; ++n) {
        const int kinds = n == 2 ? 4 : 6;  // a cluster of three, or a pair beside a real root, needs n >= 3
        const int rows = 96;
        std::vector<Known> known;
        std::vector<int> kind_of;
        std::vector<double> m;
        for (int r = 0; r < rows; ++r) {
            Known k;
            const int kind = r % kinds;
            int tries = 0;
            while (!mixed_lane(rng, n, kind, k) && ++tries < 10000) {
            }
            CHECK(tries < 10000, "degree %d kind %d: no exact polynomial", n, kind);
            known.push_back(k);
            kind_of.push_back(kind);
            m.insert(m.end(), k.coeffs.begin(), k.coeffs.end());
        }
        const std::vector<RootsResult> got = rows_on_every_isa(m, rows, n, nullptr, nullptr, kept, lanes);
        for (int r = 0; r < rows; ++r) {
            const RootsResult& res = got[r];
            int counted = 0;
            bool all_verified = true;
            for (int i = 0; i < res.n_discs; ++i) {
                counted += res.discs[i].count;
                all_verified = all_verified && res.discs[i].verified;
            }
            CHECK(counted + res.n_infinite == n, "degree %d row %d: counts", n, r);
            if (kind_of[r] <= 1) CHECK(all_verified && res.n_infinite == 0, "degree %d row %d: well separated, not verified", n, r);
            checked += check_verified_discs(res, known[r], n, r, kind_of[r]);
        }
    }
    CHECK(kept >= lanes / 3, "closed-form blocks: only %ld of %ld lanes kept", kept, lanes);
    std::printf("closed-form blocks (n 2-4): %ld lanes, %ld kept, %ld verified discs checked against exact roots\n",
                lanes, kept, checked);
}

// find_roots_rows_into (the Python binding's path: rows straight into
// row-major arrays, blocks in place) against find_roots_rows, bit for bit:
// every method, degrees 1 to 13 (13: no kernel), with and without coefficient
// radii, rows the lanes refuse among them, and the stop at the first bad row.
static void rows_into_matches_rows() {
    std::mt19937_64 rng(4242);
    std::normal_distribution<double> normal;
    long compared = 0;
    for (int n = 1; n <= kBatchMaxDegree + 1; ++n) {
        const int nc = n + 1;
        for (int trial = 0; trial < 6; ++trial) {
            const int rows = 1 + (int)(rng() % 70);
            std::vector<double> m(rows * nc), rad(rows * nc);
            for (int r = 0; r < rows; ++r) {
                const int kind = (int)(rng() % 8);
                for (int k = 0; k < nc; ++k) {
                    double v = normal(rng);
                    if (kind == 1 && k == 0) v = 0.0;                           // exact zero root
                    if (kind == 2 && k == n) v = 0.0;                           // root at infinity
                    if (kind == 3 && k == 1) v = 4.9406564584124654e-324 * 7;   // subnormal
                    if (kind == 4) v = std::ldexp(v, 900 - 300 * k);            // huge range
                    m[r * nc + k] = v;
                    rad[r * nc + k] = kind == 5 ? 0.0 : std::fabs(v) * std::ldexp(1.0, -40 - (int)(rng() % 20));
                }
                if (kind == 6) {  // a double root
                    std::vector<double> c = {1.0};
                    const double z = std::ldexp((double)(rng() % 9) - 4.0, -2);
                    for (int j = 0; j < n; ++j) {
                        const double root = j < 2 ? z : normal(rng);
                        std::vector<double> nx(c.size() + 1, 0.0);
                        for (std::size_t a = 0; a < c.size(); ++a) { nx[a] -= root * c[a]; nx[a + 1] += c[a]; }
                        c = nx;
                    }
                    for (int k = 0; k < nc; ++k) m[r * nc + k] = c[k];
                }
            }
            const bool with_bad = trial == 5;
            if (with_bad) m[(rows / 2) * nc + (int)(rng() % nc)] = std::nan("");
            for (Method meth : {Method::Auto, Method::Smith, Method::Unverified, Method::Paper}) {
                for (int family = 0; family < 2; ++family) {
                    const double* rp = family ? rad.data() : nullptr;
                    std::vector<RootsResult> ref(rows);
                    std::int64_t bad_ref = -2, bad_got = -2;
                    BatchCounters cr, cg;
                    const Status sr = find_roots_rows(m.data(), rows, nc, meth, ref.data(), &bad_ref, BatchIsa::Auto,
                                                      &cr, rp);
                    std::vector<double> center(2 * rows * n, -7.0), radius(rows * n, -7.0);
                    std::vector<std::int64_t> count(rows * n, -7);
                    std::unique_ptr<bool[]> verified(new bool[rows * n]), real(new bool[rows * n]),
                        wants(new bool[rows]);
                    std::vector<std::int32_t> n_inf(rows, -7), esc(rows, -7);
                    RowsOut out;
                    out.center = center.data();
                    out.radius = radius.data();
                    out.count = count.data();
                    out.verified = verified.get();
                    out.real = real.get();
                    out.wants_exact = wants.get();
                    out.n_infinite = n_inf.data();
                    out.escalation = esc.data();
                    const Status sg = find_roots_rows_into(m.data(), rows, nc, meth, out, &bad_got, BatchIsa::Auto,
                                                           &cg, rp);
                    CHECK(sr == sg && bad_ref == bad_got, "rows_into degree %d: status %d/%d bad %ld/%ld", n, (int)sr,
                          (int)sg, (long)bad_ref, (long)bad_got);
                    if (sr == Status::Ok)
                        CHECK(cr.rows == cg.rows && cr.kept == cg.kept && cr.lanes == cg.lanes && cr.scalar == cg.scalar,
                              "rows_into degree %d: counters", n);
                    const int upto = sr == Status::Ok ? rows : (int)bad_ref;
                    for (int r = 0; r < upto; ++r) {
                        const RootsResult& a = ref[r];
                        bool same = a.n_infinite == n_inf[r] && a.escalation == esc[r] && a.wants_exact == wants[r];
                        for (int i = 0; i < n; ++i) {
                            const int e = r * n + i;
                            if (i < a.n_discs) {
                                const RootDisc& d = a.discs[i];
                                same = same && same_bits(d.re, center[2 * e]) && same_bits(d.im, center[2 * e + 1]) &&
                                       same_bits(d.radius, radius[e]) && d.count == count[e] &&
                                       d.verified == verified[e] && d.real == real[e];
                            } else {
                                same = same && std::isnan(center[2 * e]) && std::isnan(center[2 * e + 1]) &&
                                       std::isnan(radius[e]) && count[e] == 0 && !verified[e] && !real[e];
                            }
                        }
                        if (!same && failures < 3) {
                            std::printf("ref: ndisc %d ninf %d esc %d wants %d; got ninf %d esc %d wants %d\n", a.n_discs,
                                        a.n_infinite, a.escalation, (int)a.wants_exact, n_inf[r], esc[r], (int)wants[r]);
                            for (int i = 0; i < n; ++i)
                                std::printf("  %d: ref %a %a %a %d %d %d got %a %a %a %ld %d %d\n", i,
                                            i < a.n_discs ? a.discs[i].re : 0.0, i < a.n_discs ? a.discs[i].im : 0.0,
                                            i < a.n_discs ? a.discs[i].radius : 0.0, i < a.n_discs ? a.discs[i].count : -1,
                                            i < a.n_discs ? (int)a.discs[i].verified : -1,
                                            i < a.n_discs ? (int)a.discs[i].real : -1, center[2 * (r * n + i)],
                                            center[2 * (r * n + i) + 1], radius[r * n + i], (long)count[r * n + i],
                                            (int)verified[r * n + i], (int)real[r * n + i]);
                        }
                        CHECK(same, "rows_into degree %d method %d family %d row %d (of %d, trial %d, status %d bad %ld) differs from find_roots_rows", n,
                              (int)meth, family, r, rows, trial, (int)sr, (long)bad_ref);
                        ++compared;
                    }
                }
            }
        }
    }
    std::printf("find_roots_rows_into: %ld rows bit-identical to find_roots_rows\n", compared);
}

int main() {
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    std::printf("batched kernel: %s\n", batch_isa_name(BatchIsa::Auto));
    starts_change_only_the_work();
    mixed_blocks_with_seeds();
    closed_form_blocks_mixed();
    real_seeds_of_complex_pairs_converge();
    kernel_matches_scalar_bound();
    mixed_batches();
    rows_into_matches_rows();
    flush_to_zero_refused();
    if (failures) {
        std::printf("%d failures\n", failures);
        return 1;
    }
    std::printf("roots_batch_test: all passed\n");
    return 0;
}
