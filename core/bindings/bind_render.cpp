// bind_render.cpp: the typed scene (render.h's structs as Python classes
// with checked fields), plan a frame, render tiles.
#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl_bind.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "argand/render.h"

// A scene's objects and lights are bound as list-like classes that hold the
// C++ vectors themselves, so scene.objects[0].degree = 3 changes the scene.
PYBIND11_MAKE_OPAQUE(std::vector<argand::SurfaceSpec>)
PYBIND11_MAKE_OPAQUE(std::vector<argand::Light>)

namespace py = pybind11;
using namespace argand;

namespace {

Method method_from(const std::string& name) {
    Method m;
    if (!method_from_name(name.c_str(), m)) throw py::value_error("unknown method '" + name + "'");
    return m;
}

// ---------------------------------------------------------------------------
// Checked conversions: every error names the field ("CameraSpec.up[2]: ...").
// ---------------------------------------------------------------------------

std::string describe(const py::handle& v) {
    std::string r = py::repr(v);
    if (r.size() > 60) r = r.substr(0, 57) + "...";
    return py::str(py::type::of(v).attr("__name__")).cast<std::string>() + " " + r;
}

[[noreturn]] void wrong_type(const std::string& field, const std::string& want, const py::handle& got) {
    throw py::type_error(field + ": expected " + want + ", got " + describe(got));
}

std::string number_text(double v) {
    std::string t = py::repr(py::float_(v));
    return t;
}

bool is_numpy_bool(const py::handle& v) {
    const py::handle t = py::type::of(v);
    const std::string name = py::str(t.attr("__name__"));
    return (name == "bool" || name == "bool_") && py::str(t.attr("__module__")).cast<std::string>() == "numpy";
}

/// Where a number field may lie: lo and hi, each included unless open.
struct Bounds {
    double lo = -INFINITY, hi = INFINITY;
    bool lo_open = false, hi_open = false;
};

/// The bounds of every bounded number field of the typed scene, by
/// "Struct.field" (for a field of several numbers, the bounds of each). The
/// setters below check them, and FIELD_LIMITS exports them: the scene model
/// (argand.scene.model) takes its bounds from there, so each limit is written
/// once, here.
constexpr struct {
    const char* field;
    Bounds bounds;
} kFieldLimits[] = {
    {"Material.color", {0.0, 1.0}},
    {"Material.diffuse", {0.0, 1.0}},
    {"Material.specular", {0.0, 1.0}},
    {"Material.shininess", {0.0, 10000.0, true}},
    {"Material.reflectivity", {0.0, 1.0}},
    {"Material.transparency", {0.0, 1.0}},
    {"Material.ior", {1.0, 4.0}},
    {"SurfaceSpec.clip_radius", {0.0}},
    {"Light.color", {0.0, 1.0}},
    {"Light.intensity", {0.0}},
    {"CameraSpec.fov_degrees", {1.0, 179.0, true, true}},
    {"SceneSpec.background", {0.0, 1.0}},
};

/// The bounds of field "Struct.field" (unbounded if kFieldLimits has none).
Bounds bounds_of(const std::string& field) {
    for (const auto& f : kFieldLimits)
        if (field == f.field) return f.bounds;
    return Bounds{};
}

/// The bounds as a reader writes them: "in [0.0, 1.0]", "in (0.0, 10000.0]",
/// ">= 0.0"; "" when unbounded.
std::string range_text(const Bounds& b) {
    if (std::isinf(b.lo) && std::isinf(b.hi)) return "";
    if (std::isinf(b.hi)) return (b.lo_open ? "> " : ">= ") + number_text(b.lo);
    if (std::isinf(b.lo)) return (b.hi_open ? "< " : "<= ") + number_text(b.hi);
    return "in " + std::string(b.lo_open ? "(" : "[") + number_text(b.lo) + ", " + number_text(b.hi) +
           (b.hi_open ? ")" : "]");
}

/// A finite number (int or float, not bool or str) within the bounds.
double to_number(const py::handle& v, const std::string& field, const Bounds& b = {}) {
    if (py::isinstance<py::bool_>(v) || py::isinstance<py::str>(v) || py::isinstance<py::bytes>(v) ||
        !PyNumber_Check(v.ptr()) || is_numpy_bool(v))
        wrong_type(field, "a number", v);
    double d;
    try {
        d = v.cast<double>();
    } catch (const py::cast_error&) {
        wrong_type(field, "a number", v);
    }
    if (!std::isfinite(d)) throw py::value_error(field + " must be finite, got " + number_text(d));
    const bool above = b.lo_open ? d > b.lo : d >= b.lo;
    const bool below = b.hi_open ? d < b.hi : d <= b.hi;
    if (!(above && below)) throw py::value_error(field + " must be " + range_text(b) + ", got " + number_text(d));
    return d;
}

/// An integer (int or anything with __index__, not bool) in [lo, hi].
int to_int(const py::handle& v, const std::string& field, long long lo, long long hi) {
    if (py::isinstance<py::bool_>(v) || !PyIndex_Check(v.ptr())) wrong_type(field, "an integer", v);
    const long long i = py::reinterpret_steal<py::int_>(PyNumber_Index(v.ptr())).cast<long long>();
    if (i < lo || i > hi)
        throw py::value_error(field + " must be in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " +
                              std::to_string(i));
    return static_cast<int>(i);
}

bool to_bool(const py::handle& v, const std::string& field) {
    if (!py::isinstance<py::bool_>(v)) wrong_type(field, "True or False", v);
    return v.cast<bool>();
}

/// A sequence (list, tuple, array; not a string) of exactly n items.
py::sequence to_sequence(const py::handle& v, const std::string& field, std::size_t n, const std::string& what) {
    if (!py::isinstance<py::sequence>(v) || py::isinstance<py::str>(v) || py::isinstance<py::bytes>(v)) {
        // numpy arrays are sequences through __len__/__getitem__ only when 1-D; accept any iterable.
        if (!py::isinstance<py::iterable>(v) || py::isinstance<py::str>(v)) wrong_type(field, what, v);
        return to_sequence(py::list(py::reinterpret_borrow<py::iterable>(v)), field, n, what);
    }
    auto seq = py::reinterpret_borrow<py::sequence>(v);
    if (n != 0 && seq.size() != n)
        throw py::value_error(field + ": expected " + what + ", got " + std::to_string(seq.size()) + " items");
    return seq;
}

template <std::size_t N>
void set_numbers(double (&dst)[N], const py::handle& v, const std::string& field, const Bounds& b) {
    const std::string what = std::to_string(N) + " numbers";
    auto seq = to_sequence(v, field, N, what);
    double tmp[N];
    for (std::size_t i = 0; i < N; ++i) tmp[i] = to_number(seq[i], field + "[" + std::to_string(i) + "]", b);
    std::copy(tmp, tmp + N, dst);
}

template <std::size_t N>
py::tuple numbers_of(const double (&src)[N]) {
    py::tuple t(N);
    for (std::size_t i = 0; i < N; ++i) t[i] = py::float_(src[i]);
    return t;
}

template <class T>
T& instance_of(const py::handle& v, const std::string& field, const char* type_name) {
    if (!py::isinstance<T>(v)) wrong_type(field, std::string("a ") + type_name, v);
    return v.cast<T&>();
}

// ---------------------------------------------------------------------------
// The typed scene classes
// ---------------------------------------------------------------------------

/// A field's doc with its bounds: "Diffuse weight, in [0.0, 1.0].", "[r, g, b],
/// each >= 0.0.".
std::string with_range(const char* doc, const Bounds& b, bool each) {
    const std::string range = range_text(b);
    if (range.empty()) return std::string(doc) + ".";
    return std::string(doc) + (each ? ", each " : ", ") + range + ".";
}

/// Binds one struct: its checked fields (recorded in FIELDS, in order), a
/// keyword constructor (unknown keywords refused), ==, repr and copies.
template <class T>
class Struct {
public:
    Struct(py::module_& m, const char* name, const char* doc) : cls_(m, name, doc), name_(name) {}

