// render_test.cpp: the renderer's proven pieces on their own: the band rule
// on every edge, balls against exact integer arithmetic, band membership and
// the clipping sphere on discs placed at the edges on purpose, the trig
// assumption behind the band edges, the ray coefficients' radii against a
// long double reference, the double-double refinement, and whole tiles
// (objects up to kMaxObjects, the refusal above it). Also the program the
// sanitizer build runs.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>
#include <string>

#include "../src/pixel_decision.h"
#include "../src/ray_polynomial.h"
#include "../src/refine_dd.h"
#include "argand/render.h"
#include "check.h"

using namespace argand;
using namespace argand::detail;

static constexpr double kPiDouble = 3.141592653589793;  // just below pi

static SceneSpec sphere_scene(double clip = 0.0, int copies = 1) {
    SceneSpec sc;
    for (int i = 0; i < copies; ++i) {
        SurfaceSpec s;
        s.degree = 2;
        s.terms = {{2, 0, 0, 1.0}, {0, 2, 0, 1.0}, {0, 0, 2, 1.0}, {0, 0, 0, -1.0}};
        s.clip_radius = clip;
        s.translate[0] = 0.5 * i;
        sc.objects.push_back(s);
    }
    sc.camera.position[0] = 0.3;
    sc.camera.position[1] = -4.0;
    sc.camera.position[2] = 0.7;
    return sc;
}

static FramePlan plan_with(double sigma, double delta, const SceneSpec& sc = sphere_scene()) {
    FrameParams fp;
    fp.sigma = sigma;
    fp.delta = delta;
    fp.width = fp.height = 16;
    return plan_frame(sc, fp);
}

static RootDisc disc(double re, double im, double r, bool real = false) { return RootDisc{re, im, r, 1, true, real}; }

static void test_band_rule() {
    CHECK(band_rule_holds(0.0, 0.0));
    CHECK(band_rule_holds(0.0, kPiDouble));            // sigma + delta = fl(pi) < pi
    CHECK(band_rule_holds(kPiDouble, 0.0));
    CHECK(!band_rule_holds(0.0, std::nextafter(kPiDouble, 4.0)));  // above pi
    CHECK(!band_rule_holds(-0.5, 0.2));               // a negative sigma
    CHECK(!band_rule_holds(-1e-300, 0.0));
    CHECK(!band_rule_holds(0.1, -1e-300));
    CHECK(!band_rule_holds(NAN, 0.0));
    CHECK(!band_rule_holds(0.0, INFINITY));
    // Exact sums that round to fl(pi) (half an ulp of pi is 2^-52 ~ 2.2e-16;
    // pi - fl(pi) ~ 1.2246e-16): decided on the exact sum.
    CHECK(kPiDouble + 1e-16 == kPiDouble && band_rule_holds(kPiDouble, 1e-16));
    CHECK(kPiDouble + 1.3e-16 == kPiDouble && !band_rule_holds(kPiDouble, 1.3e-16));
    const double pi_lo = 1.2246467991473532e-16;  // just above pi - fl(pi)
    CHECK(!band_rule_holds(kPiDouble, pi_lo));
    CHECK(band_rule_holds(kPiDouble, std::nextafter(pi_lo, 0.0)));
    CHECK(band_rule_holds(1.5, kPiDouble - 1.5));
    bool threw = false;
    try {
        plan_with(-0.5, 0.2);
    } catch (const std::invalid_argument& e) {
        threw = std::string(e.what()).find(kBandRule) != std::string::npos;
    }
    CHECK(threw);
}

static void test_balls() {
    // Products and sums of integers below 2^40 against exact 128-bit results.
    std::mt19937_64 rng(3);
    for (int t = 0; t < 20000; ++t) {
        const std::int64_t a = static_cast<std::int64_t>(rng() >> 24) - (1LL << 39);
        const std::int64_t b = static_cast<std::int64_t>(rng() >> 24) - (1LL << 39);
        const Ball p = Ball(static_cast<double>(a)) * Ball(static_cast<double>(b));
        const __int128 exact = static_cast<__int128>(a) * b;
        const long double diff = static_cast<long double>(exact - static_cast<__int128>(p.mid));
        CHECK(std::fabs(static_cast<double>(diff)) <= p.rad);
        // A sum spanning 60 bits: exact in long double (64), rounded in double.
        const Ball s = Ball(static_cast<double>(a) * 0x1p10) + Ball(static_cast<double>(b) * 0x1p-10);
        const long double se = static_cast<long double>(a) * 0x1p10L + static_cast<long double>(b) * 0x1p-10L;
        CHECK(std::fabs(se - static_cast<long double>(s.mid)) <= s.rad);
    }
    // Exact operations keep radius 0; zero stays exact.
    CHECK((Ball(3.0) * Ball(0.25)).rad == 0.0);
    CHECK((Ball(0.0) * Ball(1e300, 1e290)).rad == 0.0);
    CHECK((Ball(1.0) + Ball(2.0)).rad == 0.0);
    CHECK((Ball(1.0) + Ball(0x1p-60)).rad > 0.0);
    // Subnormal products carry the absolute term.
    const Ball tiny = Ball(0x1p-540) * Ball(0x1.8p-540);
    CHECK(tiny.rad >= 0x1p-1074);
}

static void test_band_membership() {
    // sigma = delta = 0: the positive real axis exactly.
    FramePlan p0 = plan_with(0.0, 0.0);
    CHECK(band_membership(disc(2.0, 0.0, 0.1, true), true, p0, true) == Verdict::Yes);
    CHECK(band_membership(disc(-2.0, 0.0, 0.1, true), true, p0, true) == Verdict::No);      // negative real root
    CHECK(band_membership(disc(2.0, 0.3, 0.1), false, p0, true) == Verdict::No);            // off the axis
    CHECK(band_membership(disc(2.0, 0.05, 0.1), false, p0, true) == Verdict::Unknown);      // straddles, not proven real
    CHECK(band_membership(disc(0.05, 0.0, 0.1, true), true, p0, true) == Verdict::Unknown); // contains 0
    // sigma = 0, delta > 0: the wedge |arg| <= delta (one wedge across the axis).
    const double delta = 0.2;
    FramePlan p1 = plan_with(0.0, delta);
    CHECK(band_membership(disc(3.0, 0.01, 0.05), false, p1, true) == Verdict::Yes);         // straddles the axis
    CHECK(band_membership(disc(3.0, -0.3, 0.05), false, p1, true) == Verdict::Yes);         // conjugate side
    CHECK(band_membership(disc(-3.0, 0.0, 0.1, true), true, p1, true) == Verdict::No);      // negative real root
    // Discs touching the edge ray at angle delta: undecided; just inside / outside: decided.
    const double c = std::cos(delta), s = std::sin(delta);
    CHECK(band_membership(disc(5 * c, 5 * s, 1e-3), false, p1, true) == Verdict::Unknown);
    const double in = delta - 1e-3, out = delta + 1e-3;
    CHECK(band_membership(disc(5 * std::cos(in), 5 * std::sin(in), 1e-3), false, p1, true) == Verdict::Yes);
    CHECK(band_membership(disc(5 * std::cos(out), 5 * std::sin(out), 1e-3), false, p1, true) == Verdict::No);
    // sigma > 0: real roots excluded, the lower edge decided the same way.
    FramePlan p2 = plan_with(0.1, 0.2);
    CHECK(band_membership(disc(2.0, 0.0, 0.01, true), true, p2, true) == Verdict::No);
    CHECK(band_membership(disc(2.0, 0.0, 0.01), false, p2, true) == Verdict::No);           // near-real: angle < 0.1
    const double mid = 0.2;
    CHECK(band_membership(disc(4 * std::cos(mid), -4 * std::sin(mid), 1e-2), false, p2, true) == Verdict::Yes);
    CHECK(band_membership(disc(4 * std::cos(0.1), 4 * std::sin(0.1), 1e-6), false, p2, true) == Verdict::Unknown);
    // sigma + delta = fl(pi): every non-real root of |arg| >= sigma, negative real roots excluded
    // (arg pi is above fl(pi)).
    FramePlan p3 = plan_with(0.0, kPiDouble);
    CHECK(band_membership(disc(-3.0, 0.5, 0.1), false, p3, true) == Verdict::Yes);
    CHECK(band_membership(disc(-3.0, 0.0, 0.1, true), true, p3, true) == Verdict::No);
    CHECK(band_membership(disc(-3.0, 1e-30, 1e-20), false, p3, true) == Verdict::Unknown);
    // A real object: only proven positive real roots.
    CHECK(band_membership(disc(2.0, 0.0, 0.1, true), true, p2, false) == Verdict::Yes);
    CHECK(band_membership(disc(2.0, 0.5, 0.1), false, p2, false) == Verdict::No);
}

