// render/frame_plan.cpp: plan_frame and every check of a scene and a
// frame's parameters, once; the band rule, the engine modes' names, and
// what identifies a frame's rays (rays_fingerprint, same_rays).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "argand/render.h"
#include "argand/roots_batch.h"
#include "../pixel_decision.h"
#include "../ray_polynomial.h"
#include "camera.h"
#include "solve.h"

namespace argand {

namespace {

/// FNV-1a over the bytes of v.
template <class T>
void mix(std::uint64_t& h, const T& v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (unsigned char c : b) h = (h ^ c) * 1099511628211ull;
}

}  // namespace

bool band_rule_holds(double sigma, double delta) {
    if (!std::isfinite(sigma) || !std::isfinite(delta) || !(sigma >= 0.0) || !(delta >= 0.0)) return false;
    // Compare the exact sum s + err (TwoSum) with pi. kPiHi is the double
    // nearest pi; pi - kPiHi lies strictly between the double before kPiLo
    // and kPiLo (checked in core/tests/render_test.cpp with 60 digits). In
    // the binade of pi, s < kPiHi gives s + err <= s + ulp/2 < kPiHi, and
    // s > kPiHi gives s + err >= kPiHi + ulp/2 > pi.
    constexpr double kPiHi = 3.141592653589793116, kPiLo = 1.2246467991473532e-16;
    const double s = sigma + delta;
    if (s < kPiHi) return true;
    if (s > kPiHi) return false;
    const double bb = s - sigma;
    const double err = (sigma - (s - bb)) + (delta - bb);
    return err < kPiLo;
}

const char* decide_mode_name(DecideMode mode) {
    switch (mode) {
    case DecideMode::Fast: return "fast";
    case DecideMode::FastScalar: return "fast-scalar";
    case DecideMode::Full: return "full";
    }
    return "?";
}

const char* shade_mode_name(ShadeMode mode) { return mode == ShadeMode::Reference ? "reference" : "fast"; }

bool decide_mode_from_name(const std::string& name, DecideMode& out) {
    for (DecideMode m : {DecideMode::Fast, DecideMode::FastScalar, DecideMode::Full})
        if (name == decide_mode_name(m)) return out = m, true;
    return false;
}

bool shade_mode_from_name(const std::string& name, ShadeMode& out) {
    for (ShadeMode m : {ShadeMode::Fast, ShadeMode::Reference})
        if (name == shade_mode_name(m)) return out = m, true;
    return false;
}

FramePlan plan_frame(const SceneSpec& scene, const FrameParams& params) {
    if (scene.objects.empty()) throw std::invalid_argument("the scene has no objects");
    if (static_cast<int>(scene.objects.size()) > kMaxObjects)
        throw std::invalid_argument("the scene has " + std::to_string(scene.objects.size()) + " objects; at most " +
                                    std::to_string(kMaxObjects) + " are allowed");
    if (params.width < 1 || params.height < 1 || params.width > kMaxFrameSide || params.height > kMaxFrameSide)
        throw std::invalid_argument("frame size must be between 1x1 and " + std::to_string(kMaxFrameSide) + "x" +
                                    std::to_string(kMaxFrameSide));
    if (!band_rule_holds(params.sigma, params.delta))
        throw std::invalid_argument("the band (sigma = " + std::to_string(params.sigma) + ", delta = " +
                                    std::to_string(params.delta) + ") breaks the band rule: " + kBandRule);
    if (params.max_depth < 0 || params.max_depth > 16) throw std::invalid_argument("max_depth must be in 0..16");
    if (sample_side(params.samples) == 0)
        throw std::invalid_argument("samples must be a square from 1 to " + std::to_string(kMaxSamples) +
                                    " (1, 4, 9, 16, 25, 36, 49 or 64), got " + std::to_string(params.samples));
    if (params.exact_pixels_per_block < 0)
        throw std::invalid_argument("exact_pixels_per_block must be >= 0 (0: no exact tier)");
    if (params.exact_max_bits < 64 || params.exact_max_bits > kMaxExactBits)
        throw std::invalid_argument("exact_max_bits must be in 64.." + std::to_string(kMaxExactBits));
    if (!batch_isa_supported(params.engine.kernel))
        throw std::invalid_argument(std::string("kernel ") + batch_isa_name(params.engine.kernel) +
                                    ": this CPU does not run it (it runs " + batch_isa_name(BatchIsa::Auto) + ")");
    FramePlan plan;
    plan.scene = scene;
    plan.params = params;
    detail::plan_camera(scene.camera, plan);
    plan.lower_edge = detail::band_edge(params.sigma, 0.0);
    plan.upper_edge = detail::band_edge(params.sigma, params.delta);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const SurfaceSpec& s = scene.objects[i];
        if (s.degree < 1 || s.degree > kMaxSurfaceDegree)
            throw std::invalid_argument("object " + std::to_string(i) + ": degree must be in 1.." +
                                        std::to_string(kMaxSurfaceDegree));
        FramePlan::ObjectPlan op;
        try {
            detail::plan_object(s, plan.eye, op);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("object " + std::to_string(i) + ": " + e.what());
        }
        plan.objects.push_back(std::move(op));
    }
    return plan;
}

