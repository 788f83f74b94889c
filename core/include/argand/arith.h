// arith.h: the one place where rounding is made explicit.
//
// Everything proven in Argand rests on the helpers in this file. The rules:
//  * The floating-point environment is IEEE-754 binary64, round to nearest,
//    with no contraction into FMA unless we ask for it (the build pins
//    -ffp-contract=off and forbids fast-math).
//  * Upper and lower bounds of nonnegative magnitudes are computed with
//    round-to-nearest followed by one step outward (pbrt-v4's NextFloatUp /
//    NextFloatDown habit): for a finite x, next_up(RN(x)) >= x and
//    next_down(RN(x)) <= x. The global rounding mode is never touched.
//  * Midpoint arithmetic is done in a scalar type T (double or DoubleDouble)
//    whose rounding error per operation is bounded by ErrorModel<T>.
//
// Contracts follow FLINT/Arb's style: each function says what it guarantees,
// and predicates answer true only when the property is certain.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace argand {

// ---------------------------------------------------------------------------
// Directed bounds for doubles.
// ---------------------------------------------------------------------------

/// Smallest double strictly greater than x, for finite x (inf stays inf, NaN
/// stays NaN). Bit manipulation, no libm call.
inline double next_up(double x) {
    x += 0.0;  // -0 becomes +0 (round to nearest), whose successor is bits + 1
    if (!(x < std::numeric_limits<double>::infinity())) return x;  // +inf, NaN
    std::int64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    // One step towards +inf in the sign-magnitude order: +1 on the bits of a
    // value >= +0, -1 on those of a negative one ((bits >> 63) is 0 or -1).
    bits += (bits >> 63) | 1;
    std::memcpy(&x, &bits, sizeof bits);
    return x;
}

/// Largest double strictly smaller than x, for finite x.
inline double next_down(double x) { return -next_up(-x); }

// Each *_up(a, b) returns a double >= the exact result, each *_down a double
// <= the exact result, for finite operands. Overflow gives +inf (still an
// upper bound); callers test finiteness where it matters.
inline double add_up(double a, double b) { return next_up(a + b); }
inline double add_down(double a, double b) { return next_down(a + b); }
inline double mul_up(double a, double b) { return next_up(a * b); }
inline double mul_down(double a, double b) { return next_down(a * b); }
inline double div_up(double a, double b) { return next_up(a / b); }
inline double div_down(double a, double b) { return next_down(a / b); }
inline double sqrt_up(double a) { return next_up(std::sqrt(a)); }
/// sqrt rounded down; a <= 0 gives 0.
inline double sqrt_down(double a) { return a > 0.0 ? std::fmax(0.0, next_down(std::sqrt(a))) : 0.0; }

/// 2^k for k in [-1022, 1023] (normal range), built from bits, exact.
inline double pow2(int k) {
    const std::uint64_t bits = static_cast<std::uint64_t>(k + 1023) << 52;
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
}

/// True iff ldexp(v, e) is exact (no overflow, no loss in the subnormal
/// range); out = ldexp(v, e) either way. The common case (a normal v whose
/// result is normal) only moves the exponent field; libm's ldexp, twice, is
/// kept for the rest (it was most of the scaling's cost on the ray caster's
/// polynomials).
inline bool exact_ldexp(double v, int e, double& out) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    if (biased != 0 && biased != 0x7ff && e > -2046 && e < 2046 && biased + e >= 1 && biased + e <= 0x7fe) {
        bits += static_cast<std::uint64_t>(static_cast<std::int64_t>(e)) << 52;
        std::memcpy(&out, &bits, sizeof out);
        return true;
    }
    if (v == 0.0) {  // (a real root's zero imaginary part: no libm calls)
        out = v;
        return true;
    }
    out = std::ldexp(v, e);
    return std::isfinite(out) && std::ldexp(out, -e) == v;
}

/// Exponent of the lowest set bit of a finite nonzero double: v is an
/// integer multiple of 2^lowest_bit(v).
inline int lowest_bit(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    const std::uint64_t fraction = bits & 0x000fffffffffffffULL;
    // Normal: (2^52 + fraction) 2^(biased - 1075); subnormal: fraction 2^-1074.
    const std::uint64_t mant = biased == 0 ? fraction : (fraction | 0x0010000000000000ULL);
    return (biased == 0 ? -1074 : biased - 1075) + __builtin_ctzll(mant);
}

/// Unit roundoff of binary64.
constexpr double kUnitRoundoff = 0x1p-53;
/// Smallest positive subnormal; every rounding error is at most half of this
/// in absolute value when the result underflows.
constexpr double kDenormMin = 0x1p-1074;