static void test_trig_assumption() {
    // band_edge assumes |cos - cos_exact|, |sin - sin_exact| <= 2^-50 on [0, pi].
    for (int i = 0; i <= 100000; ++i) {
        const double a = kPiDouble * i / 100000.0;
        const long double cl = std::cos(static_cast<long double>(a)), sl = std::sin(static_cast<long double>(a));
        CHECK(std::fabs(static_cast<long double>(std::cos(a)) - cl) <= 0x1p-51L);
        CHECK(std::fabs(static_cast<long double>(std::sin(a)) - sl) <= 0x1p-51L);
    }
}

static void test_clip() {
    ObjectRay ray;
    for (int a = 0; a < 3; ++a) {
        ray.origin[a] = Ball(0.0);
        ray.direction[a] = Ball(a == 0 ? 1.0 : 0.0);
    }
    ray.origin[0] = Ball(-5.0);
    // Points -5 + s on the x axis; sphere radius 2: inside for s in [3, 7].
    CHECK(inside_clip(ray, 4.0, 6.0, 2.0) == Verdict::Yes);
    CHECK(inside_clip(ray, 7.5, 8.0, 2.0) == Verdict::No);
    CHECK(inside_clip(ray, 6.9, 7.1, 2.0) == Verdict::Unknown);  // straddles
    CHECK(inside_clip(ray, 7.0, 7.0, 2.0) == Verdict::Yes);       // exactly on the sphere: kept (closed ball)
    CHECK(inside_clip(ray, 2.0, 2.9999999, 2.0) == Verdict::No);
}

/// The claim of ray_misses_sphere in binary128 (113 bits; a product of
/// doubles is exact there): with L = radius + sum rad(o'_k), P = sum
/// rad(d'_k), |o + s d| > L + s P for every s >= 0, i.e. A = |d|^2 - P^2 >
/// 0 (else Q(s) = A s^2 + 2 B s + C goes negative), C = |o|^2 - L^2 > 0 and
/// (B = o.d - L P >= 0 or A C > B^2). ray_misses_sphere claims only with a
/// margin of some 100 double roundings, far above binary128's own error.
static bool misses_sphere_truth(const ObjectRay& ray, double radius) {
    using Q = __float128;
    Q l = radius, p = 0, a = 0, b = 0, c = 0;
    for (int k = 0; k < 3; ++k) {
        const Q om = ray.origin[k].mid, dm = ray.direction[k].mid;
        l += static_cast<Q>(ray.origin[k].rad);
        p += static_cast<Q>(ray.direction[k].rad);
        a += dm * dm;
        b += om * dm;
        c += om * om;
    }
    const Q big_a = a - p * p, big_b = b - l * p, big_c = c - l * l;
    return big_a > 0 && big_c > 0 && (big_b >= 0 || big_a * big_c > big_b * big_b);
}

