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

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "argand/interval.h"
#include "argand/roots.h"
#include "argand/roots_batch.h"

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

/// The lights of a scene that names none: a warm key light and a cool fill.
inline std::vector<Light> default_lights() {
    return {Light{{0.6, 0.4, 1.0}, true, {1.0, 0.97, 0.92}, 0.9}, Light{{-0.8, 0.3, 0.2}, true, {0.55, 0.65, 1.0}, 0.35}};
}

struct CameraSpec {
    double position[3] = {10, 8, 6};
    double look_at[3] = {0, 0, 0};
    double up[3] = {0, 0, 1};
    double fov_degrees = 40.0;
};

// The default member initialisers of Material, SurfaceSpec, Light,
// CameraSpec and SceneSpec are the scene defaults: the binding exports them
// and argand.scene's model reads its defaults from there.
struct SceneSpec {
    std::vector<SurfaceSpec> objects;
    std::vector<Light> lights = default_lights();
    double background[3] = {0.08, 0.08, 0.1};
    CameraSpec camera;
};

/// How a pixel is decided: Fast (the quick predicates, decide_fast, with
/// the widest classify_discs this CPU runs), FastScalar (the same
/// predicates in scalar code), Full (decide_full for every pixel: the
/// reference the others are tested against).
enum class DecideMode : int { Fast = 0, FastScalar = 1, Full = 2 };
/// How a root is shaded: Fast (the tabled gradient and the fast paths) or
/// Reference (the plain per-pixel code: gradient(), std::pow, std::exp,
/// std::atan2 always). Both give the same bits.
enum class ShadeMode : int { Fast = 0, Reference = 1 };

/// The engine's modes, carried with a frame's parameters and checked by
/// plan_frame; nothing in the library reads them from anywhere else. Every
/// combination gives the same decisions (status and hit of every pixel);
/// the alternatives to the defaults are references for tests and
/// benchmarks.
struct EngineOptions {
    /// Root kernel of the primary rays: Auto (the widest batched kernel this
    /// CPU runs), Generic (sse2), Avx2, Avx512, or Scalar (find_roots sample
    /// by sample with the neighbour seeds: the reference). plan_frame
    /// refuses an instruction set this CPU does not run.
    BatchIsa kernel = BatchIsa::Auto;
    /// A ray that provably misses an object's clipping sphere skips that
    /// object's roots (detail::ray_misses_sphere); false: every ray solved
    /// and decided disc by disc (the reference).
    bool cull = true;
    /// The objects that need only real roots (every object when sigma =
    /// delta = 0; an object with space: real always) isolate the real roots
    /// in the ray's segment inside the clipping sphere (roots_real.h) instead
    /// of every complex root, where that proves the pixel; false: every
    /// root, always. Not used while a root field is recorded or replayed (a
    /// field holds every root). Off by default: in scalar code it is still
    /// slower than the batched complex kernel (docs/performance.md).
    bool real = false;
    DecideMode decide = DecideMode::Fast;
    ShadeMode shade = ShadeMode::Fast;
};

/// Names of the modes (the frame's metadata and the Python options use them).
const char* decide_mode_name(DecideMode mode);
const char* shade_mode_name(ShadeMode mode);
/// Parse those names; false for anything else.
bool decide_mode_from_name(const std::string& name, DecideMode& out);
bool shade_mode_from_name(const std::string& name, ShadeMode& out);

/// The side, in samples, of the frame-aligned blocks the neighbour seeds
/// flow in (see FrameParams::seed_from_neighbour).
constexpr int kSeedBlock = 8;

