// roots_paper.cpp: the paper's AllCPolyZero (Sanjuan-Estrada, Casado,
// García 2006, sec. 2.1-2.6) on top of Hammer et al.'s verified zero of a
// polynomial (C++ Toolbox for Verified Computing I, ch. "CPolyZero").
//
// For an approximate zero z~ and its deflated polynomial q~ = p / (t - z~),
// the unknowns y = (q_0 .. q_{n-2}, z) solve the companion eigenproblem in
// coefficient form, f(y) = 0 with (q_{n-1} = c_n fixed):
//   f_0     = -z q_0 - c_0
//   f_i     = q_{i-1} - z q_i - c_i          (1 <= i <= n-2)
//   f_{n-1} = q_{n-2} - z c_n - c_{n-1}
// f is bilinear, so f(y~ + D) = f(y~) + J(y~ + D/2) D exactly. With R an
// approximate inverse of J(y~), the Krawczyk operator
//   K(X) = -R f(y~) + (I - R J(y~ + X)) X
// satisfying K(X) in the interior of X proves (Krawczyk; Rump) that y~ + X
// holds exactly one solution y* and that J is nonsingular there (so z* is a
// simple zero). Schauder's theorem in the paper is the existence half.
// To turn uniqueness of y* into "the z-disc holds exactly one root of p" we
// also check that q(Z), the deflated coefficients over the z-disc Z, lie in
// the q-part of X: then every root in Z gives a solution in y~ + X.
#include <complex>
#include <vector>

#include "root_kernels.h"