/// ray_misses_sphere never claims a miss that binary128 refutes, on families
/// of rays placed at the sphere's edge on purpose: closest approach h =
/// radius (1 + eps) with eps of either sign from 1e-300 to 1, the sphere
/// ahead of or behind the origin, the origin inside, radii zero, tiny,
/// subnormal and large, at scales 2^-300 to 2^300; and the non-finite and
/// degenerate rays. It is not vacuous either: a ray whose closest approach
/// is beyond radius (1 + 1e-9), with radii of a few ulps, is claimed (where
/// |o|^2 lies in the range the test runs in, 2^-400 to 2^400).
static void test_ray_misses_sphere() {
    std::mt19937_64 rng(20261202);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), u01(0.0, 1.0);
    auto unit_vector = [&](double* v) {
        double n;
        do {
            for (int k = 0; k < 3; ++k) v[k] = unit(rng);
            n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        } while (n < 0.1);
        for (int k = 0; k < 3; ++k) v[k] /= n;
    };
    long claims = 0, wrong = 0, clear = 0, clear_claimed = 0;
    for (int i = 0; i < 400000; ++i) {
        double d[3], n[3];
        unit_vector(d);
        unit_vector(n);
        // n perpendicular to d (Gram-Schmidt; exactness does not matter:
        // the truth reads the rounded ray).
        const double dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        for (int k = 0; k < 3; ++k) n[k] -= dn * d[k];
        const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (nn < 0.1) continue;
        for (int k = 0; k < 3; ++k) n[k] /= nn;
        const double radius = std::ldexp(0.5 + u01(rng), static_cast<int>(rng() % 601) - 300);
        const double eps = (rng() % 2 ? 1.0 : -1.0) * std::pow(10.0, -300.0 * u01(rng) * u01(rng) * u01(rng));
        const double h = radius * (1.0 + eps);
        // t > 0: the sphere lies ahead (s = t is the closest approach);
        // t < 0: behind; |t| small: the origin near or inside the sphere.
        const double t = radius * (rng() % 4 == 0 ? unit(rng) : 40.0 * unit(rng));
        ObjectRay ray;
        const int rad_kind = static_cast<int>(rng() % 5);
        for (int k = 0; k < 3; ++k) {
            const double o = h * n[k] - t * d[k];
            double orad = 0.0, drad = 0.0;
            switch (rad_kind) {
                case 1: orad = std::fabs(o) * 0x1p-52 * u01(rng); drad = 0x1p-52 * u01(rng); break;
                case 2: orad = 0x1p-1074 * static_cast<double>(rng() % 8); drad = 0x1p-1074 * static_cast<double>(rng() % 8); break;
                case 3: orad = radius * 1e-3 * u01(rng); drad = 1e-3 * u01(rng); break;
                case 4: orad = radius * std::pow(10.0, -16.0 * u01(rng)); drad = std::pow(10.0, -16.0 * u01(rng)); break;
                default: break;
            }
            ray.origin[k] = Ball(o, orad);
            ray.direction[k] = Ball(d[k], drad);
        }
        const bool claim = ray_misses_sphere(ray, radius);
        claims += claim;
        if (claim && !misses_sphere_truth(ray, radius)) {
            ++wrong;
            if (wrong < 5)
                std::fprintf(stderr, "false miss: radius %a eps %g t %g radii kind %d\n", radius, eps, t, rad_kind);
        }
        if (rad_kind <= 1 && eps > 1e-9 && radius > 0x1p-190 && radius < 0x1p190) {  // (|o|^2 within the tested range)
            ++clear;
            clear_claimed += claim;
        }
    }
    std::printf("ray_misses_sphere: %ld claims, %ld clear misses of which %ld claimed\n", claims, clear, clear_claimed);
    CHECK(wrong == 0);
    CHECK(claims > 10000);
    CHECK(clear > 1000 && clear_claimed == clear);
    // Degenerate and non-finite rays claim nothing; a plain miss and a
    // plain hit.
    ObjectRay ray;
    for (int k = 0; k < 3; ++k) {
        ray.origin[k] = Ball(k == 0 ? -10.0 : 0.0);
        ray.direction[k] = Ball(k == 0 ? 1.0 : 0.0);
    }
    CHECK(!ray_misses_sphere(ray, 2.0));  // through the centre
    ray.origin[1] = Ball(3.0);
    CHECK(ray_misses_sphere(ray, 2.0));   // passes at distance 3
    CHECK(!ray_misses_sphere(ray, 3.0));  // touches: |o + 10 d| = 3 exactly
    ray.direction[0] = Ball(-1.0);        // away from the sphere
    CHECK(ray_misses_sphere(ray, 3.0));
    ray.origin[1] = Ball(0.0);
    CHECK(ray_misses_sphere(ray, 9.0));   // behind the origin, |o| = 10 > 9
    CHECK(!ray_misses_sphere(ray, 10.0)); // the origin on the sphere
    CHECK(!ray_misses_sphere(ray, 11.0)); // the origin inside
    for (double bad : {0.0, static_cast<double>(INFINITY), -static_cast<double>(INFINITY), static_cast<double>(NAN), 1e300}) {
        ObjectRay r2 = ray;
        for (int k = 0; k < 3; ++k) r2.direction[k] = Ball(bad);
        CHECK(!ray_misses_sphere(r2, 1.0));
        r2 = ray;
        r2.origin[2] = Ball(bad);
        if (!std::isfinite(bad)) CHECK(!ray_misses_sphere(r2, 1.0));
        r2 = ray;
        r2.origin[2].rad = bad;
        if (!std::isfinite(bad)) CHECK(!ray_misses_sphere(r2, 1.0));
    }
}

/// p(t) = F(o + t d) in long double (a reference for the radii).
static void reference_coefficients(const SurfaceSpec& s, const double* o, const double* d, long double* out) {
    for (int k = 0; k <= s.degree; ++k) out[k] = 0;
    long double oo[3], od[3];
    for (int r = 0; r < 3; ++r) {
        oo[r] = od[r] = 0;
        for (int c = 0; c < 3; ++c) {
            oo[r] += static_cast<long double>(s.linear[3 * r + c]) * (static_cast<long double>(o[c]) - s.translate[c]);
            od[r] += static_cast<long double>(s.linear[3 * r + c]) * d[c];
        }
    }
    for (const Term& t : s.terms) {
        long double poly[kMaxDegree + 1] = {1};
        int deg = 0;
        const int e[3] = {t.ex, t.ey, t.ez};
        for (int a = 0; a < 3; ++a)
            for (int m = 0; m < e[a]; ++m) {
                for (int k = deg + 1; k >= 1; --k) poly[k] = poly[k] * oo[a] + poly[k - 1] * od[a];
                poly[0] *= oo[a];
                ++deg;
            }
        for (int k = 0; k <= deg; ++k) out[k] += t.coeff * poly[k];
    }
}

static void test_ray_coefficients() {
    // A sextic with a rotated, translated transform: the general direction path.
    SceneSpec sc;
    SurfaceSpec s;
    s.degree = 6;
    s.terms = {{6, 0, 0, 1.0}, {0, 6, 0, 1.0}, {0, 0, 6, 1.0}, {2, 2, 2, -3.1}, {1, 1, 0, 0.7}, {0, 0, 0, -1.0}};
    const double ca = std::cos(0.3), sa = std::sin(0.3);
    const double L[9] = {ca, -sa, 0, sa, ca, 0, 0, 0, 1.25};
    for (int i = 0; i < 9; ++i) s.linear[i] = L[i];
    s.translate[0] = 0.1;
    s.translate[2] = -0.2;
    sc.objects.push_back(s);
    sc.camera.position[0] = 3.3;
    sc.camera.position[1] = -2.9;
    sc.camera.position[2] = 1.7;
    FrameParams fp;
    fp.width = fp.height = 9;
    const FramePlan plan = plan_frame(sc, fp);
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 9; ++x) {
            const Ray ray = primary_ray(plan, x, y);
            RayCoefficients<double> p;
            ObjectRay oray;
            primary_ray_polynomial(plan.scene.objects[0], plan.objects[0], ray.direction, p, oray);
            RayCoefficients<DoubleDouble> pd;
            primary_ray_polynomial_dd(plan.scene.objects[0], plan.objects[0], ray.direction, pd);
            long double ref[kMaxDegree + 1];
            reference_coefficients(plan.scene.objects[0], ray.origin, ray.direction, ref);
            CHECK(p.finite && pd.finite);
            // The secondary-ray expansion from a point off the eye.
            const double off[3] = {ray.origin[0] + 0.37, ray.origin[1] - 1.1, ray.origin[2] + 0.05};
            RayCoefficients<double> pg;
            ObjectRay gray;
            general_ray_polynomial(plan.scene.objects[0], off, ray.direction, pg, gray);
            long double gref[kMaxDegree + 1];
            reference_coefficients(plan.scene.objects[0], off, ray.direction, gref);
            CHECK(pg.finite);
            for (int k = 0; k <= 6; ++k) {
                CHECK(std::fabs(gref[k] - pg.c[k]) <= pg.r[k] + 1e-17L * (1 + std::fabs(gref[k])));
                CHECK(pg.r[k] < 1e-11 * (1 + std::fabs(static_cast<double>(gref[k]))));
            }
            for (int k = 0; k <= 6; ++k) {
                // long double's own error is ~1e-19 relative: allow it on top.
                const long double slack = 1e-17L * (1 + std::fabs(ref[k]));
                CHECK(std::fabs(ref[k] - p.c[k]) <= p.r[k] + slack);
                CHECK(p.r[k] < 1e-12 * (1 + std::fabs(static_cast<double>(ref[k]))));  // and it is tight
                CHECK(pd.r[k] < 1e-25 * (1 + std::fabs(static_cast<double>(ref[k]))));
                const long double dd = static_cast<long double>(pd.c[k].hi) + pd.c[k].lo;
                CHECK(std::fabs(ref[k] - dd) <= pd.r[k] + slack);
            }
        }
    // Exact zeros stay exact: x y + z - 1 along the y axis (d = (0, 1, 0)):
    // the t^2 coefficient G_xy d_x d_y is an exact zero (a root at infinity).
    SceneSpec sp;
    SurfaceSpec q;
    q.degree = 2;
    q.terms = {{1, 1, 0, 1.0}, {0, 0, 1, 1.0}, {0, 0, 0, -1.0}};
    sp.objects.push_back(q);
    sp.camera.position[0] = 0.0;
    sp.camera.position[1] = -4.0;
    sp.camera.position[2] = 0.0;
    FrameParams f1;
    f1.width = f1.height = 1;
    const FramePlan pl = plan_frame(sp, f1);
    const Ray ray = primary_ray(pl, 0, 0);
    RayCoefficients<double> p;
    ObjectRay oray;
    primary_ray_polynomial(pl.scene.objects[0], pl.objects[0], ray.direction, p, oray);
    CHECK(ray.direction[0] == 0.0 && ray.direction[2] == 0.0 && ray.direction[1] == 1.0);
    CHECK(p.c[2] == 0.0 && p.r[2] == 0.0);
    CHECK(p.c[0] == -1.0);
}

