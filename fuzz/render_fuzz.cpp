// render_fuzz.cpp: libFuzzer target for the scene path of the C++ core:
// plan_frame + render_tile on scenes built from the fuzzer's bytes.
//
// Scenes respect what the scene layer guarantees the core (exponents >= 0
// whose sum is at most the object's degree, degree 1..12) and nothing else:
// coefficients, camera, transforms, clip radii, materials, lights and the
// frame's sigma/delta are arbitrary doubles (NaN and infinities included),
// 1..24 objects (beyond any fixed-size array), frames up to 6x6 pixels.
// plan_frame may refuse a scene with std::invalid_argument; anything else
// must render without a crash, undefined behaviour or hang, and the AOVs
// must have the frame's size and documented status values.
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "argand/render.h"
#include "fuzz_input.h"

using namespace argand;

namespace {

[[noreturn]] void fail(const char* what) {
    std::fprintf(stderr, "render_fuzz: contract violated: %s\n", what);
    std::abort();
}

double value(argand_fuzz::FuzzInput& in, bool raw) { return raw ? in.raw_double() : in.structured_double(); }

SurfaceSpec surface(argand_fuzz::FuzzInput& in, bool raw) {
    SurfaceSpec s;
    s.degree = in.in_range(1, 12);
    const int n_terms = in.in_range(1, 10);
    for (int t = 0; t < n_terms; ++t) {
        Term term;
        term.ex = in.in_range(0, s.degree);
        term.ey = in.in_range(0, s.degree - term.ex);
        term.ez = in.in_range(0, s.degree - term.ex - term.ey);
        term.coeff = value(in, raw);
        s.terms.push_back(term);
    }
    const std::uint8_t flags = in.byte();
    s.complex_space = (flags & 1) != 0;
    if (flags & 2) s.clip_radius = value(in, raw);
    if (flags & 4)
        for (double& v : s.linear) v = value(in, raw);
    if (flags & 8)
        for (double& v : s.translate) v = value(in, raw);
    if (flags & 16) {
        Material& m = s.material;
        for (double& v : m.color) v = value(in, raw);
        m.diffuse = value(in, raw);
        m.specular = value(in, raw);
        m.shininess = value(in, raw);
        m.reflectivity = value(in, raw);
        m.transparency = value(in, raw);
        m.ior = value(in, raw);
    }
    return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    argand_fuzz::FuzzInput in(data, size);
    const std::uint8_t control = in.byte();
    const bool raw = (control & 1) != 0;
    SceneSpec scene;
    const int n_objects = (control & 2) ? in.in_range(1, 24) : in.in_range(1, 3);
    for (int i = 0; i < n_objects; ++i) scene.objects.push_back(surface(in, raw));
    const int n_lights = in.in_range(0, 2);
    scene.lights.clear();  // (not the default lights: 0 to 2 of the input's)
    for (int i = 0; i < n_lights; ++i) {
        Light light;
        for (double& v : light.vector) v = value(in, raw);
        light.directional = (in.byte() & 1) != 0;
        light.intensity = value(in, raw);
        scene.lights.push_back(light);
    }
    if (control & 4) {
        for (double& v : scene.camera.position) v = value(in, raw);
        for (double& v : scene.camera.look_at) v = value(in, raw);
        for (double& v : scene.camera.up) v = value(in, raw);
        scene.camera.fov_degrees = value(in, raw);
    }
    FrameParams params;
    params.sigma = (control & 8) ? value(in, raw) : 0.0;
    params.delta = (control & 16) ? value(in, raw) : 0.35;
    params.width = in.in_range(1, 6);
    params.height = in.in_range(1, 6);
    params.method = static_cast<Method>(in.in_range(0, 3));
    params.max_depth = in.in_range(0, 3);
    params.hue_by_argument = (control & 32) != 0;
    params.seed_from_neighbour = (control & 64) != 0;

    FramePlan plan;
    try {
        plan = plan_frame(scene, params);
    } catch (const std::invalid_argument&) {
        return 0;  // a refusal with a reason is a valid outcome
    }
    TileAOVs out;
    render_tile(plan, TileRect{0, 0, params.width, params.height}, out);
    const std::size_t pixels = static_cast<std::size_t>(params.width) * params.height;
    if (out.rgba.size() != 4 * pixels || out.status.size() != pixels || out.modulus.size() != pixels ||
        out.count.size() != pixels)
        fail("AOVs do not have the frame's size");
    for (std::uint8_t s : out.status)
        if (s > kUndecided) fail("a status outside PixelStatus");
    return 0;
}
