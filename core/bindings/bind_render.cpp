// bind_render.cpp: plan a frame from plain Python data, render tiles.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

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

constexpr int kInterleavedChannels = 10;

template <class T>
py::array_t<T> as_image(const std::vector<T>& v, int h, int w, int channels) {
    std::vector<py::ssize_t> shape = {h, w};
    if (channels > 1) shape.push_back(channels);
    py::array_t<T> a(shape);
    std::copy(v.begin(), v.end(), a.mutable_data());
    return a;
}

}  // namespace

void init_render(py::module_& m) {
    py::class_<FramePlan>(m, "FramePlan", "A frame planned once (camera, Taylor expansions); render tiles from it.")
        .def_property_readonly("width", [](const FramePlan& p) { return p.params.width; })
        .def_property_readonly("height", [](const FramePlan& p) { return p.params.height; });
    m.def(
        "plan_frame",
        [](const py::dict& scene, double sigma, double delta, int width, int height, const std::string& method,
           int max_depth, bool hue_by_argument, bool seed_from_neighbour) {
            FrameParams fp;
            fp.sigma = sigma;
            fp.delta = delta;
            fp.width = width;
            fp.height = height;
            fp.method = method_from(method);
            fp.max_depth = max_depth;
            fp.hue_by_argument = hue_by_argument;
            fp.seed_from_neighbour = seed_from_neighbour;
            try {
                return plan_frame(scene_from(scene), fp);
            } catch (const std::invalid_argument& e) {
                throw py::value_error(e.what());
            }
        },
        py::arg("scene"), py::arg("sigma"), py::arg("delta"), py::arg("width"), py::arg("height"),
        py::arg("method") = "auto", py::arg("max_depth") = 3, py::arg("hue_by_argument") = false,
        py::arg("seed_from_neighbour") = true);
    m.def(
        "render_tile",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1) {
            TileAOVs t;
            {
                py::gil_scoped_release release;
                render_tile(plan, TileRect{x0, y0, x1, y1}, t);
            }
            py::dict out;
            out["rgba"] = as_image(t.rgba, t.height, t.width, 4);
            out["Z"] = as_image(t.modulus, t.height, t.width, 1);
            out["arg"] = as_image(t.argument, t.height, t.width, 1);
            out["re"] = as_image(t.re, t.height, t.width, 1);
            out["im"] = as_image(t.im, t.height, t.width, 1);
            out["count"] = as_image(t.count, t.height, t.width, 1);
            out["status"] = as_image(t.status, t.height, t.width, 1);
            out["escalations"] = t.escalations;
            out["root_calls"] = t.root_calls;
            return out;
        },
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"));
    m.def(
        "render_tile_into",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, py::array_t<float, py::array::c_style> out, int ox,
           int oy) {
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
                throw py::value_error("out must be a C-contiguous (h, w, 10) float32 array");
            const py::ssize_t oh = out.shape(0), ow = out.shape(1);
            if (ox < 0 || oy < 0 || ox + (x1 - x0) > ow || oy + (y1 - y0) > oh)
                throw py::value_error("the tile does not fit in out at the given offset");
            float* base = out.mutable_data();
            TileAOVs t;
            std::int64_t by_status[4] = {0, 0, 0, 0}, hits = 0;
            {
                py::gil_scoped_release release;
                render_tile(plan, TileRect{x0, y0, x1, y1}, t);
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
                        ++by_status[t.status[i] & 3];
                        hits += p[3] > 0.0f;
                    }
                }
            }
            return py::make_tuple(t.escalations, t.root_calls, py::make_tuple(by_status[0], by_status[1], by_status[2], by_status[3]),
                                  hits);
        },
        "Renders the tile [x0, x1) x [y0, y1) into out[oy:, ox:] as 10 interleaved float32 channels (R, G, B, A, "
        "Z, arg, re, im, count, status: the EXR's layout). Returns (escalations, root_calls, pixels per status "
        "code 0..3, pixels that hit a surface).",
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("out").noconvert(), py::arg("ox") = 0,
        py::arg("oy") = 0);
    m.def(
        "ray_polynomial",
        [](const FramePlan& plan, int object, std::array<double, 3> origin, std::array<double, 3> direction) {
            const int n = plan.scene.objects.at(object).degree;
            py::array_t<double> c(n + 1);
            ray_polynomial(plan, object, origin.data(), direction.data(), c.mutable_data());
            return c;
        },
        py::arg("plan"), py::arg("object"), py::arg("origin"), py::arg("direction"));
    m.def(
        "pixel_direction",
        [](const FramePlan& p, double x, double y) {
            const double aspect = static_cast<double>(p.params.width) / p.params.height;
            const double sx = (2.0 * (x + 0.5) / p.params.width - 1.0) * p.tan_half_fov * aspect;
            const double sy = (1.0 - 2.0 * (y + 0.5) / p.params.height) * p.tan_half_fov;
            std::array<double, 3> d;
            for (int a = 0; a < 3; ++a) d[a] = p.forward[a] + sx * p.right[a] + sy * p.up[a];
            const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (double& v : d) v /= n;
            return py::make_tuple(std::array<double, 3>{p.eye[0], p.eye[1], p.eye[2]}, d);
        },
        "The primary ray (eye, unit direction) through the centre of pixel (x, y).");
}