static void test_refinement() {
    // (t - 2)(t - 2 - 1e-9)(t + 1): a disc around 2 refined in double-double
    // must still hold exactly the root 2 (not the one at 2 + 1e-9).
    RayCoefficients<DoubleDouble> p;
    p.n = 3;
    const long double a = 2, b = 2 + 1e-9L, c = -1;
    const long double k0 = -a * b * c, k1 = a * b + a * c + b * c, k2 = -(a + b + c);
    const long double coeffs[4] = {k0, k1, k2, 1};
    for (int k = 0; k <= 3; ++k) {
        const double hi = static_cast<double>(coeffs[k]);
        p.c[k] = DoubleDouble(hi, static_cast<double>(coeffs[k] - hi));
        p.r[k] = 1e-30;  // covers long double's rounding of the coefficients
    }
    p.finite = true;
    RootDisc d = disc(2.0 - 1e-10, 0.0, 4e-10);  // holds 2 only
    const bool ok = refine_disc_dd(p, true, d);
    CHECK(ok);
    CHECK(d.radius < 1e-15);
    CHECK(std::fabs(d.re - 2.0) <= d.radius + 1e-300);
    // A disc holding both roots is not a count-1 disc: refinement refuses clusters.
    RootDisc cluster{2.0, 0.0, 1e-8, 2, true, false};
    CHECK(!refine_disc_dd(p, false, cluster));
}

static void test_isolation() {
    // (t - 2)(t - 2 - 1e-9)(t + 1) with coefficient radii 1e-30: one double
    // disc holding both roots near 2 is split into two proven discs.
    RayCoefficients<DoubleDouble> p;
    p.n = 3;
    const long double a = 2, b = 2 + 1e-9L, c = -1;
    const long double coeffs[4] = {-a * b * c, a * b + a * c + b * c, -(a + b + c), 1};
    for (int k = 0; k <= 3; ++k) {
        const double hi = static_cast<double>(coeffs[k]);
        p.c[k] = DoubleDouble(hi, static_cast<double>(coeffs[k] - hi));
        p.r[k] = 1e-30;
    }
    p.finite = true;
    RootsResult res;
    res.n_infinite = 0;
    res.n_discs = 2;
    res.discs[0] = RootDisc{2.0, 0.0, 1e-7, 2, true, false};
    res.discs[1] = RootDisc{-1.0, 0.0, 1e-12, 1, true, true};
    CHECK(isolate_dd(p, res));
    CHECK(res.n_discs == 3);
    int near2 = 0;
    for (int i = 0; i < res.n_discs; ++i) {
        const RootDisc& d = res.discs[i];
        CHECK(d.verified && d.count == 1 && d.radius < 1e-12);
        const bool holds_a = std::hypot(d.re - 2.0, d.im) <= d.radius;
        const bool holds_b = std::hypot(d.re - static_cast<double>(b), d.im) <= d.radius + 1e-18;
        const bool holds_c = std::hypot(d.re + 1.0, d.im) <= d.radius;
        CHECK(holds_a + holds_b + holds_c == 1);
        near2 += holds_a || holds_b;
    }
    CHECK(near2 == 2);
    // Radii that blur the two roots together: refused, res untouched.
    for (int k = 0; k <= 3; ++k) p.r[k] = 1e-12;
    res.n_discs = 2;
    res.discs[0] = RootDisc{2.0, 0.0, 1e-5, 2, true, false};
    res.discs[1] = RootDisc{-1.0, 0.0, 1e-12, 1, true, true};
    CHECK(!isolate_dd(p, res));
    CHECK(res.n_discs == 2 && res.discs[0].count == 2);
}

static void test_tiles_and_limits() {
    // 18 objects (the old 16-entry array overflowed) render, clipped and not.
    for (double clip : {0.0, 1.5}) {
        FramePlan pl = plan_with(0.0, 0.3, sphere_scene(clip, 18));
        TileAOVs t;
        render_tile(pl, TileRect{0, 0, 16, 16}, t);
        CHECK(t.width == 16 && t.height == 16 && t.status.size() == 256 && t.escalation.size() == 256);
        int certified = 0;
        for (auto v : t.status) certified += v == kCertified;
        CHECK(certified > 200);
    }
    FramePlan full = plan_with(0.0, 0.0, sphere_scene(0.0, kMaxObjects));
    TileAOVs t;
    render_tile(full, TileRect{0, 0, 16, 16}, t);
    CHECK(t.status.size() == 256);
    bool threw = false;
    try {
        plan_with(0.0, 0.0, sphere_scene(0.0, kMaxObjects + 1));
    } catch (const std::invalid_argument& e) {
        threw = std::string(e.what()).find(std::to_string(kMaxObjects)) != std::string::npos;
    }
    CHECK(threw);
    // explain_pixel runs render_tile's path: same status and escalation.
    FramePlan pl = plan_with(0.0, 0.2, sphere_scene(1.2, 3));
    TileAOVs all;
    render_tile(pl, TileRect{0, 0, 16, 16}, all);
    for (int y = 0; y < 16; y += 5)
        for (int x = 0; x < 16; x += 3) {
            const PixelExplanation e = explain_pixel(pl, x, y, 0);
            CHECK(e.status == all.status[y * 16 + x]);
            CHECK(e.level == all.escalation[y * 16 + x]);
            CHECK(e.hit == (all.rgba[4 * (y * 16 + x) + 3] > 0));
        }
}