struct FrameParams {
    double sigma = 0.0;
    double delta = 0.0;
    int width = 256;
    int height = 256;
    Method method = Method::Auto;
    int max_depth = 3;           // reflection / refraction bounces
    bool hue_by_argument = false;
    // Neighbour seeds flow within blocks of kSeedBlock x kSeedBlock samples
    // aligned on the frame's grid of samples (and within a tile): every row
    // and column of samples that is a multiple of kSeedBlock starts
    // unseeded, so a frame cut into tiles whose sides are multiples of
    // kSeedBlock is the same bits whatever the tile size (and a frame of k x k
    // samples per pixel has the seeds of the frame k times its size).
    bool seed_from_neighbour = true;
    int samples = 1;             // per pixel: a square (1, 4, 9, ..., kMaxSamples), see sample_side
    // The exact tier (ladder level 5, an ExactSolver given to render_tile):
    // at most this many samples of each block of kSeedBlock x kSeedBlock
    // samples go to it (0: off; the first ones, in tracing order), and it
    // works up to this many bits of precision. A budget per frame-aligned
    // block, not per tile: a block lies inside one tile (tiles are
    // kSeedBlock pixels multiples) and its samples are traced in the same
    // order whatever the tiling or thread, so which rays get the tier does
    // not depend on them. 8: a singular line through a block is served
    // whole, and at most an eighth of a frame's rays cost an exact solve.
    int exact_pixels_per_block = 8;
    int exact_max_bits = 2048;
    EngineOptions engine;
};

/// Most samples per pixel (plan_frame refuses more).
constexpr int kMaxSamples = 64;
/// Samples per pixel form a side x side grid of strata; a pixel's sample k
/// (0 <= k < samples) sits at the centre of stratum (k % side, k / side), so
/// the samples of a W x H frame are exactly the pixel centres of the
/// (side W) x (side H) frame. Returns side, or 0 when `samples` is not the
/// square of 1..8 (the allowed values).
int sample_side(int samples);

/// Most objects in one scene (plan_frame refuses more).
constexpr int kMaxObjects = 32;
/// Highest total degree of a surface (plan_frame refuses more). The root
/// core goes to kMaxDegree; a surface's degree is kept lower because the
/// Taylor plan and the per-pixel work grow with its number of monomials
/// ((n + 1)(n + 2)(n + 3) / 6: 455 at degree 12).
constexpr int kMaxSurfaceDegree = 12;
/// Highest working precision of the exact tier, in bits (plan_frame refuses more).
constexpr int kMaxExactBits = 1 << 16;
/// Largest frame side in pixels (plan_frame refuses more).
constexpr int kMaxFrameSide = 8192;

/// The band rule, checked by plan_frame: the band [sigma, sigma + delta]
/// (and its conjugate) lies in [0, pi]. The sum is the exact sum of the two
/// doubles and pi the exact pi.
constexpr const char* kBandRule = "sigma >= 0, delta >= 0 and sigma + delta <= pi";
/// True iff (sigma, delta) satisfy kBandRule (finite, decided exactly).
bool band_rule_holds(double sigma, double delta);

struct TileRect {
    int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
};

/// Pixel status (the `status` AOV). Codes are ordered: the higher, the less
/// was proven; a pixel of several samples has the highest code of its
/// samples (its status never claims more than every sample proved).
/// All decisions are about the exact ray polynomial of the pixel's ray (exact
/// double origin and direction) through the surface with its exact double
/// coefficients; docs/rendering.md says what that covers.
enum PixelStatus : std::uint8_t {
    kCertified = 0,   // proven: the chosen root is in the band, inside the clipping
                      // sphere, of one root, and the smallest such (up to its
                      // conjugate); for a miss: every root proven out of the band
                      // or clipped
    kCluster = 1,     // the deciding disc holds several roots that no tier of the
                      // ladder separated (a tangent ray, a singular point), or the
                      // ray lies in the surface
    kUnverified = 2,  // some root of the ray polynomial is not enclosed (root core
                      // gave an unverified entry) or a coefficient overflowed
    kUndecided = 3,   // band, clipping or ordering undecided after the whole ladder:
                      // a band edge, the sphere or another root's modulus lies
                      // within the final discs
};