const char* render_kernel(const FramePlan& plan) { return batch_isa_name(detail::resolved_kernel(plan.params.engine)); }

void ray_polynomial(const FramePlan& plan, int object, const double origin[3], const double direction[3], double* coeffs,
                    double* radius) {
    const SurfaceSpec& s = plan.scene.objects.at(object);
    detail::RayCoefficients<double> p;
    detail::ObjectRay ray;
    detail::general_ray_polynomial(s, origin, direction, p, ray);
    for (int k = 0; k <= s.degree; ++k) {
        coeffs[k] = p.c[k];
        if (radius) radius[k] = p.r[k];
    }
}

void rebased_ray_polynomial(const FramePlan& plan, int object, const double direction[3], double t0, double* coeffs,
                            double* radius) {
    const SurfaceSpec& s = plan.scene.objects.at(object);
    detail::RayCoefficients<double> q;
    detail::rebased_ray_polynomial(s, plan.objects.at(object), direction, t0, q);
    for (int k = 0; k <= s.degree; ++k) {
        coeffs[k] = q.c[k];
        radius[k] = q.finite ? q.r[k] : INFINITY;
    }
}

std::uint64_t rays_fingerprint(const FramePlan& a) {
    // The fields same_rays compares, in its order.
    std::uint64_t h = 1469598103934665603ull;
    const FrameParams& p = a.params;
    mix(h, p.width), mix(h, p.height), mix(h, static_cast<int>(p.method)), mix(h, p.max_depth);
    mix(h, p.hue_by_argument), mix(h, p.seed_from_neighbour), mix(h, p.samples), mix(h, p.exact_pixels_per_block);
    mix(h, p.exact_max_bits), mix(h, static_cast<int>(p.engine.kernel)), mix(h, p.engine.cull), mix(h, p.engine.real);
    mix(h, static_cast<int>(p.engine.decide)), mix(h, static_cast<int>(p.engine.shade));
    mix(h, a.tan_half_fov), mix(h, a.scene_distance);
    for (int k = 0; k < 3; ++k) mix(h, a.eye[k]), mix(h, a.forward[k]), mix(h, a.right[k]), mix(h, a.up[k]);
    const SceneSpec& s = a.scene;
    mix(h, s.objects.size()), mix(h, s.lights.size());
    for (int k = 0; k < 3; ++k) mix(h, s.background[k]);
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
        const SurfaceSpec& u = s.objects[i];
        mix(h, u.degree), mix(h, u.terms.size()), mix(h, u.complex_space), mix(h, u.clip_radius);
        mix(h, a.objects[i].origin);
        for (const Term& t : u.terms) mix(h, t.coeff), mix(h, t.ex), mix(h, t.ey), mix(h, t.ez);
    }
    return h;
}

bool same_rays(const FramePlan& a, const FramePlan& b) {
    const FrameParams &p = a.params, &q = b.params;
    if (p.width != q.width || p.height != q.height || p.method != q.method || p.max_depth != q.max_depth ||
        p.hue_by_argument != q.hue_by_argument || p.seed_from_neighbour != q.seed_from_neighbour ||
        p.samples != q.samples || p.exact_pixels_per_block != q.exact_pixels_per_block ||
        p.exact_max_bits != q.exact_max_bits || p.engine.kernel != q.engine.kernel || p.engine.cull != q.engine.cull ||
        p.engine.real != q.engine.real ||
        p.engine.decide != q.engine.decide || p.engine.shade != q.engine.shade)
        return false;
    if (a.tan_half_fov != b.tan_half_fov || a.scene_distance != b.scene_distance) return false;
    for (int k = 0; k < 3; ++k)
        if (a.eye[k] != b.eye[k] || a.forward[k] != b.forward[k] || a.right[k] != b.right[k] || a.up[k] != b.up[k])
            return false;
    const SceneSpec &s = a.scene, &t = b.scene;
    if (s.objects.size() != t.objects.size() || s.lights.size() != t.lights.size()) return false;
    for (int k = 0; k < 3; ++k)
        if (s.background[k] != t.background[k]) return false;
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
        const SurfaceSpec &u = s.objects[i], &v = t.objects[i];
        if (u.degree != v.degree || u.terms.size() != v.terms.size() || u.complex_space != v.complex_space ||
            u.clip_radius != v.clip_radius || std::memcmp(&a.objects[i].origin, &b.objects[i].origin,
                                                          sizeof(a.objects[i].origin)) != 0)
            return false;
        for (std::size_t k = 0; k < u.terms.size(); ++k)
            if (u.terms[k].coeff != v.terms[k].coeff || u.terms[k].ex != v.terms[k].ex ||
                u.terms[k].ey != v.terms[k].ey || u.terms[k].ez != v.terms[k].ez)
                return false;
    }
    return true;
}

}  // namespace argand