/// The exact tier's hook contract: called only for primary rays not proven
/// after level 4, at most exact_pixels_per_block times per 8x8 block, with the
/// pixel's own ray; its decided answer is what the pixel shows, its
/// undecided answer keeps the ladder's picture, and pixels beyond the budget
/// are level 7. (The solver here answers from the query alone: the real one
/// is argand.render.exact, tested in tests/render/test_exact.py.)
static void test_exact_hook() {
    // The unit sphere clipped by the unit ball: every real root lies on the
    // sphere, which no disc decides (status 3 after level 4).
    SceneSpec sc = sphere_scene(1.0);
    sc.camera.position[0] = 0.0;
    sc.camera.position[2] = 0.3;
    FrameParams fp;
    fp.width = fp.height = 9;
    FramePlan pl = plan_frame(sc, fp);
    TileAOVs plain;
    render_tile(pl, TileRect{0, 0, 9, 9}, plain);
    int open = 0;
    for (auto v : plain.status) open += v != kCertified;
    CHECK(open > 4);
    int calls = 0;
    bool rays_match = true;
    ExactSolver undecided = [&](const FramePlan& p, const ExactQuery& q) {
        ++calls;
        const Ray r = primary_ray(p, q.x, q.y);
        for (int a = 0; a < 3; ++a)
            rays_match = rays_match && r.origin[a] == q.ray.origin[a] && r.direction[a] == q.ray.direction[a];
        ExactAnswer a;
        a.status = kUndecided;
        return a;
    };
    pl.params.exact_pixels_per_block = 3;
    TileAOVs t;
    render_tile(pl, TileRect{0, 0, 9, 9}, t, &undecided);
    // The budget is per frame-aligned block of kSeedBlock x kSeedBlock
    // samples: the 9x9 frame has four (8x8, 1x8, 8x1, 1x1).
    int open_in[2][2] = {{0, 0}, {0, 0}};
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 9; ++x) open_in[y / kSeedBlock][x / kSeedBlock] += plain.status[y * 9 + x] != kCertified;
    int budgeted = 0;
    for (auto& row : open_in)
        for (int n : row) budgeted += std::min(n, 3);
    CHECK(budgeted < open && calls == budgeted && rays_match);
    int at_exact = 0, over = 0;
    for (std::size_t i = 0; i < t.status.size(); ++i) {
        at_exact += t.escalation[i] == kLevelExact;
        over += t.escalation[i] == kLevelExactOverCap;
        CHECK(t.status[i] == plain.status[i]);            // undecided: the ladder's status
        CHECK(t.rgba[4 * i + 3] == plain.rgba[4 * i + 3]);  // and its picture
    }
    CHECK(at_exact == budgeted && over == open - budgeted);
    // A decided answer (here: a proven miss) is what the pixel shows.
    ExactSolver miss = [&](const FramePlan&, const ExactQuery&) {
        ExactAnswer a;
        a.decided = true;
        a.status = kCertified;
        return a;
    };
    pl.params.exact_pixels_per_block = 100;
    render_tile(pl, TileRect{0, 0, 9, 9}, t, &miss);
    for (std::size_t i = 0; i < t.status.size(); ++i) {
        CHECK(t.status[i] == kCertified);
        if (plain.status[i] != kCertified) CHECK(t.escalation[i] == kLevelExact && t.rgba[4 * i + 3] == 0.0f);
    }
    // Off (budget 0) or no hook: the ladder stops at level 4.
    pl.params.exact_pixels_per_block = 0;
    calls = 0;
    render_tile(pl, TileRect{0, 0, 9, 9}, t, &undecided);
    CHECK(calls == 0 && t.escalation == plain.escalation);
    bool threw = false;
    fp.exact_max_bits = 32;
    try {
        plan_frame(sc, fp);
    } catch (const std::invalid_argument&) {
        threw = true;
    }
    CHECK(threw);
}

// Samples per pixel: the squares up to kMaxSamples; sample k of pixel (x, y)
// is, to the bit, pixel (side x + k % side, side y + k / side) of the frame
// side times finer; a sampled tile's status is the worst of its samples'.
static void test_samples() {
    for (int n = -1; n <= kMaxSamples + 1; ++n) {
        const int side = sample_side(n);
        CHECK(side == ((n == 1 || n == 4 || n == 9 || n == 16 || n == 25 || n == 36 || n == 49 || n == 64)
                           ? static_cast<int>(std::lround(std::sqrt(n)))
                           : 0));
    }
    const SceneSpec sc = sphere_scene(1.2);
    FrameParams coarse_p, fine_p;
    coarse_p.width = 5;
    coarse_p.height = 3;
    coarse_p.samples = 9;
    fine_p.width = 15;
    fine_p.height = 9;
    const FramePlan coarse = plan_frame(sc, coarse_p), fine = plan_frame(sc, fine_p);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x)
            for (int k = 0; k < 9; ++k) {
                const Ray a = primary_ray(coarse, x, y, k), b = primary_ray(fine, 3 * x + k % 3, 3 * y + k / 3);
                for (int i = 0; i < 3; ++i) CHECK(a.direction[i] == b.direction[i] && a.origin[i] == b.origin[i]);
            }
    TileAOVs c, f;
    render_tile(coarse, TileRect{0, 0, 5, 3}, c);
    render_tile(fine, TileRect{0, 0, 15, 9}, f);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x) {
            int worst = 0, certified = 0, hits = 0;
            for (int k = 0; k < 9; ++k) {
                const std::size_t i = static_cast<std::size_t>(3 * y + k / 3) * 15 + 3 * x + k % 3;
                worst = std::max<int>(worst, f.status[i]);
                certified += f.status[i] == kCertified;
                hits += f.rgba[4 * i + 3] > 0.0f;
            }
            const std::size_t p = static_cast<std::size_t>(y) * 5 + x;
            CHECK(c.status[p] == worst);
            CHECK(c.certified_share[p] == static_cast<float>(certified / 9.0));
            CHECK(c.rgba[4 * p + 3] == static_cast<float>(hits / 9.0));
        }
    coarse_p.samples = 8;
    bool refused = false;
    try {
        plan_frame(sc, coarse_p);
    } catch (const std::invalid_argument&) {
        refused = true;
    }
    CHECK(refused);
}

/// Tracer::decide's fast predicates (pixel_decision.h, *_fast) against their
/// references, on random discs and on discs placed at every edge on purpose:
/// each must return exactly what the reference returns.
static RootDisc random_disc(std::mt19937_64& g, double edge_a, double edge_b) {
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    auto pick = [&](int n) { return static_cast<int>(u01(g) * n) % n; };
    const double rho = std::pow(10.0, -3.0 + 6.0 * u01(g)) * (pick(20) == 0 ? 1e-300 : 1.0);
    const double radii[] = {0.0, 0x1p-1074, 1e-300, 1e-17, 1e-16, 1e-14, 1e-12, 1e-9, 1e-6, 1e-3, 0.1, 0.7};
    double radius = radii[pick(12)] * (pick(3) == 0 ? 1.0 : rho);
    double angle;
    switch (pick(6)) {
        case 0: angle = kPiDouble * (2.0 * u01(g) - 1.0); break;                 // anywhere
        case 1: angle = edge_a + (pick(2) ? 1 : -1) * std::ldexp(u01(g), -pick(60)); break;  // at the lower edge
        case 2: angle = edge_b + (pick(2) ? 1 : -1) * std::ldexp(u01(g), -pick(60)); break;  // at the upper edge
        case 3: angle = pick(2) ? edge_a : edge_b; break;                          // exactly on an edge
        case 4: angle = std::ldexp(u01(g), -pick(60)) * (pick(2) ? 1 : -1); break;  // near the positive axis
        default: angle = kPiDouble - std::ldexp(u01(g), -pick(60)); break;        // near the negative axis
    }
    if (pick(2)) angle = -angle;  // the conjugate side
    RootDisc d{rho * std::cos(angle), rho * std::sin(angle), radius, 1, true, false};
    switch (pick(8)) {
        case 0: d.im = 0.0; d.real = true; break;                                 // a real root (solver's flag)
        case 1: d.im = std::ldexp(d.radius, -pick(4)) * (pick(2) ? 1 : -1); break;  // meets its mirror
        case 2: d.count = 2 + pick(3); break;                                    // a cluster
        case 3: if (pick(4) == 0) d = RootDisc{0.0, 0.0, 0.0, 1, true, false}; break;  // the exact root 0
        case 4: d.radius = std::fabs(d.re) * (1.0 + 1e-3 * u01(g)); break;        // holds or nearly holds 0
        default: break;
    }
    return d;
}

