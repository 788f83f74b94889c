// bind_render.cpp: plan a frame from plain Python data, render tiles.
#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <complex>
#include <memory>
#include <stdexcept>
#include <string>

#include "argand/render.h"

namespace py = pybind11;
using namespace argand;

namespace {

template <std::size_t N>
void copy_array(const py::handle& src, double (&dst)[N], const char* what) {
    auto v = src.cast<std::vector<double>>();
    if (v.size() != N) throw py::value_error(std::string(what) + " must have " + std::to_string(N) + " numbers");
    for (std::size_t i = 0; i < N; ++i) dst[i] = v[i];
}

Method method_from(const std::string& name) {
    Method m;
    if (!method_from_name(name.c_str(), m)) throw py::value_error("unknown method '" + name + "'");
    return m;
}

SceneSpec scene_from(const py::dict& d) {
    SceneSpec sc;
    for (const auto& o : d["objects"].cast<py::list>()) {
        const py::dict od = o.cast<py::dict>();
        SurfaceSpec s;
        for (const auto& t : od["terms"].cast<py::list>()) {
            auto tt = t.cast<py::tuple>();
            s.terms.push_back({tt[0].cast<int>(), tt[1].cast<int>(), tt[2].cast<int>(), tt[3].cast<double>()});
        }
        s.degree = od["degree"].cast<int>();
        s.complex_space = od["complex"].cast<bool>();
        s.clip_radius = od["clip_radius"].cast<double>();
        const py::dict md = od["material"].cast<py::dict>();
        copy_array(md["color"], s.material.color, "material.color");
        s.material.diffuse = md["diffuse"].cast<double>();
        s.material.specular = md["specular"].cast<double>();
        s.material.shininess = md["shininess"].cast<double>();
        s.material.reflectivity = md["reflectivity"].cast<double>();
        s.material.transparency = md["transparency"].cast<double>();
        s.material.ior = md["ior"].cast<double>();
        copy_array(od["linear"], s.linear, "linear");
        copy_array(od["translate"], s.translate, "translate");
        sc.objects.push_back(std::move(s));
    }
    for (const auto& l : d["lights"].cast<py::list>()) {
        const py::dict ld = l.cast<py::dict>();
        Light light;
        copy_array(ld["vector"], light.vector, "light vector");
        light.directional = ld["directional"].cast<bool>();
        copy_array(ld["color"], light.color, "light color");
        light.intensity = ld["intensity"].cast<double>();
        sc.lights.push_back(light);
    }
    copy_array(d["background"], sc.background, "background");
    const py::dict cd = d["camera"].cast<py::dict>();
    copy_array(cd["position"], sc.camera.position, "camera.position");
    copy_array(cd["look_at"], sc.camera.look_at, "camera.look_at");
    copy_array(cd["up"], sc.camera.up, "camera.up");
    sc.camera.fov_degrees = cd["fov"].cast<double>();
    return sc;
}

/// The farm's interleaved layout (the EXR's channel order); Python's
/// argand.render.frames.INTERLEAVED_CHANNELS must equal it (tested).
constexpr const char* kInterleavedNames[] = {"R", "G", "B", "A", "Z", "arg", "re", "im", "count", "status", "escalation"};
constexpr int kInterleavedChannels = sizeof(kInterleavedNames) / sizeof(kInterleavedNames[0]);

template <class T>
py::array_t<T> as_image(const std::vector<T>& v, int h, int w, int channels) {
    std::vector<py::ssize_t> shape = {h, w};
    if (channels > 1) shape.push_back(channels);
    py::array_t<T> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

/// The exact tier's hook around a Python callable `fn(frame, query) ->
/// dict` (argand.render.exact.decide_pixel): called from render_tile with
/// the GIL released, it takes the GIL for the call. `frame` (the objects,
/// band and caps, as plain Python data) is built once per hook, on its
/// first call; the callable may cache in it. A Python exception propagates
/// out of render_tile.
struct PythonExactSolver {
    py::object fn;
    py::object frame;  // built lazily (under the GIL)

    static py::dict frame_dict(const FramePlan& plan) {
        py::dict f;
        py::list objects;
        for (const SurfaceSpec& s : plan.scene.objects) {
            py::dict o;
            py::list terms;
            for (const Term& t : s.terms) terms.append(py::make_tuple(t.ex, t.ey, t.ez, t.coeff));
            o["terms"] = terms;
            o["degree"] = s.degree;
            o["complex"] = s.complex_space;
            o["clip_radius"] = s.clip_radius;
            o["linear"] = std::vector<double>(s.linear, s.linear + 9);
            o["translate"] = std::vector<double>(s.translate, s.translate + 3);
            objects.append(o);
        }
        f["objects"] = objects;
        f["sigma"] = plan.params.sigma;
        f["delta"] = plan.params.delta;
        f["max_bits"] = plan.params.exact_max_bits;
        return f;
    }

    ExactAnswer operator()(const FramePlan& plan, const ExactQuery& q) {
        py::gil_scoped_acquire gil;
        if (!frame) frame = frame_dict(plan);
        py::dict query;
        query["x"] = q.x;
        query["y"] = q.y;
        query["origin"] = std::array<double, 3>{q.ray.origin[0], q.ray.origin[1], q.ray.origin[2]};
        query["direction"] = std::array<double, 3>{q.ray.direction[0], q.ray.direction[1], q.ray.direction[2]};
        query["explain"] = q.explain;
        const py::dict r = fn(frame, query).cast<py::dict>();
        ExactAnswer a;
        a.decided = r["decided"].cast<bool>();
        a.status = static_cast<std::uint8_t>(r["status"].cast<int>());
        if (a.status > kUndecided) throw py::value_error("the exact solver returned status " + std::to_string(a.status));
        a.multiple = r["multiple"].cast<bool>();
        a.hit = r["hit"].cast<bool>();
        a.object = r["object"].cast<int>();
        if (a.hit && (a.object < 0 || a.object >= static_cast<int>(plan.scene.objects.size())))
            throw py::value_error("the exact solver returned object " + std::to_string(a.object));
        a.re = r["re"].cast<double>();
        a.im = r["im"].cast<double>();
        a.modulus = r["modulus"].cast<double>();
        a.eligible = r["eligible"].cast<int>();
        a.reason = r["reason"].cast<std::string>();
        if (r.contains("steps")) a.steps = r["steps"].cast<std::vector<std::string>>();
        return a;
    }
};

/// Holds a PythonExactSolver for one binding call (created and destroyed
/// under the GIL; render_tile only calls it).
struct ExactHook {
    std::unique_ptr<PythonExactSolver> holder;
    ExactSolver solver;
    explicit ExactHook(const py::object& fn) {
        if (fn.is_none()) return;
        if (!PyCallable_Check(fn.ptr())) throw py::type_error("exact must be a callable (frame, query) -> dict, or None");
        holder = std::make_unique<PythonExactSolver>();
        holder->fn = fn;
        PythonExactSolver* h = holder.get();
        solver = [h](const FramePlan& plan, const ExactQuery& q) { return (*h)(plan, q); };
    }
    const ExactSolver* get() const { return solver ? &solver : nullptr; }
};

}  // namespace

void init_render(py::module_& m) {
    py::class_<FramePlan>(m, "FramePlan", "A frame planned once (camera, Taylor expansions); render tiles from it.")
        .def_property_readonly("width", [](const FramePlan& p) { return p.params.width; })
        .def_property_readonly("height", [](const FramePlan& p) { return p.params.height; });
    m.def(
        "plan_frame",
        [](const py::dict& scene, double sigma, double delta, int width, int height, const std::string& method,
           int max_depth, bool hue_by_argument, bool seed_from_neighbour, int exact_pixels_per_tile,
           int exact_max_bits) {
            FrameParams fp;
            fp.sigma = sigma;
            fp.delta = delta;
            fp.width = width;
            fp.height = height;
            fp.method = method_from(method);
            fp.max_depth = max_depth;
            fp.hue_by_argument = hue_by_argument;
            fp.seed_from_neighbour = seed_from_neighbour;
            fp.exact_pixels_per_tile = exact_pixels_per_tile;
            fp.exact_max_bits = exact_max_bits;
            try {
                return plan_frame(scene_from(scene), fp);
            } catch (const std::invalid_argument& e) {
                throw py::value_error(e.what());
            }
        },
        py::arg("scene"), py::arg("sigma"), py::arg("delta"), py::arg("width"), py::arg("height"),
        py::arg("method") = "auto", py::arg("max_depth") = 3, py::arg("hue_by_argument") = false,
        py::arg("seed_from_neighbour") = true, py::arg("exact_pixels_per_tile") = FrameParams{}.exact_pixels_per_tile,
        py::arg("exact_max_bits") = FrameParams{}.exact_max_bits);
    m.def(
        "render_tile",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, const py::object& exact) {
            TileAOVs t;
            ExactHook hook(exact);
            {
                py::gil_scoped_release release;
                render_tile(plan, TileRect{x0, y0, x1, y1}, t, hook.get());
            }
            py::dict out;
            out["rgba"] = as_image(t.rgba, t.height, t.width, 4);
            out["Z"] = as_image(t.modulus, t.height, t.width, 1);
            out["arg"] = as_image(t.argument, t.height, t.width, 1);
            out["re"] = as_image(t.re, t.height, t.width, 1);
            out["im"] = as_image(t.im, t.height, t.width, 1);
            out["count"] = as_image(t.count, t.height, t.width, 1);
            out["status"] = as_image(t.status, t.height, t.width, 1);
            out["escalation"] = as_image(t.escalation, t.height, t.width, 1);
            out["escalations"] = t.escalations;
            out["root_calls"] = t.root_calls;
            return out;
        },
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("exact") = py::none());
    m.def(
        "render_tile_into",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, py::array_t<float, py::array::c_style> out, int ox,
           int oy, const py::object& exact) {
            // The farm's layout: the EXR's interleaved channels, written in
            // place (no per-AOV arrays to allocate and stitch in Python).
            // `out` is taken without conversion: a converted copy would take
            // the pixels and be thrown away.
            const int W = plan.params.width, H = plan.params.height;
            if (!(0 <= x0 && x0 < x1 && x1 <= W && 0 <= y0 && y0 < y1 && y1 <= H))
                throw py::value_error("tile [" + std::to_string(x0) + ", " + std::to_string(x1) + ") x [" +
                                      std::to_string(y0) + ", " + std::to_string(y1) + ") is not inside the " +
                                      std::to_string(W) + "x" + std::to_string(H) + " frame");
            if (out.ndim() != 3 || out.shape(2) != kInterleavedChannels)
                throw py::value_error("out must be a C-contiguous (h, w, " + std::to_string(kInterleavedChannels) +
                                      ") float32 array");
            const py::ssize_t oh = out.shape(0), ow = out.shape(1);
            if (ox < 0 || oy < 0 || ox + (x1 - x0) > ow || oy + (y1 - y0) > oh)
                throw py::value_error("the tile does not fit in out at the given offset");
            float* base = out.mutable_data();
            TileAOVs t;
            ExactHook hook(exact);
            std::int64_t by_status[4] = {0, 0, 0, 0}, hits = 0;
            {
                py::gil_scoped_release release;
                render_tile(plan, TileRect{x0, y0, x1, y1}, t, hook.get());
                for (int y = 0; y < t.height; ++y) {
                    float* p = base + (static_cast<std::size_t>(oy + y) * ow + ox) * kInterleavedChannels;
                    for (int x = 0; x < t.width; ++x, p += kInterleavedChannels) {
                        const std::size_t i = static_cast<std::size_t>(y) * t.width + x;
                        for (int c = 0; c < 4; ++c) p[c] = t.rgba[4 * i + c];
                        p[4] = t.modulus[i];
                        p[5] = t.argument[i];
                        p[6] = t.re[i];
                        p[7] = t.im[i];
                        p[8] = static_cast<float>(t.count[i]);
                        p[9] = static_cast<float>(t.status[i]);
                        p[10] = static_cast<float>(t.escalation[i]);
                        ++by_status[t.status[i] & 3];
                        hits += p[3] > 0.0f;
                    }
                }
            }
            return py::make_tuple(t.escalations, t.root_calls, py::make_tuple(by_status[0], by_status[1], by_status[2], by_status[3]),
                                  hits);
        },
        "Renders the tile [x0, x1) x [y0, y1) into out[oy:, ox:] as 11 interleaved float32 channels (R, G, B, A, "
        "Z, arg, re, im, count, status, escalation: INTERLEAVED_CHANNELS, the EXR's layout). Returns (escalations, root_calls, pixels per status "
        "code 0..3, pixels that hit a surface).",
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("out").noconvert(), py::arg("ox") = 0,
        py::arg("oy") = 0, py::arg("exact") = py::none());
    m.def(
        "ray_polynomial",
        [](const FramePlan& plan, int object, std::array<double, 3> origin, std::array<double, 3> direction,
           bool with_radius) -> py::object {
            if (object < 0 || object >= static_cast<int>(plan.scene.objects.size()))
                throw py::value_error("object must be in 0.." + std::to_string(plan.scene.objects.size() - 1));
            const int n = plan.scene.objects[object].degree;
            py::array_t<double> c(n + 1), r(n + 1);
            ray_polynomial(plan, object, origin.data(), direction.data(), c.mutable_data(), r.mutable_data());
            if (with_radius) return py::make_tuple(c, r);
            return std::move(c);
        },
        "The ray polynomial F(o + t d) of one object, lowest degree first; with_radius: (coeffs, radius) where "
        "radius[k] bounds |exact coefficient - coeffs[k]|.",
        py::arg("plan"), py::arg("object"), py::arg("origin"), py::arg("direction"), py::arg("with_radius") = false);
    auto primary = [](const FramePlan& p, int x, int y) {
        if (x < 0 || x >= p.params.width || y < 0 || y >= p.params.height)
            throw py::value_error("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is not inside the " +
                                  std::to_string(p.params.width) + "x" + std::to_string(p.params.height) + " frame");
        const Ray r = primary_ray(p, x, y);
        return py::make_tuple(std::array<double, 3>{r.origin[0], r.origin[1], r.origin[2]},
                              std::array<double, 3>{r.direction[0], r.direction[1], r.direction[2]});
    };
    m.def("primary_ray", primary,
          "The primary ray (origin, unit direction) of pixel (x, y): the exact doubles render_tile uses.",
          py::arg("plan"), py::arg("x"), py::arg("y"));
    m.def(
        "explain_pixel",
        [](const FramePlan& plan, int x, int y, int row_start, const py::object& exact) {
            PixelExplanation e;
            ExactHook hook(exact);
            try {
                e = explain_pixel(plan, x, y, row_start, hook.get());
            } catch (const std::invalid_argument& err) {
                throw py::value_error(err.what());
            }
            py::dict out;
            out["origin"] = std::array<double, 3>{e.ray.origin[0], e.ray.origin[1], e.ray.origin[2]};
            out["direction"] = std::array<double, 3>{e.ray.direction[0], e.ray.direction[1], e.ray.direction[2]};
            py::list polys;
            for (const auto& p : e.polynomials) {
                py::dict d;
                d["object"] = p.object;
                d["coeffs"] = p.coeffs;
                d["radius"] = p.radius;
                d["roots_status"] = p.roots_status;
                d["seeded"] = p.seeded;
                d["root_escalation"] = p.root_escalation;
                d["complete"] = p.complete;
                polys.append(d);
            }
            out["polynomials"] = polys;
            static const char* verdict[] = {"yes", "no", "unknown", "not needed"};
            py::list discs;
            for (const auto& d : e.discs) {
                py::dict o;
                o["object"] = d.object;
                o["center"] = std::complex<double>(d.disc.re, d.disc.im);
                o["radius"] = d.disc.radius;
                o["count"] = d.disc.count;
                o["verified"] = d.disc.verified;
                o["real"] = d.real;
                o["modulus"] = py::make_tuple(d.modulus_lo, d.modulus_hi);
                o["at_origin"] = d.at_origin;
                o["in_band"] = verdict[d.band];
                o["inside_clip"] = verdict[d.clip];
                o["live"] = d.live;
                o["eligible"] = d.eligible;
                discs.append(o);
            }
            out["discs"] = discs;
            out["chosen"] = e.chosen;
            out["hit"] = e.hit;
            out["status"] = static_cast<int>(e.status);
            out["escalation"] = static_cast<int>(e.level);
            out["reason"] = e.reason;
            out["root"] = std::complex<double>(e.root_re, e.root_im);
            out["exact_ran"] = e.exact_ran;
            if (e.exact_ran) {
                py::dict x;
                x["decided"] = e.exact.decided;
                x["status"] = static_cast<int>(e.exact.status);
                x["multiple"] = e.exact.multiple;
                x["hit"] = e.exact.hit;
                x["object"] = e.exact.object;
                x["root"] = std::complex<double>(e.exact.re, e.exact.im);
                x["eligible"] = e.exact.eligible;
                x["reason"] = e.exact.reason;
                x["steps"] = e.exact.steps;
                out["exact"] = x;
            }
            return out;
        },
        "Runs render_tile's code path for pixel (x, y) of a tile whose rows start at column row_start, and returns "
        "its ray, ray polynomials (with coefficient radii), discs, each decision, the status and the ladder level.",
        py::arg("plan"), py::arg("x"), py::arg("y"), py::arg("row_start"), py::arg("exact") = py::none());
    m.attr("MAX_OBJECTS") = kMaxObjects;
    m.attr("MAX_SURFACE_DEGREE") = kMaxSurfaceDegree;
    m.attr("MAX_FRAME_SIDE") = kMaxFrameSide;
    m.attr("MAX_EXACT_BITS") = kMaxExactBits;
    m.attr("EXACT_PIXELS_PER_TILE") = FrameParams{}.exact_pixels_per_tile;
    m.attr("EXACT_MAX_BITS") = FrameParams{}.exact_max_bits;
    m.attr("BAND_RULE") = kBandRule;
    m.def("band_rule_holds", &band_rule_holds, "True iff (sigma, delta) satisfy BAND_RULE (decided exactly).",
          py::arg("sigma"), py::arg("delta"));
    py::list names;
    for (const char* n : kInterleavedNames) names.append(n);
    m.attr("INTERLEAVED_CHANNELS") = py::tuple(names);
}
