// render.cpp: the complex-space ray caster.
#include "argand/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "argand/arith.h"

namespace argand {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// Small vector helpers
// ---------------------------------------------------------------------------
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline void normalize3(double* v) {
    const double n = std::sqrt(dot3(v, v));
    if (n > 0) { v[0] /= n; v[1] /= n; v[2] /= n; }
}
inline void cross3(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
/// out = M v for a row-major 3x3 matrix.
inline void mat_vec(const double* m, const double* v, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = m[3 * r] * v[0] + m[3 * r + 1] * v[1] + m[3 * r + 2] * v[2];
}
/// out = M^T v.
inline void mat_t_vec(const double* m, const double* v, double* out) {
    for (int c = 0; c < 3; ++c) out[c] = m[c] * v[0] + m[3 + c] * v[1] + m[6 + c] * v[2];
}
inline void to_object(const SurfaceSpec& s, const double* world_point, double* out) {
    const double d[3] = {world_point[0] - s.translate[0], world_point[1] - s.translate[1], world_point[2] - s.translate[2]};
    mat_vec(s.linear, d, out);
}

double binomial(int n, int k) {
    double r = 1.0;
    for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
    return r;
}

// ---------------------------------------------------------------------------
// Ray polynomials
// ---------------------------------------------------------------------------

/// p(t) = F(o + t d) for object-space o, d by direct expansion of each term
/// (used for secondary rays, whose origins vary).
void expand_general(const SurfaceSpec& s, const double* o, const double* d, double* coeffs) {
    const int n = s.degree;
    for (int k = 0; k <= n; ++k) coeffs[k] = 0.0;
    // Powers (o_i + t d_i)^a as polynomials in t, for a = 0..n.
    double pw[3][kMaxDegree + 1][kMaxDegree + 1];
    for (int axis = 0; axis < 3; ++axis) {
        pw[axis][0][0] = 1.0;
        for (int k = 1; k <= n; ++k) pw[axis][0][k] = 0.0;
        for (int a = 1; a <= n; ++a) {
            pw[axis][a][0] = pw[axis][a - 1][0] * o[axis];
            for (int k = 1; k <= a; ++k) pw[axis][a][k] = pw[axis][a - 1][k] * o[axis] + pw[axis][a - 1][k - 1] * d[axis];
            for (int k = a + 1; k <= n; ++k) pw[axis][a][k] = 0.0;
        }
    }
    double tmp[kMaxDegree + 1];
    for (const Term& term : s.terms) {
        // (x part) * (y part) * (z part), truncated at degree n.
        for (int k = 0; k <= n; ++k) tmp[k] = 0.0;
        for (int i = 0; i <= term.ex; ++i)
            for (int j = 0; j <= term.ey; ++j) {
                const double xy = pw[0][term.ex][i] * pw[1][term.ey][j];
                if (xy == 0.0) continue;
                for (int l = 0; l <= term.ez; ++l) tmp[i + j + l] += xy * pw[2][term.ez][l];
            }
        for (int k = 0; k <= n; ++k) coeffs[k] += term.coeff * tmp[k];
    }
}

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

// ---------------------------------------------------------------------------
// Band membership of a disc
// ---------------------------------------------------------------------------
enum Membership { kInBand = 0, kOutOfBand = 1, kBandUndecided = 2 };

/// Where the roots in a verified disc lie relative to the band
/// [sigma, sigma+delta] U [-sigma-delta, -sigma]. A disc proven to hold one
/// real root is placed exactly (theta = 0 or pi), so delta = 0, sigma = 0
/// selects exactly the positive real roots.
Membership classify(const RootDisc& d, double sigma, double delta, bool complex_space) {
    const bool exact_real = d.real && d.count == 1;
    if (!complex_space || exact_real) {
        if (exact_real) {
            if (d.re - d.radius > 0.0) return (sigma <= 0.0 || !complex_space) ? kInBand : kOutOfBand;
            if (d.re + d.radius < 0.0) return (complex_space && sigma + delta >= kPi) ? kInBand : kOutOfBand;
            return kBandUndecided;
        }
        // A real object shows positive real roots only.
        if (std::fabs(d.im) > d.radius || d.re + d.radius <= 0.0) return kOutOfBand;
        return kBandUndecided;
    }
    const double rho = std::hypot(d.re, d.im);
    if (!(rho > d.radius)) return kBandUndecided;
    // Angular interval covered by the disc, widened by a margin that covers
    // the rounding of atan2 and asin (a few ulps of pi).
    const double margin = 1e-13;
    const double centre = std::atan2(d.im, d.re);
    const double half = std::asin(std::min(1.0, d.radius / rho));
    const double lo = centre - half - margin, hi = centre + half + margin;
    const double b1lo = sigma, b1hi = sigma + delta, b2lo = -sigma - delta, b2hi = -sigma;
    if ((lo >= b1lo && hi <= b1hi) || (lo >= b2lo && hi <= b2hi)) return kInBand;
    // Disjoint from both bands (checking the interval shifted by -2pi, 0, 2pi)?
    for (int shift = -1; shift <= 1; ++shift) {
        const double l = lo + 2 * kPi * shift, h = hi + 2 * kPi * shift;
        if (!(h < b1lo || l > b1hi) || !(h < b2lo || l > b2hi)) return kBandUndecided;
    }
    return kOutOfBand;
}

/// Approximate membership of an unverified root's centre.
bool centre_in_band(const RootDisc& d, double sigma, double delta, bool complex_space) {
    if (!complex_space) return std::fabs(d.im) <= 1e-9 * std::fabs(d.re) && d.re > 0.0;
    const double theta = std::atan2(d.im, d.re);
    return (theta >= sigma && theta <= sigma + delta) || (theta >= -sigma - delta && theta <= -sigma);
}

// ---------------------------------------------------------------------------
// Tracing
// ---------------------------------------------------------------------------
struct Candidate {
    int object;
    RootDisc disc;
    double mod, lo, hi;
    Membership membership;
    bool unverified;
};

/// A disc of one object's polynomial, kept to reason about conjugates.
struct ObjectDisc {
    int object;
    RootDisc disc;
};

/// True iff candidate i holds exactly the conjugate of the root in candidate
/// `best` (so both have the same modulus). Proof: p is real, so conj(root)
/// is a root and lies in the mirror image M of best's disc. When every disc
/// of that object's polynomial is verified, the discs cover all its roots,
/// so conj(root) lies in a disc meeting M; if candidate i's disc is the only
/// one that meets M and it holds exactly one root, that root is conj(root).
bool is_mirror_twin(const Candidate* cand, int best, int i, const ObjectDisc* all, int n_all,
                    const bool* object_all_verified) {
    const RootDisc& b = cand[best].disc;
    const int obj = cand[i].object;
    if (!object_all_verified[obj]) return false;
    auto meets_mirror = [&](const RootDisc& d) {
        return std::hypot(d.re - b.re, d.im + b.im) <= (d.radius + b.radius) * (1 + 1e-12) + 1e-300;
    };
    if (!cand[i].disc.verified || cand[i].disc.count != 1 || !meets_mirror(cand[i].disc)) return false;
    int meeting = 0;
    for (int j = 0; j < n_all; ++j)
        if (all[j].object == obj && meets_mirror(all[j].disc)) ++meeting;
    return meeting == 1;
}

struct HitInfo {
    bool hit = false;
    int object = -1;
    RootDisc disc{};
    double modulus = kInf;
    int eligible = 0;
    std::uint8_t status = kCertified;
    bool escalated = false;
};

struct Seeds {
    // Per object, the previous pixel's roots (scaled coordinates are not
    // needed: find_roots takes them in t).
    double re[kMaxDegree], im[kMaxDegree];
    bool valid = false;
};

class Tracer {
public:
    Tracer(const FramePlan& plan) : plan_(plan) {}

    /// Intersects a ray with every object and chooses the pixel's root.
    /// `primary` selects the per-frame Taylor coefficients.
    HitInfo intersect(const double* o, const double* d, bool primary, Seeds* seeds, std::int64_t* calls) const {
        const FrameParams& fp = plan_.params;
        Candidate cand[4 * kMaxDegree];
        int n_cand = 0;
        ObjectDisc all[4 * kMaxDegree];
        int n_all = 0;
        bool object_all_verified[16] = {};
        bool unverified_seen = false;
        int eligible = 0;
        bool escalated = false;
        for (int obj = 0; obj < static_cast<int>(plan_.scene.objects.size()); ++obj) {
            const SurfaceSpec& s = plan_.scene.objects[obj];
            double coeffs[kMaxDegree + 1];
            double od[3], oo[3];
            mat_vec(s.linear, d, od);
            if (primary) {
                primary_coefficients(obj, od, coeffs);
                for (int a = 0; a < 3; ++a) oo[a] = plan_.objects[obj].origin[a];
            } else {
                to_object(s, o, oo);
                expand_general(s, oo, od, coeffs);
            }
            RootsResult res;
            const bool use_seed = seeds && seeds[obj].valid && fp.seed_from_neighbour && s.degree > 4;
            const Status st = find_roots(coeffs, s.degree + 1, fp.method, res, use_seed ? seeds[obj].re : nullptr,
                                         use_seed ? seeds[obj].im : nullptr);
            if (calls) ++*calls;
            if (st != Status::Ok) {  // the ray misses in every sense (F constant along it)
                if (seeds) seeds[obj].valid = false;
                continue;
            }
            if (res.escalation > 0 || res.wants_exact) escalated = true;
            if (obj < 16) {
                object_all_verified[obj] = true;
                for (int i = 0; i < res.n_discs; ++i) {
                    object_all_verified[obj] = object_all_verified[obj] && res.discs[i].verified;
                    if (n_all < 4 * kMaxDegree) all[n_all++] = {obj, res.discs[i]};
                    else object_all_verified[obj] = false;
                }
            }
            // Seed the next pixel with these approximations when complete.
            if (seeds) {
                int m = 0;
                for (int i = 0; i < res.n_discs && m < s.degree; ++i)
                    for (int c = 0; c < std::max(1, static_cast<int>(res.discs[i].count)) && m < s.degree; ++c) {
                        seeds[obj].re[m] = res.discs[i].re;
                        seeds[obj].im[m] = res.discs[i].im;
                        ++m;
                    }
                seeds[obj].valid = (m == s.degree && res.n_infinite == 0);
            }
            for (int i = 0; i < res.n_discs; ++i) {
                const RootDisc& disc = res.discs[i];
                if (disc.count <= 0) continue;
                const double mod = std::hypot(disc.re, disc.im);
                if (!(mod > 1e-9)) continue;  // the camera sits on the surface
                // Clipping sphere (object space), judged at the centre.
                if (s.clip_radius > 0.0) {
                    double p[3];
                    for (int a = 0; a < 3; ++a) p[a] = oo[a] + mod * od[a];
                    if (dot3(p, p) > s.clip_radius * s.clip_radius) continue;
                }
                Candidate c{obj, disc, mod, mod - disc.radius, mod + disc.radius, kOutOfBand, false};
                if (!disc.verified) {
                    if (!centre_in_band(disc, fp.sigma, fp.delta, s.complex_space)) {
                        unverified_seen = true;
                        continue;
                    }
                    c.unverified = true;
                    c.membership = kBandUndecided;
                } else {
                    c.membership = classify(disc, fp.sigma, fp.delta, s.complex_space);
                    if (c.membership == kOutOfBand) continue;
                    if (c.membership == kInBand) eligible += disc.count;
                }
                if (n_cand < 4 * kMaxDegree) cand[n_cand++] = c;
            }
        }
        HitInfo h;
        h.eligible = eligible;
        h.escalated = escalated;
        if (n_cand == 0) {
            h.status = unverified_seen ? kUnverified : kCertified;
            return h;
        }
        int best = 0;
        for (int i = 1; i < n_cand; ++i)
            if (cand[i].mod < cand[best].mod) best = i;
        const Candidate& c = cand[best];
        h.hit = true;
        h.object = c.object;
        h.disc = c.disc;
        h.modulus = c.mod;
        if (c.unverified) h.status = kUnverified;
        else if (c.disc.count > 1) h.status = kCluster;
        else if (c.membership != kInBand) h.status = kUndecided;
        else {
            // Proven smallest: its largest modulus is below every other
            // candidate's smallest, except the conjugate of the chosen root
            // itself (same modulus): a disc of the same real polynomial that
            // is the only one meeting the chosen disc's mirror image holds
            // exactly that conjugate.
            bool smallest = true;
            for (int i = 0; i < n_cand && smallest; ++i) {
                if (i == best || c.hi < cand[i].lo) continue;
                if (cand[i].object == c.object && is_mirror_twin(cand, best, i, all, n_all, object_all_verified)) continue;
                smallest = false;
            }
            h.status = smallest ? (unverified_seen ? kUnverified : kCertified) : kUndecided;
        }
        return h;
    }

    /// Colour seen along a ray (recursion for real reflective / transparent
    /// objects). `hit` is the already computed intersection.
    void shade(const double* o, const double* d, const HitInfo& hit, int depth, double* rgb) const {
        const SceneSpec& sc = plan_.scene;
        if (!hit.hit) {
            for (int a = 0; a < 3; ++a) rgb[a] = sc.background[a];
            return;
        }
        const SurfaceSpec& s = sc.objects[hit.object];
        const Material& m = s.material;
        // Hit point: distance |t| along the ray (a real point for every root).
        double p[3];
        for (int a = 0; a < 3; ++a) p[a] = o[a] + hit.modulus * d[a];
        // Normal: real part of grad F at the complex point o' + t d'.
        double oo[3], od[3];
        to_object(s, o, oo);
        mat_vec(s.linear, d, od);
        const Complex<double> t(hit.disc.re, hit.disc.im);
        Complex<double> z[3], g[3];
        for (int a = 0; a < 3; ++a) z[a] = Complex<double>(oo[a], 0.0) + mul_real(t, od[a]);
        gradient(s, z, g);
        const double gobj[3] = {g[0].re, g[1].re, g[2].re};
        double n[3];
        mat_t_vec(s.linear, gobj, n);
        normalize3(n);
        if (dot3(n, d) > 0) for (double& v : n) v = -v;
        // Base colour, or hue by argument.
        double base[3] = {m.color[0], m.color[1], m.color[2]};
        if (plan_.params.hue_by_argument && s.complex_space) {
            const double theta = std::fabs(std::atan2(hit.disc.im, hit.disc.re));
            const double h = std::fmod(theta / kPi * 6.0 * 2.0, 6.0);  // hue sweep over [0, pi/2]
            const double x = 1 - std::fabs(std::fmod(h, 2.0) - 1);
            const double hues[6][3] = {{1, x, 0}, {x, 1, 0}, {0, 1, x}, {0, x, 1}, {x, 0, 1}, {1, 0, x}};
            const int i = std::min(5, static_cast<int>(h));
            for (int a = 0; a < 3; ++a) base[a] = 0.25 + 0.75 * hues[i][a];
        }
        double local[3] = {0, 0, 0};
        const double ambient = 0.12;
        for (int a = 0; a < 3; ++a) local[a] = ambient * base[a];
        for (const Light& l : sc.lights) {
            double L[3];
            if (l.directional) {
                for (int a = 0; a < 3; ++a) L[a] = l.vector[a];
            } else {
                for (int a = 0; a < 3; ++a) L[a] = l.vector[a] - p[a];
            }
            normalize3(L);
            const double ndl = dot3(n, L);
            if (ndl <= 0) continue;
            double R[3];
            for (int a = 0; a < 3; ++a) R[a] = 2 * ndl * n[a] - L[a];
            const double rv = std::max(0.0, -dot3(R, d));
            const double spec = m.specular * std::pow(rv, m.shininess);
            for (int a = 0; a < 3; ++a)
                local[a] += l.intensity * l.color[a] * (m.diffuse * ndl * base[a] + spec);
        }
        // Depth cue from the modulus (the paper colours by the minimum
        // modulus): roots nearer than the scene's centre are brighter.
        const double cue = std::exp(-std::max(0.0, hit.modulus / plan_.scene_distance - 0.6));
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
            const HitInfo h2 = intersect(ro, rd, false, nullptr, nullptr);
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
            const HitInfo h2 = intersect(to, td, false, nullptr, nullptr);
            shade(to, td, h2, depth + 1, col);
            for (int a = 0; a < 3; ++a) rgb[a] += m.transparency * col[a] * (0.6 + 0.4 * base[a]);
        }
    }

    void primary_coefficients(int obj, const double* od, double* coeffs) const {
        const FramePlan::ObjectPlan& op = plan_.objects[obj];
        const int n = plan_.scene.objects[obj].degree;
        double px[kMaxDegree + 1], py[kMaxDegree + 1], pz[kMaxDegree + 1];
        px[0] = py[0] = pz[0] = 1.0;
        for (int k = 1; k <= n; ++k) {
            px[k] = px[k - 1] * od[0];
            py[k] = py[k - 1] * od[1];
            pz[k] = pz[k - 1] * od[2];
        }
        for (int k = 0; k <= n; ++k) {
            double sum = 0.0;
            for (int i = op.k_begin[k]; i < op.k_begin[k + 1]; ++i) sum += op.g[i] * px[op.ex[i]] * py[op.ey[i]] * pz[op.ez[i]];
            coeffs[k] = sum;
        }
    }

private:
    const FramePlan& plan_;
};

}  // namespace