/// The names of the statuses, by code (exported to Python as STATUS_NAMES).
constexpr const char* kStatusNames[] = {"certified", "cluster", "unverified", "undecided"};

/// Ladder levels (the `escalation` AOV): how far a pixel had to go.
enum LadderLevel : std::uint8_t {
    kLevelFirst = 0,      // decided from the first root discs
    kLevelRootTier = 1,   // the root core needed its double-double tier
    kLevelUnseeded = 2,   // retried without the neighbouring pixel's seeds
    kLevelRebased = 3,    // a cluster re-isolated in double from the ray polynomial
                          // expanded about a point near it (rebased_ray_polynomial)
    kLevelDoubleDouble = 4,  // discs refined with double-double ray coefficients
    kLevelExact = 5,         // decided by the exact tier (ExactSolver) on the exact
                             // rational ray polynomial; status 3 after it: its
                             // precision cap was reached
    kLevelExactMultiple = 6, // the exact tier proved a multiple root at the pixel's
                             // root (or the ray in the surface): status 1, proven
    kLevelExactOverCap = 7,  // not proven after level 4, and the block's exact-tier
                             // budget (exact_pixels_per_block) was spent
};
/// The names of the ladder levels, by level (exported as LADDER_LEVEL_NAMES).
constexpr const char* kLadderLevelNames[] = {"first",          "root double-double",          "unseeded retry",
                                             "rebased ray",    "double-double ray", "exact",
                                             "exact: multiple root proven", "exact: over the work cap"};

/// AOVs of one tile, row-major, (y1 - y0) rows of (x1 - x0) pixels.
/// With several samples per pixel: the colour is the mean of the samples'
/// colours and A the share of samples that hit; the status is the worst
/// (highest code) and the escalation the highest level of the samples;
/// Z, arg, re, im and count describe one sample, the shown sample: the
/// hitting sample of least |t| (the first such), or the first sample when
/// none hits (docs/rendering.md).
/// The AOVs a frame carries besides its colour (R, G, B, A), in the EXR's
/// channel order: the one table of them. The bindings export it as
/// _core.AOVS ((name, NumPy dtype) pairs) and name their planes from it;
/// argand.render.frames builds its planes, dtypes and the EXR's channels
/// from _core.AOVS. TileAOVs and TileView hold them in this order (Z is
/// `modulus`, arg `argument`).
struct AovSpec {
    const char* name;
    const char* dtype;
};
inline constexpr AovSpec kAovs[] = {{"Z", "float32"},     {"arg", "float32"},    {"re", "float32"},
                                    {"im", "float32"},    {"count", "int32"},    {"status", "uint8"},
                                    {"escalation", "uint8"}, {"certified_share", "float32"}};
inline constexpr int kAovCount = static_cast<int>(sizeof(kAovs) / sizeof(kAovs[0]));

struct TileAOVs {
    int width = 0, height = 0;
    std::vector<float> rgba;      // 4 per pixel, linear colour; A = 1 on a hit, 0 on a miss
                                  // (misses carry the background colour, not premultiplied)
    std::vector<float> modulus;   // Z: |t| of the chosen root (inf on a miss)
    std::vector<float> argument;  // arg t of the chosen root (0 on a miss)
    std::vector<float> re, im;    // the chosen root
    std::vector<std::int32_t> count;   // eligible roots in the band (with multiplicity)
    std::vector<std::uint8_t> status;  // PixelStatus
    std::vector<std::uint8_t> escalation;  // LadderLevel
    std::vector<float> certified_share;  // share of the pixel's samples that are certified
    // Figures.
    std::int64_t escalations = 0;      // pixels whose ladder level is above 0
    std::int64_t root_calls = 0;
};