    /// A field with a getter (returns a Python value) and a checked setter.
    template <class Get, class Set>
    Struct& field(const char* name, Get get, Set set, const char* doc,
                  py::return_value_policy policy = py::return_value_policy::automatic) {
        const std::string where = name_ + "." + name;
        cls_.def_property(name, py::cpp_function(get, policy),
                          py::cpp_function([set, where](T& self, const py::object& v) { set(self, v, where); }), doc);
        fields_.append(name);
        return *this;
    }

    /// A number field, within its kFieldLimits bounds (named in its doc).
    Struct& number(const char* name, double T::*member, const char* doc) {
        const Bounds b = bounds_of(name_ + "." + name);
        return field(name, [member](const T& s) { return s.*member; },
                     [member, b](T& s, const py::object& v, const std::string& where) { s.*member = to_number(v, where, b); },
                     with_range(doc, b, false).c_str());
    }

    /// A field of N numbers, each within the field's kFieldLimits bounds.
    template <std::size_t N>
    Struct& numbers(const char* name, double (T::*member)[N], const char* doc) {
        const Bounds b = bounds_of(name_ + "." + name);
        return field(name, [member](const T& s) { return numbers_of(s.*member); },
                     [member, b](T& s, const py::object& v, const std::string& where) { set_numbers(s.*member, v, where, b); },
                     with_range(doc, b, true).c_str());
    }

    Struct& flag(const char* name, bool T::*member, const char* doc) {
        return field(name, [member](const T& s) { return s.*member; },
                     [member](T& s, const py::object& v, const std::string& where) { s.*member = to_bool(v, where); }, doc);
    }

