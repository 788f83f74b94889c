// ray_run_test.cpp: the lane-parallel primary ray polynomials
// (primary_ray_polynomial_run) against the scalar primary_ray_polynomial,
// bit for bit, for every instruction set this CPU runs: random surfaces of
// degree 1 to 12 (dense and sparse), signed-permutation and general linear
// parts, random cameras, directions with tiny, subnormal, zero and negative
// zero components (the underflow slack and the exact-zero branches), runs of
// 1 to 32 cells. And find_roots_soa against find_roots_rows (the restart
// loop over bad rows that PrimaryBatch used), row by row, bit for bit.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "../src/ray_polynomial.h"
#include "../src/root_kernels.h"
#include "argand/render.h"
#include "argand/roots_batch.h"
#include "check.h"

using namespace argand;
using namespace argand::detail;

static bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
/// Bit for bit, except that any two NaNs agree: a NaN's sign and payload
/// depend on which operand the compiler put first (x86 keeps the first
/// NaN operand's), not on the arithmetic; NaNs only occur in a polynomial
/// with finite = false, of which nothing is claimed or used.
static bool same_value(double a, double b) { return same_bits(a, b) || (std::isnan(a) && std::isnan(b)); }

static SurfaceSpec random_surface(std::mt19937_64& rng, int n, bool dense, int transform) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    SurfaceSpec s;
    s.degree = n;
    for (int a = 0; a <= n; ++a)
        for (int b = 0; a + b <= n; ++b)
            for (int c = 0; a + b + c <= n; ++c) {
                if (!dense && rng() % 3 != 0 && !(a + b + c == n && a == n)) continue;
                double v = u(rng);
                if (rng() % 17 == 0) v = std::ldexp(v, -300);  // tiny coefficients (no-underflow threshold)
                s.terms.push_back({a, b, c, v});
            }
    s.terms.push_back({0, 0, 0, -0.5});
    if (transform == 1) {  // a signed permutation other than the identity
        const double L[9] = {0, -1, 0, 0, 0, 1, 1, 0, 0};
        for (int i = 0; i < 9; ++i) s.linear[i] = L[i];
    } else if (transform == 2) {  // a general linear part (rotation and scale)
        const double t = u(rng) * 3.0, f = 1.0 + 0.5 * u(rng);
        const double L[9] = {f * std::cos(t), -std::sin(t), 0.1, std::sin(t), std::cos(t), 0.0, 0.2, 0.0, 1.3};
        for (int i = 0; i < 9; ++i) s.linear[i] = L[i];
    }
    for (int a = 0; a < 3; ++a) s.translate[a] = 0.25 * u(rng);
    return s;
}

static double random_component(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    switch (rng() % 13) {
        case 12: return std::ldexp(u(rng), 200);  // huge: the coefficients overflow (finite = false)
        case 0: return 0.0;
        case 1: return -0.0;
        case 2: return std::ldexp(u(rng), -200);   // tiny: the underflow slack
        case 3: return std::ldexp(u(rng), -1040);  // subnormal
        case 4: return std::ldexp(u(rng), -60);
        default: return u(rng);
    }
}

