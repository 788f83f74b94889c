// render/camera.cpp: sample directions, primary rays and the camera part
// of plan_frame (camera.h).
#include "camera.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "vec3.h"

namespace argand {
namespace detail {

void sample_direction(const FramePlan& plan, int sx_cell, int sy_cell, int side, double* d) {
    const FrameParams& fp = plan.params;
    const double aspect = static_cast<double>(fp.width) / fp.height;
    const double cols = static_cast<double>(side) * fp.width, rows = static_cast<double>(side) * fp.height;
    const double sx = (2.0 * (sx_cell + 0.5) / cols - 1.0) * plan.tan_half_fov * aspect;
    const double sy = (1.0 - 2.0 * (sy_cell + 0.5) / rows) * plan.tan_half_fov;
    for (int a = 0; a < 3; ++a) d[a] = plan.forward[a] + sx * plan.right[a] + sy * plan.up[a];
    normalize3(d);
}

void plan_camera(const CameraSpec& cam, FramePlan& plan) {
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
}

}  // namespace detail

int sample_side(int samples) {
    for (int side = 1; side * side <= kMaxSamples; ++side)
        if (side * side == samples) return side;
    return 0;
}

Ray primary_ray(const FramePlan& plan, int x, int y, int sample) {
    const int side = sample_side(plan.params.samples);
    if (sample < 0 || sample >= plan.params.samples)
        throw std::invalid_argument("sample must be in 0.." + std::to_string(plan.params.samples - 1));
    return detail::sample_ray(plan, side * x + sample % side, side * y + sample / side, side);
}

}  // namespace argand