static void test_fast_decisions() {
    std::mt19937_64 g(20261202);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    const double bands[][2] = {{0.0, 0.0},  {0.0, kPiDouble / 9}, {0.0, kPiDouble / 18}, {0.3, kPiDouble / 4},
                               {0.1, 0.2},  {0.0, kPiDouble},     {1.0, 0.0},            {0.5, kPiDouble - 0.5},
                               {1e-300, 0.3}};
    long compared = 0, mirror_real = 0, twins = 0;
    long memo_shared = 0;
    const int n_bands = static_cast<int>(sizeof bands / sizeof bands[0]);
    for (int bi = 0; bi < n_bands; ++bi) {
        const auto& b = bands[bi];
        const FramePlan plan = plan_with(b[0], b[1]);
        // Another band of the same rays (render_tile_bands' sharing of a
        // ClassifyMemo).
        const FramePlan other = plan_with(bands[(bi + 3) % n_bands][0], bands[(bi + 3) % n_bands][1]);
        for (int cs = 0; cs < 2; ++cs) {
            const BandPlan bp = band_plan(plan, cs == 1);
            for (int trial = 0; trial < 4000; ++trial) {
                // One polynomial's discs (all verified), with conjugate pairs.
                RootDisc all[12];
                int n = 1 + static_cast<int>(u01(g) * 8);
                for (int i = 0; i < n; ++i) all[i] = random_disc(g, b[0], b[0] + b[1]);
                for (int i = 0; i < n && n < 12; ++i)
                    if (u01(g) < 0.3) {  // its mirror image, exact or slightly off
                        RootDisc m = all[i];
                        m.im = -m.im;
                        if (u01(g) < 0.5) m.re += m.radius * 0.25;
                        all[n++] = m;
                    }
                for (int i = 0; i < n; ++i) {
                    const bool real = proven_real(all, n, i, true);
                    if (real && !all[i].real) ++mirror_real;
                    CHECK(band_fast_verified(all, n, i, bp) == band_membership(all[i], real, plan, cs == 1));
                    CHECK(band_fast(all[i], false, bp) == band_membership(all[i], false, plan, cs == 1));
                    CHECK(band_fast(all[i], true, bp) == band_membership(all[i], true, plan, cs == 1));
                    double lo, hi, lo2, hi2;
                    modulus_bounds(all[i], lo, hi);
                    modulus_fast(all[i], lo2, hi2);
                    CHECK(std::memcmp(&lo, &lo2, sizeof lo) == 0 && std::memcmp(&hi, &hi2, sizeof hi) == 0);
                    for (int j = 0; j < n; ++j) {
                        if (j == i) continue;
                        const bool t = is_mirror_twin(all[i], all[j], all, n, true);
                        twins += t;
                        CHECK(is_mirror_twin_fast(all, n, i, j) == t);
                    }
                    ++compared;
                }
            }
        }
        // The edges themselves: edge_range_fast's signs are edge_range's.
        for (const FramePlan::BandEdge& e : {plan.lower_edge, plan.upper_edge}) {
            const FastEdge f = fast_edge(e);
            for (int trial = 0; trial < 20000; ++trial) {
                const RootDisc d = random_disc(g, b[0], b[0] + b[1]);
                const double x = d.re, y = std::fabs(d.im);
                double lo, hi, lo2, hi2;
                edge_range(e, x, y, d.radius, lo, hi);
                edge_range_fast(f, x, y, d.radius, lo2, hi2);
                CHECK((lo >= 0.0) == (lo2 >= 0.0) && (lo > 0.0) == (lo2 > 0.0));
                CHECK((hi <= 0.0) == (hi2 <= 0.0) && (hi < 0.0) == (hi2 < 0.0));
            }
        }
    }
    // Moduli at the edges of modulus_fast's shortcuts: the lower bound at
    // and around 0, radii up to infinity, moduli at the safe range's ends.
    for (double re : {1.0, 3.7, 1e-300, 0x1p-500, 0x1.0000000000001p-500, 0x1p500, 1e200, 0x1p-1074}) {
        for (double im : {0.0, 0.5 * re, -re}) {
            const double m = std::sqrt(re * re + im * im);
            const double a1 = std::nextafter(m * (1.0 - 4.0 * 0x1p-53), 0.0);
            for (double r : {0.0, a1, std::nextafter(a1, 0.0), std::nextafter(a1, 1e308), a1 - 0x1p-1074, 0.5 * m, 1e308,
                             1.7976931348623157e308, static_cast<double>(INFINITY)}) {
                const RootDisc d{re, im, r, 1, true, false};
                double lo, hi, lo2, hi2;
                modulus_bounds(d, lo, hi);
                modulus_fast(d, lo2, hi2);
                CHECK(std::memcmp(&lo, &lo2, sizeof lo) == 0 && std::memcmp(&hi, &hi2, sizeof hi) == 0);
            }
        }
    }
    CHECK(compared > 100000);
    CHECK(mirror_real > 100);  // realness by the mirror test was exercised
    CHECK(twins > 100);
    // The sphere: random rays and modulus ranges, many straddling the sphere.
    long yes = 0, no = 0, unknown = 0;
    for (int trial = 0; trial < 200000; ++trial) {
        ObjectRay ray;
        const double scale = std::pow(10.0, -2.0 + 4.0 * u01(g));
        for (int a = 0; a < 3; ++a) {
            ray.origin[a] = Ball(scale * (2.0 * u01(g) - 1.0) * 10.0, u01(g) < 0.5 ? 0.0 : std::ldexp(u01(g), -40 - trial % 20));
            ray.direction[a] = Ball(2.0 * u01(g) - 1.0, u01(g) < 0.5 ? 0.0 : std::ldexp(u01(g), -45 - trial % 15));
        }
        if (trial % 7 == 0) ray.direction[trial % 3] = Ball(0.0);
        // A modulus range around a point s0 of the ray; the sphere through
        // that point (to a relative 2^-k), or anywhere.
        const double s0 = scale * 20.0 * u01(g);
        double p2 = 0.0;
        for (int a = 0; a < 3; ++a) {
            const double v = ray.origin[a].mid + s0 * ray.direction[a].mid;
            p2 += v * v;
        }
        double radius = std::sqrt(p2) * (1.0 + (2.0 * u01(g) - 1.0) * std::ldexp(1.0, -static_cast<int>(u01(g) * 60)));
        if (trial % 5 == 0) radius = scale * std::pow(10.0, -1.0 + 2.0 * u01(g));
        if (trial % 97 == 0) radius *= 1e-300;
        double width = std::ldexp(u01(g), -static_cast<int>(u01(g) * 50)) * scale;
        if (trial % 11 == 0) width = 0.0;
        double lo = std::max(0.0, s0 - width * u01(g));
        if (trial % 13 == 0) lo = 0.0;
        const double hi = lo + width;
        const Verdict v = inside_clip(ray, lo, hi, radius);
        CHECK(clip_fast(ray, clip_sums(ray), lo, hi, radius) == v);
        yes += v == Verdict::Yes;
        no += v == Verdict::No;
        unknown += v == Verdict::Unknown;
    }
    std::printf("clip cases: %ld yes, %ld no, %ld unknown\n", yes, no, unknown);
    CHECK(yes > 1000 && no > 1000 && unknown > 100);
    // The x-axis ray of test_clip: every case, fast and full alike.
    ObjectRay ray;
    for (int a = 0; a < 3; ++a) {
        ray.origin[a] = Ball(a == 0 ? -5.0 : 0.0);
        ray.direction[a] = Ball(a == 0 ? 1.0 : 0.0);
    }
    const double ranges[][2] = {{4.0, 6.0}, {7.5, 8.0}, {6.9, 7.1}, {7.0, 7.0}, {2.0, 2.9999999}, {3.0, 3.0}};
    for (const auto& r : ranges) CHECK(clip_fast(ray, clip_sums(ray), r[0], r[1], 2.0) == inside_clip(ray, r[0], r[1], 2.0));
}