static void test_primary_run() {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<BatchIsa> isas = {BatchIsa::Generic};
    if (batch_isa_supported(BatchIsa::Avx2)) isas.push_back(BatchIsa::Avx2);
    if (batch_isa_supported(BatchIsa::Avx512)) isas.push_back(BatchIsa::Avx512);
    long compared = 0, slack_lanes = 0, inexact_lanes = 0, nonfinite_lanes = 0;
    for (int trial = 0; trial < 312; ++trial) {
        const int n = trial < 240 ? 1 + trial % 8 : 9 + (trial / 3) % 4;  // (then degrees 9 to 12)
        SceneSpec sc;
        sc.objects.push_back(random_surface(rng, n, trial % 2 == 0, trial % 3));
        sc.camera.position[0] = 0.3 + u(rng);
        sc.camera.position[1] = -4.0 + u(rng);
        sc.camera.position[2] = 0.7 + u(rng);
        FrameParams fp;
        fp.width = fp.height = 8;
        FramePlan plan;
        try {
            plan = plan_frame(sc, fp);
        } catch (const std::invalid_argument&) {
            CHECK(false);
            continue;
        }
        const SurfaceSpec& s = plan.scene.objects[0];
        const FramePlan::ObjectPlan& op = plan.objects[0];
        const int cells = 1 + static_cast<int>(rng() % kRunCells);
        double dx[kRunCells], dy[kRunCells], dz[kRunCells];
        for (int c = 0; c < cells; ++c) {
            dx[c] = random_component(rng);
            dy[c] = random_component(rng);
            dz[c] = random_component(rng);
        }
        for (BatchIsa isa : isas) {
            PrimaryRun run;
            primary_ray_polynomial_run(s, op, dx, dy, dz, cells, run, isa);
            CHECK(run.n == n && run.cells == cells);
            for (int c = 0; c < cells; ++c) {
                const double d[3] = {dx[c], dy[c], dz[c]};
                RayCoefficients<double> p;
                ObjectRay ray;
                primary_ray_polynomial(s, op, d, p, ray);
                bool same = p.n == run.n && p.finite == (run.finite[c] != 0);
                for (int k = 0; k <= n; ++k) {
                    same = same && same_value(p.c[k], run.c[k][c]) && same_value(p.r[k], run.r[k][c]);
                    if (p.finite) same = same && same_bits(p.c[k], run.c[k][c]) && same_bits(p.r[k], run.r[k][c]);
                }
                for (int a = 0; a < 3; ++a)
                    same = same && same_bits(ray.direction[a].mid, run.dir[a][c]) &&
                           same_bits(ray.direction[a].rad, run.dir_rad[a][c]);
                if (!same) {
                    std::fprintf(stderr, "trial %d isa %s cell %d/%d degree %d differs (finite %d %d)\n", trial, batch_isa_name(isa), c,
                                 cells, n, p.finite, run.finite[c]);
                    for (int k = 0; k <= n; ++k) std::fprintf(stderr, "  %d: %a %a | %a %a\n", k, p.c[k], run.c[k][c], p.r[k], run.r[k][c]);
                }
                CHECK(same);
                ++compared;
                double amin = 1.0;
                for (int a = 0; a < 3; ++a)
                    if (run.mag[a][c] > 0.0) amin = std::fmin(amin, run.mag[a][c]);
                slack_lanes += amin < op.no_underflow_threshold;
                inexact_lanes += !op.direction_exact;
                nonfinite_lanes += !p.finite;
            }
        }
    }
    std::printf("primary runs: %ld lanes compared (%ld with the underflow slack, %ld inexact directions, %ld not finite)\n",
                compared, slack_lanes, inexact_lanes, nonfinite_lanes);
    CHECK(compared > 5000);
    CHECK(slack_lanes > 100);
    CHECK(inexact_lanes > 1000);
    CHECK(nonfinite_lanes > 0);
}