    py::class_<T>& done() {
        cls_.attr("FIELDS") = py::tuple(fields_);
        const std::string name = name_;
        cls_.def(py::init([name](const py::kwargs& kw) {
                     py::object self = py::cast(T{}, py::return_value_policy::move);
                     const py::tuple fields = self.attr("FIELDS");
                     for (const auto& item : kw) {
                         if (!fields.contains(item.first))
                             throw py::type_error(name + " has no field '" + py::str(item.first).cast<std::string>() +
                                                  "'; its fields: " + py::str(", ").attr("join")(fields).cast<std::string>());
                         py::setattr(self, item.first, item.second);
                     }
                     return self.cast<T>();
                 }),
                 ("A " + name + " with the defaults of render.h, and the given fields (each checked as when set).").c_str());
        cls_.def("__eq__", [](const py::object& a, const py::object& b) -> py::object {
            if (!py::isinstance(b, py::type::of(a))) return py::reinterpret_borrow<py::object>(Py_NotImplemented);
            for (const auto& f : a.attr("FIELDS").cast<py::tuple>())
                if (!a.attr(f).equal(b.attr(f))) return py::bool_(false);
            return py::bool_(true);
        });
        cls_.attr("__hash__") = py::none();
        cls_.def("__repr__", [name](const py::object& self) {
            std::string out = name + "(";
            bool first = true;
            for (const auto& f : self.attr("FIELDS").cast<py::tuple>()) {
                out += (first ? "" : ", ") + f.cast<std::string>() + "=" + py::repr(self.attr(f)).cast<std::string>();
                first = false;
            }
            return out + ")";
        });
        cls_.def("__copy__", [](const T& self) { return T(self); });
        cls_.def("__deepcopy__", [](const T& self, const py::object&) { return T(self); }, py::arg("memo"));
        return cls_;
    }

private:
    py::class_<T> cls_;
    std::string name_;
    py::list fields_;
};

/// A list-like class holding std::vector<T> (append, index, len, iterate);
/// == compares items.
template <class T>
void bind_list(py::module_& m, const char* name) {
    py::bind_vector<std::vector<T>>(m, name)
        .def("__eq__", [](const py::object& a, const py::object& b) -> py::object {
            if (!py::isinstance<py::sequence>(b) || py::isinstance<py::str>(b))
                return py::reinterpret_borrow<py::object>(Py_NotImplemented);
            const py::sequence x = a, y = b;
            if (x.size() != y.size()) return py::bool_(false);
            for (std::size_t i = 0; i < x.size(); ++i)
                if (!x[i].equal(y[i])) return py::bool_(false);
            return py::bool_(true);
        })
        .def("__repr__", [](const py::object& self) { return py::repr(py::list(self)); })
        .def("__copy__", [](const std::vector<T>& v) { return std::vector<T>(v); })
        .def("__deepcopy__", [](const std::vector<T>& v, const py::object&) { return std::vector<T>(v); }, py::arg("memo"));
}

template <class T>
std::vector<T> list_of(const py::handle& v, const std::string& field, const char* type_name, std::size_t max_items) {
    auto seq = to_sequence(v, field, 0, std::string("a list of ") + type_name);
    if (seq.size() > max_items)
        throw py::value_error(field + ": " + std::to_string(seq.size()) + " items; at most " + std::to_string(max_items) +
                              " are allowed");
    std::vector<T> out;
    for (std::size_t i = 0; i < seq.size(); ++i)
        out.push_back(instance_of<T>(seq[i], field + "[" + std::to_string(i) + "]", type_name));
    return out;
}

void bind_scene(py::module_& m) {
    Struct<Material>(m, "Material", "Phong shading, mirror reflection and refraction (render.h's Material).")
        .numbers("color", &Material::color, "Base colour [r, g, b], linear")
        .number("diffuse", &Material::diffuse, "Diffuse weight")
        .number("specular", &Material::specular, "Specular weight")
        .number("shininess", &Material::shininess, "Phong exponent")
        .number("reflectivity", &Material::reflectivity, "Mirror weight (real objects)")
        .number("transparency", &Material::transparency, "Refraction weight (real objects)")
        .number("ior", &Material::ior, "Index of refraction")
        .done();
    Struct<SurfaceSpec>(m, "SurfaceSpec", "One surface F(x, y, z) = 0 in object space (render.h's SurfaceSpec).")
        .field("terms",
               [](const SurfaceSpec& s) {
                   py::tuple t(s.terms.size());
                   for (std::size_t i = 0; i < s.terms.size(); ++i)
                       t[i] = py::make_tuple(s.terms[i].ex, s.terms[i].ey, s.terms[i].ez, s.terms[i].coeff);
                   return t;
               },
               [](SurfaceSpec& s, const py::object& v, const std::string& where) {
                   auto seq = to_sequence(v, where, 0, "a list of (ex, ey, ez, coeff) terms");
                   std::vector<Term> terms;
                   for (std::size_t i = 0; i < seq.size(); ++i) {
                       const std::string at = where + "[" + std::to_string(i) + "]";
                       auto t = to_sequence(seq[i], at, 4, "(ex, ey, ez, coeff)");
                       terms.push_back({to_int(t[0], at + ".ex", 0, kMaxSurfaceDegree),
                                        to_int(t[1], at + ".ey", 0, kMaxSurfaceDegree),
                                        to_int(t[2], at + ".ez", 0, kMaxSurfaceDegree), to_number(t[3], at + ".coeff")});
                   }
                   s.terms = std::move(terms);
               },
               "The monomials: a tuple of (ex, ey, ez, coeff), exponents of x, y, z.")
        .field("degree", [](const SurfaceSpec& s) { return s.degree; },
               [](SurfaceSpec& s, const py::object& v, const std::string& where) {
                   s.degree = to_int(v, where, 1, kMaxSurfaceDegree);
               },
               "Total degree, 1..MAX_SURFACE_DEGREE (plan_frame checks every term against it).")
        .flag("complex_space", &SurfaceSpec::complex_space,
              "True: roots in the band of complex space; False: only proven real roots (a real object).")
        .number("clip_radius", &SurfaceSpec::clip_radius, "Clipping sphere about the object's origin (0: none)")
        .field("material", [](SurfaceSpec& s) -> Material& { return s.material; },
               [](SurfaceSpec& s, const py::object& v, const std::string& where) {
                   s.material = instance_of<Material>(v, where, "Material");
               },
               "The Material (changed in place: surface.material.diffuse = 0.5).", py::return_value_policy::reference_internal)
        .numbers("linear", &SurfaceSpec::linear, "Object = linear (world - translate): 9 numbers, row-major")
        .numbers("translate", &SurfaceSpec::translate, "The object's origin in the world")
        .done();
    Struct<Light>(m, "Light", "A light at infinity or a point light (render.h's Light).")
        .numbers("vector", &Light::vector, "Direction towards the light (directional) or its position")
        .flag("directional", &Light::directional, "True: vector is a direction; False: a position.")
        .numbers("color", &Light::color, "[r, g, b]")
        .number("intensity", &Light::intensity, "Intensity")
        .done();
    Struct<CameraSpec>(m, "CameraSpec", "A pinhole camera (render.h's CameraSpec).")
        .numbers("position", &CameraSpec::position, "The eye")
        .numbers("look_at", &CameraSpec::look_at, "The point at the frame's centre")
        .numbers("up", &CameraSpec::up, "Up (not parallel to look_at - position)")
        .number("fov_degrees", &CameraSpec::fov_degrees, "Vertical field of view in degrees")
        .done();
    bind_list<SurfaceSpec>(m, "SurfaceSpecList");
    bind_list<Light>(m, "LightList");
    Struct<SceneSpec>(m, "SceneSpec", "What plan_frame renders: objects, lights, background, camera (render.h's SceneSpec).")
        .field("objects", [](SceneSpec& s) -> std::vector<SurfaceSpec>& { return s.objects; },
               [](SceneSpec& s, const py::object& v, const std::string& where) {
                   s.objects = list_of<SurfaceSpec>(v, where, "SurfaceSpec", kMaxObjects);
               },
               "The surfaces (at most MAX_OBJECTS), a list held by the scene.", py::return_value_policy::reference_internal)
        .field("lights", [](SceneSpec& s) -> std::vector<Light>& { return s.lights; },
               [](SceneSpec& s, const py::object& v, const std::string& where) {
                   s.lights = list_of<Light>(v, where, "Light", 1024);
               },
               "The lights, a list held by the scene (default: render.h's default_lights()).",
               py::return_value_policy::reference_internal)
        .numbers("background", &SceneSpec::background, "[r, g, b] of a miss")
        .field("camera", [](SceneSpec& s) -> CameraSpec& { return s.camera; },
               [](SceneSpec& s, const py::object& v, const std::string& where) {
                   s.camera = instance_of<CameraSpec>(v, where, "CameraSpec");
               },
               "The CameraSpec (changed in place: scene.camera.fov_degrees = 30).", py::return_value_policy::reference_internal)
        .done();
    py::dict limits;
    for (const auto& f : kFieldLimits)
        limits[f.field] = py::make_tuple(f.bounds.lo, f.bounds.hi, f.bounds.lo_open, f.bounds.hi_open);
    m.attr("FIELD_LIMITS") = limits;
}

/// The farm's interleaved layout (the EXR's channel order): R, G, B, A,
/// then render.h's kAovs; argand.render.frames.INTERLEAVED_CHANNELS is built
/// from the same table.
constexpr int kInterleavedChannels = 4 + kAovCount;
const char* interleaved_name(int c) {
    static constexpr const char* kColour[] = {"R", "G", "B", "A"};
    return c < 4 ? kColour[c] : kAovs[c - 4].name;
}

/// The exact tier's hook around a Python callable `fn(frame, query) ->
/// dict` (argand.render.exact.decide_pixel): called from render_tile with
/// the GIL released, it takes the GIL for the call. `frame` (the objects,
/// band and caps, as plain Python data) is built once per hook and plan, on its
/// first call; the callable may cache in it. A Python exception propagates
/// out of render_tile.
struct PythonExactSolver {
    py::object fn;
    // Built lazily (under the GIL), one per plan: render_tile_bands calls
    // one hook for several bands, each with its own sigma and delta.
    std::vector<std::pair<const FramePlan*, py::object>> frames;

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
        py::object frame;
        for (const auto& [p, f] : frames)
            if (p == &plan) frame = f;
        if (!frame) {
            frame = frame_dict(plan);
            frames.emplace_back(&plan, frame);
        }
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

/// Refuses a tile [x0, x1) x [y0, y1) that is empty or not inside the W x H frame.
void check_tile_in_frame(int W, int H, int x0, int y0, int x1, int y1) {
    if (!(0 <= x0 && x0 < x1 && x1 <= W && 0 <= y0 && y0 < y1 && y1 <= H))
        throw py::value_error("tile [" + std::to_string(x0) + ", " + std::to_string(x1) + ") x [" +
                              std::to_string(y0) + ", " + std::to_string(y1) + ") is not inside the " +
                              std::to_string(W) + "x" + std::to_string(H) + " frame");
}

/// A TileView onto nine planes (render_tile_frame's layout) whose rows are
/// `stride` pixels apart, starting at pixel `at`.
template <class F, class I, class U>
TileView view_of_planes(F& rgba, F& z, F& arg, F& re, F& im, I& count, U& status, U& escalation, F& share,
                        std::ptrdiff_t stride, std::size_t at) {
    TileView v;
    v.stride = stride;
    v.rgba = rgba.mutable_data() + 4 * at;
    v.modulus = z.mutable_data() + at;
    v.argument = arg.mutable_data() + at;
    v.re = re.mutable_data() + at;
    v.im = im.mutable_data() + at;
    v.count = count.mutable_data() + at;
    v.status = status.mutable_data() + at;
    v.escalation = escalation.mutable_data() + at;
    v.certified_share = share.mutable_data() + at;
    return v;
}

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
    bind_scene(m);
    py::class_<FramePlan>(m, "FramePlan", "A frame planned once (camera, Taylor expansions); render tiles from it.")
        .def_property_readonly("width", [](const FramePlan& p) { return p.params.width; })
        .def_property_readonly("height", [](const FramePlan& p) { return p.params.height; })
        .def_property_readonly("samples", [](const FramePlan& p) { return p.params.samples; })
        .def_property_readonly("engine", [](const FramePlan& p) {
            // The engine options as planned (kernel as asked: "auto" stays "auto").
            py::dict d;
            d["kernel"] = p.params.engine.kernel == BatchIsa::Auto ? "auto" : batch_isa_name(p.params.engine.kernel);
            d["cull"] = p.params.engine.cull;
            d["real"] = p.params.engine.real;
            d["decide"] = decide_mode_name(p.params.engine.decide);
            d["shade"] = shade_mode_name(p.params.engine.shade);
            return d;
        });
    m.def(
        "plan_frame",
        [](const py::object& scene, double sigma, double delta, int width, int height, const std::string& method,
           int max_depth, bool hue_by_argument, bool seed_from_neighbour, int exact_pixels_per_block,
           int exact_max_bits, int samples, const std::string& kernel, bool cull, const std::string& decide,
           const std::string& shade, bool real) {
            const SceneSpec& spec =
                instance_of<SceneSpec>(scene, "scene", "SceneSpec (argand.render.convert.to_core_scene makes one)");
            FrameParams fp;
            fp.sigma = sigma;
            fp.delta = delta;
            fp.width = width;
            fp.height = height;
            fp.method = method_from(method);
            fp.max_depth = max_depth;
            fp.hue_by_argument = hue_by_argument;
            fp.seed_from_neighbour = seed_from_neighbour;
            fp.exact_pixels_per_block = exact_pixels_per_block;
            fp.exact_max_bits = exact_max_bits;
            fp.samples = samples;
            if (!batch_isa_from_name(kernel.c_str(), fp.engine.kernel))
                throw py::value_error("kernel " + kernel + " names no root kernel: use auto, scalar, sse2, avx2 or avx512");
            fp.engine.cull = cull;
            fp.engine.real = real;
            if (!decide_mode_from_name(decide, fp.engine.decide))
                throw py::value_error("decide " + decide + " names no decision mode: use fast, fast-scalar or full");
            if (!shade_mode_from_name(shade, fp.engine.shade))
                throw py::value_error("shade " + shade + " names no shading mode: use fast or reference");
            try {
                return plan_frame(spec, fp);
            } catch (const std::invalid_argument& e) {
                throw py::value_error(e.what());
            }
        },
        py::arg("scene"), py::arg("sigma"), py::arg("delta"), py::arg("width"), py::arg("height"),
        py::arg("method") = "auto", py::arg("max_depth") = 3, py::arg("hue_by_argument") = false,
        py::arg("seed_from_neighbour") = true, py::arg("exact_pixels_per_block") = FrameParams{}.exact_pixels_per_block,
        py::arg("exact_max_bits") = FrameParams{}.exact_max_bits, py::arg("samples") = 1, py::arg("kernel") = "auto",
        py::arg("cull") = true, py::arg("decide") = "fast", py::arg("shade") = "fast", py::arg("real") = false);
    m.def(
        "render_tile",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, const py::object& exact) {
            // The tile's arrays are made here, unset, and render_tile writes
            // every pixel of every AOV straight into them (no tile vectors
            // to fill and copy).
            const TileRect r{std::max(0, x0), std::max(0, y0), std::min(plan.params.width, x1),
                             std::min(plan.params.height, y1)};
            const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
            const std::vector<py::ssize_t> plane = {h, w}, quad = {h, w, 4};
            py::array_t<float> rgba(quad), z(plane), arg(plane), re(plane), im(plane), share(plane);
            py::array_t<std::int32_t> count(plane);
            py::array_t<std::uint8_t> status(plane), escalation(plane);
            TileView v;
            v.stride = w;
            v.rgba = rgba.mutable_data();
            v.modulus = z.mutable_data();
            v.argument = arg.mutable_data();
            v.re = re.mutable_data();
            v.im = im.mutable_data();
            v.count = count.mutable_data();
            v.status = status.mutable_data();
            v.escalation = escalation.mutable_data();
            v.certified_share = share.mutable_data();
            ExactHook hook(exact);
            {
                py::gil_scoped_release release;
                render_tile(plan, r, v, hook.get());
            }
            py::dict out;
            out["rgba"] = rgba;
            out[kAovs[0].name] = z;
            out[kAovs[1].name] = arg;
            out[kAovs[2].name] = re;
            out[kAovs[3].name] = im;
            out[kAovs[4].name] = count;
            out[kAovs[5].name] = status;
            out[kAovs[6].name] = escalation;
            out[kAovs[7].name] = share;
            out["escalations"] = v.escalations;
            out["root_calls"] = v.root_calls;
            return out;
        },
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("exact") = py::none());
    m.def(
        "render_tile_frame",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, py::array_t<float, py::array::c_style> rgba,
           py::array_t<float, py::array::c_style> z, py::array_t<float, py::array::c_style> arg,
           py::array_t<float, py::array::c_style> re, py::array_t<float, py::array::c_style> im,
           py::array_t<std::int32_t, py::array::c_style> count, py::array_t<std::uint8_t, py::array::c_style> status,
           py::array_t<std::uint8_t, py::array::c_style> escalation,
           py::array_t<float, py::array::c_style> share, const py::object& exact) {
            // render_frame's layout: the frame's own arrays, written in
            // place at the tile's pixels (no tile arrays to allocate, fill
            // and copy into the frame). The arrays are taken without
            // conversion: a converted copy would take the pixels and be
            // thrown away.
            const int W = plan.params.width, H = plan.params.height;
            check_tile_in_frame(W, H, x0, y0, x1, y1);
            auto check = [H, W](const py::array& a, const char* name, int channels) {
                const bool ok = channels == 1 ? a.ndim() == 2 && a.shape(0) == H && a.shape(1) == W
                                              : a.ndim() == 3 && a.shape(0) == H && a.shape(1) == W &&
                                                    a.shape(2) == channels;
                if (!ok)
                    throw py::value_error(std::string(name) + " must be a C-contiguous (" + std::to_string(H) + ", " +
                                          std::to_string(W) + (channels == 1 ? "" : ", 4") + ") array");
            };
            check(rgba, "rgba", 4);
            check(z, kAovs[0].name, 1);
            check(arg, kAovs[1].name, 1);
            check(re, kAovs[2].name, 1);
            check(im, kAovs[3].name, 1);
            check(count, kAovs[4].name, 1);
            check(status, kAovs[5].name, 1);
            check(escalation, kAovs[6].name, 1);
            check(share, kAovs[7].name, 1);
            TileView v = view_of_planes(rgba, z, arg, re, im, count, status, escalation, share, W,
                                        static_cast<std::size_t>(y0) * W + x0);
            ExactHook hook(exact);
            {
                py::gil_scoped_release release;
                render_tile(plan, TileRect{x0, y0, x1, y1}, v, hook.get());
            }
            const auto& st = v.by_status;
            const auto& lv = v.by_level;
            return py::make_tuple(v.escalations, v.root_calls, py::make_tuple(st[0], st[1], st[2], st[3]), v.hits,
                                  py::make_tuple(lv[0], lv[1], lv[2], lv[3], lv[4], lv[5], lv[6], lv[7]));
        },
        "Renders the tile [x0, x1) x [y0, y1) straight into the frame's arrays (rgba (H, W, 4) float32; Z, arg, re, "
        "im, certified_share (H, W) float32; count (H, W) int32; status, escalation (H, W) uint8; C-contiguous), "
        "at the tile's pixels: the values render_tile returns. Returns (escalations, root_calls, pixels per status "
        "code 0..3, pixels that hit (alpha > 0), pixels per ladder level 0..7), counted as the pixels were written.",
        py::arg("plan"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("rgba").noconvert(),
        py::arg("Z").noconvert(), py::arg("arg").noconvert(), py::arg("re").noconvert(), py::arg("im").noconvert(),
        py::arg("count").noconvert(), py::arg("status").noconvert(), py::arg("escalation").noconvert(),
        py::arg("certified_share").noconvert(), py::arg("exact") = py::none());
    m.def(
        "render_tile_bands",
        [](const std::vector<const FramePlan*>& plans, int x0, int y0, int x1, int y1, const py::list& outs, int ox,
           int oy, const py::object& exact, bool record, const py::object& field) -> py::object {
            // Several bands of one tile, its primary roots solved once
            // (render_tile_bands): band b's pixels go into outs[b], a tuple
            // of the nine planes render_tile_frame takes, at [oy.., ox..].
            if (plans.empty()) throw py::value_error("plans must hold at least one FramePlan");
            if (static_cast<std::size_t>(py::len(outs)) != plans.size())
                throw py::value_error("outs must hold one tuple of planes per plan");
            const int W = plans[0]->params.width, H = plans[0]->params.height;
            check_tile_in_frame(W, H, x0, y0, x1, y1);
            if (ox < 0) ox = x0;
            if (oy < 0) oy = y0;
            std::vector<TileView> views(plans.size());
            std::vector<py::array> keep;
            for (std::size_t b = 0; b < plans.size(); ++b) {
                if (outs[b].is_none()) continue;  // the band's figures only (a TileView without planes)
                const py::tuple planes = outs[b].cast<py::tuple>();
                if (planes.size() != 9) throw py::value_error("outs[" + std::to_string(b) + "] must hold 9 planes");
                // Plane k (the rgba plane first): of its type, C-contiguous,
                // holding the tile at (ox, oy), as wide as the rgba plane.
                std::ptrdiff_t width = -1;
                auto plane = [&](int k, const char* name, int channels, auto tag) {
                    using T = decltype(tag);
                    auto a = py::array_t<T, py::array::c_style>::ensure(planes[k]);
                    const bool typed = a && py::isinstance<py::array_t<T>>(planes[k]) &&
                                       (planes[k].cast<py::array>().flags() & py::array::c_style);
                    const bool shaped = typed && (channels == 1 ? a.ndim() == 2 : a.ndim() == 3 && a.shape(2) == channels) &&
                                        oy + (y1 - y0) <= a.shape(0) && ox + (x1 - x0) <= a.shape(1) &&
                                        (width < 0 || a.shape(1) == width);
                    if (!shaped)
                        throw py::value_error(std::string("outs[") + std::to_string(b) + "]." + name +
                                              ": a C-contiguous array of the right type, as wide as rgba, that holds "
                                              "the tile at (" + std::to_string(ox) + ", " + std::to_string(oy) + ")");
                    keep.push_back(a);
                    return a;
                };
                auto rgba = plane(0, "rgba", 4, float{});
                width = rgba.shape(1);
                auto z = plane(1, kAovs[0].name, 1, float{});
                auto arg = plane(2, kAovs[1].name, 1, float{});
                auto re = plane(3, kAovs[2].name, 1, float{});
                auto im = plane(4, kAovs[3].name, 1, float{});
                auto count = plane(5, kAovs[4].name, 1, std::int32_t{});
                auto status = plane(6, kAovs[5].name, 1, std::uint8_t{});
                auto escalation = plane(7, kAovs[6].name, 1, std::uint8_t{});
                auto share = plane(8, kAovs[7].name, 1, float{});
                views[b] = view_of_planes(rgba, z, arg, re, im, count, status, escalation, share, width,
                                          static_cast<std::size_t>(oy) * width + ox);
            }
            std::vector<TileView*> ptrs;
            for (TileView& v : views) ptrs.push_back(&v);
            ExactHook hook(exact);
            RootField recorded, replayed;
            if (!field.is_none()) {
                if (record) throw py::value_error("record a root field or replay one (field), not both");
                const py::buffer_info info = py::buffer(field).request();
                if (info.itemsize != 1 || info.ndim != 1)
                    throw py::value_error("field must be bytes (a root field render_tile_bands recorded)");
                const auto* p = static_cast<const std::uint8_t*>(info.ptr);
                replayed.bytes.assign(p, p + info.size);
            }
            try {
                py::gil_scoped_release release;
                render_tile_bands(plans, TileRect{x0, y0, x1, y1}, ptrs, hook.get(), record ? &recorded : nullptr,
                                  field.is_none() ? nullptr : &replayed);
            } catch (const std::invalid_argument& e) {
                throw py::value_error(e.what());
            }
            py::list figures;
            for (const TileView& v : views) {
                const auto& st = v.by_status;
                const auto& lv = v.by_level;
                figures.append(py::make_tuple(v.escalations, v.root_calls, py::make_tuple(st[0], st[1], st[2], st[3]),
                                              v.hits, py::make_tuple(lv[0], lv[1], lv[2], lv[3], lv[4], lv[5], lv[6], lv[7])));
            }
            if (record)
                return py::make_tuple(figures, py::bytes(reinterpret_cast<const char*>(recorded.bytes.data()),
                                                         recorded.bytes.size()));
            return std::move(figures);
        },
        "Renders the tile [x0, x1) x [y0, y1) of every band of `plans` (FramePlans of one scene and camera that "
        "differ in sigma and delta only), the primary roots solved once: band b into outs[b] (None: its figures "
        "only, no pixel written), a tuple of planes "
        "(rgba (h, w, 4) float32; Z, arg, re, im (h, w) float32; count (h, w) int32; status, escalation (h, w) "
        "uint8; certified_share (h, w) float32; C-contiguous), the tile at (ox, oy) (default (x0, y0): frame-sized "
        "planes). Each band's pixels are the bits render_tile gives for its plan alone. Returns, per band, "
        "(escalations, root_calls, pixels per status code 0..3, pixels that hit, pixels per ladder level 0..7). "
        "With record=True, returns (that list, the tile's root field as bytes); with field=bytes (a root field "
        "recorded for the same rays and tile), the primary roots are read from it instead of solved, the same bits.",
        py::arg("plans"), py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"), py::arg("outs"), py::arg("ox") = -1,
        py::arg("oy") = -1, py::arg("exact") = py::none(), py::kw_only(), py::arg("record") = false,
        py::arg("field") = py::none());
    m.def("rays_fingerprint", [](const FramePlan& plan) { return rays_fingerprint(plan); },
          "A fingerprint of the plan's rays (scene, camera, parameters; sigma and delta aside): a root field "
          "recorded for one plan replays for another only if their fingerprints agree.",
          py::arg("plan"));
    m.def(
        "render_tile_into",
        [](const FramePlan& plan, int x0, int y0, int x1, int y1, py::array_t<float, py::array::c_style> out, int ox,
           int oy, const py::object& exact) {
            // The farm's layout: the EXR's interleaved channels, written in
            // place (no per-AOV arrays to allocate and stitch in Python).
            // `out` is taken without conversion: a converted copy would take
            // the pixels and be thrown away.
            const int W = plan.params.width, H = plan.params.height;
            check_tile_in_frame(W, H, x0, y0, x1, y1);
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
                        p[11] = t.certified_share[i];
                        ++by_status[t.status[i] & 3];
                        hits += p[3] > 0.0f;
                    }
                }
            }
            return py::make_tuple(t.escalations, t.root_calls, py::make_tuple(by_status[0], by_status[1], by_status[2], by_status[3]),
                                  hits);
        },
        "Renders the tile [x0, x1) x [y0, y1) into out[oy:, ox:] as 12 interleaved float32 channels (R, G, B, A, "
        "Z, arg, re, im, count, status, escalation, certified_share: INTERLEAVED_CHANNELS, the EXR's layout). Returns (escalations, root_calls, pixels per status "
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
    m.def(
        "rebased_ray_polynomial",
        [](const FramePlan& plan, int object, std::array<double, 3> direction, double t0) {
            if (object < 0 || object >= static_cast<int>(plan.scene.objects.size()))
                throw py::value_error("object must be in 0.." + std::to_string(plan.scene.objects.size() - 1));
            const int n = plan.scene.objects[object].degree;
            py::array_t<double> c(n + 1), r(n + 1);
            rebased_ray_polynomial(plan, object, direction.data(), t0, c.mutable_data(), r.mutable_data());
            return py::make_tuple(c, r);
        },
        "The primary ray polynomial along `direction` (from the plan's eye) about the point at t0: (coeffs, radius) "
        "of q(s) = p(t0 + s), p(t) = F(eye + t direction), radius[k] bounding |exact q_k - coeffs[k]| (infinite "
        "where the expansion overflowed). The ladder's rebased level re-isolates a cluster from it.",
        py::arg("plan"), py::arg("object"), py::arg("direction"), py::arg("t0"));
    auto primary = [](const FramePlan& p, int x, int y, int sample) {
        if (x < 0 || x >= p.params.width || y < 0 || y >= p.params.height)
            throw py::value_error("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is not inside the " +
                                  std::to_string(p.params.width) + "x" + std::to_string(p.params.height) + " frame");
        if (sample < 0 || sample >= p.params.samples)
            throw py::value_error("sample must be in 0.." + std::to_string(p.params.samples - 1) + " (the plan has " +
                                  std::to_string(p.params.samples) + " samples per pixel), got " + std::to_string(sample));
        const Ray r = primary_ray(p, x, y, sample);
        return py::make_tuple(std::array<double, 3>{r.origin[0], r.origin[1], r.origin[2]},
                              std::array<double, 3>{r.direction[0], r.direction[1], r.direction[2]});
    };
    m.def("primary_ray", primary,
          "The primary ray (origin, unit direction) of sample `sample` of pixel (x, y): the exact doubles render_tile "
          "uses. Sample k sits at the centre of stratum (k % side, k // side) of the pixel's side x side grid.",
          py::arg("plan"), py::arg("x"), py::arg("y"), py::arg("sample") = 0);
    m.def(
        "explain_pixel",
        [](const FramePlan& plan, int x, int y, int row_start, int sample, const py::object& exact, int column_start) {
            PixelExplanation e;
            ExactHook hook(exact);
            try {
                e = explain_pixel(plan, x, y, row_start, sample, hook.get(), column_start);
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
                d["outside_sphere"] = p.outside_sphere;
                d["provisional"] = p.provisional;
                d["settled"] = p.settled;
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
        "Runs render_tile's code path for sample `sample` of pixel (x, y) of a tile whose rows start at column "
        "row_start and whose first row is column_start, and returns its ray, ray polynomials (with coefficient radii), discs, each decision, the status "
        "and the ladder level.",
        py::arg("plan"), py::arg("x"), py::arg("y"), py::arg("row_start"), py::arg("sample") = 0,
        py::arg("exact") = py::none(), py::arg("column_start") = 0);
    m.def("render_kernel", [](const FramePlan& plan) { return std::string(render_kernel(plan)); },
          "The root kernel of the plan's primary rays (its engine option kernel, auto resolved): 'scalar' or the "
          "batched kernel's instruction set.", py::arg("plan"));
    m.attr("MAX_OBJECTS") = kMaxObjects;
    m.attr("MAX_SURFACE_DEGREE") = kMaxSurfaceDegree;
    m.attr("MAX_FRAME_SIDE") = kMaxFrameSide;
    m.attr("MAX_SAMPLES") = kMaxSamples;
    m.attr("EXACT_BITS_LIMIT") = kMaxExactBits;
    m.attr("EXACT_PIXELS_PER_BLOCK") = FrameParams{}.exact_pixels_per_block;
    m.attr("EXACT_DEFAULT_BITS") = FrameParams{}.exact_max_bits;
    m.attr("BAND_RULE") = kBandRule;
    py::dict status_names, level_names;
    for (int c = 0; c < static_cast<int>(std::size(kStatusNames)); ++c) status_names[py::int_(c)] = kStatusNames[c];
    for (int c = 0; c < static_cast<int>(std::size(kLadderLevelNames)); ++c) level_names[py::int_(c)] = kLadderLevelNames[c];
    m.attr("STATUS_NAMES") = status_names;
    m.attr("LADDER_LEVEL_NAMES") = level_names;
    m.def("sample_side", &sample_side,
          "side for samples = side * side (1..8), else 0: the allowed sample counts are the squares up to MAX_SAMPLES.",
          py::arg("samples"));
    m.def("band_rule_holds", &band_rule_holds, "True iff (sigma, delta) satisfy BAND_RULE (decided exactly).",
          py::arg("sigma"), py::arg("delta"));
    py::list names, aovs;
    for (int c = 0; c < kInterleavedChannels; ++c) names.append(interleaved_name(c));
    for (const AovSpec& a : kAovs) aovs.append(py::make_tuple(a.name, a.dtype));
    m.attr("INTERLEAVED_CHANNELS") = py::tuple(names);
    m.attr("AOVS") = py::tuple(aovs);
}
