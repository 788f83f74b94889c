// smith_test.cpp: Smith's radii, both the outward-rounded (smith_radii) and
// the a-posteriori (smith_radii_fast) bound, against a reference computed in
// long double from the same exact inputs. A radius must never fall below the
// exact value n |p(x_i)| / |c_n prod (x_i - x_j)|.
#include <cmath>
#include <cstdio>
#include <random>

#include "../src/root_kernels.h"

using namespace argand;
using namespace argand::detail;

static int failures = 0;

// Reference radius in long double (64-bit mantissa: ~2^-63 relative error
// per operation, far below the 2^-52 the bounds are built on).
static long double reference_radius(const double* c, int n, const Complex<double>* x, int i) {
    long double pr = c[n], pi = 0;
    for (int k = n - 1; k >= 0; --k) {
        long double r = pr * x[i].re - pi * x[i].im + c[k];
        long double m = pr * x[i].im + pi * x[i].re;
        pr = r;
        pi = m;
    }
    long double num = std::sqrt(pr * pr + pi * pi), den = std::fabs((long double)c[n]);
    for (int j = 0; j < n; ++j) {
        if (j == i) continue;
        long double dr = (long double)x[i].re - x[j].re, di = (long double)x[i].im - x[j].im;
        den *= std::sqrt(dr * dr + di * di);
    }
    return n * num / den;
}

int main() {
    std::mt19937_64 rng(11);
    std::normal_distribution<double> normal;
    std::uniform_int_distribution<int> degree(1, 12), expo(-30, 30);
    double r[kMaxDegree], low[kMaxDegree * kMaxDegree];
    int checked_fast = 0, checked_slow = 0;
    for (int t = 0; t < 20000; ++t) {
        const int n = degree(rng);
        double c[kMaxDegree + 1];
        for (int k = 0; k <= n; ++k) c[k] = std::ldexp(normal(rng), t % 4 == 0 ? expo(rng) : 0);
        Complex<double> x[kMaxDegree];
        // Half the time converged approximations, half the time rough ones
        // (there |p(x)| dominates and the bound is nearly tight).
        initial_guesses(c, n, x);
        if (t % 2 == 0) aberth(c, n, x, 80);
        else
            for (int i = 0; i < n; ++i) x[i] = x[i] + Complex<double>(1e-3 * normal(rng), 1e-3 * normal(rng));
        if (smith_radii_fast(c, n, x, r, low)) {
            ++checked_fast;
            for (int i = 0; i < n; ++i)
                if ((long double)r[i] < reference_radius(c, n, x, i) * (1 - 1e-17L)) {
                    std::fprintf(stderr, "fast radius below exact: t=%d n=%d i=%d\n", t, n, i);
                    ++failures;
                }
            // Pair lower bounds really are below the distances.
            for (int i = 0; i < n; ++i)
                for (int j = i + 1; j < n; ++j) {
                    long double dr = (long double)x[i].re - x[j].re, di = (long double)x[i].im - x[j].im;
                    if ((long double)low[i * n + j] > std::sqrt(dr * dr + di * di)) {
                        std::fprintf(stderr, "pair bound above distance: t=%d\n", t);
                        ++failures;
                    }
                }
        }
        if (smith_radii(c, n, x, r)) {
            ++checked_slow;
            for (int i = 0; i < n; ++i)
                if ((long double)r[i] < reference_radius(c, n, x, i) * (1 - 1e-17L)) {
                    std::fprintf(stderr, "outward-rounded radius below exact: t=%d n=%d i=%d\n", t, n, i);
                    ++failures;
                }
        }
    }
    // The fast path must refuse what its argument does not cover.
    {
        const double c[3] = {1e300, 0.0, 1.0};  // roots of modulus 1e150
        Complex<double> x[2] = {{0.0, 1e150}, {0.0, -1e150}};
        if (smith_radii_fast(c, 2, x, r, low)) {
            std::fprintf(stderr, "fast path accepted |x| > 2^8\n");
            ++failures;
        }
        const double d[3] = {1.0, 0.0, 1.0};
        Complex<double> y[2] = {{0.0, 1.0}, {0.0, 1.0 + 1e-140}};  // nearly coincident
        if (smith_radii_fast(d, 2, y, r, low)) {
            std::fprintf(stderr, "fast path accepted a pair distance below 2^-450\n");
            ++failures;
        }
    }
    if (checked_fast < 10000 || checked_slow < 10000) {
        std::fprintf(stderr, "too few cases checked: fast %d slow %d\n", checked_fast, checked_slow);
        ++failures;
    }
    if (failures) {
        std::fprintf(stderr, "smith_test: %d failures\n", failures);
        return 1;
    }
    std::printf("smith_test: %d fast and %d outward-rounded cases checked\n", checked_fast, checked_slow);
    return 0;
}
