// render/tracer.h: the Tracer, which follows one band's rays through the
// pipeline: the roots of each object along a ray (solve.h), the pixel's
// decision (decide.h), the escalation ladder while it is not proven
// (ladder.cpp) and the shading of the root it shows (shade.h). One per band
// and thread, reused from sample to sample (its scratch, counters and the
// tile's exact-tier budget). Internal header.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "argand/render.h"
#include "../polish.h"
#include "decide.h"
#include "shade.h"
#include "solve.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// A sample's polished root, kept for the other bands of the sample
/// (render_tile_bands): a band whose certified hit is the same disc of the
/// same object, polished the same way (on the real line or off it), takes
/// it instead of polishing again: the same bits, since polishing reads
/// only the disc, the ray and its coefficients.
struct PolishMemo {
    bool valid = false;
    bool real = false;
    int object = -1;
    RootDisc disc{};
    double re = 0, im = 0, modulus = 0;
    bool same(const HitInfo& h, bool real_hit) const {
        return valid && real == real_hit && object == h.object && std::memcmp(&disc, &h.disc, sizeof disc) == 0;
    }
};

class Tracer {
public:
    explicit Tracer(const FramePlan& plan, const ExactSolver* exact = nullptr, bool cull = true);

    std::int64_t root_calls = 0;

    /// Intersects a ray with every object and decides the pixel's root,
    /// climbing the ladder while the decision is not proven. `primary`: the
    /// ray is a primary ray (the plan's eye, the Taylor plan). `trace`
    /// (optional) receives every decision.
    /// `pre` (primary rays only): the sample's roots, solved in a batch, for
    /// the objects the batch covers.
    /// `filled` (with pre): intersect_batched has put the batch's roots in
    /// the depth-0 slots already and decide_fast did not certify them: they
    /// are not filled again, and decided in full straight away.
    HitInfo intersect(const double* o, const double* d, bool primary, Seeds* seeds, int depth, PixelExplanation* trace,
                      const BatchedCell* pre = nullptr, bool filled = false);

    /// intersect for a primary ray whose objects the batch solved, every
    /// one of them (pre), in the common case: decide_fast certifies the
    /// pixel. Then it does what intersect does for that ray (the batch's
    /// roots into the depth-0 slots, the level, decide's result, the root
    /// calls counted) without the rest of the ladder, and returns true with
    /// h (default-constructed by the caller) exactly intersect's result.
    /// Otherwise false (nothing counted, h unspecified), with `filled` true
    /// when the slots hold the batch's roots (decide_fast ran and did not
    /// certify): the caller runs intersect with that, which decides them in
    /// full without filling them again.
    /// `values` false (a band whose pixels are not written, whose hits
    /// bounce no ray): the hit's root is not polished (its value only feeds
    /// the AOVs and the colour; the decision and every figure stay).
    /// `dir`: the sample's world direction (polish's). `memo` (optional):
    /// the sample's polished root, shared with the tile's other bands.
    bool intersect_batched(const BatchedCell& pre, HitInfo& h, bool& filled, bool values, const double* dir,
                           PolishMemo* memo = nullptr) {
        filled = false;
        if (decider_.full_only()) return false;
        const int n_obj = static_cast<int>(plan_.scene.objects.size());
        ObjectRoots* roots = scratch_.data();  // (depth 0's slots)
        std::uint8_t level = kLevelFirst;
        decider_.recording = false;
        int calls = 0;
        for (int obj = 0; obj < n_obj; ++obj) {
            ObjectRoots& r = roots[obj];
            pre.batch->fill(obj, pre.cell, r, false);
            r.have_dd = false;
            calls += !r.outside_sphere;
            if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
        }
        // (decide_fast, for one object straight to its decide_one.)
        filled = true;
        if (!(n_obj == 1 ? decider_.decide_one(roots, h) : decider_.decide_fast(roots, h))) return false;
        root_calls += calls;
        if (values && h.hit) {
            const bool real = proven_real_hit(h);
            if (memo != nullptr && memo->same(h, real)) {  // (another band's, for this disc: the same bits)
                h.disc.re = memo->re;
                h.disc.im = memo->im;
                h.modulus = memo->modulus;
            } else {
                const RootDisc before = h.disc;
                const int object = h.object;
                show_root(
                    h, [&](double* c, double* r) { pre.batch->coefficients(object, pre.cell, c, r); },
                    plan_.scene.objects[object].degree, real, dir);
                if (memo != nullptr) {
                    memo->valid = true;
                    memo->real = real;
                    memo->object = h.object;
                    memo->disc = before;
                    memo->re = h.disc.re;
                    memo->im = h.disc.im;
                    memo->modulus = h.modulus;
                }
            }
        }
        upper_half(h);
        h.level = level;
        return true;
    }