static void test_sample_directions() {
    // render/camera.cpp's sample_direction, written out (the renderer's frames,
    // compared by the Python tests, check the real one).
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int trial = 0; trial < 50; ++trial) {
        SampleRowInput in;
        for (int a = 0; a < 3; ++a) {
            in.forward[a] = u(rng);
            in.right[a] = u(rng);
            in.up[a] = u(rng);
        }
        const int width = 1 + static_cast<int>(rng() % 300), height = 1 + static_cast<int>(rng() % 300), side = 1 + trial % 3;
        in.tan_half_fov = 0.3 + 0.5 * (u(rng) + 1.0);
        in.aspect = static_cast<double>(width) / height;
        in.cols = static_cast<double>(side) * width;
        const int sy_cell = static_cast<int>(rng() % (side * height));
        in.sy = (1.0 - 2.0 * (sy_cell + 0.5) / (static_cast<double>(side) * height)) * in.tan_half_fov;
        if (trial == 3) in.forward[0] = in.forward[1] = in.forward[2] = in.right[0] = in.right[1] = in.right[2] = 0.0,
                        in.up[0] = in.up[1] = in.up[2] = 0.0;  // zero norm: left as is
        const int first = static_cast<int>(rng() % 40), cells = 1 + static_cast<int>(rng() % kRunCells);
        for (BatchIsa isa : {BatchIsa::Generic, BatchIsa::Avx2, BatchIsa::Avx512}) {
            if (!batch_isa_supported(isa)) continue;
            double dx[kRunCells], dy[kRunCells], dz[kRunCells];
            sample_direction_run(in, first, cells, dx, dy, dz, isa);
            for (int c = 0; c < cells; ++c) {
                const int sx_cell = first + c;
                const double sx = (2.0 * (sx_cell + 0.5) / in.cols - 1.0) * in.tan_half_fov * in.aspect;
                double d[3];
                for (int a = 0; a < 3; ++a) d[a] = in.forward[a] + sx * in.right[a] + in.sy * in.up[a];
                const double nn = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                if (nn > 0) {
                    d[0] /= nn;
                    d[1] /= nn;
                    d[2] /= nn;
                }
                CHECK(same_bits(d[0], dx[c]) && same_bits(d[1], dy[c]) && same_bits(d[2], dz[c]));
            }
        }
    }
}

static bool same_result(const RootsResult& a, const RootsResult& b) {
    if (a.n_discs != b.n_discs || a.n_infinite != b.n_infinite || a.wants_exact != b.wants_exact ||
        a.escalation != b.escalation)
        return false;
    for (int i = 0; i < a.n_discs; ++i) {
        const RootDisc &x = a.discs[i], &y = b.discs[i];
        if (!same_bits(x.re, y.re) || !same_bits(x.im, y.im) || !same_bits(x.radius, y.radius) || x.count != y.count ||
            x.verified != y.verified || x.real != y.real)
            return false;
    }
    return true;
}