FramePlan plan_frame(const SceneSpec& scene, const FrameParams& params) {
    if (scene.objects.empty()) throw std::invalid_argument("the scene has no objects");
    if (params.width < 1 || params.height < 1) throw std::invalid_argument("frame size must be at least 1x1");
    FramePlan plan;
    plan.scene = scene;
    plan.params = params;
    const CameraSpec& cam = scene.camera;
    for (int a = 0; a < 3; ++a) {
        plan.eye[a] = cam.position[a];
        plan.forward[a] = cam.look_at[a] - cam.position[a];
    }
    normalize3(plan.forward);
    cross3(plan.forward, cam.up, plan.right);
    if (dot3(plan.right, plan.right) < 1e-20) throw std::invalid_argument("camera up is parallel to the view direction");
    normalize3(plan.right);
    cross3(plan.right, plan.forward, plan.up);
    if (!(cam.fov_degrees > 0 && cam.fov_degrees < 180)) throw std::invalid_argument("fov must be in (0, 180) degrees");
    plan.tan_half_fov = std::tan(cam.fov_degrees * kPi / 360.0);
    double to_target[3];
    for (int a = 0; a < 3; ++a) to_target[a] = cam.look_at[a] - cam.position[a];
    plan.scene_distance = std::max(1e-9, std::sqrt(dot3(to_target, to_target)));
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const SurfaceSpec& s = scene.objects[i];
        if (s.degree < 1 || s.degree > kMaxDegree)
            throw std::invalid_argument("object " + std::to_string(i) + ": degree must be in 1.." + std::to_string(kMaxDegree));
        const int n = s.degree;
        FramePlan::ObjectPlan op;
        to_object(s, plan.eye, op.origin);
        // Taylor coefficients of F(o' + v): binomial expansion of each term.
        // Dense index over (a, b, c) with a, b, c <= n.
        const int side = n + 1;
        std::vector<double> dense(side * side * side, 0.0);
        for (const Term& t : s.terms) {
            if (t.ex + t.ey + t.ez > n) throw std::invalid_argument("a term exceeds the declared degree");
            for (int a = 0; a <= t.ex; ++a)
                for (int b = 0; b <= t.ey; ++b)
                    for (int c = 0; c <= t.ez; ++c)
                        dense[(a * side + b) * side + c] +=
                            t.coeff * binomial(t.ex, a) * std::pow(op.origin[0], t.ex - a) * binomial(t.ey, b) *
                            std::pow(op.origin[1], t.ey - b) * binomial(t.ez, c) * std::pow(op.origin[2], t.ez - c);
        }
        op.k_begin.assign(n + 2, 0);
        for (int k = 0; k <= n; ++k) {
            op.k_begin[k] = static_cast<int>(op.g.size());
            for (int a = 0; a <= k; ++a)
                for (int b = 0; a + b <= k; ++b) {
                    const int c = k - a - b;
                    const double v = dense[(a * side + b) * side + c];
                    if (v == 0.0) continue;
                    op.ex.push_back(a);
                    op.ey.push_back(b);
                    op.ez.push_back(c);
                    op.g.push_back(v);
                }
        }
        op.k_begin[n + 1] = static_cast<int>(op.g.size());
        plan.objects.push_back(std::move(op));
    }
    return plan;
}

