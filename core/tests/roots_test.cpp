// roots_test.cpp: C++ regressions of find_roots, inputs that once gave a
// false claim or hung: the subnormal
// pair (discs enlarged by the back-mapping from scaled coordinates must be
// re-proven), distances that no longer underflow, and the hang on a
// polynomial whose Aberth iterates overflow (separate_duplicates on
// (inf, inf)). The test's own time limit (ctest TIMEOUT) catches a hang.
#include <cmath>
#include <cstdio>
#include <limits>

#include "../src/root_kernels.h"
#include "argand/roots.h"

using namespace argand;

static int failures = 0;
#define CHECK(cond, ...)                                   \
    do {                                                   \
        if (!(cond)) {                                     \
            ++failures;                                    \
            std::printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            std::printf(__VA_ARGS__);                      \
            std::printf("\n");                             \
        }                                                  \
    } while (0)

// |a - b| <= r in long double (64-bit mantissa, exponent range far beyond
// double's: subnormal doubles are normal long doubles, and their squares do
// not underflow). Used only on cases with a wide margin.
static bool inside(long double re, long double im, const RootDisc& d) {
    const long double dr = re - d.re, di = im - d.im;
    return dr * dr + di * di <= (long double)d.radius * d.radius;
}
static bool disjoint(const RootDisc& a, const RootDisc& b) {
    const long double dr = (long double)a.re - b.re, di = (long double)a.im - b.im;
    const long double s = (long double)a.radius + b.radius;
    return dr * dr + di * di > s * s;
}

static void subnormal_pair() {
    // Roots 3.31561832457e-316 and 3.31561852220e-316 (python-flint, exact
    // coefficients): 4 smallest subnormals apart.
    const double c[3] = {1e-323, -5.960464477539065e-08, 8.98846567431158e+307};
    const long double roots[2] = {3.31561832457e-316L, 3.31561852220e-316L};
    for (Method m : {Method::Auto, Method::Smith, Method::Paper}) {
        RootsResult out;
        CHECK(find_roots(c, 3, m, out) == Status::Ok, "status");
        int total = 0;
        for (int i = 0; i < out.n_discs; ++i) {
            const RootDisc& d = out.discs[i];
            total += d.count;
            if (!d.verified) continue;
            const int held = inside(roots[0], 0, d) + inside(roots[1], 0, d);
            CHECK(held == d.count, "method %d disc %d D(%g, %g) claims %d, holds %d", (int)m, i, d.re, d.radius, d.count, held);
            for (int j = 0; j < i; ++j)
                if (out.discs[j].verified)
                    CHECK(disjoint(d, out.discs[j]), "method %d discs %d and %d overlap", (int)m, j, i);
        }
        CHECK(total == 2, "method %d counts add up to %d", (int)m, total);
    }
}

static void distances_do_not_underflow() {
    // Two points 3 smallest subnormals apart: the lower bound must be
    // positive (it was 0) and the upper bound near 3 * 2^-1074 (it was 2^-537).
    const double a = 0x1p-1060, b = a + 3 * 0x1p-1074;
    const double lo = detail::dist_down(a, 0.0, b, 0.0), hi = detail::dist_up(a, 0.0, b, 0.0);
    CHECK(lo > 0.0 && lo <= 3 * 0x1p-1074, "dist_down %a", lo);
    CHECK(hi >= 3 * 0x1p-1074 && hi <= 8 * 0x1p-1074, "dist_up %a", hi);
    // Huge points: no overflow to inf in the squares.
    const double big = 0x1p900;
    CHECK(detail::dist_down(big, big, -big, -big) > 0x1p900, "dist_down huge %a", detail::dist_down(big, big, -big, -big));
    CHECK(std::isfinite(detail::dist_up(big, big, -big, -big)), "dist_up huge");
}

static void separate_duplicates_is_bounded() {
    const double inf = std::numeric_limits<double>::infinity();
    Complex<double> x[3] = {{inf, inf}, {inf, inf}, {1.0, 0.0}};
    CHECK(!detail::separate_duplicates(x, 3), "(inf, inf) duplicates must be refused");
    Complex<double> y[3] = {{1.0, 0.0}, {1.0, 0.0}, {1e-320, 0.0}};
    Complex<double> z[2] = {{1e-320, 0.0}, {1e-320, 0.0}};
    CHECK(detail::separate_duplicates(y, 3) && !(y[0].re == y[1].re && y[0].im == y[1].im), "finite duplicates");
    CHECK(detail::separate_duplicates(z, 2) && !(z[0].re == z[1].re && z[0].im == z[1].im), "subnormal duplicates");
}

static void degree_28_terminates() {
    const double c[29] = {1.3717184153639859e-157, -1.0391484405447758e-297, 2.723972157661776e+210,
        -9.707740580867129e+54, -1.4901246637232697e-172, -4.218755978779295e+163, -8.413588009074627e-107,
        -1.0851869956386902e+75, -4.661404193118651e-150, 8.341869753420077e-228, 0.0, 1.8404125953218852e-253,
        6.346983260760478e-129, 2.3208536824839123e+287, 2.668316609168716e-129, 4.849251448213098e+133,
        3.6250507820760566e+251, -3.5386798119736807e+139, 1.4443947564486516e+260, 1.0529725621883041e+278,
        3.531910842249658e+77, 1.2366630377600412e+24, -3.9561947606209976e+254, 2.5172134353050576e+273,
        4.223409502227807e+171, -1.6657973080861845e+53, -1.2888203837117396e+212, 1.9723345897243053e-229,
        -8.129635132647983e-269};
    for (Method m : {Method::Auto, Method::Smith, Method::Paper, Method::Unverified}) {
        RootsResult out;
        CHECK(find_roots(c, 29, m, out) == Status::Ok, "status");
        int total = 0;
        for (int i = 0; i < out.n_discs; ++i) total += out.discs[i].count;
        CHECK(total + out.n_infinite == 28, "method %d: counts %d", (int)m, total);
    }
}

int main() {
    subnormal_pair();
    distances_do_not_underflow();
    separate_duplicates_is_bounded();
    degree_28_terminates();
    if (failures) {
        std::printf("%d failures\n", failures);
        return 1;
    }
    std::printf("roots_test: all checks passed\n");
    return 0;
}
