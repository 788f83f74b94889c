// arith_test.cpp: adversarial checks of the outward-rounding helpers and the
// double-double building blocks. Exact references come from long double
// where it is wider than double, and from exact identities otherwise.
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>

#include "argand/arith.h"
#include "check.h"

using namespace argand;

int main() {
    // next_up / next_down at the ends of ranges.
    CHECK(next_up(0.0) == kDenormMin);
    CHECK(next_down(0.0) == -kDenormMin);
    CHECK(next_up(-kDenormMin) == -0.0);
    CHECK(next_up(1.0) == 1.0 + 0x1p-52);
    CHECK(next_down(1.0) == 1.0 - 0x1p-53);
    CHECK(next_up(std::numeric_limits<double>::max()) == INFINITY);
    CHECK(std::isinf(next_up(INFINITY)));
    CHECK(std::isnan(next_up(NAN)));
    CHECK(next_up(0x1p-1022) == 0x1p-1022 + kDenormMin);

    // Directed ops bracket the exact result (TwoSum / TwoProd give it).
    std::mt19937_64 rng(7);

    // exact_ldexp's exponent-field fast path and lowest_bit's mantissa read
    // agree with libm (ldexp twice, frexp) on random bit patterns: normal,
    // subnormal, zero, and exponents that overflow, underflow or lose bits.
    {
        auto reference_ldexp = [](double v, int e, double& out) {
            out = std::ldexp(v, e);
            return std::isfinite(out) && std::ldexp(out, -e) == v;
        };
        auto reference_lowest_bit = [](double v) {
            int q;
            const double m = std::frexp(std::fabs(v), &q);
            auto mantissa = static_cast<std::uint64_t>(std::ldexp(m, 53));
            int tz = 0;
            while ((mantissa & 1u) == 0) { mantissa >>= 1; ++tz; }
            return q - 53 + tz;
        };
        for (int t = 0; t < 2000000; ++t) {
            std::uint64_t bits = rng();
            if (t % 3 == 0) bits &= 0x800fffffffffffffULL | ((rng() % 4) << 52);  // subnormal / tiny
            if (t % 1000 == 0) bits = (rng() % 2) << 63;                        // +-0
            double v;
            std::memcpy(&v, &bits, sizeof v);
            if (!std::isfinite(v)) continue;
            const int e = t % 2 ? static_cast<int>(rng() % 200) - 100 : static_cast<int>(rng() % 4200) - 2100;
            double fast, slow;
            const bool fast_exact = exact_ldexp(v, e, fast), slow_exact = reference_ldexp(v, e, slow);
            CHECK(fast_exact == slow_exact);
            CHECK(std::memcmp(&fast, &slow, sizeof fast) == 0);
            if (v != 0.0) CHECK(lowest_bit(v) == reference_lowest_bit(v));
        }
        double out;
        CHECK(exact_ldexp(0x1p-1022, -1, out) && out == 0x1p-1023);          // into the subnormals, exact
        CHECK(!exact_ldexp(0x1.0000000000001p-1022, -2, out));               // loses the last bit
        CHECK(!exact_ldexp(0x1p1023, 1, out) && std::isinf(out));            // overflows
        CHECK(lowest_bit(1.0) == 0 && lowest_bit(3.0) == 0 && lowest_bit(0.75) == -2);
        CHECK(lowest_bit(kDenormMin) == -1074 && lowest_bit(-0x1p-1022) == -1022);
    }
    std::uniform_real_distribution<double> mant(0.5, 1.0);
    std::uniform_int_distribution<int> ex(-1060, 1000);
    for (int t = 0; t < 200000; ++t) {
        double a = std::ldexp(mant(rng), ex(rng)), b = std::ldexp(mant(rng), ex(rng));
        if (t % 3 == 0) b = a * (1 + 0x1p-40);
        double s, e;
        detail::two_sum(a, b, s, e);
        // exact sum = s + e
        double up = add_up(a, b), dn = add_down(a, b);
        CHECK(up > s || (up == s && e <= 0));
        CHECK(dn < s || (dn == s && e >= 0));
        double p, pe;
        detail::two_prod(a, b, p, pe);
        if (std::fabs(p) > 0x1p-960 && std::isfinite(p)) {  // two_prod is exact there
            double mu = mul_up(a, b), md = mul_down(a, b);
            CHECK(mu > p || (mu == p && pe <= 0));
            CHECK(md < p || (md == p && pe >= 0));
        }
        // hypot bounds bracket the long double modulus.
        long double exact = std::sqrt((long double)a * a + (long double)b * b);
        if (std::isfinite(hypot_up(a, b)) && exact > 0x1p-1000L) {
            CHECK((long double)hypot_up(a, b) >= exact);
            CHECK((long double)hypot_down(a, b) <= exact);
        }
    }

    // Double-double: (1 + 2^-60)^2 keeps the 2^-59 term; a - a == 0.
    DoubleDouble x(1.0, 0x1p-60);
    DoubleDouble y = x * x;
    CHECK(y.hi == 1.0 && y.lo == 0x1p-59);
    DoubleDouble z = x - x;
    CHECK(z.hi == 0.0 && z.lo == 0.0);
    // Normalization |lo| <= ulp(hi)/2 after random sums and products.
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int t = 0; t < 100000; ++t) {
        // Normalized operands (the building blocks' precondition).
        DoubleDouble a = DoubleDouble(u(rng)) + DoubleDouble(u(rng) * 0x1p-54);
        DoubleDouble b = DoubleDouble(u(rng)) + DoubleDouble(u(rng) * 0x1p-54);
        DoubleDouble s = a + b, p = a * b, q = a / b;
        CHECK(std::fabs(s.lo) <= 0x1p-53 * std::fabs(s.hi) || s.hi == 0.0);
        CHECK(std::fabs(p.lo) <= 0x1p-53 * std::fabs(p.hi) || p.hi == 0.0);
        // q * b ~ a to double-double accuracy.
        DoubleDouble back = q * b - a;
        CHECK(std::fabs(back.hi) <= 0x1p-95 * (std::fabs(a.hi) + 1e-300) + 1e-300);
    }
    // Complex error model: |fl(ab) - ab| <= mul_rel |a||b| (exact ref by dd).
    for (int t = 0; t < 100000; ++t) {
        Complex<double> a(u(rng), u(rng)), b(u(rng), u(rng));
        Complex<double> p = a * b;
        Complex<DoubleDouble> ad(DoubleDouble(a.re), DoubleDouble(a.im)), bd(DoubleDouble(b.re), DoubleDouble(b.im));
        Complex<DoubleDouble> pd = ad * bd;  // accurate to ~2^-100
        double err = std::hypot((DoubleDouble(p.re) - pd.re).hi, (DoubleDouble(p.im) - pd.im).hi);
        CHECK(err <= ErrorModel<double>::mul_rel * std::hypot(a.re, a.im) * std::hypot(b.re, b.im) * (1 + 1e-10) + 1e-300);
    }
    return check_summary("arith_test");
}
