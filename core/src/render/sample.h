// render/sample.h: one sample traced: its primary ray, the Tracer's
// intersection (with the ladder) and shading, the colour rounded to float
// (render_tile's samples and explain_pixel's). Internal header.
#pragma once

#include "argand/render.h"
#include "camera.h"
#include "tracer.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// One sample's outcome (a primary ray: traced and shaded).
struct SampleResult {
    HitInfo hit;
    float rgb[3];
};

/// Traces and shades the sample at cell (sx_cell, sy_cell) of the frame's
/// grid of samples.
/// `dir` (optional): the sample's direction, already made by
/// sample_direction for these cells (render_tile's batch): not made again.
/// (Inlined: render_tile's calls are specialised, trace and the rest
/// known; see PixelAccumulator::add for what that asks of add.)
[[gnu::always_inline]] inline SampleResult trace_sample(const FramePlan& plan, Tracer& tracer, int sx_cell, int sy_cell,
                                                       int side, Seeds* seeds, PixelExplanation* trace,
                                                       const BatchedCell* pre = nullptr, const double* dir = nullptr,
                                                       bool filled = false) {
    Ray ray;
    if (dir) {
        for (int a = 0; a < 3; ++a) {
            ray.origin[a] = plan.eye[a];
            ray.direction[a] = dir[a];
        }
    } else {
        ray = sample_ray(plan, sx_cell, sy_cell, side);
    }
    for (int a = 0; a < 3; ++a) tracer.current_direction_[a] = ray.direction[a];
    tracer.pixel_x_ = sx_cell / side;  // the pixel holding the sample (for the exact tier)
    tracer.pixel_y_ = sy_cell / side;
    tracer.exact_block_ = static_cast<std::int64_t>(sy_cell / kSeedBlock) << 32 | (sx_cell / kSeedBlock);
    SampleResult s;
    s.hit = tracer.intersect(ray.origin, ray.direction, true, seeds, 0, trace, pre, filled);
    if (trace) trace->ray = ray;
    double rgb[3];
    if (s.hit.hit) tracer.shade(ray.origin, ray.direction, s.hit, 0, rgb);
    else for (int a = 0; a < 3; ++a) rgb[a] = plan.scene.background[a];
    for (int a = 0; a < 3; ++a) s.rgb[a] = static_cast<float>(rgb[a]);
    return s;
}

}  // namespace argand::detail

#pragma GCC visibility pop