/// Where render_tile writes a tile's AOVs (TileAOVs's meaning, pixel by
/// pixel): each plane's pixel (x, y) of the tile (0-based, y < height,
/// x < width) at [y * stride + x] (rgba: 4 floats from 4 * (y * stride +
/// x)). stride >= width: a tile inside a frame's planes is their pixel
/// (x0, y0) with stride the frame's width, so render_tile writes straight
/// into the frame (no tile arrays to allocate, fill and copy). Every pixel
/// of the tile is written, every AOV (a miss included).
/// (A view whose rgba is null holds no planes: the renderer counts its
/// figures and writes no pixel, for a caller that needs a band's figures
/// only, such as the farm's tiles whose frames are decided again on request.)
struct TileView {
    int width = 0, height = 0;
    std::ptrdiff_t stride = 0;  // pixels per row of every plane
    float* rgba = nullptr;
    float* modulus = nullptr;
    float* argument = nullptr;
    float* re = nullptr;
    float* im = nullptr;
    std::int32_t* count = nullptr;
    std::uint8_t* status = nullptr;
    std::uint8_t* escalation = nullptr;
    float* certified_share = nullptr;
    // Figures (TileAOVs's).
    std::int64_t escalations = 0;
    std::int64_t root_calls = 0;
    // Counted as the pixels are written (render_frame's and the farm's
    // figures, without a pass over the AOVs): pixels per status code, per
    // ladder level, and pixels whose alpha is above 0 (some sample hit).
    std::int64_t by_status[4] = {0, 0, 0, 0};
    std::int64_t by_level[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    std::int64_t hits = 0;
};

/// A ray: exact double origin and (unit, up to rounding) direction.
struct Ray {
    double origin[3];
    double direction[3];
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
        // a + b + c = k. Each coefficient is a ball: the exact coefficient
        // of F(o' + v) at the exact o' = linear (eye - translate) lies in
        // [g - g_rad, g + g_rad] (and in [g_dd - g_dd_rad, g_dd + g_dd_rad]).
        std::vector<int> k_begin;          // size n + 2
        std::vector<int> ex, ey, ez;
        std::vector<double> g, g_rad;
        std::vector<DoubleDouble> g_dd;
        std::vector<double> g_dd_rad;
        // Per total degree k: the factors of the per-pixel error bound
        // (ray_polynomial.cpp), in double and in double-double.
        std::vector<double> weight_factor, radius_factor, weight_factor_dd, radius_factor_dd;
        // Per k: max over the monomials of |g| + g_rad, for the underflow slack.
        std::vector<double> magnitude;
        // Nonzero |direction'| components at least this large keep every
        // nonzero product above 2^-1000 (no underflow: no slack needed).
        double no_underflow_threshold = 0.0;
        // linear is a signed permutation (entries 0 and +-1): the object-space
        // direction is exact.
        bool direction_exact = false;
        Ball origin[3];                    // o' (object space camera origin), enclosed
        BallDD origin_dd[3];
    };
    std::vector<ObjectPlan> objects;
    // The band's edges (sigma and the exact sum sigma + delta), with
    // enclosures of their cosine and sine (pixel_decision.cpp).
    struct BandEdge {
        double cos_mid, sin_mid, err;  // |cos - cos_mid|, |sin - sin_mid| <= err
    };
    BandEdge lower_edge, upper_edge;
};

/// The exact tier: a pixel whose primary ray is not proven after level 4 is
/// decided on the exact rational ray polynomial of its ray (the exact double
/// origin and direction, the exact double coefficients and transform) by a
/// solver outside the C++ core (the Python binding wraps
/// argand.render.exact). The solver's answer is a proof where `decided` is
/// true: status 0 (hit on the given root, or a miss), or status 1 with a
/// proven multiple root at the pixel's root (or the ray in the surface).
/// `decided` false: its precision cap left a comparison open (`status` 3,
/// `reason` says which); render_tile then keeps its own picture.
struct ExactQuery {
    int x, y;
    Ray ray;
    bool explain;            // fill ExactAnswer::steps
};
struct ExactAnswer {
    bool decided = false;
    std::uint8_t status = kUndecided;
    bool multiple = false;   // the answer rests on a proven multiple root
    bool hit = false;
    int object = -1;
    double re = 0.0, im = 0.0, modulus = 0.0;  // the chosen root (nearest doubles)
    int eligible = 0;        // eligible roots with multiplicity
    std::string reason;
    std::vector<std::string> steps;  // what it did (explain only)
};
using ExactSolver = std::function<ExactAnswer(const FramePlan&, const ExactQuery&)>;

