// polish_test.cpp: polish_root (polish.h) against roots known exactly or
// correctly rounded, from starts all over their discs: the same double
// whatever the start, false where the disc does not hold the root.
#include <cmath>
#include <cstdio>
#include <random>

#include "check.h"
#include "polish.h"

using namespace argand;
using argand::detail::polish_root;
using argand::detail::wants_polish;

namespace {
RootDisc disc(double re, double im, double radius, bool real, int count = 1, bool verified = true) {
    return RootDisc{re, im, radius, count, verified, real};
}
}  // namespace

int main() {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);

    // t^2 - 2: the positive root is sqrt(2) correctly rounded, from any start
    // in a disc of radius 1e-2 (real iteration).
    {
        const double c[] = {-2.0, 0.0, 1.0};
        for (int i = 0; i < 200; ++i) {
            double re = NAN, im = NAN;
            const RootDisc d = disc(std::sqrt(2.0) + 0.009 * u(rng), 0.0, 0.02, true);
            CHECK(polish_root(c, 2, d, re, im));
            CHECK(re == std::sqrt(2.0) && im == 0.0);
        }
    }
    // (t - 1.5)(t + 2.25)(t^2 - 1.5 t + 2.125): roots 1.5, -2.25, 0.75 +- 1.25 i,
    // every coefficient exact; complex iteration for the pair.
    {
        // (t^2 + 0.75 t - 3.375)(t^2 - 1.5 t + 2.125)
        const double c[] = {-3.375 * 2.125, 0.75 * 2.125 + 3.375 * 1.5, 2.125 - 1.125 - 3.375, 0.75 - 1.5, 1.0};
        for (int i = 0; i < 200; ++i) {
            double re = NAN, im = NAN;
            const RootDisc d = disc(0.75 + 0.004 * u(rng), 1.25 + 0.004 * u(rng), 0.01, false);
            CHECK(polish_root(c, 4, d, re, im));
            CHECK(re == 0.75 && im == 1.25);
            CHECK(polish_root(c, 4, disc(-2.25 + 0.01 * u(rng), 0.0, 0.03, true), re, im));
            CHECK(re == -2.25 && im == 0.0);
        }
    }
    // t^2 - 2 t + 3: 1 +- i sqrt(2).
    {
        const double c[] = {3.0, -2.0, 1.0};
        double re = NAN, im = NAN;
        CHECK(polish_root(c, 2, disc(1.0003, -1.4139, 0.01, false), re, im));
        CHECK(re == 1.0 && im == -std::sqrt(2.0));
    }
    // A root the caller proved real (`real`), in a disc whose centre lies
    // off the axis and that is not marked real: the real iteration gives the
    // correctly rounded root and im = 0 exactly; a centre already within
    // kPolishRelativeRadius of it gives its real part, im = 0. Without
    // `real` the complex iteration reaches the same real part.
    {
        const double c[] = {-2.0, 0.0, 1.0};
        for (int i = 0; i < 200; ++i) {
            double re = NAN, im = NAN;
            const RootDisc d = disc(std::sqrt(2.0) + 0.004 * u(rng), 0.004 * u(rng), 0.01, false);
            CHECK(polish_root(c, 2, d, re, im, true));
            CHECK(re == std::sqrt(2.0) && im == 0.0 && !std::signbit(im));
            CHECK(polish_root(c, 2, d, re, im));
            CHECK(re == std::sqrt(2.0) && std::fabs(im) < 1e-30);
        }
        const double near = std::sqrt(2.0) * (1.0 + 0x1p-40);
        double re = NAN, im = NAN;
        CHECK(polish_root(c, 2, disc(near, 1e-9, 0.01, false), re, im, true));
        CHECK(re == near && im == 0.0);
    }
    // Refusals: a disc not verified, one of two roots, one that holds no
    // root (the iteration leaves it), a start at a zero derivative.
    {
        const double c[] = {-2.0, 0.0, 1.0};
        double re = 7.0, im = 7.0;
        CHECK(!polish_root(c, 2, disc(1.41, 0.0, 0.01, true, 1, false), re, im));
        CHECK(!polish_root(c, 2, disc(1.41, 0.0, 0.01, true, 2), re, im));
        CHECK(!polish_root(c, 2, disc(3.0, 0.0, 0.5, true), re, im));
        CHECK(!polish_root(c, 2, disc(0.0, 0.0, 0.1, true), re, im));
        CHECK(re == 7.0 && im == 7.0);  // untouched
        const double cubed[] = {-1.0, 3.0, -3.0, 1.0};  // (t - 1)^3: no simple root to polish
        CHECK(!polish_root(cubed, 3, disc(1.0, 0.0, 0.0, true), re, im));
    }
    // polish_root_at_point: F = x^2 + y^2 + z^2 - 4 (the sphere of radius 2)
    // along rays from z = -10. On the axis its roots are t = 8 and 12; from
    // (0, 3, -10) the pair 10 +- sqrt(5) i. From any start in a disc of
    // radius 1e-2 the root to a double's accuracy; false for a disc that
    // holds none, or a start the iteration leaves the disc from.
    {
        SurfaceSpec sphere;
        sphere.degree = 2;
        sphere.terms = {{2, 0, 0, 1.0}, {0, 2, 0, 1.0}, {0, 0, 2, 1.0}, {0, 0, 0, -4.0}};
        detail::RayPoint axis{&sphere, {0.0, 0.0, -10.0}, {0.0, 0.0, 1.0}};
        detail::RayPoint aside{&sphere, {0.0, 3.0, -10.0}, {0.0, 0.0, 1.0}};
        // Their ray polynomials, t^2 - 20 t + 96 and t^2 - 20 t + 105, with
        // the derivative's coefficients a little off, as rounding leaves them.
        const double on_axis[] = {96.0, -20.0 * (1 + 1e-9), 1.0}, off_axis[] = {105.0, -20.0 * (1 - 1e-9), 1.0};
        const double root5 = std::sqrt(5.0);
        for (int i = 0; i < 100; ++i) {
            double re = 8.0 + 0.009 * u(rng), im = 0.0;
            CHECK(detail::polish_root_at_point(axis, on_axis, 2, disc(8.0 + 0.005 * u(rng), 0.0, 0.02, true), re, im));
            CHECK(std::fabs(re - 8.0) <= 0x1p-50 * 8.0 && im == 0.0);
            re = 10.0 + 0.009 * u(rng);
            im = root5 + 0.009 * u(rng);
            CHECK(detail::polish_root_at_point(aside, off_axis, 2, disc(10.0, root5, 0.02, false), re, im));
            CHECK(std::fabs(re - 10.0) <= 0x1p-50 * 10.0 && std::fabs(im - root5) <= 0x1p-50 * 10.0);
        }
        double re = 9.0, im = 0.0;
        CHECK(!detail::polish_root_at_point(axis, on_axis, 2, disc(9.0, 0.0, 0.5, true), re, im));  // no root in it
        CHECK(re == 9.0 && im == 0.0);  // untouched
        CHECK(!detail::polish_root_at_point(axis, on_axis, 2, disc(8.0, 0.0, 0.01, true, 1, false), re, im));
    }
    // polish_ill_conditioned: the coefficients' radii against the root's
    // slope. t^2 - 2 at sqrt(2) (slope 2 sqrt(2)): radii of 1e-20 move it by
    // far less than 2^-24 of it, radii of 1e-6 by far more; an infinite
    // radius always counts.
    {
        const double c[] = {-2.0, 0.0, 1.0};
        const double tiny[] = {1e-20, 1e-20, 1e-20}, wide[] = {1e-6, 1e-6, 1e-6}, inf[] = {INFINITY, 0.0, 0.0};
        CHECK(!detail::polish_ill_conditioned(c, tiny, 2, std::sqrt(2.0), 0.0));
        CHECK(detail::polish_ill_conditioned(c, wide, 2, std::sqrt(2.0), 0.0));
        CHECK(detail::polish_ill_conditioned(c, inf, 2, std::sqrt(2.0), 0.0));
        CHECK(detail::polish_ill_conditioned(c, wide, 2, 1.0, 1.0));  // (complex: the complex Horner)
    }
    // canonical_root: the same double from every centre of a disc around
    // one root (the centres spread over 1e-9, where polish_root keeps the
    // centre as it is), on the real line and off it, below the axis too
    // (the conjugate, im >= 0): within a few ulps of sqrt(2); of 1 + sqrt(2) i
    // for t^2 - 2t + 3. False for a disc without the root, of two roots, or
    // unverified.
    {
        const double c[] = {-2.0, 0.0, 1.0}, q[] = {3.0, -2.0, 1.0};
        const double s2 = std::sqrt(2.0);
        double re0 = NAN, im0 = NAN, cre0 = NAN, cim0 = NAN;
        CHECK(detail::canonical_root(c, 2, disc(s2, 0.0, 2e-9, true), re0, im0));
        CHECK(std::fabs(re0 - s2) <= 4e-16 && im0 == 0.0);
        CHECK(detail::canonical_root(q, 2, disc(1.0, s2, 3e-9, false), cre0, cim0));
        CHECK(std::fabs(cre0 - 1.0) <= 4e-16 && std::fabs(cim0 - s2) <= 4e-16);
        for (int i = 0; i < 200; ++i) {
            double re = NAN, im = NAN;
            const double off = 1e-9 * u(rng), off2 = 1e-9 * u(rng);
            CHECK(detail::canonical_root(c, 2, disc(s2 + off, 0.0, 2.5e-9, true), re, im));
            CHECK(re == re0 && im == 0.0);
            CHECK(detail::canonical_root(q, 2, disc(1.0 + off, s2 - off2, 3e-9, false), re, im));
            CHECK(re == cre0 && im == cim0);
            CHECK(detail::canonical_root(q, 2, disc(1.0 - off2, -s2 + off, 3e-9, false), re, im));
            CHECK(re == cre0 && im == cim0);  // (below the axis: the conjugate)
        }
        double re = 7.0, im = 7.0;
        CHECK(!detail::canonical_root(c, 2, disc(3.0, 0.0, 0.1, true), re, im));
        CHECK(!detail::canonical_root(c, 2, disc(s2, 0.0, 1e-9, true, 2), re, im));
        CHECK(!detail::canonical_root(c, 2, disc(s2, 0.0, 1e-9, true, 1, false), re, im));
        CHECK(re == 7.0 && im == 7.0);  // untouched
    }
    // one_float: one float32 for the whole interval, or false where a
    // rounding step (the midpoint of two floats) lies in it.
    CHECK(detail::one_float(1.0, 0.0));
    CHECK(detail::one_float(1.0 + 0x1p-30, 0x1p-30));
    CHECK(!detail::one_float(1.0 + 0x1p-24, 0x1p-40));  // (between 1 and 1 + 2^-23)
    CHECK(detail::one_float(-3.0 - 0x1p-40, 0x1p-40));
    CHECK(!detail::one_float(0.0, 1e-30));  // (-1e-30 and 1e-30 are floats of their own)
    CHECK(!detail::one_float(NAN, 0.0));
    CHECK(!detail::one_float(1.0, NAN));
    // polish_ill_conditioned_at: the test of polish_ill_conditioned with the
    // slope given (t^2 - 2 at sqrt(2), slope 2 sqrt(2)).
    {
        const double tiny[] = {1e-20, 1e-20, 1e-20}, wide[] = {1e-6, 1e-6, 1e-6};
        CHECK(!detail::polish_ill_conditioned_at(tiny, 2, std::sqrt(2.0), 0.0, 2.0 * std::sqrt(2.0)));
        CHECK(detail::polish_ill_conditioned_at(wide, 2, std::sqrt(2.0), 0.0, 2.0 * std::sqrt(2.0)));
        CHECK(detail::polish_ill_conditioned_at(tiny, 2, std::sqrt(2.0), 0.0, NAN));
    }
    // round_to_float: to nearest float32, ties to even.
    CHECK(detail::round_to_float(1.0 + 0x1p-30) == 1.0);
    CHECK(detail::round_to_float(1.0 + 0x1p-23 - 0x1p-30) == 1.0 + 0x1p-23);
    CHECK(detail::round_to_float(1.0 + 0x1p-24) == 1.0);
    CHECK(detail::round_to_float(-3.0) == -3.0);
    // wants_polish: wide discs of one verified root only.
    CHECK(wants_polish(disc(4.2, 0.0, 0.05, true)));
    CHECK(!wants_polish(disc(4.2, 0.0, 1e-9, true)));
    CHECK(!wants_polish(disc(4.2, 0.0, 0.05, true, 2)));
    CHECK(!wants_polish(disc(4.2, 0.0, 0.05, true, 1, false)));
    return check_summary("polish_test");
}
