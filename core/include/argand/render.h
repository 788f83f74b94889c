// render.h: ray casting algebraic surfaces in complex space (the paper's
// section 3), one tile of one frame at a time.
//
// A frame is (scene, sigma, delta). For each pixel the ray o + t d (|d| = 1,
// so |t| is a distance) turns each surface F into p(t) = F(o + t d), a real
// polynomial of the surface's degree; the verified core gives its roots. A
// root t = rho e^{i theta} is eligible when theta lies in the band
// [sigma, sigma + delta] or its conjugate [-sigma - delta, -sigma]; the pixel
// shows the eligible root of least modulus.
//
// Setup once per frame (plan_frame): the camera basis and, per object, the
// Taylor expansion G(v) = F(o' + v) of the surface at the camera origin o'
// in object space, so a pixel's coefficients cost O(number of terms):
// p_k = sum_{|a| = k} G_a d'^a.
#pragma once

#include <cstdint>
#include <vector>

#include "argand/roots.h"

namespace argand {

struct Term {
    int ex, ey, ez;   // exponents of x, y, z
    double coeff;
};

struct Material {
    double color[3] = {0.85, 0.55, 0.25};
    double diffuse = 0.8;
    double specular = 0.3;
    double shininess = 32.0;
    double reflectivity = 0.0;
    double transparency = 0.0;
    double ior = 1.5;
};

struct SurfaceSpec {
    std::vector<Term> terms;
    int degree = 0;
    bool complex_space = true;   // false: only proven real roots (a "real" object)
    double clip_radius = 0.0;    // <= 0: no clipping sphere (object space, centred at 0)
    Material material;
    // Object space = linear * (world - translate).
    double linear[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double translate[3] = {0, 0, 0};
};

struct Light {
    double vector[3] = {1, 1, 1};  // direction towards the light, or a position
    bool directional = true;
    double color[3] = {1, 1, 1};
    double intensity = 1.0;
};

struct CameraSpec {
    double position[3] = {10, 8, 6};
    double look_at[3] = {0, 0, 0};
    double up[3] = {0, 0, 1};
    double fov_degrees = 40.0;
};

struct SceneSpec {
    std::vector<SurfaceSpec> objects;
    std::vector<Light> lights;
    double background[3] = {0.08, 0.08, 0.1};
    CameraSpec camera;
};

struct FrameParams {
    double sigma = 0.0;
    double delta = 0.0;
    int width = 256;
    int height = 256;
    Method method = Method::Auto;
    int max_depth = 3;           // reflection / refraction bounces
    bool hue_by_argument = false;
    bool seed_from_neighbour = true;
};

struct TileRect {
    int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
};

/// Pixel status (the `status` AOV).
enum PixelStatus : std::uint8_t {
    kCertified = 0,   // the chosen root is proven in the band and proven the smallest
                      // (for a miss: every root proven outside the band or clipped)
    kCluster = 1,     // chosen among a cluster (a disc holding several roots)
    kUnverified = 2,  // chosen root (or a root that might be eligible) unverified
    kUndecided = 3,   // band membership or the ordering by modulus undecided
};

/// AOVs of one tile, row-major, (y1 - y0) rows of (x1 - x0) pixels.
struct TileAOVs {
    int width = 0, height = 0;
    std::vector<float> rgba;      // 4 per pixel, linear colour; A = 1 on a hit, 0 on a miss
                                  // (misses carry the background colour, not premultiplied)
    std::vector<float> modulus;   // Z: |t| of the chosen root (inf on a miss)
    std::vector<float> argument;  // arg t of the chosen root (0 on a miss)
    std::vector<float> re, im;    // the chosen root
    std::vector<std::int32_t> count;   // eligible roots in the band (with multiplicity)
    std::vector<std::uint8_t> status;  // PixelStatus
    // Figures.
    std::int64_t escalations = 0;      // pixels whose roots needed double-double or more
    std::int64_t root_calls = 0;
};

/// Everything a frame needs that does not depend on the pixel.
struct FramePlan {
    SceneSpec scene;
    FrameParams params;
    double eye[3];
    double forward[3], right[3], up[3];
    double tan_half_fov;
    double scene_distance;  // camera to look_at, the scale of the depth cue
    struct ObjectPlan {
        // Taylor coefficients of F(o' + v) as dense monomials up to degree n,
        // grouped by total degree: for k, the monomials (a, b, c) with
        // a + b + c = k and their coefficients.
        std::vector<int> k_begin;          // size n + 2
        std::vector<int> ex, ey, ez;
        std::vector<double> g;
        double origin[3];                  // o' (object space camera origin)
    };
    std::vector<ObjectPlan> objects;
};

/// Validates the scene for rendering (degree 1..kMaxDegree per object, at
/// least one object, finite numbers). Throws std::invalid_argument with the
/// reason.
FramePlan plan_frame(const SceneSpec& scene, const FrameParams& params);

/// Renders the pixels of `rect` (clamped to the frame). Thread-safe for
/// distinct tiles of the same plan. Never touches Python.
void render_tile(const FramePlan& plan, const TileRect& rect, TileAOVs& out);

/// The ray polynomial p(t) = F(o + t d) of object i for a world ray (exposed
/// for tests and the reference renderer). coeffs gets degree + 1 entries.
void ray_polynomial(const FramePlan& plan, int object, const double origin[3], const double direction[3],
                    double* coeffs);

}  // namespace argand