namespace argand::detail {
namespace {

template <class T>
struct Ball {
    Complex<T> mid;
    double rad = 0.0;
};

/// Upper bound of |a| for a complex ball.
template <class T>
inline double ball_mag_up(const Ball<T>& b) { return add_up(mag_up(b.mid), b.rad); }

/// Gamma for a length-len dot product in T: |fl(sum a_k b_k) - sum a_k b_k|
/// <= gamma * sum |a_k||b_k| + len * 2 abs_err. First-order bound is
/// (mul_rel + len * add_rel); we double it for the second-order terms.
template <class T>
inline double dot_gamma(int len) {
    using E = ErrorModel<T>;
    return mul_up(2.0, add_up(E::mul_rel, mul_up(static_cast<double>(len), E::add_rel)));
}

/// Solves the dense complex system by Gaussian elimination with partial
/// pivoting to produce R ~ A^{-1} (approximate; nothing proven). Returns false
/// if a pivot vanished.
template <class T>
bool approximate_inverse(std::vector<Complex<T>>& a, int n, std::vector<Complex<T>>& inv) {
    inv.assign(n * n, Complex<T>(T(0.0)));
    for (int i = 0; i < n; ++i) inv[i * n + i] = Complex<T>(T(1.0));
    for (int col = 0; col < n; ++col) {
        int piv = col;
        double best = mag_approx(a[col * n + col]);
        for (int r = col + 1; r < n; ++r) {
            const double v = mag_approx(a[r * n + col]);
            if (v > best) { best = v; piv = r; }
        }
        if (!(best > 0.0)) return false;
        if (piv != col)
            for (int k = 0; k < n; ++k) {
                std::swap(a[col * n + k], a[piv * n + k]);
                std::swap(inv[col * n + k], inv[piv * n + k]);
            }
        const Complex<T> d = Complex<T>(T(1.0)) / a[col * n + col];
        for (int k = 0; k < n; ++k) {
            a[col * n + k] = a[col * n + k] * d;
            inv[col * n + k] = inv[col * n + k] * d;
        }
        for (int r = 0; r < n; ++r) {
            if (r == col) continue;
            const Complex<T> f = a[r * n + col];
            if (mag_approx(f) == 0.0) continue;
            for (int k = 0; k < n; ++k) {
                a[r * n + k] = a[r * n + k] - f * a[col * n + k];
                inv[r * n + k] = inv[r * n + k] - f * inv[col * n + k];
            }
        }
    }
    for (const auto& v : inv)
        if (!is_finite(v)) return false;
    return true;
}

/// Hammer's verification of the zero near z (exact in T) of p (degree n).
/// On success returns true and a radius: D(z, radius) holds exactly one
/// root of p, and it is simple.
template <class T>
bool verify_zero(const double* c, int n, Complex<T> z, double& radius) {
    using E = ErrorModel<T>;
    // Deflated coefficients q~ by Horner (recurrence (5) of the paper).
    std::vector<Complex<T>> q(n);
    q[n - 1] = Complex<T>(T(c[n]));
    for (int i = n - 1; i >= 1; --i) q[i - 1] = add_real(q[i] * z, T(c[i]));

    // Residual f(y~) as balls.
    std::vector<Ball<T>> f(n);
    const double az = mag_up(z);
    for (int i = 0; i < n; ++i) {
        // f_i = [q_{i-1}] - z q_i - c_i, with q_{n-1} = c_n, q_{-1} = 0.
        const Complex<T> prod = z * q[i];
        double err = add_up(mul_up(E::mul_rel, mul_up(az, mag_up(q[i]))), E::abs_err);
        Complex<T> acc = -prod;
        if (i >= 1) {
            acc = q[i - 1] + acc;
            err = add_up(err, add_up(mul_up(E::add_rel, mag_up(acc)), E::abs_err));
        }
        acc = add_real(acc, T(-c[i]));
        err = add_up(err, add_up(mul_up(E::add_rel, mag_up(acc)), E::abs_err));
        f[i] = {acc, err};
    }

    // Jacobian J(y~) (exact entries) and R ~ J^{-1}.
    std::vector<Complex<T>> jac(n * n, Complex<T>(T(0.0)));
    for (int i = 0; i < n; ++i) {
        if (i >= 1) jac[i * n + (i - 1)] = Complex<T>(T(1.0));
        if (i <= n - 2) {
            jac[i * n + i] = -z;
            jac[i * n + (n - 1)] = -q[i];
        } else {
            jac[i * n + (n - 1)] = Complex<T>(T(-c[n]));
        }
    }
    std::vector<Complex<T>> work = jac, R;
    if (!approximate_inverse(work, n, R)) return false;

    // |R f~| (upper bounds) and |I - R J~| (upper bounds), |R| (upper bounds).
    const double g = dot_gamma<T>(n + 1);
    std::vector<double> rf(n), absR(n * n), defect(n * n);
    for (int i = 0; i < n; ++i) {
        Complex<T> s(T(0.0));
        double sum_abs = 0.0, sum_rad = 0.0;
        for (int k = 0; k < n; ++k) {
            s = s + R[i * n + k] * f[k].mid;
            const double ar = mag_up(R[i * n + k]);
            absR[i * n + k] = ar;
            sum_abs = add_up(sum_abs, mul_up(ar, mag_up(f[k].mid)));
            sum_rad = add_up(sum_rad, mul_up(ar, f[k].rad));
        }
        rf[i] = add_up(add_up(mag_up(s), mul_up(g, sum_abs)), add_up(sum_rad, (2.0 * n + 2.0) * E::abs_err));
        for (int j = 0; j < n; ++j) {
            Complex<T> m(T(i == j ? 1.0 : 0.0));
            double sum = 1.0;
            for (int k = 0; k < n; ++k) {
                m = m - R[i * n + k] * jac[k * n + j];
                sum = add_up(sum, mul_up(absR[i * n + k], mag_up(jac[k * n + j])));
            }
            defect[i * n + j] = add_up(add_up(mag_up(m), mul_up(g, sum)), (2.0 * n + 2.0) * E::abs_err);
        }
    }
    for (double v : rf)
        if (!std::isfinite(v)) return false;

    // Epsilon-inflation iteration on the radii of X (a product of discs).
    std::vector<double> x(n), kx(n);
    for (int i = 0; i < n; ++i) x[i] = add_up(mul_up(2.0, rf[i]), 0x1p-1000);
    const int zi = n - 1;
    for (int iter = 0; iter < 12; ++iter) {
        bool inside = true;
        for (int i = 0; i < n; ++i) {
            double s = rf[i];
            for (int j = 0; j < n; ++j) {
                s = add_up(s, mul_up(defect[i * n + j], x[j]));
                // (J(y~ + X) - J~) X: row j of it is bounded by 2 r_z r_{q_j}.
                if (j <= n - 2) s = add_up(s, mul_up(absR[i * n + j], mul_up(2.0, mul_up(x[zi], x[j]))));
            }
            kx[i] = s;
            if (!(s < x[i])) inside = false;
        }
        if (inside) {
            // q(Z) must lie in the q-part of X for the z-disc to hold exactly
            // one root. Ball Horner over Z = D(z, kx[zi]).
            const double rz = kx[zi];
            Ball<T> qb{Complex<T>(T(c[n])), 0.0};
            bool range_ok = true;
            for (int i = n - 1; i >= 1 && range_ok; --i) {
                const double am = mag_up(qb.mid);
                Complex<T> mid = add_real(qb.mid * z, T(c[i]));
                double rad = add_up(add_up(mul_up(am, rz), mul_up(qb.rad, az)), mul_up(qb.rad, rz));
                rad = add_up(rad, add_up(mul_up(E::mul_rel, mul_up(am, az)), add_up(mul_up(E::add_rel, mag_up(mid)), 2.0 * E::abs_err)));
                qb = {mid, rad};
                // Compare with q~_{i-1} + X_{i-1}.
                const double gap = add_up(mag_up(qb.mid - q[i - 1]),
                                          add_up(mul_up(E::add_rel, mag_up(qb.mid - q[i - 1])), E::abs_err));
                if (!(add_up(gap, qb.rad) < x[i - 1])) range_ok = false;
            }
            if (range_ok) {
                radius = rz;
                return std::isfinite(rz);
            }
            // Widen the q radii and try again.
            for (int i = 0; i < n - 1; ++i) x[i] = mul_up(x[i], 4.0);
            continue;
        }
        for (int i = 0; i < n; ++i) x[i] = add_up(mul_up(std::fmax(x[i], kx[i]), 1.5), 0x1p-1000);
    }
    return false;
}

using cd = std::complex<double>;

/// Laguerre's method on a complex polynomial a[0..m] (approximation only).
cd laguerre(const std::vector<cd>& a, int m, cd x) {
    for (int it = 0; it < 80; ++it) {
        cd p = a[m], d1 = 0.0, d2 = 0.0;
        for (int k = m - 1; k >= 0; --k) {
            d2 = d2 * x + d1;
            d1 = d1 * x + p;
            p = p * x + a[k];
        }
        if (std::abs(p) == 0.0) return x;
        const cd G = d1 / p;
        const cd H = G * G - 2.0 * d2 / p;
        const cd sq = std::sqrt(static_cast<double>(m - 1) * (static_cast<double>(m) * H - G * G));
        cd den = (std::abs(G + sq) >= std::abs(G - sq)) ? G + sq : G - sq;
        cd step = (std::abs(den) > 0.0) ? static_cast<double>(m) / den : cd(1.0 + std::abs(x), 0.5) * 0.1;
        // Break limit cycles now and then, as Numerical Recipes does.
        if (it % 10 == 9) step *= 0.5 + 0.1 * (it / 10);
        const cd next = x - step;
        if (next == x) return x;
        x = next;
        if (std::abs(step) <= 1e-15 * std::abs(x)) return x;
    }
    return x;
}

/// Newton polishing on the original p in T.
template <class T>
Complex<T> newton_polish(const double* c, int n, Complex<T> z, int iters) {
    for (int it = 0; it < iters; ++it) {
        Complex<T> p, dp;
        eval_with_derivative(c, n, z, p, dp);
        if (mag_approx(dp) == 0.0) break;
        const Complex<T> step = p / dp;
        if (!is_finite(step)) break;
        z = z - step;
        if (mag_approx(step) <= working_epsilon<T>() * mag_approx(z)) break;
    }
    return z;
}

/// Try to verify z, first snapped onto the real axis when nearly real.
template <class T>
bool verify_with_snap(const double* c, int n, Complex<T>& z, double& radius) {
    if (std::fabs(to_double(z.im)) <= 1e-10 * mag_approx(z)) {
        Complex<T> zr(z.re, T(0.0));
        zr = newton_polish(c, n, zr, 3);
        if (verify_zero(c, n, zr, radius)) {
            z = zr;
            return true;
        }
    }
    return verify_zero(c, n, z, radius);
}

}  // namespace

void solve_paper(const double* c, int n, KernelResult& out) {
    // AllCPolyZero: approximate a zero of the deflated polynomial, verify it
    // on the ORIGINAL polynomial, deflate, repeat.
    std::vector<cd> defl(c, c + n + 1);
    int m = n;
    cd start(0.0, 0.0);
    out.n_discs = n;
    out.escalation = 0;
    for (int k = 0; k < n; ++k) {
        cd z = laguerre(defl, m, start);
        Complex<double> zc = newton_polish(c, n, Complex<double>(z.real(), z.imag()), 4);
        double radius = 0.0;
        bool ok = verify_with_snap(c, n, zc, radius);
        if (!ok) {
            // Section 2.6: redo the verification in double-length arithmetic.
            out.escalation = 1;
            Complex<DoubleDouble> zd(DoubleDouble(zc.re), DoubleDouble(zc.im));
            zd = newton_polish(c, n, zd, 8);
            double rd = 0.0;
            if (verify_with_snap(c, n, zd, rd)) {
                const Complex<double> zh = to_double(zd);
                zc = zh;
                radius = add_up(rd, hypot_up(std::fabs(zd.re.lo), std::fabs(zd.im.lo)));
                ok = true;
            }
        }
        RootDisc& d = out.discs[k];
        d.re = zc.re;
        d.im = zc.im;
        d.count = 1;
        d.verified = ok;
        d.real = ok && zc.im == 0.0;
        if (ok) {
            d.radius = radius;
        } else {
            Complex<double> p, dp;
            eval_with_derivative(c, n, zc, p, dp);
            d.radius = n * mag_approx(p) / mag_approx(dp);
            if (!std::isfinite(d.radius)) d.radius = std::numeric_limits<double>::infinity();
        }
        // Deflate the approximation (not the verified disc) from defl.
        const cd zz(z);
        std::vector<cd> q(m);
        q[m - 1] = defl[m];
        for (int i = m - 1; i >= 1; --i) q[i - 1] = q[i] * zz + defl[i];
        defl.assign(q.begin(), q.end());
        --m;
        start = zz;
    }
    // Verified discs each hold exactly one root; two that are not proven
    // disjoint may hold the same root twice: keep the first.
    for (int a = 0; a < n; ++a) {
        if (!out.discs[a].verified) continue;
        for (int b = 0; b < a; ++b) {
            if (!out.discs[b].verified) continue;
            if (dist_down(out.discs[a].re, out.discs[a].im, out.discs[b].re, out.discs[b].im) <=
                add_up(out.discs[a].radius, out.discs[b].radius)) {
                out.discs[a].verified = false;
                out.discs[a].real = false;
                break;
            }
        }
    }
    out.wants_exact = false;
    for (int a = 0; a < n; ++a)
        if (!out.discs[a].verified) out.wants_exact = true;
}

}  // namespace argand::detail
