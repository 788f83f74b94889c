// polish.cpp: see polish.h.
#include "polish.h"

#include <cmath>

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

/// Newton's iteration in double on the real root in d, from its centre,
/// to a step below kNearDouble of the iterate; an iterate that leaves d,
/// a zero or non-finite value or derivative, or kMaxSteps ends it, at the
/// last iterate inside d. (Proves nothing: a start for the double-double
/// steps, which keep every proof where it was.)
double near_root_real(const double* c, int n, const RootDisc& d) {
    double x = d.re;
    for (int step = 0; step < kMaxSteps; ++step) {
        double p = c[n], dp = 0.0;
        for (int k = n - 1; k >= 0; --k) {
            dp = dp * x + p;
            p = p * x + c[k];
        }
        const double dx = p / dp, next = x - dx;
        const double off = next - d.re;  // (squares: no bound is claimed)
        if (!std::isfinite(next) || !(off * off + d.im * d.im <= d.radius * d.radius)) break;
        x = next;
        if (std::fabs(dx) <= kNearDouble * std::fabs(x)) break;
    }
    return x;
}

/// near_root_real for a root off the real line.
Complex<double> near_root(const double* c, int n, const RootDisc& d) {
    Complex<double> z(d.re, d.im);
    for (int step = 0; step < kMaxSteps; ++step) {
        Complex<double> p(c[n], 0.0), dp(0.0, 0.0);
        for (int k = n - 1; k >= 0; --k) {
            dp = dp * z + p;
            p = add_real(p * z, c[k]);
        }
        const Complex<double> dz = p / dp, next = z - dz;
        const double off_re = next.re - d.re, off_im = next.im - d.im;  // (squares: no bound is claimed)
        if (!is_finite(next) || !(off_re * off_re + off_im * off_im <= d.radius * d.radius)) break;
        z = next;
        if (mag2_approx(dz) <= kNearDouble * kNearDouble * mag2_approx(z)) break;
    }
    return z;
}
}  // namespace

bool wants_polish(const RootDisc& d) {
    return d.verified && d.count == 1 && d.radius > kPolishRelativeRadius * std::hypot(d.re, d.im);
}

bool polish_root(const double* c, int n, const RootDisc& d, double& re, double& im, bool real) {
    real = real || d.real;
    using DD = DoubleDouble;
    if (n < 1 || !d.verified || d.count != 1) return false;
    {
        // Newton's step in double from the centre: where it is below
        // kPolishRelativeRadius of the root, the centre is as good as a
        // float32 AOV can show (most discs are wide from their coefficients'
        // radii, not from their centres), and is kept (a root proven real
        // by the caller: the centre's real part, on the real line).
        const Complex<double> z(d.re, real ? 0.0 : d.im);
        Complex<double> p(c[n], 0.0), dp(0.0, 0.0);
        for (int k = n - 1; k >= 0; --k) {
            dp = dp * z + p;
            p = add_real(p * z, c[k]);
        }
        const double step = std::hypot(p.re, p.im), slope = std::hypot(dp.re, dp.im);
        if (std::isfinite(step) && std::isfinite(slope) && step <= kPolishRelativeRadius * slope * std::hypot(z.re, z.im)) {
            if (!real || d.im == 0.0) return false;
            re = d.re;
            im = 0.0;
            return true;
        }
    }
    if (real) {
        DD x(near_root_real(c, n, d));
        for (int step = 0; step < kMaxSteps; ++step) {
            DD p(c[n]), dp(0.0);
            for (int k = n - 1; k >= 0; --k) {
                dp = dp * x + p;
                p = p * x + DD(c[k]);
            }
            if (dp.hi == 0.0 || !is_finite(p) || !is_finite(dp)) return false;
            const DD dx = p / dp;
            x = x - dx;
            if (!is_finite(x) || !(std::hypot(x.hi - d.re, d.im) <= d.radius)) return false;
            if (std::fabs(dx.hi) <= kSettled * std::fabs(x.hi)) {
                re = x.hi + x.lo;  // (normalised: x.hi, the nearest double)
                im = 0.0;
                return true;
            }
        }
        return false;
    }
    using C = Complex<DD>;
    const Complex<double> start = near_root(c, n, d);
    C z(DD(start.re), DD(start.im));
    for (int step = 0; step < kMaxSteps; ++step) {
        C p(DD(c[n]), DD(0.0)), dp(DD(0.0), DD(0.0));
        for (int k = n - 1; k >= 0; --k) {
            dp = dp * z + p;
            p = add_real(p * z, DD(c[k]));
        }
        if ((dp.re.hi == 0.0 && dp.im.hi == 0.0) || !is_finite(p) || !is_finite(dp)) return false;
        const C dz = p / dp;
        z = z - dz;
        if (!is_finite(z) || !(std::hypot(z.re.hi - d.re, z.im.hi - d.im) <= d.radius)) return false;
        if (std::hypot(dz.re.hi, dz.im.hi) <= kSettled * std::hypot(z.re.hi, z.im.hi)) {
            re = z.re.hi + z.re.lo;
            im = z.im.hi + z.im.lo;
            return true;
        }
    }
    return false;
}

}  // namespace argand::detail
