// polish.cpp: see polish.h.
#include "polish.h"

#include <cmath>
#include <type_traits>

#include "argand/arith.h"

namespace argand::detail {

namespace {
constexpr int kMaxSteps = 8;
// A step this small (relative) ends the iteration: Newton's next error is
// of its square, far below a double's last place (the double-double
// evaluation's own error, some 2^-100 times the root's condition number,
// may keep the steps from ever getting much smaller).
constexpr double kSettled = 0x1p-64;
// Newton's iteration in double first, from the disc's centre, to a step of
// this size (relative) or the noise of the double evaluation: its error is
// then about a double's last place, and the double-double steps that
// follow (each some ten times the cost of a double step) settle in two
// instead of four or five from a centre 1e-3 off.
constexpr double kNearDouble = 0x1p-30;
// canonical_root's steps at most (from 2^-20 off, halving near a double root).
constexpr int kCanonicalSteps = 40;
// Newton's iteration on F at the point (polish_root_at_point) ends once a
// step is below this (relative): the iterate is then within the step's
// square of the root, or within the evaluation's own noise, far below a
// float32 AOV's resolution (2^-24).
constexpr double kPointSettled = 0x1p-30;
// A root whose coefficients' radii may move it by more than this
// (relative, to first order) is polished with F at the point.
constexpr double kIllConditioned = 0x1p-24;

// Newton's iteration on the real line (double, DoubleDouble) and off it
// (Complex<double>, Complex<DoubleDouble>) is one template below; these
// overloads are what differs, each the operation the twin it replaces did.
using DD = DoubleDouble;
using CD = Complex<double>;
using CDD = Complex<DD>;

double coefficient(double c, double) { return c; }
DD coefficient(double c, DD) { return DD(c); }
CD coefficient(double c, CD) { return CD(c, 0.0); }
CDD coefficient(double c, CDD) { return CDD(DD(c), DD(0.0)); }
double plus(double p, double c) { return p + c; }
DD plus(DD p, double c) { return p + DD(c); }
CD plus(CD p, double c) { return add_real(p, c); }
CDD plus(CDD p, double c) { return add_real(p, DD(c)); }

bool finite(double x) { return std::isfinite(x); }
template <class T> bool finite(T x) { return is_finite(x); }
// (the leading doubles of an iterate's real and imaginary parts)
double re_hi(double x) { return x; }
double re_hi(DD x) { return x.hi; }
double re_hi(CD z) { return z.re; }
double re_hi(CDD z) { return z.re.hi; }
double im_hi(double) { return 0.0; }
double im_hi(DD) { return 0.0; }
double im_hi(CD z) { return z.im; }
double im_hi(CDD z) { return z.im.hi; }
bool zero(DD x) { return x.hi == 0.0; }
bool zero(CDD z) { return z.re.hi == 0.0 && z.im.hi == 0.0; }

/// p(z) and p'(z) by Horner's rule, in T.
template <class T> void horner(const double* c, int n, T z, T& p, T& dp) {
    p = coefficient(c[n], z);
    dp = coefficient(0.0, z);
    for (int k = n - 1; k >= 0; --k) {
        dp = dp * z + p;
        p = plus(p * z, c[k]);
    }
}

/// A double step dz from z is below kNearDouble of z.
bool near_double(double dx, double x) { return std::fabs(dx) <= kNearDouble * std::fabs(x); }
bool near_double(CD dz, CD z) { return mag2_approx(dz) <= kNearDouble * kNearDouble * mag2_approx(z); }

/// Newton's iteration in double (T: double on the real line, CD off it)
/// on the root in d, from its centre, where p and dp are already p(z) and
/// p'(z), to a step below kNearDouble of the iterate; an iterate that
/// leaves d, a zero or non-finite value or derivative, or kMaxSteps ends
/// it, at the last iterate inside d. (Proves nothing: a start for the
/// double-double steps, which keep every proof where it was.)
template <class T> T near_root(const double* c, int n, const RootDisc& d, T z, T p, T dp) {
    for (int step = 0; step < kMaxSteps; ++step) {
        if (step > 0) horner(c, n, z, p, dp);
        const T dz = p / dp, next = z - dz;
        // (squares: no bound is claimed)
        const double off_re = re_hi(next) - d.re, off_im = im_hi(next) - d.im;
        if (!finite(next) || !(off_re * off_re + off_im * off_im <= d.radius * d.radius)) break;
        z = next;
        if (near_double(dz, z)) break;
    }
    return z;
}

/// Newton's iteration in double-double (T: DD on the real line, CDD off
/// it) from z to a step below kSettled inside d: true with the root
/// rounded to double in (re, im), false where it leaves d, meets a zero or
/// non-finite derivative, or does not settle in kMaxSteps.
template <class T> bool settle(const double* c, int n, const RootDisc& d, T z, double& re, double& im) {
    for (int step = 0; step < kMaxSteps; ++step) {
        T p, dp;
        horner(c, n, z, p, dp);
        if (zero(dp) || !finite(p) || !finite(dp)) return false;
        const T dz = p / dp;
        z = z - dz;
        if (!finite(z) || !(std::hypot(re_hi(z) - d.re, im_hi(z) - d.im) <= d.radius)) return false;
        if (std::hypot(re_hi(dz), im_hi(dz)) <= kSettled * std::hypot(re_hi(z), im_hi(z))) {
            if constexpr (std::is_same_v<T, DD>) {
                re = z.hi + z.lo;  // (normalised: z.hi, the nearest double)
                im = 0.0;
            } else {
                re = z.re.hi + z.re.lo;
                im = z.im.hi + z.im.lo;
            }
            return true;
        }
    }
    return false;
}
}  // namespace

bool wants_polish(const RootDisc& d) {
    return d.verified && d.count == 1 && d.radius > kPolishRelativeRadius * std::hypot(d.re, d.im);
}

bool polish_root(const double* c, int n, const RootDisc& d, double& re, double& im, bool real) {
    real = real || d.real;
    if (n < 1 || !d.verified || d.count != 1) return false;
    // Newton's step in double from the centre: where it is below
    // kPolishRelativeRadius of the root, the centre is as good as a float32
    // AOV can show (most discs are wide from their coefficients' radii, not
    // from their centres), and is kept (a root proven real by the caller:
    // the centre's real part, on the real line). Its p and p' start the
    // iteration below. (On the real line the complex Horner at im = 0 is
    // the real one: every imaginary part stays 0.)
    const CD z(d.re, real ? 0.0 : d.im);
    CD p, dp;
    horner(c, n, z, p, dp);
    const double step = std::hypot(p.re, p.im), slope = std::hypot(dp.re, dp.im);
    if (std::isfinite(step) && std::isfinite(slope) && step <= kPolishRelativeRadius * slope * std::hypot(z.re, z.im)) {
        if (!real || d.im == 0.0) return false;
        re = d.re;
        im = 0.0;
        return true;
    }
    if (real) return settle(c, n, d, DD(near_root(c, n, d, d.re, p.re, dp.re)), re, im);
    const CD start = near_root(c, n, d, z, p, dp);
    return settle(c, n, d, CDD(DD(start.re), DD(start.im)), re, im);
}

namespace {
/// canonical_root's iteration (T: double on the real line, CD off it),
/// inside the disc centred at (dre, dim) of radius r.
template <class T> bool canonical_in(const double* c, int n, double dre, double dim, double r, T z, double& re,
                                     double& im, double* slope) {
    // (The start may lie outside the disc, and so may the iterates on the
    // way: the end must lie in it. Near a double root the steps only halve:
    // up to kCanonicalSteps of them. Squared sizes: estimates, nothing is
    // claimed of them. The end depends on the start, which is the same for
    // every disc around the root, not on how close to the root it is.)
    double size = INFINITY, slope2 = 0.0;
    bool settled = false;
    for (int step = 0; step < kCanonicalSteps && !settled; ++step) {
        T p, dp;
        horner(c, n, z, p, dp);
        if (!finite(p) || !finite(dp) || (re_hi(dp) == 0.0 && im_hi(dp) == 0.0)) return false;
        const T dz = p / dp, next = z - dz;
        if (!finite(next)) return false;
        slope2 = re_hi(dp) * re_hi(dp) + im_hi(dp) * im_hi(dp);  // (|p'| at the iterate stepped from)
        z = next;
        size = re_hi(dz) * re_hi(dz) + im_hi(dz) * im_hi(dz);
        settled = size <= kNearDouble * kNearDouble * (re_hi(z) * re_hi(z) + im_hi(z) * im_hi(z));
    }
    const double off_re = re_hi(z) - dre, off_im = im_hi(z) - dim;
    if (!settled || !(off_re * off_re + off_im * off_im <= r * r)) return false;
    re = re_hi(z);
    im = im_hi(z);
    if (slope) *slope = std::sqrt(slope2);
    return true;
}
}  // namespace

bool canonical_root(const double* c, int n, const RootDisc& d, double& re, double& im, bool real, double* slope) {
    real = real || d.real;
    if (n < 1 || !d.verified || d.count != 1 || !std::isfinite(d.re) || !std::isfinite(d.im) ||
        !std::isfinite(d.radius))
        return false;
    const double dim = real ? 0.0 : std::fabs(d.im);  // (the upper half-plane's disc)
    int e;
    std::frexp(std::max(std::fabs(d.re), dim), &e);
    const double g = std::ldexp(1.0, e - 20);  // (a power of two: the rounding below is exact)
    const double sre = std::nearbyint(d.re / g) * g;
    if (real) return canonical_in(c, n, d.re, 0.0, d.radius, sre, re, im, slope);
    // (A disc across the real axis: on it first, where the iteration
    // settles only at a real root, then the disc's one root; so a real root
    // shows im = 0 whether or not its disc was proven real.)
    if (dim <= d.radius && canonical_in(c, n, d.re, dim, d.radius, sre, re, im, slope)) return true;
    // (Off the axis the start is too: a start on it stays on it.)
    const double sim = std::max(std::nearbyint(dim / g) * g, g);
    return canonical_in(c, n, d.re, dim, d.radius, CD(sre, sim), re, im, slope);
}

bool one_float(double x, double r) {
    if (!std::isfinite(x) || !(r >= 0.0)) return false;
    return static_cast<float>(next_down(x - r)) == static_cast<float>(next_up(x + r));
}

__attribute__((noinline)) double round_to_float(double x) { return static_cast<float>(x); }

void polish_start(const double* c, int n, const RootDisc& d, double& re, double& im, bool real) {
    real = real || d.real;
    if (n < 1) return;
    const CD z(d.re, real ? 0.0 : d.im);
    CD p, dp;
    horner(c, n, z, p, dp);
    if (real) {
        re = near_root(c, n, d, d.re, p.re, dp.re);
        im = 0.0;
        return;
    }
    const CD start = near_root(c, n, d, z, p, dp);
    re = start.re;
    im = start.im;
}

bool polish_ill_conditioned_at(const double* r, int n, double re, double im, double slope) {
    const double m = std::hypot(re, im);
    double moved = 0.0;  // sum of r_k |z|^k
    for (int k = n; k >= 0; --k) moved = moved * m + r[k];
    return !(std::isfinite(moved) && std::isfinite(slope) && moved <= kIllConditioned * m * slope);
}

bool polish_ill_conditioned(const double* c, const double* r, int n, double re, double im) {
    if (n < 1) return false;
    double slope;
    if (im == 0.0) {  // (on the real line: the real Horner)
        double p, dp;
        horner(c, n, re, p, dp);
        slope = std::fabs(dp);
    } else {
        CD p, dp;
        horner(c, n, CD(re, im), p, dp);
        slope = std::hypot(dp.re, dp.im);
    }
    return polish_ill_conditioned_at(r, n, re, im, slope);
}

namespace {
double times(double a, double b) { return a * b; }
CD times(CD a, double b) { return CD(a.re * b, a.im * b); }
double at_point(double, double o) { return o; }
CD at_point(CD, double o) { return CD(o, 0.0); }

/// F(o' + t d') at t, evaluated at the point o' + t d' in T (double or
/// Complex<double>).
template <class T> T point_value(const RayPoint& ray, T t) {
    const SurfaceSpec& s = *ray.surface;
    const int n = s.degree;
    T pw[3][kMaxDegree + 1];
    for (int a = 0; a < 3; ++a) {
        pw[a][0] = at_point(t, 1.0);
        const T q = at_point(t, ray.origin[a]) + times(t, ray.direction[a]);
        for (int k = 1; k <= n; ++k) pw[a][k] = pw[a][k - 1] * q;
    }
    T p = at_point(t, 0.0);
    for (const Term& term : s.terms) p = p + times(pw[0][term.ex] * pw[1][term.ey] * pw[2][term.ez], term.coeff);
    return p;
}

bool zero(double x) { return x == 0.0; }
bool zero(CD z) { return z.re == 0.0 && z.im == 0.0; }

/// Newton's iteration in double on F along the ray: its value evaluated
/// at the point (point_value), its derivative from the ray polynomial's
/// double coefficients c (within their radii of the exact one's: Newton's
/// steps then shrink the error by that relative amount or its square,
/// whichever is larger), from z: true with the root in (re, im) once a
/// step is below kPointSettled of the iterate inside d; false where an
/// iterate leaves d, meets a zero or non-finite derivative, or kMaxSteps
/// pass first.
template <class T> bool settle_at_point(const RayPoint& ray, const double* c, int n, const RootDisc& d, T z,
                                        double& re, double& im) {
    for (int step = 0; step < kMaxSteps; ++step) {
        T p, dp;
        horner(c, n, z, p, dp);
        p = point_value(ray, z);
        if (zero(dp) || !finite(p) || !finite(dp)) return false;
        const T dz = p / dp;
        z = z - dz;
        if (!finite(z) || !(std::hypot(re_hi(z) - d.re, im_hi(z) - d.im) <= d.radius)) return false;
        if (std::hypot(re_hi(dz), im_hi(dz)) <= kPointSettled * std::hypot(re_hi(z), im_hi(z))) {
            re = re_hi(z);
            im = im_hi(z);
            return true;
        }
    }
    return false;
}
}  // namespace

bool polish_root_at_point(const RayPoint& ray, const double* c, int n, const RootDisc& d, double& re, double& im,
                          bool real) {
    real = real || d.real;
    if (ray.surface == nullptr || n < 1 || ray.surface->degree != n || !d.verified || d.count != 1) return false;
    if (real) return settle_at_point(ray, c, n, d, re, re, im);
    return settle_at_point(ray, c, n, d, CD(re, im), re, im);
}

}  // namespace argand::detail