    /// intersect_batched for a band counted, not written (no planes), whose
    /// hits bounce no ray, in a scene of one object the batch solved:
    /// decide_one on the sample's roots `r` (PrimaryBatch::fill'ed once for
    /// every such band of the sample: fill reads no band). True where
    /// intersect_batched returns true, with whether it hits (`hit`); false
    /// where it returns false: the caller takes that path. The caller
    /// counts what intersect_batched's answer adds to the figures: its root
    /// call (!r.outside_sphere) and its level (counted_level).
    bool decide_counted(const ObjectRoots& r, bool& hit) const {
        if (decider_.full_only()) return false;
        int best, eligible;
        const bool decided = decider_.decide_one_verdict(&r, best, eligible);
        hit = best >= 0;
        return decided;
    }
    /// decide_counted of roots Decider::keyable, `key` their band verdicts
    /// under this band (detail::band_keys_four of counted_plan()); `shared`:
    /// the answer is every band's with these verdicts (decide_one_keyed).
    bool decide_counted_keyed(const ObjectRoots& r, std::uint16_t key, bool& hit, bool& shared) const {
        shared = false;
        return !decider_.full_only() && decider_.decide_one_keyed(&r, key, hit, shared);
    }
    bool counted_keyable(const ObjectRoots& r) const { return decider_.keyable(r); }
    const detail::ClassifyPlan* counted_plan() const { return decider_.object_plan(); }
    /// The ladder level of a sample decide_counted decided.
    static std::uint8_t counted_level(const ObjectRoots& r) {
        return r.res.escalation > 0 ? kLevelRootTier : kLevelFirst;
    }

    /// A hit shows its root with im >= 0: the ray polynomial is real, so
    /// the conjugate of a root is a root of the same modulus, and the band
    /// (|arg| in [sigma, sigma + delta]) holds both. Which of the two the
    /// solver listed first depends on its seeds and kernel; the value
    /// written does not. (Shading is the same for both, bit for bit: the
    /// normal is the real part of the gradient at o + t d, the hit point at
    /// |t|, and every operation on the conjugate is exactly mirrored.)
    static void upper_half(HitInfo& h) {
        if (h.hit && h.disc.im < 0.0) h.disc.im = -h.disc.im;
    }

    /// The value a hit shows, in the AOVs (Z, re, im, arg) and in its
    /// colour (shaded at it): its root rounded to float32, the AOVs'
    /// precision, the same bits whatever kernel, seeds, tiling or
    /// escalation proved its disc. The disc's one root by canonical_root
    /// (Newton's iteration in double from a start that does not depend on
    /// the disc's centre); where the coefficients' radii may move that root
    /// by more than a float32 shows (polish_ill_conditioned, at that root),
    /// a primary ray's root (`dir`: its world direction) is polished again
    /// with F evaluated at the point along the ray (polish_root_at_point),
    /// from there. Where canonical_root does not settle: a wide disc's root
    /// polished as before (polish), else the disc's centre. The disc's
    /// proof and every decision stay.
    /// `coefficients(c, r)` fills the ray polynomial's coefficients and
    /// radii (n + 1 each): called only where the disc does not settle the
    /// value by itself (the common case needs none).
    template <class Coefficients>
    void show_root(HitInfo& h, Coefficients&& coefficients, int n, bool real, const double* dir) {
        // (The proven disc, on the upper half-plane: the conjugate of a
        // root is a root, and upper_half shows that one anyway.)
        RootDisc disc = h.disc;
        if (!real && !disc.real && disc.im < 0.0) disc.im = -disc.im;
        // (A disc whose every point rounds to one float32, in re and in im,
        // holds a root that rounds to it: canonical_root's too, which lies
        // in it; the common case, at no cost. (A wide disc is not that
        // narrow.) On the real line, a root proven real, im is 0. A centre
        // on the axis is not a proof: its disc crosses the axis, and is
        // settled below, on the axis first.)
        const bool on_line = real || disc.real;
        if (disc.verified && disc.count == 1 && detail::one_float(disc.re, disc.radius) &&
            (on_line || detail::one_float(disc.im, disc.radius))) {
            set_float(h, disc.re, on_line ? 0.0 : disc.im);
            return;
        }
        double c[kMaxDegree + 1], r[kMaxDegree + 1];
        coefficients(c, r);
        double re, im;
        double slope;
        if (detail::canonical_root(c, n, disc, re, im, real, &slope)) {
            if (dir != nullptr && detail::polish_ill_conditioned_at(r, n, re, im, slope)) {
                detail::RayPoint ray = ray_point(h.object, dir);
                double a = re, b = im;
                if (detail::polish_root_at_point(ray, c, n, disc, a, b, real)) {
                    re = a;
                    im = b;
                }
            }
            set_float(h, re, im);
            return;
        }
        if (detail::wants_polish(disc)) polish(h, c, r, n, real, dir);
        else if (real) to_real_line(h);
        // (A disc across the real axis: its imaginary extent holds both
        // signs, and the centre's is noise; 0, its middle, is shown.)
        const bool across = h.disc.im != 0.0 && std::fabs(h.disc.im) <= h.disc.radius;
        set_float(h, h.disc.re, across ? 0.0 : h.disc.im);
    }