void ray_polynomial(const FramePlan& plan, int object, const double origin[3], const double direction[3], double* coeffs) {
    const SurfaceSpec& s = plan.scene.objects.at(object);
    double oo[3], od[3];
    to_object(s, origin, oo);
    mat_vec(s.linear, direction, od);
    expand_general(s, oo, od, coeffs);
}

void render_tile(const FramePlan& plan, const TileRect& rect_in, TileAOVs& out) {
    const FrameParams& fp = plan.params;
    TileRect r{std::max(0, rect_in.x0), std::max(0, rect_in.y0), std::min(fp.width, rect_in.x1), std::min(fp.height, rect_in.y1)};
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    out.width = w;
    out.height = h;
    const std::size_t np = static_cast<std::size_t>(w) * h;
    out.rgba.assign(4 * np, 0.0f);
    out.modulus.assign(np, std::numeric_limits<float>::infinity());
    out.argument.assign(np, 0.0f);
    out.re.assign(np, 0.0f);
    out.im.assign(np, 0.0f);
    out.count.assign(np, 0);
    out.status.assign(np, kCertified);
    out.escalations = 0;
    out.root_calls = 0;
    Tracer tracer(plan);
    const double aspect = static_cast<double>(fp.width) / fp.height;
    std::vector<Seeds> seeds(plan.scene.objects.size());
    for (int y = r.y0; y < r.y1; ++y) {
        for (Seeds& s : seeds) s.valid = false;
        for (int x = r.x0; x < r.x1; ++x) {
            // Pixel centre -> unit world direction.
            const double sx = (2.0 * (x + 0.5) / fp.width - 1.0) * plan.tan_half_fov * aspect;
            const double sy = (1.0 - 2.0 * (y + 0.5) / fp.height) * plan.tan_half_fov;
            double d[3];
            for (int a = 0; a < 3; ++a) d[a] = plan.forward[a] + sx * plan.right[a] + sy * plan.up[a];
            normalize3(d);
            const HitInfo hit = tracer.intersect(plan.eye, d, true, seeds.data(), &out.root_calls);
            const std::size_t i = static_cast<std::size_t>(y - r.y0) * w + (x - r.x0);
            out.status[i] = hit.status;
            out.count[i] = hit.eligible;
            if (hit.escalated) ++out.escalations;
            if (!hit.hit) {
                for (int a = 0; a < 3; ++a) out.rgba[4 * i + a] = static_cast<float>(plan.scene.background[a]);
                out.rgba[4 * i + 3] = 0.0f;
                continue;
            }
            double rgb[3];
            tracer.shade(plan.eye, d, hit, 0, rgb);
            for (int a = 0; a < 3; ++a) out.rgba[4 * i + a] = static_cast<float>(rgb[a]);
            out.rgba[4 * i + 3] = 1.0f;
            out.modulus[i] = static_cast<float>(hit.modulus);
            out.argument[i] = static_cast<float>(std::atan2(hit.disc.im, hit.disc.re));
            out.re[i] = static_cast<float>(hit.disc.re);
            out.im[i] = static_cast<float>(hit.disc.im);
        }
    }
}

}  // namespace argand