/// Upper bound of sqrt(x^2 + y^2) (the modulus), for finite x, y.
inline double hypot_up(double x, double y) {
    return sqrt_up(add_up(mul_up(x, x), mul_up(y, y)));
}
/// Lower bound of sqrt(x^2 + y^2), >= 0.
inline double hypot_down(double x, double y) {
    return sqrt_down(add_down(mul_down(x, x), mul_down(y, y)));
}

// ---------------------------------------------------------------------------
// Double-double ("double-length", the paper's section 2.6) scalars.
// Value = hi + lo with |lo| <= ulp(hi)/2 after every operation (normalized).
// Algorithms from Joldes, Muller, Popescu (2017), "Tight and rigorous error
// bounds for basic building blocks of double-word arithmetic": the accurate
// addition (Alg. 6, relative error <= 3u^2 + O(u^3)) and DWTimesDW1 (Alg. 10,
// relative error <= 7u^2), u = 2^-53, as long as nothing underflows.
// ---------------------------------------------------------------------------

struct DoubleDouble {
    double hi;
    double lo;
    DoubleDouble() = default;  // trivial, like double
    constexpr DoubleDouble(double h) : hi(h), lo(0.0) {}  // NOLINT: exact widening
    constexpr DoubleDouble(double h, double l) : hi(h), lo(l) {}
};

namespace detail {
// Error-free transforms: s + e == a + b exactly (barring overflow).
inline void two_sum(double a, double b, double& s, double& e) {
    s = a + b;
    double bb = s - a;
    e = (a - (s - bb)) + (b - bb);
}
// Requires |a| >= |b| or a == 0.
inline void fast_two_sum(double a, double b, double& s, double& e) {
    s = a + b;
    e = b - (s - a);
}
// p + e == a * b exactly unless the product underflows or overflows.
inline void two_prod(double a, double b, double& p, double& e) {
    p = a * b;
#if defined(__FMA__) || defined(__FP_FAST_FMA)
    e = std::fma(a, b, -p);
#else
    // Dekker/Veltkamp splitting (exact for |a|, |b| < 2^996).
    constexpr double kSplit = 134217729.0;  // 2^27 + 1
    double ta = kSplit * a, a_hi = ta - (ta - a), a_lo = a - a_hi;
    double tb = kSplit * b, b_hi = tb - (tb - b), b_lo = b - b_hi;
    e = ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo;
#endif
}
}  // namespace detail

inline DoubleDouble operator+(DoubleDouble x, DoubleDouble y) {
    double sh, sl, th, tl;
    detail::two_sum(x.hi, y.hi, sh, sl);
    detail::two_sum(x.lo, y.lo, th, tl);
    sl += th;
    detail::fast_two_sum(sh, sl, sh, sl);
    sl += tl;
    detail::fast_two_sum(sh, sl, sh, sl);
    return {sh, sl};
}
inline DoubleDouble operator-(DoubleDouble x) { return {-x.hi, -x.lo}; }
inline DoubleDouble operator-(DoubleDouble x, DoubleDouble y) { return x + (-y); }
inline DoubleDouble operator*(DoubleDouble x, DoubleDouble y) {
    double ch, cl1;
    detail::two_prod(x.hi, y.hi, ch, cl1);
    double tl = x.hi * y.lo;
    double cl2 = x.lo * y.hi + tl;
    double cl3 = cl1 + cl2;
    double zh, zl;
    detail::fast_two_sum(ch, cl3, zh, zl);
    return {zh, zl};
}
/// Division (not used in any proven quantity, only in approximations).
inline DoubleDouble operator/(DoubleDouble x, DoubleDouble y) {
    double q1 = x.hi / y.hi;
    DoubleDouble r = x - y * DoubleDouble(q1);
    double q2 = r.hi / y.hi;
    r = r - y * DoubleDouble(q2);
    double q3 = r.hi / y.hi;
    double s, e;
    detail::fast_two_sum(q1, q2, s, e);
    return DoubleDouble(s, e) + DoubleDouble(q3);
}
inline DoubleDouble& operator+=(DoubleDouble& x, DoubleDouble y) { return x = x + y; }
inline DoubleDouble& operator-=(DoubleDouble& x, DoubleDouble y) { return x = x - y; }
inline DoubleDouble& operator*=(DoubleDouble& x, DoubleDouble y) { return x = x * y; }

inline double to_double(double x) { return x; }
inline double to_double(DoubleDouble x) { return x.hi; }
inline bool is_finite(double x) { return std::isfinite(x); }
inline bool is_finite(DoubleDouble x) { return std::isfinite(x.hi) && std::isfinite(x.lo); }

/// Upper / lower bounds of |x|. For a normalized DoubleDouble, |lo| <= u|hi|.
inline double abs_up(double x) { return std::fabs(x); }
inline double abs_down(double x) { return std::fabs(x); }
inline double abs_up(DoubleDouble x) { return add_up(std::fabs(x.hi), std::fabs(x.lo)); }
inline double abs_down(DoubleDouble x) { return std::fmax(0.0, add_down(std::fabs(x.hi), -std::fabs(x.lo))); }