// classify_discs_avx2 / classify_discs_scalar against decide_full's
// references, disc by disc: random disc sets (conjugate pairs, clusters,
// discs on and near band edges, at zero, meeting their mirror) on random rays
// with a clipping sphere through one of the discs (so their quick sphere test
// straddles it) or none, at bands with sigma = 0 and > 0, delta = 0, the
// half-plane.
static void test_classify_discs() {
    std::mt19937_64 g(20261203);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    const double bands[][2] = {{0.0, 0.0}, {0.0, kPiDouble / 9}, {0.3, kPiDouble / 4}, {1.0, 0.0},
                               {0.0, kPiDouble}, {0.2, kPiDouble - 0.2}, {1e-300, 0.3}};
    long compared = 0, live = 0, eligible = 0;
    const bool avx2 = classify_discs_avx2_supported();
    std::printf("classify_discs_avx2 supported: %d\n", avx2 ? 1 : 0);
    long memo_shared = 0;
    const int n_bands = static_cast<int>(sizeof bands / sizeof bands[0]);
    for (int bi = 0; bi < n_bands; ++bi) {
        const auto& b = bands[bi];
        const FramePlan plan = plan_with(b[0], b[1]);
        // Another band of the same rays (render_tile_bands' sharing of a
        // ClassifyMemo).
        const FramePlan other = plan_with(bands[(bi + 3) % n_bands][0], bands[(bi + 3) % n_bands][1]);
        for (int cs = 0; cs < 2; ++cs) {
            for (int trial = 0; trial < 6000; ++trial) {
                RootDisc all[16];
                int n = 1 + static_cast<int>(u01(g) * 9);
                for (int i = 0; i < n; ++i) all[i] = random_disc(g, b[0], b[0] + b[1]);
                for (int i = 0; i < n && n < 16; ++i)
                    if (u01(g) < 0.3) {  // its mirror image, exact or slightly off
                        RootDisc m = all[i];
                        m.im = -m.im;
                        if (u01(g) < 0.3) m.re += m.radius * 0.25;
                        all[n++] = m;
                    }
                if (u01(g) < 0.05) all[static_cast<int>(u01(g) * n)].count = 0;
                ObjectRay ray;
                const double scale = std::pow(10.0, -2.0 + 3.0 * u01(g));
                for (int a = 0; a < 3; ++a) {
                    ray.origin[a] = Ball(scale * (2.0 * u01(g) - 1.0), u01(g) < 0.5 ? 0.0 : std::ldexp(u01(g), -45));
                    ray.direction[a] = Ball(2.0 * u01(g) - 1.0, u01(g) < 0.5 ? 0.0 : std::ldexp(u01(g), -50));
                }
                // The sphere: none, anywhere, or through the point at a
                // disc's modulus (to a relative 2^-k).
                double radius = 0.0;
                const int kind = static_cast<int>(u01(g) * 4);
                if (kind == 1) radius = scale * std::pow(10.0, -1.0 + 3.0 * u01(g));
                if (kind >= 2) {
                    const RootDisc& d = all[static_cast<int>(u01(g) * n)];
                    const double s0 = std::hypot(d.re, d.im);
                    double p2 = 0.0;
                    for (int a = 0; a < 3; ++a) {
                        const double v = ray.origin[a].mid + s0 * ray.direction[a].mid;
                        p2 += v * v;
                    }
                    radius = std::sqrt(p2) * (1.0 + (2.0 * u01(g) - 1.0) * std::ldexp(1.0, -static_cast<int>(u01(g) * 55)));
                }
                const ClassifyPlan cp = classify_plan(plan, cs == 1, radius);
                DiscVerdicts vs, va;
                classify_discs_scalar(all, n, cp, ray, vs);
                classify_discs_avx2(all, n, cp, ray, va);
                CHECK(vs.live == va.live && vs.eligible == va.eligible);
                CHECK(vs.best == va.best && vs.count == va.count && vs.blockers == va.blockers);
                if (avx2 && n <= ClassifyMemo::kDiscs) {
                    // The memo filled by another band (its moduli and sphere
                    // kept for the groups that band needed), then by this
                    // band itself: the same verdicts as without a memo.
                    for (int fill = 0; fill < 2; ++fill) {
                        ClassifyMemo memo;
                        DiscVerdicts vo, vm;
                        if (fill == 0) classify_discs_avx2(all, n, classify_plan(other, cs == 1, radius), ray, vo, &memo);
                        else classify_discs_avx2(all, n, cp, ray, vo, &memo);
                        memo_shared += memo.groups != 0;
                        classify_discs_avx2(all, n, cp, ray, vm, &memo);
                        CHECK(vm.live == va.live && vm.eligible == va.eligible && vm.best == va.best &&
                              vm.count == va.count && vm.blockers == va.blockers);
                        for (std::uint64_t m = va.live; m != 0; m &= m - 1) {
                            const int i = __builtin_ctzll(m);
                            CHECK(std::memcmp(&vm.lo[i], &va.lo[i], 8) == 0 && std::memcmp(&vm.hi[i], &va.hi[i], 8) == 0);
                        }
                    }
                }
                for (int i = 0; i < n; ++i) {
                    const RootDisc& d = all[i];
                    const std::uint64_t bit = std::uint64_t{1} << i;
                    bool ref_live = false, ref_eligible = false;
                    double lo = 0.0, hi = 0.0;
                    if (d.count > 0 && !(d.re == 0.0 && d.im == 0.0 && d.radius == 0.0)) {
                        const Verdict band = band_membership(d, proven_real(all, n, i, true), plan, cs == 1);
                        if (band != Verdict::No) {
                            modulus_bounds(d, lo, hi);
                            const Verdict clip = radius > 0.0 ? inside_clip(ray, lo, hi, radius) : Verdict::Yes;
                            ref_live = clip != Verdict::No;
                            ref_eligible = ref_live && band == Verdict::Yes && clip == Verdict::Yes;
                        }
                    }
                    CHECK(((va.live & bit) != 0) == ref_live && ((va.eligible & bit) != 0) == ref_eligible);
                    CHECK(((vs.live & bit) != 0) == ref_live && ((vs.eligible & bit) != 0) == ref_eligible);
                    if (ref_live) {
                        CHECK(std::memcmp(&va.lo[i], &lo, 8) == 0 && std::memcmp(&va.hi[i], &hi, 8) == 0);
                        CHECK(std::memcmp(&vs.lo[i], &lo, 8) == 0 && std::memcmp(&vs.hi[i], &hi, 8) == 0);
                    }
                    live += ref_live;
                    eligible += ref_eligible;
                    ++compared;
                }
            }
        }
    }
    std::printf("classify: %ld discs, %ld live, %ld eligible; %ld memos shared\n", compared, live, eligible,
                memo_shared);
    CHECK(!avx2 || memo_shared > 1000);
    CHECK(compared > 100000 && live > 10000 && eligible > 5000);
}