static void test_soa_driver() {
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    long rows_compared = 0, kept = 0, scalar = 0, merged = 0;
    for (int trial = 0; trial < 496; ++trial) {
        const int n = trial < 400 ? 1 + trial % 8 : 9 + (trial / 4) % 4, nc = n + 1;  // (then degrees 9 to 12)
        const int rows = 1 + static_cast<int>(rng() % 40);
        const std::int64_t stride = rows + static_cast<int>(rng() % 3);
        const bool with_radius = trial % 4 != 3, with_start = trial % 2 == 0;
        const Method method = trial % 7 == 6 ? Method::Unverified : (trial % 11 == 10 ? Method::Paper : Method::Auto);
        std::vector<double> aos(static_cast<std::size_t>(rows) * nc), aos_rad(aos.size());
        std::vector<double> aos_sre(static_cast<std::size_t>(rows) * n), aos_sim(aos_sre.size());
        std::vector<std::uint8_t> skip(rows);
        for (int j = 0; j < rows; ++j) {
            const int kind = static_cast<int>(rng() % 20);
            // Roots near the unit circle from a random real polynomial, or
            // a row the lanes refuse: c_0 = 0, c_n = 0, not finite, every
            // coefficient zero (ZeroPolynomial), a negative or NaN radius,
            // a double root, or a skipped row.
            for (int k = 0; k < nc; ++k) {
                aos[j * nc + k] = u(rng);
                aos_rad[j * nc + k] = std::fabs(u(rng)) * 1e-14;
            }
            if (kind == 0) aos[j * nc] = 0.0;
            if (kind == 1) aos[j * nc + n] = 0.0;
            if (kind == 2) aos[j * nc + rng() % nc] = NAN;
            if (kind == 3)
                for (int k = 0; k < nc; ++k) aos[j * nc + k] = 0.0;
            if (kind == 4 && with_radius) aos_rad[j * nc + rng() % nc] = (rng() % 2) ? -1.0 : NAN;
            if (kind >= 9 && kind <= 11 && n >= 5) {
                // Real roots in [-1, 1], two of them 1e-9 apart (and, for
                // kind 11, two more 1e-7 apart): a cluster the lanes'
                // discs prove but cannot separate.
                double root[16];
                for (int i = 0; i < n; ++i) root[i] = u(rng);
                root[1] = root[0] + 1e-9 * (1.5 + u(rng));
                if (kind == 11 && n >= 6) root[3] = root[2] + 1e-7 * (1.5 + u(rng));
                double poly[17] = {1.0};
                for (int i = 0; i < n; ++i) {
                    for (int k = i + 1; k >= 1; --k) poly[k] = poly[k - 1] - root[i] * poly[k];
                    poly[0] = -root[i] * poly[0];
                }
                for (int k = 0; k < nc; ++k) aos[j * nc + k] = poly[k];
            }
            if (kind == 5 && n >= 2) {  // (t - 1)^2 (t^(n-2) + ...)
                for (int k = 0; k < nc; ++k) aos[j * nc + k] = 0.0;
                aos[j * nc] = 1.0;
                aos[j * nc + 1] = -2.0;
                aos[j * nc + 2] = 1.0;
            }
            if (kind == 6) aos[j * nc + rng() % nc] = std::ldexp(1.0, -1060);  // subnormal coefficient
            skip[j] = kind == 7;
            for (int i = 0; i < n; ++i) {
                const double a = 2.0 * 3.141592653589793 * i / n;
                aos_sre[j * n + i] = (kind == 8 && i == 0) ? NAN : std::cos(a) * (1.0 + 0.01 * u(rng));
                aos_sim[j * n + i] = std::sin(a);
            }
        }
        std::vector<double> soa(static_cast<std::size_t>(stride) * nc, 7.0), soa_rad(soa.size(), 7.0);
        // (the starts with their own stride on every third trial)
        const std::int64_t sstride = trial % 3 == 1 ? rows + 5 : stride;
        std::vector<double> soa_sre(static_cast<std::size_t>(sstride) * n, 7.0), soa_sim(soa_sre.size(), 7.0);
        for (int j = 0; j < rows; ++j) {
            for (int k = 0; k < nc; ++k) {
                soa[k * stride + j] = aos[j * nc + k];
                soa_rad[k * stride + j] = aos_rad[j * nc + k];
            }
            for (int i = 0; i < n; ++i) {
                soa_sre[i * sstride + j] = aos_sre[j * n + i];
                soa_sim[i * sstride + j] = aos_sim[j * n + i];
            }
        }
        for (BatchIsa isa : {BatchIsa::Scalar, BatchIsa::Generic, BatchIsa::Avx2, BatchIsa::Avx512}) {
            if (!batch_isa_supported(isa)) continue;
            // The reference: find_roots_rows over the rows not skipped, restarted after each bad row.
            std::vector<int> index;
            std::vector<double> c, r, sre, sim;
            for (int j = 0; j < rows; ++j) {
                if (skip[j]) continue;
                index.push_back(j);
                c.insert(c.end(), aos.begin() + j * nc, aos.begin() + (j + 1) * nc);
                r.insert(r.end(), aos_rad.begin() + j * nc, aos_rad.begin() + (j + 1) * nc);
                sre.insert(sre.end(), aos_sre.begin() + j * n, aos_sre.begin() + (j + 1) * n);
                sim.insert(sim.end(), aos_sim.begin() + j * n, aos_sim.begin() + (j + 1) * n);
            }
            const std::int64_t m = static_cast<std::int64_t>(index.size());
            std::vector<RootsResult> ref(m);
            std::vector<Status> ref_status(m, Status::Ok);
            std::int64_t start = 0;
            while (start < m) {
                std::int64_t bad = -1;
                const Status st = find_roots_rows(c.data() + start * nc, m - start, nc, method, ref.data() + start, &bad,
                                                  isa, nullptr, with_radius ? r.data() + start * nc : nullptr,
                                                  with_start ? sre.data() + start * n : nullptr,
                                                  with_start ? sim.data() + start * n : nullptr);
                if (st == Status::Ok) break;
                ref_status[start + bad] = st;
                start = start + bad + 1;
            }
            SoaRows in;
            in.coeffs = soa.data();
            in.radius = with_radius ? soa_rad.data() : nullptr;
            in.start_re = with_start ? soa_sre.data() : nullptr;
            in.start_im = with_start ? soa_sim.data() : nullptr;
            in.skip = skip.data();
            in.rows = rows;
            in.stride = stride;
            in.start_stride = sstride == stride && trial % 2 ? 0 : sstride;
            in.n_coeffs = nc;
            std::vector<RootsResult> got(rows);
            std::vector<Status> got_status(rows, Status::TooLarge);
            BatchCounters cnt;
            find_roots_soa(in, method, got.data(), got_status.data(), isa, &cnt);
            CHECK(cnt.rows == m);
            CHECK(cnt.kept + cnt.scalar == m);
            kept += cnt.kept;
            scalar += cnt.scalar;
            for (std::int64_t i = 0; i < m; ++i) {
                const int j = index[i];
                const bool same = got_status[j] == ref_status[i] && same_result(got[j], ref[i]);
                if (!same)
                    std::fprintf(stderr, "trial %d isa %s row %d degree %d: find_roots_soa differs\n", trial,
                                 batch_isa_name(isa), j, n);
                CHECK(same);
                ++rows_compared;
            }
            for (int j = 0; j < rows; ++j)
                if (skip[j]) CHECK(got_status[j] == Status::TooLarge);  // untouched
            // With SoaRows::provisional: a row is either the same answer, or
            // its lane's discs merged, which find_roots_lane_seeded from the
            // lane's approximations turns into the same answer to the bit
            // (what Tracer::settle does); the merged discs count every root.
            if (method == Method::Unverified) continue;
            std::vector<std::uint8_t> prov(rows, 9);
            std::vector<double> lre(static_cast<std::size_t>(rows) * n), lim(lre.size());
            in.provisional = prov.data();
            in.lane_re = lre.data();
            in.lane_im = lim.data();
            std::vector<RootsResult> got2(rows);
            std::vector<Status> got2_status(rows, Status::TooLarge);
            find_roots_soa(in, method, got2.data(), got2_status.data(), isa);
            for (std::int64_t i = 0; i < m; ++i) {
                const int j = index[i];
                CHECK(prov[j] == 0 || prov[j] == 1);
                if (prov[j] == 1) {
                    ++merged;
                    int total = 0;
                    for (int d = 0; d < got2[j].n_discs; ++d) {
                        total += got2[j].discs[d].count;
                        CHECK(got2[j].discs[d].verified);
                    }
                    CHECK(total == n && got2_status[j] == Status::Ok);
                    RootsResult settled;
                    const Status st = detail::find_roots_lane_seeded(
                        aos.data() + j * nc, nc, method, settled, lre.data() + j * n, lim.data() + j * n,
                        with_radius ? aos_rad.data() + j * nc : nullptr);
                    CHECK(st == ref_status[i] && same_result(settled, ref[i]));
                } else {
                    CHECK(got2_status[j] == ref_status[i] && same_result(got2[j], ref[i]));
                }
            }
        }
    }
    std::printf("find_roots_soa with provisional rows: %ld rows merged by their lanes\n", merged);
    CHECK(merged > 50);
    std::printf("find_roots_soa: %ld rows compared (%ld kept by the lanes, %ld by find_roots)\n", rows_compared, kept,
                scalar);
    CHECK(kept > 1000 && scalar > 500);
}

int main() {
    test_primary_run();
    test_sample_directions();
    test_soa_driver();
    return check_summary("ray_run_test");
}
