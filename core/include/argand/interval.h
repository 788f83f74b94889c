// interval.h: balls and intervals of doubles, rounded outward through the
// directed helpers of arith.h (the one place where rounding is made
// explicit). Used by the renderer to carry the error of a ray polynomial's
// coefficients from the exact double camera origin to the root core, and to
// decide the clipping sphere for a whole disc.
//
// Contracts (Arb's style): a Ball b stands for the set [b.mid - b.rad,
// b.mid + b.rad]; every operation returns a ball that contains the exact
// result of the operation applied to any members of its operands. A ball
// with rad == 0 is an exact double, and operations whose result is exact
// (products by 0, sums without rounding error) keep rad == 0: exact zeros
// stay exact, which the root core needs (an exact zero coefficient is a root
// at 0 or at infinity). Overflow gives an infinite or NaN mid or rad;
// callers test is_finite() before using a ball as a bound.
#pragma once

#include <cmath>
#include <cstdint>

#include "argand/arith.h"

namespace argand {

// ---------------------------------------------------------------------------
// Upper bounds that keep exact zeros (arith.h's *_up round 0 up to the
// smallest subnormal, which would make every exact zero inexact).
// ---------------------------------------------------------------------------

/// Upper bound of a + b for a, b >= 0; exact (no step) when one is 0.
inline double add_up0(double a, double b) { return a == 0.0 ? b : b == 0.0 ? a : add_up(a, b); }
/// Upper bound of a * b for a, b >= 0; 0 when one is 0.
inline double mul_up0(double a, double b) { return (a == 0.0 || b == 0.0) ? 0.0 : mul_up(a, b); }

/// Upper bound of |a + b - RN(a + b)| for finite a, b: TwoSum gives the
/// rounding error exactly (Knuth), also for subnormal results.
inline double add_error(double a, double b, double s) {
    double bb = s - a;
    return std::fabs((a - (s - bb)) + (b - bb));
}

/// Upper bound of |a * b - RN(a * b)| for finite a, b. When the product is
/// at least 2^-969 in magnitude, Dekker's TwoProduct gives the error exactly;
/// below that (the product may have lost bits to gradual underflow, and
/// TwoProduct's own splitting may underflow) the bound is u |p| + 2^-1074
/// rounded up to 2^-1020 (a generous absolute term, far below any
/// coefficient the renderer sees). Exact zero when a or b is 0.
inline double mul_error(double a, double b, double p) {
    if (a == 0.0 || b == 0.0) return 0.0;
    if (std::fabs(p) < 0x1p-969) return 0x1p-1020;
    double hi, lo;
    detail::two_prod(a, b, hi, lo);
    return std::fabs(lo);
}

// ---------------------------------------------------------------------------
// Balls (midpoint-radius), as Arb's arb_t over binary64.
// ---------------------------------------------------------------------------

struct Ball {
    double mid = 0.0;
    double rad = 0.0;
    Ball() = default;
    constexpr Ball(double m) : mid(m), rad(0.0) {}  // NOLINT: exact widening
    constexpr Ball(double m, double r) : mid(m), rad(r) {}
};

inline bool is_finite(const Ball& b) { return std::isfinite(b.mid) && std::isfinite(b.rad); }
/// Upper bound of every |x|, x in b.
inline double abs_up(const Ball& b) { return add_up0(std::fabs(b.mid), b.rad); }

/// The exact integer v (v < 2^63) as a ball: the nearest double and the
/// exact distance to it (an integer below 2^11, exactly representable).
inline Ball ball_from_integer(std::uint64_t v) {
    const double m = static_cast<double>(v);
    const std::int64_t diff = static_cast<std::int64_t>(v) - static_cast<std::int64_t>(m);
    return Ball(m, std::fabs(static_cast<double>(diff)));
}

inline Ball operator+(const Ball& a, const Ball& b) {
    const double s = a.mid + b.mid;
    return Ball(s, add_up0(add_up0(a.rad, b.rad), add_error(a.mid, b.mid, s)));
}
inline Ball operator-(const Ball& a) { return Ball(-a.mid, a.rad); }
inline Ball operator-(const Ball& a, const Ball& b) { return a + (-b); }
/// |xy - ab| <= |a| rb + ra |b| + ra rb for x in a, y in b.
inline Ball operator*(const Ball& a, const Ball& b) {
    const double p = a.mid * b.mid;
    double r = mul_error(a.mid, b.mid, p);
    r = add_up0(r, mul_up0(std::fabs(a.mid), b.rad));
    r = add_up0(r, mul_up0(a.rad, std::fabs(b.mid)));
    r = add_up0(r, mul_up0(a.rad, b.rad));
    return Ball(p, r);
}
inline Ball& operator+=(Ball& a, const Ball& b) { return a = a + b; }
inline Ball& operator*=(Ball& a, const Ball& b) { return a = a * b; }

// ---------------------------------------------------------------------------
// Closed intervals [lo, hi] (outward rounded), for decisions.
// ---------------------------------------------------------------------------

struct Interval {
    double lo = 0.0;
    double hi = 0.0;
};

// Directed sums and products that step outward only when rounding happened
// (an exact result stays exact: a point exactly on the clipping sphere is
// decided, not left straddling).
inline double sum_down(double a, double b) {
    const double s = a + b;
    return add_error(a, b, s) == 0.0 ? s : next_down(s);
}
inline double sum_up(double a, double b) {
    const double s = a + b;
    return add_error(a, b, s) == 0.0 ? s : next_up(s);
}
inline double product_down(double a, double b) {
    const double p = a * b;
    return mul_error(a, b, p) == 0.0 ? p : next_down(p);
}
inline double product_up(double a, double b) {
    const double p = a * b;
    return mul_error(a, b, p) == 0.0 ? p : next_up(p);
}

inline Interval to_interval(const Ball& b) {
    if (b.rad == 0.0) return {b.mid, b.mid};
    return {add_down(b.mid, -b.rad), add_up(b.mid, b.rad)};
}
inline Interval operator+(const Interval& a, const Interval& b) { return {sum_down(a.lo, b.lo), sum_up(a.hi, b.hi)}; }
/// Product with a nonnegative scalar interval s = [slo, shi], slo >= 0.
inline Interval scale_nonnegative(const Interval& a, double slo, double shi) {
    const double c1 = a.lo >= 0 ? product_down(a.lo, slo) : product_down(a.lo, shi);
    const double c2 = a.hi >= 0 ? product_up(a.hi, shi) : product_up(a.hi, slo);
    return {c1, c2};
}
/// {x^2 : x in a}.
inline Interval square(const Interval& a) {
    if (a.lo >= 0) return {std::fmax(0.0, product_down(a.lo, a.lo)), product_up(a.hi, a.hi)};
    if (a.hi <= 0) return {std::fmax(0.0, product_down(a.hi, a.hi)), product_up(a.lo, a.lo)};
    const double m = std::fmax(-a.lo, a.hi);
    return {0.0, product_up(m, m)};
}

// ---------------------------------------------------------------------------
// Balls with a double-double midpoint, for the renderer's double-double
// tier. Bounds from Joldes, Muller, Popescu (2017), as in arith.h: a dd sum
// is within 3u^2 and a dd product within 7u^2 of the exact result (u =
// 2^-53), relative, as long as nothing underflows. We charge 2^-100 of the
// computed magnitude (> 7u^2 / (1 - 7u^2); the surplus, at least 2^-102 of
// a result >= 2^-900, covers the few absolute 2^-1075 losses of a low part
// that underflows), plus an absolute 2^-1020 when the result is below
// 2^-900, and nothing when the result is exact by construction (a product
// by an exact zero, a sum with an exact zero, an exact cancellation: a dd
// sum of two dd numbers is 0 only when they are exactly opposite, or when
// it is below 2^-900 and charged the absolute term).
// ---------------------------------------------------------------------------

constexpr double kDoubleDoubleRel = 0x1p-100;
constexpr double kDoubleDoubleAbs = 0x1p-1020;
constexpr double kDoubleDoubleTiny = 0x1p-900;

struct BallDD {
    DoubleDouble mid{0.0};
    double rad = 0.0;
    BallDD() = default;
    constexpr BallDD(double m) : mid(m), rad(0.0) {}  // NOLINT: exact widening
    BallDD(DoubleDouble m, double r) : mid(m), rad(r) {}
};

inline bool is_zero(DoubleDouble x) { return x.hi == 0.0 && x.lo == 0.0; }
/// Upper bound of |x| that is 0 for an exact zero (arith.h's abs_up steps
/// 0 up to the smallest subnormal).
inline double abs_up0(DoubleDouble x) { return is_zero(x) ? 0.0 : abs_up(x); }
inline bool is_finite(const BallDD& b) { return is_finite(b.mid) && std::isfinite(b.rad); }
inline double abs_up(const BallDD& b) { return add_up0(abs_up0(b.mid), b.rad); }

/// The exact integer v (v < 2^63) as an exact double-double.
inline BallDD ball_dd_from_integer(std::uint64_t v) {
    const double hi = static_cast<double>(v);
    const double lo = static_cast<double>(static_cast<std::int64_t>(v) - static_cast<std::int64_t>(hi));
    return BallDD(DoubleDouble(hi, lo), 0.0);
}

/// The rounding charge of a dd operation whose result is v (see above).
inline double dd_rounding(DoubleDouble v) {
    const double m = abs_up(v);
    const double rel = mul_up(kDoubleDoubleRel, m);
    return m < kDoubleDoubleTiny ? add_up(rel, kDoubleDoubleAbs) : rel;
}

inline BallDD operator+(const BallDD& a, const BallDD& b) {
    const DoubleDouble s = a.mid + b.mid;
    double r = add_up0(a.rad, b.rad);
    const bool exact = is_zero(a.mid) || is_zero(b.mid);
    if (!exact) {
        const double m = std::fmin(abs_up(a.mid), abs_up(b.mid));
        // An exact cancellation of operands that are not tiny gives an exact 0.
        if (!(is_zero(s) && m >= kDoubleDoubleTiny)) r = add_up0(r, dd_rounding(s));
    }
    return BallDD(s, r);
}
inline BallDD operator-(const BallDD& a) { return BallDD(-a.mid, a.rad); }
inline BallDD operator*(const BallDD& a, const BallDD& b) {
    const DoubleDouble p = a.mid * b.mid;
    double r = 0.0;
    if (!is_zero(a.mid) && !is_zero(b.mid)) r = dd_rounding(p);
    r = add_up0(r, mul_up0(abs_up0(a.mid), b.rad));
    r = add_up0(r, mul_up0(a.rad, abs_up0(b.mid)));
    r = add_up0(r, mul_up0(a.rad, b.rad));
    return BallDD(p, r);
}
inline BallDD& operator+=(BallDD& a, const BallDD& b) { return a = a + b; }

}  // namespace argand
