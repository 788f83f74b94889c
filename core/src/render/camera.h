// render/camera.h: the camera: a frame's grid of samples, their unit
// world directions and primary rays, and the camera part of plan_frame.
// Internal header.
#pragma once

#include "argand/render.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// Sample centre -> unit world direction (the one formula for render_tile,
/// primary_ray and explain_pixel). (sx, sy) is a cell of the frame's grid
/// of samples, side times finer than the pixels: the samples of a W x H
/// frame are the pixel centres of the (side W) x (side H) frame, to the bit
/// (the aspect W / H is the same correctly rounded quotient).
void sample_direction(const FramePlan& plan, int sx_cell, int sy_cell, int side, double* d);

/// The primary ray of a sample (the eye, sample_direction).
inline Ray sample_ray(const FramePlan& plan, int sx_cell, int sy_cell, int side) {
    Ray r;
    for (int a = 0; a < 3; ++a) r.origin[a] = plan.eye[a];
    sample_direction(plan, sx_cell, sy_cell, side, r.direction);
    return r;
}

/// plan_frame's camera: eye, forward, right, up, tan_half_fov and
/// scene_distance of `plan` from `cam`. Throws std::invalid_argument for a
/// camera whose up is parallel to its view direction or whose field of view
/// is not in (0, 180) degrees.
void plan_camera(const CameraSpec& cam, FramePlan& plan);

}  // namespace argand::detail

#pragma GCC visibility pop
