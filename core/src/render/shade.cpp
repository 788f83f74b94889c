// render/shade.cpp: shading (shade.h): ShadePlan, the gradient of a
// surface at a complex point (and its real and flattened forms, the same
// bits), the lights, the depth cue, reflection and refraction
// (Tracer::shade).
#include "shade.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "argand/arith.h"
#include "tracer.h"
#include "vec3.h"

namespace argand::detail {
namespace {

/// Gradient of F at a complex object-space point (for the normal).
void gradient(const SurfaceSpec& s, const Complex<double>* z, Complex<double>* grad) {
    Complex<double> pw[3][kMaxDegree + 1];
    for (int a = 0; a < 3; ++a) {
        pw[a][0] = Complex<double>(1.0, 0.0);
        for (int k = 1; k <= s.degree; ++k) pw[a][k] = pw[a][k - 1] * z[a];
    }
    for (int a = 0; a < 3; ++a) grad[a] = Complex<double>(0.0, 0.0);
    for (const Term& t : s.terms) {
        const int e[3] = {t.ex, t.ey, t.ez};
        for (int a = 0; a < 3; ++a) {
            if (e[a] == 0) continue;
            Complex<double> v(t.coeff * e[a], 0.0);
            for (int b = 0; b < 3; ++b) v = v * pw[b][b == a ? e[b] - 1 : e[b]];
            grad[a] = grad[a] + v;
        }
    }
}

/// True when spec = specular * pow(rv, shininess) is so small that
/// diffuse[a] + spec == diffuse[a] (round to nearest) for a = 0, 1, 2, so
/// that shade may leave spec (and pow) out with the same bits. For
/// 0 < rv <= 1 and shininess >= k >= 1 (k <= 64): pow(rv, shininess) <=
/// rv^k (1 + 2^-52) (glibc's pow is within 1 ulp), and rv^k <= q (1 + 2^-48)
/// + 2^-1070 for q = rv^k by binary powering (at most 14 roundings, each
/// within a factor 1 + 2^-53 or, below the normal range, 2^-1075 of the
/// product; every factor is at most 1, so no error grows). So
/// |spec| < |specular| (4 q + 2^-1000) / 2 when that is finite, and the
/// test below keeps |spec| under a quarter of half an ulp of the least
/// |diffuse[a]| (2^(e - 53), 2^e <= |diffuse[a]| < 2^(e + 1), each normal):
/// x + s rounds to x for |s| below half the spacing of the doubles next to
/// x, which is at least 2^(e - 53) / 2 on either side. A NaN or an
/// infinity anywhere fails a comparison: pow.
inline bool specular_negligible(int k, double rv, double specular, const double* diffuse) {
    double q = 1.0, b = rv;
    for (;;) {
        if (k & 1) q = q * b;
        k >>= 1;
        if (k == 0) break;
        b = b * b;
    }
    std::uint64_t bits[3];
    std::memcpy(bits, diffuse, sizeof bits);
    std::uint64_t f = 0x7ff;
    for (int a = 0; a < 3; ++a) f = std::min(f, (bits[a] >> 52) & 0x7ff);
    // (f = 0: a zero or subnormal; 0x7ff: not finite; f - 1023 - 53 >= -1000
    // keeps 2^(e - 53) normal and far above the 2^-1000 slack.)
    bool finite = true;
    for (int a = 0; a < 3; ++a) finite &= ((bits[a] >> 52) & 0x7ff) != 0x7ff;
    if (!finite || f < 1023 + 53 - 1000 + 64) return false;
    double half_ulp;
    const std::uint64_t hb = (f - 53) << 52;
    std::memcpy(&half_ulp, &hb, sizeof half_ulp);
    return std::fabs(specular) * (4.0 * q + 0x1p-1000) < half_ulp;
}

/// mat_vec (transpose false) or mat_t_vec (true) of s.linear and v, with no
/// products where `identity` (linear is the identity to the bit) and every
/// v[a] is finite and nonzero.
///
/// Contract (-ffp-contract=off, round to nearest): both compute
/// out[r] = (m_0 v_0 + m_1 v_1) + m_2 v_2 with the row's (or column's) three
/// entries, here one exactly 1.0 and two +0.0. 1.0 * v_r = v_r exactly; +0.0
/// * v for a finite v is a zero (of either sign); and x + (+-0) = (+-0) + x = x
/// exactly for every nonzero x. So every sum, in either order, is v_r to the
/// bit. A zero v_r (whose sign the sum may change), an infinity or a NaN
/// (0 * inf = NaN) takes the products.
[[gnu::always_inline]] inline void linear_apply(const SurfaceSpec& s, bool identity, bool transpose, const double* v,
                                                double* out) {
    // From the bits: with the sign shifted out, a finite nonzero double is
    // 0 < b << 1 < 0x7ff << 53 (zero: 0; infinity: 0x7ff << 53; NaN: above),
    // i.e. (b << 1) - 1 < (0x7ff << 53) - 1 in unsigned arithmetic.
    std::uint64_t b[3];
    std::memcpy(b, v, sizeof b);
    constexpr std::uint64_t kTop = (std::uint64_t{0x7ff} << 53) - 1;
    const bool plain = identity & ((b[0] << 1) - 1 < kTop) & ((b[1] << 1) - 1 < kTop) & ((b[2] << 1) - 1 < kTop);
    if (plain) {
        for (int a = 0; a < 3; ++a) out[a] = v[a];
    } else if (transpose) {
        mat_t_vec(s.linear, v, out);
    } else {
        mat_vec(s.linear, v, out);
    }
}

/// gradient() from the flattened terms: the same complex operations in the
/// same order (a product by pw[b][0] = 1 included: it is not always exact
/// in complex arithmetic, e.g. for a signed zero or an infinity), only the
/// powers no term uses are not formed. The real parts, to the bit.
void gradient_flat(const ShadePlan::Object& ob, const Complex<double>* z, double* grad_re) {
    // The powers k = 1..max k_max, the axes side by side (as in
    // gradient_real: an axis's powers beyond its k_max are never read, each
    // one read is the same chain pw[k - 1][a] * z[a]).
    Complex<double> pw[kMaxDegree + 1][3];
    for (int a = 0; a < 3; ++a) pw[0][a] = Complex<double>(1.0, 0.0);
    for (int k = 1; k <= ob.k_top; ++k)
        for (int a = 0; a < 3; ++a) pw[k][a] = pw[k - 1][a] * z[a];
    Complex<double> grad[3] = {Complex<double>(0.0, 0.0), Complex<double>(0.0, 0.0), Complex<double>(0.0, 0.0)};
    for (const GradientTerm& g : ob.terms) {
        Complex<double> v(g.ce, 0.0);
        for (int b = 0; b < 3; ++b) v = v * pw[g.k[b]][b];
        grad[g.axis] = grad[g.axis] + v;
    }
    for (int a = 0; a < 3; ++a) grad_re[a] = grad[a].re;
}

/// The real parts of gradient() at a real point z = x + 0i (a real root:
/// t.im = 0, so z.im = 0 + t.im od = +0), in real arithmetic; false (and
/// nothing written) where that is not proven to give the same bits.
///
/// Contract: gradient()'s complex products are (a.re b.re - a.im b.im,
/// a.re b.im + a.im b.re). If every imaginary part is a zero and every
/// a.re b.re is a finite nonzero double, the real part is
/// a.re b.re - (+-0) = a.re b.re exactly and the imaginary part is again a
/// zero (finite * zero + zero * finite); the sums grad + v are the same
/// double additions in both. So the real parts agree to the bit as soon as
/// every real product formed (powers of x_a, ce times powers) is finite and
/// nonzero, and a product by 1 may then be skipped (x * 1 = x). The check:
/// with 2^lo_a <= |x_a| < 2^(lo_a + 1), L = min(0, min lo_a), H = max(0,
/// max lo_a + 1), D = degree, every exact product of ce (2^ce_lo <= |ce| <
/// 2^(ce_hi + 1)) and at most D coordinates lies in [2^(ce_lo + D L),
/// 2^(ce_hi + 1 + D H)); each of its at most D + 3 roundings (normal range,
/// round to nearest) changes it by a factor within (1 -+ 2^-53), and
/// (1 - 2^-53)^67 > 1/2, (1 + 2^-53)^67 < 2. So ce_lo + D L - 1 >= -1021
/// and ce_hi + D H + 2 <= 1023 keep every product normal and finite (by
/// induction over the chain: each partial product has a subset of the
/// factors, inside the same range since L <= 0 <= H), and likewise
/// D L - 1 >= -1021, D H + 1 <= 1023 for the powers alone.
bool gradient_real(const ShadePlan::Object& ob, const double* x, double* grad_re) {
    if (!ob.real_ok) return false;
    // The check above, per coordinate (ShadePlan::build): the biased
    // exponent f of x_a in [real_f_lo, real_f_hi] (within 1..0x7fe, so a
    // zero, subnormal or non-finite x_a takes the complex path).
    std::uint64_t b[3];
    std::memcpy(b, x, sizeof b);
    const std::uint32_t span = ob.real_f_hi - ob.real_f_lo;
    bool in = true;
    for (int a = 0; a < 3; ++a)
        in &= static_cast<std::uint32_t>((b[a] >> 52) & 0x7ff) - ob.real_f_lo <= span;
    if (!in) return false;
    // The powers k = 1..max k_max, the three axes side by side (an axis's
    // powers beyond its k_max are formed but never read; each one read is
    // the same chain pw[a][k - 1] * x[a] as before, so the same double).
    double pw[kMaxDegree + 1][3];
    for (int a = 0; a < 3; ++a) pw[0][a] = 1.0;
    for (int k = 1; k <= ob.k_top; ++k)
        for (int a = 0; a < 3; ++a) pw[k][a] = pw[k - 1][a] * x[a];
    double g[3] = {0.0, 0.0, 0.0};
    // (The factors by GradientTerm::f: the same products in the same order,
    // and products by pw[0][0] = 1.0, exact, in place of the branches.)
    const double* pwf = &pw[0][0];
    for (const GradientTerm& t : ob.terms) {
        const double v = ((t.ce * pwf[t.f[0]]) * pwf[t.f[1]]) * pwf[t.f[2]];
        g[t.axis] = g[t.axis] + v;
    }
    for (int a = 0; a < 3; ++a) grad_re[a] = g[a];
    return true;
}

}  // namespace

void ShadePlan::build(const FramePlan& plan) {
    reference = plan.params.engine.shade == ShadeMode::Reference;
    const SceneSpec& sc = plan.scene;
    objects.assign(sc.objects.size(), Object{});
    for (std::size_t i = 0; i < sc.objects.size(); ++i) {
        const SurfaceSpec& s = sc.objects[i];
        Object& ob = objects[i];
        ob.real_ok = true;
        bool first = true;
        for (const Term& t : s.terms) {
            const int e[3] = {t.ex, t.ey, t.ez};
            for (int a = 0; a < 3; ++a) {
                if (e[a] == 0) continue;
                GradientTerm g{t.coeff * e[a], a, {e[0], e[1], e[2]}, {0, 0, 0}};
                g.k[a] -= 1;
                for (int b = 0, j = 0; b < 3; ++b)
                    if (g.k[b] != 0) g.f[j++] = g.k[b] * 3 + b;
                for (int b = 0; b < 3; ++b) ob.k_max[b] = std::max(ob.k_max[b], g.k[b]);
                ob.terms.push_back(g);
                if (!std::isfinite(g.ce) || g.ce == 0.0) {
                    ob.real_ok = false;
                    continue;
                }
                const int l = std::ilogb(g.ce);
                ob.ce_lo = first ? l : std::min(ob.ce_lo, l);
                ob.ce_hi = first ? l : std::max(ob.ce_hi, l);
                first = false;
            }
        }
        ob.k_top = std::max(ob.k_max[0], std::max(ob.k_max[1], ob.k_max[2]));
        // gradient_real's condition on (lo, hi) (lo = min(0, min l_a),
        // hi = max(0, max l_a + 1), l_a = ilogb x_a): A(lo) and B(hi),
        // A true from some lo_min <= 0 upward, B up to some hi_max >= 0
        // (monotone in lo and hi; D >= 1). So it holds iff every l_a is
        // in [lo_min, hi_max - 1] (if A(0) and B(0) hold at all), read
        // as a range of the biased exponent field (1..0x7fe: normal).
        {
            const long D = s.degree;
            const auto A = [&](long lo) { return ob.ce_lo + D * lo - 1 >= -1021 && D * lo - 1 >= -1021; };
            const auto B = [&](long hi) { return ob.ce_hi + D * hi + 2 <= 1023 && D * hi + 1 <= 1023; };
            if (D >= 1 && A(0) && B(0)) {
                long lo = 0, hi = 0;
                while (A(lo - 1)) --lo;
                while (B(hi + 1)) ++hi;
                const long f_lo = std::max(1L, lo + 1023), f_hi = std::min(0x7feL, hi - 1 + 1023);
                if (f_lo <= f_hi) {
                    ob.real_f_lo = static_cast<std::uint32_t>(f_lo);
                    ob.real_f_hi = static_cast<std::uint32_t>(f_hi);
                } else {
                    ob.real_ok = false;
                }
            } else {
                ob.real_ok = false;
            }
        }
        const double sh = s.material.shininess;
        ob.spec_k = sh >= 1.0 ? static_cast<int>(std::min(64.0, std::floor(sh))) : 0;
        // |diffuse[a]| <= |m.diffuse| |ndl| max(1, |color|) (base <= 1
        // with hues; |ndl| <= 1 but for rounding), and the test needs
        // 4 |specular| rv^k < 2^-53 min |diffuse[a]|.
        if (ob.spec_k > 0) {
            const Material& mt = s.material;
            double cmax = 1.0;
            for (int a = 0; a < 3; ++a) cmax = std::max(cmax, std::fabs(mt.color[a]));
            const double room = std::fabs(mt.diffuse) * cmax * 1.01 * 0x1p-53 / (4.0 * std::fabs(mt.specular));
            const double cut = std::pow(room, 1.0 / ob.spec_k) * 1.01;
            ob.spec_rv_cut = std::isnan(cut) ? 1.0 : cut;
        }
        to_object(s, plan.eye, ob.eye_object);
        static const double kIdentity[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
        ob.identity = std::memcmp(s.linear, kIdentity, sizeof kIdentity) == 0;  // +0 entries, not -0
    }
    lights.assign(sc.lights.size(), LightRec{});
    for (std::size_t i = 0; i < sc.lights.size(); ++i) {
        for (int a = 0; a < 3; ++a) lights[i].dir[a] = sc.lights[i].vector[a];
        normalize3(lights[i].dir);
        for (int a = 0; a < 3; ++a) lights[i].ic[a] = sc.lights[i].intensity * sc.lights[i].color[a];
        lights[i].directional = sc.lights[i].directional;
        need_point = need_point || !sc.lights[i].directional;
    }
    for (const SurfaceSpec& s : sc.objects)
        need_point = need_point || s.material.reflectivity > 0 || s.material.transparency > 0;
}

void Tracer::shade(const double* o, const double* d, const HitInfo& hit, int depth, double* rgb) {
    const SceneSpec& sc = plan_.scene;
    if (!hit.hit) {
        for (int a = 0; a < 3; ++a) rgb[a] = sc.background[a];
        return;
    }
    if (!shading_ready_) {
        shading_.build(plan_);
        shading_ready_ = true;
    }
    const SurfaceSpec& s = sc.objects[hit.object];
    const ShadePlan::Object& sob = shading_.objects[hit.object];
    const Material& m = s.material;
    const bool ref = shading_.reference;
    // Hit point: distance |t| along the ray (a real point for every root).
    // (Read only by a point light and the bounces: formed only where
    // one of them may read it.)
    double p[3];
    if (ref || shading_.need_point) for (int a = 0; a < 3; ++a) p[a] = o[a] + hit.modulus * d[a];
    // Normal: real part of grad F at the complex point o' + t d'.
    // (The primary rays' origin, the eye, is in object space once per
    // frame: the same to_object, the same bits. Depth 0 is a primary
    // ray, whose origin is the eye's doubles: trace_sample.)
    double oo[3], od[3];
    if (!ref && (depth == 0 || std::memcmp(o, plan_.eye, sizeof oo) == 0)) {
        for (int a = 0; a < 3; ++a) oo[a] = sob.eye_object[a];
    } else {
        to_object(s, o, oo);
    }
    if (ref) {
        mat_vec(s.linear, d, od);
    } else {
        linear_apply(s, sob.identity, false, d, od);
    }
    double gobj[3];
    bool real_done = false;
    if (ref) {
        const Complex<double> t(hit.disc.re, hit.disc.im);
        Complex<double> z[3], g[3];
        for (int a = 0; a < 3; ++a) z[a] = Complex<double>(oo[a], 0.0) + mul_real(t, od[a]);
        gradient(s, z, g);
        for (int a = 0; a < 3; ++a) gobj[a] = g[a].re;
        real_done = true;
    } else if (hit.disc.im == 0.0) {
        // A real root: z = oo + t.re od (+0 i), in real arithmetic
        // where gradient_real proves the bits are gradient()'s.
        double x[3];
        for (int a = 0; a < 3; ++a) x[a] = oo[a] + hit.disc.re * od[a];
        real_done = gradient_real(sob, x, gobj);
    }
    if (!real_done) {
        const Complex<double> t(hit.disc.re, hit.disc.im);
        Complex<double> z[3];
        for (int a = 0; a < 3; ++a) z[a] = Complex<double>(oo[a], 0.0) + mul_real(t, od[a]);
        gradient_flat(sob, z, gobj);
    }
    double n[3];
    if (ref) {
        mat_t_vec(s.linear, gobj, n);
    } else {
        linear_apply(s, sob.identity, true, gobj, n);
    }
    normalize3(n);
    if (dot3(n, d) > 0) for (double& v : n) v = -v;
    // Base colour, or hue by argument.
    double base[3] = {m.color[0], m.color[1], m.color[2]};
    if (plan_.params.hue_by_argument && s.complex_space) {
        const double theta =
            std::fabs(ref ? std::atan2(hit.disc.im, hit.disc.re) : argument_of(hit.disc.im, hit.disc.re));
        const double h = std::fmod(theta / kPi * 6.0 * 2.0, 6.0);  // hue sweep over [0, pi/2]
        const double x = 1 - std::fabs(std::fmod(h, 2.0) - 1);
        const double hues[6][3] = {{1, x, 0}, {x, 1, 0}, {0, 1, x}, {0, x, 1}, {x, 0, 1}, {1, 0, x}};
        const int i = std::min(5, static_cast<int>(h));
        for (int a = 0; a < 3; ++a) base[a] = 0.25 + 0.75 * hues[i][a];
    }
    double local[3] = {0, 0, 0};
    const double ambient = 0.12;
    for (int a = 0; a < 3; ++a) local[a] = ambient * base[a];
    const std::size_t n_lights = shading_.lights.size();
    for (std::size_t li = 0; li < n_lights; ++li) {
        const ShadePlan::LightRec& rec = shading_.lights[li];
        double L[3];
        if (rec.directional && !ref) {
            for (int a = 0; a < 3; ++a) L[a] = rec.dir[a];  // normalize3(vector), once
        } else if (rec.directional) {
            for (int a = 0; a < 3; ++a) L[a] = sc.lights[li].vector[a];
            normalize3(L);
        } else {
            for (int a = 0; a < 3; ++a) L[a] = sc.lights[li].vector[a] - p[a];
            normalize3(L);
        }
        const double ndl = dot3(n, L);
        if (ndl <= 0) continue;
        double R[3];
        for (int a = 0; a < 3; ++a) R[a] = 2 * ndl * n[a] - L[a];
        const double rv = std::max(0.0, -dot3(R, d));
        if (ref) {
            const Light& l = sc.lights[li];
            const double spec = m.specular * std::pow(rv, m.shininess);
            for (int a = 0; a < 3; ++a)
                local[a] += l.intensity * l.color[a] * (m.diffuse * ndl * base[a] + spec);
            continue;
        }
        const double* ic = rec.ic;  // l.intensity * l.color[a], once
        // The diffuse terms m.diffuse * ndl * base[a], as parsed.
        const double dn = m.diffuse * ndl;
        const double diffuse[3] = {dn * base[0], dn * base[1], dn * base[2]};
        if (rv > 0.0 && rv <= 1.0 && rv <= sob.spec_rv_cut &&
            specular_negligible(sob.spec_k, rv, m.specular, diffuse)) {
            // diffuse[a] + spec == diffuse[a] for every a: no pow.
            for (int a = 0; a < 3; ++a) local[a] += ic[a] * diffuse[a];
            continue;
        }
        // pow(+0, y) = +0 for every y > 0 (C11 F.10.4.4): no call.
        const double spec = m.specular * (rv == 0.0 && m.shininess > 0 ? 0.0 : std::pow(rv, m.shininess));
        for (int a = 0; a < 3; ++a) local[a] += ic[a] * (diffuse[a] + spec);
    }
    // Depth cue from the modulus (the paper colours by the minimum
    // modulus): roots nearer than the scene's centre are brighter.
    // (exp(-0) = 1 exactly: no call for the near roots.)
    const double cue_arg = std::max(0.0, hit.modulus / plan_.scene_distance - 0.6);
    const double cue = !ref && cue_arg == 0.0 ? 1.0 : std::exp(-cue_arg);
    for (double& v : local) v *= 0.55 + 0.45 * cue;
    const bool bounces = !s.complex_space && depth < plan_.params.max_depth &&
                         (m.reflectivity > 0 || m.transparency > 0);
    if (!bounces) {
        for (int a = 0; a < 3; ++a) rgb[a] = local[a];
        return;
    }
    const double w_local = std::max(0.0, 1.0 - m.reflectivity - m.transparency);
    for (int a = 0; a < 3; ++a) rgb[a] = w_local * local[a];
    const double eps = 1e-6 * (1.0 + hit.modulus);
    const double cosi = -dot3(n, d);
    if (m.reflectivity > 0) {
        double rd[3], ro[3], col[3];
        for (int a = 0; a < 3; ++a) rd[a] = d[a] + 2 * cosi * n[a];
        normalize3(rd);
        for (int a = 0; a < 3; ++a) ro[a] = p[a] + eps * n[a];
        const HitInfo h2 = intersect(ro, rd, false, nullptr, depth + 1, nullptr);
        shade(ro, rd, h2, depth + 1, col);
        for (int a = 0; a < 3; ++a) rgb[a] += m.reflectivity * col[a];
    }
    if (m.transparency > 0) {
        // Entering or leaving: compare the original gradient's side.
        double gworld[3];
        mat_t_vec(s.linear, gobj, gworld);
        const bool entering = dot3(gworld, d) < 0;  // F grows outward
        const double eta = entering ? 1.0 / m.ior : m.ior;
        const double k = 1 - eta * eta * (1 - cosi * cosi);
        double td[3], to[3], col[3];
        if (k < 0) {  // total internal reflection
            for (int a = 0; a < 3; ++a) td[a] = d[a] + 2 * cosi * n[a];
        } else {
            for (int a = 0; a < 3; ++a) td[a] = eta * d[a] + (eta * cosi - std::sqrt(k)) * n[a];
        }
        normalize3(td);
        for (int a = 0; a < 3; ++a) to[a] = p[a] + eps * td[a];
        const HitInfo h2 = intersect(to, td, false, nullptr, depth + 1, nullptr);
        shade(to, td, h2, depth + 1, col);
        for (int a = 0; a < 3; ++a) rgb[a] += m.transparency * col[a] * (0.6 + 0.4 * base[a]);
    }
}

}  // namespace argand::detail