/// Validates the scene and the frame for rendering (1..kMaxObjects objects,
/// degree 1..kMaxSurfaceDegree per object, frame sides 1..kMaxFrameSide, kBandRule, a valid camera). Throws
/// std::invalid_argument with the reason.
FramePlan plan_frame(const SceneSpec& scene, const FrameParams& params);

/// Renders the pixels of `rect` (clamped to the frame). Thread-safe for
/// distinct tiles of the same plan. Never touches Python itself; `exact`
/// (optional) is called for primary rays still unproven after level 4, at
/// most params.exact_pixels_per_block times per block of kSeedBlock x
/// kSeedBlock samples.
void render_tile(const FramePlan& plan, const TileRect& rect, TileAOVs& out, const ExactSolver* exact = nullptr);
/// The same pixels into `out`'s planes (the bits render_tile into a
/// TileAOVs gives): out's pointers are the tile's pixel (0, 0), of the
/// clamped rect (x0, y0); width and height are set here from the clamped
/// rect, and the figures (escalations, root_calls) too. The planes must
/// hold the tile's rows at out.stride pixels apart (stride >= the clamped
/// width).
void render_tile(const FramePlan& plan, const TileRect& rect, TileView& out, const ExactSolver* exact = nullptr);

/// The root field of one tile (render_tile_bands' record and replay): the
/// primary rays' roots of its samples as the batched kernel solved them,
/// run by run, per batched object (status, discs with their counts and
/// proofs, the lane approximations of a provisional cell), after a header
/// naming the rays (rays_fingerprint) and the tile. Objects the batch does
/// not solve (degree above the kernel's, method "paper", the scalar kernel)
/// hold nothing and are solved per band as before.
struct RootField {
    std::vector<std::uint8_t> bytes;
};

/// True iff two plans trace the same rays and solve the same polynomials:
/// the same scene (objects, their terms and places, lights, background),
/// camera and parameters, sigma and delta aside.
bool same_rays(const FramePlan& a, const FramePlan& b);

/// Renders tile `rect` of several bands at once: plans[b] (all same_rays
/// with plans[0], else std::invalid_argument) into outs[b]. The primary
/// rays' roots are solved once for all bands; each band is then decided,
/// escalated and shaded on its own, so outs[b] holds exactly the bits
/// render_tile(*plans[b], rect, *outs[b], exact) writes (the single-band
/// render_tile is this function with one band).
///
/// A tile's root field: with `record`, the primary roots the tile's samples
/// were solved to are kept in *record (its bytes replaced); with `replay`
/// (a field recorded for the same rays and tile), they are read from it
/// instead of solved. Either way every band's pixels are the bits
/// render_tile gives: a field replays the very answers of the solve that
/// recorded it, and everything else (polynomials, clip tests, decisions,
/// the ladder, shading) is computed as without one. Throws
/// std::invalid_argument for a field of other rays or another tile (its
/// header), or one cut short or damaged.
void render_tile_bands(const std::vector<const FramePlan*>& plans, const TileRect& rect,
                       const std::vector<TileView*>& outs, const ExactSolver* exact = nullptr,
                       RootField* record = nullptr, const RootField* replay = nullptr);

/// A fingerprint of everything same_rays compares (sigma and delta aside):
/// plans whose fingerprints differ do not trace the same rays.
std::uint64_t rays_fingerprint(const FramePlan& plan);