    /// show_root's fallback for a wide disc where canonical_root does not
    /// settle: the hit's value (its disc's centre) replaced by the disc's
    /// one root to double accuracy
    /// (polish_root), where it settles; the disc's proof and the decision
    /// stay. So a wide disc writes its root, not the solver's approximation.
    /// `real`: the hit's root is proven real (proven_real_hit): the
    /// iteration stays on the real line, and the value is written there
    /// (im = 0) even where it does not settle.
    /// The root of the double coefficients c is the exact polynomial's
    /// within what their radii r move it: where that may be more than a
    /// float32 AOV shows (polish_ill_conditioned: a root near another, or
    /// a surface far from the eye for its degree), a primary ray's root
    /// (`dir`: its world direction; null for other rays, whose
    /// coefficients are expanded at their own origin) is polished again
    /// with F evaluated at the point along the ray (polish_root_at_point).
    void polish(HitInfo& h, const double* c, const double* r, int n, bool real, const double* dir) {
        const RootDisc disc = h.disc;  // (the proven disc; set_root moves h's value)
        double re, im;
        if (dir != nullptr && detail::polish_ill_conditioned(c, r, n, disc.re, real ? 0.0 : disc.im)) {
            // (Started from the coefficients' root in double; where F at the
            // point does not settle, polish_root's value as for any root.)
            detail::RayPoint ray = ray_point(h.object, dir);
            detail::polish_start(c, n, disc, re, im, real);
            if (detail::polish_root_at_point(ray, c, n, disc, re, im, real)) {
                set_root(h, re, im);
                return;
            }
        }
        if (detail::polish_root(c, n, disc, re, im, real)) set_root(h, re, im);
        else if (real) to_real_line(h);
    }

    /// h shows (re, im) rounded to float32 (an imaginary part 0 as +0).
    static void set_float(HitInfo& h, double re, double im) {
        const double a = detail::round_to_float(re), b = detail::round_to_float(im) + 0.0;
        h.disc.re = a;
        h.disc.im = b;
        // (Floats: their squares are exact in double and their sum rounds
        // once, far from overflow and underflow; no hypot needed.)
        h.modulus = b == 0.0 && !std::isnan(a) ? std::fabs(a) : std::sqrt(a * a + b * b);
    }

    /// The primary ray along world direction `dir` in object `obj`'s space.
    detail::RayPoint ray_point(int obj, const double* dir) const {
        const SurfaceSpec& s = plan_.scene.objects[obj];
        detail::RayPoint ray;
        ray.surface = &s;
        for (int a = 0; a < 3; ++a) {
            ray.origin[a] = plan_.objects[obj].origin[a].mid;
            const double* L = s.linear + 3 * a;
            ray.direction[a] = L[0] * dir[0] + L[1] * dir[1] + L[2] * dir[2];
        }
        return ray;
    }

