// render/shade.h: what shading needs that depends only on the frame
// (ShadePlan, built once per Tracer). Tracer::shade (shade.cpp) colours a
// ray's root: the normal from the gradient, the lights, the depth cue, and
// the reflected and refracted rays of real objects. Internal header.
#pragma once

#include <cstdint>
#include <vector>

#include "argand/render.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// One term of the gradient, flattened: d/d axis of coeff x^ex y^ey z^ez is
/// ce x^k[0] y^k[1] z^k[2] with ce = coeff * e[axis] (the same double
/// product as gradient()'s) and k = the exponents, axis's lowered by one.
struct GradientTerm {
    double ce;
    int axis;
    int k[3];
    // gradient_real's factors: flat indices k[b] * 3 + b into its power
    // table pw[k][b] of the axes b with k[b] != 0, in axis order, then 0
    // (pw[0][0] = 1.0: a product by it is exact, v * 1.0 = v).
    int f[3];
};

/// What shading needs that depends only on the frame (built once per
/// Tracer). Every value is made by the same operations as the per-pixel
/// code it replaces, so the pixels keep their bits.
struct ShadePlan {
    struct Object {
        std::vector<GradientTerm> terms;  // gradient()'s order: term by term, axis 0..2 within a term
        int k_max[3] = {0, 0, 0};         // highest power of each coordinate the terms use
        int k_top = 0;                    // max of k_max
        bool real_ok = false;             // every ce finite and nonzero (gradient_real may run)
        int ce_lo = 0, ce_hi = 0;         // ilogb range of the ce
        // gradient_real's range check, per coordinate (see there): the
        // biased exponent field f of every x_a in [real_f_lo, real_f_hi]
        // (real_ok false where no x passes).
        std::uint32_t real_f_lo = 1, real_f_hi = 0;
        // spec_k >= 1: shade may skip pow(rv, shininess) for 0 < rv <= 1
        // when its product with the specular factor cannot change the
        // diffuse terms it is added to (rv^shininess <= rv^spec_k there);
        // 0: always pow.
        int spec_k = 0;
        // specular_negligible cannot hold for rv > spec_rv_cut (a filter
        // only: that test decides).
        double spec_rv_cut = 0.0;
        double eye_object[3];             // to_object(eye): the primary rays' origin in object space
        bool identity = false;            // linear is the identity, bit for bit (see linear_apply)
    };
    std::vector<Object> objects;
    struct LightRec {
        double dir[3];  // a directional light's normalize3(vector)
        // l.intensity * l.color[a]: shade's `l.intensity * l.color[a] * (...)`
        // parses as (l.intensity * l.color[a]) * (...), so the product formed
        // once per frame is the same double.
        double ic[3];
        bool directional;
    };
    std::vector<LightRec> lights;  // the scene's, in order
    // Some light is a point light, or some object bounces rays: shade
    // needs the hit point.
    bool need_point = false;
    // ShadeMode::Reference: shade() runs its plain per-pixel code
    // (gradient(), std::pow, std::exp, std::atan2 always), the reference
    // the fast paths are tested against to the bit (tests/render/test_shade.py).
    bool reference = false;

    /// Fills the plan for `plan`'s scene and engine options.
    void build(const FramePlan& plan);
};

}  // namespace argand::detail

#pragma GCC visibility pop