/// The primary ray of sample `sample` (0..samples - 1) of pixel (x, y):
/// the very doubles render_tile uses.
Ray primary_ray(const FramePlan& plan, int x, int y, int sample = 0);

/// The root kernel render_tile and explain_pixel use for the plan's primary
/// rays (plan.params.engine.kernel, Auto resolved): "avx512", "avx2" or
/// "sse2", a batched kernel (each run of 32 samples of a row of samples is
/// solved together by find_roots_rows, per object of degree <= 8, method
/// other than "paper"); "scalar", find_roots sample by sample with the
/// neighbour's roots as seeds (the reference). Both prove the same
/// decisions (docs/rendering.md).
const char* render_kernel(const FramePlan& plan);

/// The ray polynomial p(t) = F(o + t d) of object i for a world ray (exposed
/// for tests and the reference renderer): coeffs gets degree + 1 entries and,
/// when radius is given, radius[k] bounds |exact p_k - coeffs[k]|.
void ray_polynomial(const FramePlan& plan, int object, const double origin[3], const double direction[3],
                    double* coeffs, double* radius = nullptr);
/// The primary ray polynomial along `direction` (from the plan's eye)
/// about the point at t0: q(s) = p(t0 + s), where p(t) = F(eye + t d), and
/// radius[k] bounds |exact q_k - coeffs[k]| (the ladder's rebased level).
void rebased_ray_polynomial(const FramePlan& plan, int object, const double direction[3], double t0, double* coeffs,
                            double* radius);

/// Everything render_tile decided for one pixel (`argand render --explain`).
struct ExplainedDisc {
    int object;
    RootDisc disc;           // the final disc (after any refinement)
    double modulus_lo, modulus_hi;
    bool real;               // its single root proven real
    bool at_origin;          // the exact root t = 0 (not shown)
    std::uint8_t band;       // 0 yes, 1 no, 2 unknown (all roots in the band?)
    std::uint8_t clip;       // 0 inside, 1 outside, 2 straddling (no sphere: 0), 3 not
                             // evaluated (the disc is out of the band)
    bool live;               // may be the pixel's root
    bool eligible;           // proven in the band and inside
};
struct ExplainedPolynomial {
    int object;
    std::vector<double> coeffs, radius;  // the ray polynomial and its coefficient radii
    int roots_status;        // argand::Status of find_roots
    bool seeded;             // started from the neighbouring pixel's roots
    int root_escalation;     // the root core's own tier (0 double, 1 double-double)
    bool complete;           // every disc verified (they cover every root)
    bool outside_sphere = false;  // the ray provably misses the clipping sphere: not solved, no disc
    bool provisional = false;     // the batch lane's discs merged into clusters (SoaRows::provisional)
    bool settled = false;         // the lane's merged discs did not decide: the row solved again
};
struct PixelExplanation {
    Ray ray;
    std::vector<ExplainedPolynomial> polynomials;
    std::vector<ExplainedDisc> discs;
    int chosen = -1;         // index into discs of the pixel's root, -1 for a miss
    bool hit = false;
    std::uint8_t status = kCertified;
    std::uint8_t level = kLevelFirst;
    std::string reason;      // why the status is what it is
    bool exact_ran = false;  // the exact tier ran for this pixel
    ExactAnswer exact;       // its answer (with its steps)
    double root_re = 0.0, root_im = 0.0;  // the pixel's root (on a hit)
};

/// Runs render_tile's code path for sample `sample` of pixel (x, y), as part
/// of a tile whose rows start at column row_start and whose first row is
/// column_start (the neighbour seeds of that row of samples, and the batched
/// kernel's seeds from the samples above, are replayed from there or from
/// the start of the pixel's seed block, whichever is later), and records every
/// decision. The exact tier (when given) runs for that sample only, whatever
/// the tile's budget.
PixelExplanation explain_pixel(const FramePlan& plan, int x, int y, int row_start, int sample = 0,
                               const ExactSolver* exact = nullptr, int column_start = 0);

}  // namespace argand