    /// h shows the root (re, im) of its disc.
    static void set_root(HitInfo& h, double re, double im) {
        h.disc.re = re;
        h.disc.im = im;
        h.modulus = im == 0.0 && !std::isnan(re) ? std::fabs(re) : std::hypot(re, im);
    }

    /// A certified hit whose root is proven real: in a band that is the
    /// positive real axis (sigma = delta = 0, or a real object; band_verdict
    /// says Yes on the axis only for a disc proven real), or in any band, a
    /// one-root disc flagged real (the batch's mirror test,
    /// PrimaryBatch::solve: the root in it is real).
    bool proven_real_hit(const HitInfo& h) const {
        return h.hit && h.status == kCertified &&
               (decider_.real_axis(h.object) || (h.disc.real && h.disc.count == 1 && h.disc.verified));
    }

    /// A root proven real shows its value on the real line: the disc's
    /// centre's real part, im = 0 (the centre's imaginary part is the
    /// solver's noise, within the disc's radius).
    static void to_real_line(HitInfo& h) {
        if (h.disc.im == 0.0) return;
        h.disc.im = 0.0;
        h.modulus = !std::isnan(h.disc.re) ? std::fabs(h.disc.re) : h.modulus;
    }

    /// Colour seen along a ray (recursion for real reflective / transparent
    /// objects). `hit` is the already computed intersection.
    void shade(const double* o, const double* d, const HitInfo& hit, int depth, double* rgb);

    ShadePlan shading_;           // shade()'s per-frame data, built on its first hit
    bool shading_ready_ = false;

private:
    /// find_roots on the object's ray polynomial (with its coefficient radii).
    void solve(ObjectRoots& r, int degree, const Seeds* seed);

    /// Levels 3 and 4, for a primary ray: a polynomial with a live cluster
    /// is re-isolated from scratch, first in double from the ray polynomial
    /// about the cluster (rebase: level 3), else with double-double ray
    /// coefficients (isolate_dd); then every live verified count-1 disc of
    /// the others is shrunk with double-double coefficients (level 4).
    /// Returns the level reached: kLevelDoubleDouble where a double-double
    /// step changed a disc, else kLevelRebased where a rebase did, else
    /// kLevelFirst (nothing changed).
    /// `memo` (optional): the sample's answers shared with the tile's other
    /// bands (LadderMemo): a question asked before takes its answer.
    std::uint8_t refine(ObjectRoots* roots, const std::vector<DiscInfo>& infos, LadderMemo* memo);

    /// Every root of the primary ray polynomial of object `obj`, in double,
    /// from its expansion about the point at t0 (rebased_ray_polynomial),
    /// t0 the real part of own's cluster disc of least |centre|: true, with
    /// own's discs replaced by the proven discs of the roots t0 + s, where
    /// every root gets its own verified disc, all pairwise disjoint; false
    /// (own untouched) otherwise.
    bool rebase(int obj, RootsResult& own) const;

    void record(const ObjectRoots* roots, const std::vector<DiscInfo>& infos, const HitInfo& h, PixelExplanation* t) const;

public:
    double current_direction_[3] = {0, 0, 0};
    int pixel_x_ = 0, pixel_y_ = 0;  // the pixel being traced (for the exact tier)
    // The block of kSeedBlock x kSeedBlock samples holding the sample being
    // traced (row << 32 | column): the exact tier's budget is per block.
    std::int64_t exact_block_ = 0;
    bool explaining_ = false;         // explain_pixel: the exact tier runs only for the traced pixel

private:
    const FramePlan& plan_;
    const ExactSolver* exact_ = nullptr;
    bool cull_ = true;  // ray_misses_sphere skips an object's roots (EngineOptions::cull)
    // Samples sent to the exact tier, per block of this tile (exact_block_).
    // (Few blocks reach the tier: a short list searched from its end.)
    std::vector<std::pair<std::int64_t, int>> exact_used_;
    std::vector<ObjectRoots> scratch_;
    std::vector<std::vector<DiscInfo>> infos_;
    Decider decider_;  // the band's decisions (and the choice record reads)
    bool seed_objects_ = false;  // some object's Seeds are kept (degree > 4, seed_from_neighbour)
};

}  // namespace argand::detail

#pragma GCC visibility pop