// ---------------------------------------------------------------------------
// Complex numbers over T (std::complex<T> is unspecified for non-float T and
// its operator* may be compiled with NaN-recovery branches; keep ours plain).
// ---------------------------------------------------------------------------

template <class T>
struct Complex {
    T re;
    T im;
    Complex() = default;  // trivial: arrays of Complex are not zeroed
    Complex(T r) : re(r), im(0.0) {}  // NOLINT
    Complex(T r, T i) : re(r), im(i) {}
};

template <class T> inline Complex<T> operator+(Complex<T> a, Complex<T> b) { return {a.re + b.re, a.im + b.im}; }
template <class T> inline Complex<T> operator-(Complex<T> a, Complex<T> b) { return {a.re - b.re, a.im - b.im}; }
template <class T> inline Complex<T> operator-(Complex<T> a) { return {-a.re, -a.im}; }
template <class T> inline Complex<T> operator*(Complex<T> a, Complex<T> b) {
    return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re};
}
template <class T> inline Complex<T> mul_real(Complex<T> a, T b) { return {a.re * b, a.im * b}; }
template <class T> inline Complex<T> add_real(Complex<T> a, T b) { return {a.re + b, a.im}; }
/// Division for approximations only (no error bound is claimed).
template <class T> inline Complex<T> operator/(Complex<T> a, Complex<T> b) {
    // The textbook formula is fine here: the iterates are scaled to modulus
    // ~1 before the solvers run. One division, two multiplications.
    const T inv = T(1.0) / (b.re * b.re + b.im * b.im);
    return {(a.re * b.re + a.im * b.im) * inv, (a.im * b.re - a.re * b.im) * inv};
}
/// 1 / b (approximation only).
template <class T> inline Complex<T> reciprocal(Complex<T> b) {
    const T inv = T(1.0) / (b.re * b.re + b.im * b.im);
    return {b.re * inv, -(b.im * inv)};
}
template <class T> inline Complex<T> conj(Complex<T> a) { return {a.re, -a.im}; }

template <class T> inline Complex<double> to_double(Complex<T> z) { return {to_double(z.re), to_double(z.im)}; }
template <class T> inline bool is_finite(Complex<T> z) { return is_finite(z.re) && is_finite(z.im); }

/// Upper bound of |z|.
template <class T> inline double mag_up(Complex<T> z) { return hypot_up(abs_up(z.re), abs_up(z.im)); }
/// Lower bound of |z|, >= 0.
template <class T> inline double mag_down(Complex<T> z) { return hypot_down(abs_down(z.re), abs_down(z.im)); }
/// Fast approximate modulus and its square (no bound claimed; may overflow
/// for moduli above 1e154, which the solvers never see after scaling).
template <class T> inline double mag2_approx(Complex<T> z) {
    const double r = to_double(z.re), i = to_double(z.im);
    return r * r + i * i;
}
template <class T> inline double mag_approx(Complex<T> z) { return std::sqrt(mag2_approx(z)); }

// ---------------------------------------------------------------------------
// Error model: bounds on the rounding error of one complex operation in T,
// as |computed - exact| <= rel * (magnitude named below) + abs.
// ---------------------------------------------------------------------------

template <class T> struct ErrorModel;

template <> struct ErrorModel<double> {
    // Complex product a*b by the naive formula without FMA:
    // |fl(ab) - ab| <= sqrt(5) u |a||b| (Brent, Percival, Zimmermann 2007).
    static constexpr double mul_rel = 2.25 * kUnitRoundoff;
    // Complex sum (componentwise rounding): |fl(a+b) - (a+b)| <= u |a+b|,
    // bounded by u times the modulus of the computed result over (1-u).
    static constexpr double add_rel = 1.0000001 * kUnitRoundoff;
    // Absolute slack covering gradual underflow in one operation.
    static constexpr double abs_err = 8.0 * kDenormMin;
};

template <> struct ErrorModel<DoubleDouble> {
    // Real dd ops: <= 7u^2 (multiplication), <= 3u^2 (addition), u = 2^-53.
    // A complex product is two real products and one addition per part:
    // |err| <= (2*7u^2 + 3u^2) * 2 |a||b| < 2^-100 |a||b|. We take 2^-99.
    static constexpr double mul_rel = 0x1p-99;
    // A complex sum: <= 3u^2 per part, relative to the computed modulus.
    static constexpr double add_rel = 0x1p-103;
    // Gradual underflow: a dd operation performs ~10 roundings, each of which
    // may lose up to 2^-1075 absolutely; the relative bounds above assume no
    // underflow. Generous slack:
    static constexpr double abs_err = 0x1p-1040;
};

}  // namespace argand