/// A tile's planes, owned (render_tile_bands writes through a TileView).
struct OwnedTile {
    int w, h;
    std::vector<float> rgba, z, arg, re, im, share;
    std::vector<std::int32_t> count;
    std::vector<std::uint8_t> status, level;
    TileView v;
    OwnedTile(int w_, int h_) : w(w_), h(h_) {
        const std::size_t n = static_cast<std::size_t>(w) * h;
        rgba.assign(4 * n, -1.0f), z.assign(n, -1.0f), arg.assign(n, -1.0f), re.assign(n, -1.0f), im.assign(n, -1.0f);
        share.assign(n, -1.0f), count.assign(n, -1), status.assign(n, 99), level.assign(n, 99);
        v.stride = w;
        v.rgba = rgba.data(), v.modulus = z.data(), v.argument = arg.data(), v.re = re.data(), v.im = im.data();
        v.count = count.data(), v.status = status.data(), v.escalation = level.data(), v.certified_share = share.data();
    }
    bool same(const OwnedTile& o) const {
        return std::memcmp(rgba.data(), o.rgba.data(), rgba.size() * 4) == 0 &&
               std::memcmp(z.data(), o.z.data(), z.size() * 4) == 0 && std::memcmp(re.data(), o.re.data(), re.size() * 4) == 0 &&
               std::memcmp(im.data(), o.im.data(), im.size() * 4) == 0 && count == o.count && status == o.status &&
               level == o.level;
    }
};

/// The root field: recorded once, replayed for other bands with the bits of
/// a render from scratch; a field of another tile or cut anywhere, or with
/// a byte too many, is refused before anything is read out of bounds (the
/// sanitizer build runs this too).
static void test_root_field() {
    SceneSpec sc;
    SurfaceSpec s;  // x^6 + y^6 + z^6 - 1: degree 6, batched and seeded
    s.degree = 6;
    s.terms = {{6, 0, 0, 1.0}, {0, 6, 0, 1.0}, {0, 0, 6, 1.0}, {0, 0, 0, -1.0}};
    s.clip_radius = 1.6;
    sc.objects.push_back(s);
    sc.camera.position[0] = 0.3;
    sc.camera.position[1] = -4.0;
    sc.camera.position[2] = 0.7;
    auto plan = [&](double sigma, double delta) {
        FrameParams fp;
        fp.sigma = sigma;
        fp.delta = delta;
        fp.width = 40;
        fp.height = 24;
        return plan_frame(sc, fp);
    };
    const FramePlan a = plan(0.0, 0.0), b = plan(0.4, 0.9), c = plan(0.0, kPiDouble);
    const TileRect r{8, 0, 40, 24};
    RootField field;
    OwnedTile ta(32, 24);
    render_tile_bands({&a}, r, {&ta.v}, nullptr, &field, nullptr);
    CHECK(field.bytes.size() > 32 * 24 * 5);
    for (const FramePlan* p : {&a, &b, &c}) {
        OwnedTile scratch(32, 24), derived(32, 24);
        render_tile_bands({p}, r, {&scratch.v}, nullptr, nullptr, nullptr);
        render_tile_bands({p}, r, {&derived.v}, nullptr, nullptr, &field);
        CHECK(scratch.same(derived));
    }
    auto refused = [&](const RootField& f, const TileRect& rr) {
        OwnedTile t(40, 24);
        try {
            render_tile_bands({&b}, rr, {&t.v}, nullptr, nullptr, &f);
        } catch (const std::invalid_argument&) {
            return true;
        }
        return false;
    };
    CHECK(refused(field, TileRect{0, 0, 32, 24}));  // another tile
    for (std::size_t cut : {field.bytes.size() - 1, field.bytes.size() / 2, std::size_t{40}, std::size_t{3}}) {
        RootField f;
        f.bytes.assign(field.bytes.begin(), field.bytes.begin() + static_cast<std::ptrdiff_t>(cut));
        CHECK(refused(f, r));
    }
    RootField longer = field;
    longer.bytes.push_back(0);
    CHECK(refused(longer, r));
    // Every single byte after the header set to 255 (a disc count above the
    // degree, flags that do not exist, a status out of range, or a length
    // that runs past the end): refused, or read within bounds.
    for (std::size_t at = 28; at < field.bytes.size(); at += 97) {
        RootField f = field;
        f.bytes[at] = 255;
        OwnedTile t(32, 24);
        try {
            render_tile_bands({&b}, r, {&t.v}, nullptr, nullptr, &f);
        } catch (const std::invalid_argument&) {
        }
    }
    const FramePlan other = [&] {
        SceneSpec sc2 = sc;
        sc2.objects[0].terms[3].coeff = -1.5;
        FrameParams fp = a.params;
        return plan_frame(sc2, fp);
    }();
    CHECK(rays_fingerprint(other) != rays_fingerprint(a));
    CHECK(rays_fingerprint(b) == rays_fingerprint(a));
    {
        OwnedTile t(32, 24);
        bool threw = false;
        try {
            render_tile_bands({&other}, r, {&t.v}, nullptr, nullptr, &field);
        } catch (const std::invalid_argument&) {
            threw = true;
        }
        CHECK(threw);
    }
}

int main() {
    test_band_rule();
    test_balls();
    test_band_membership();
    test_trig_assumption();
    test_clip();
    test_ray_misses_sphere();
    test_fast_decisions();
    test_classify_discs();
    test_ray_coefficients();
    test_refinement();
    test_isolation();
    test_tiles_and_limits();
    test_exact_hook();
    test_samples();
    test_root_field();
    return check_summary("render_test");
}
