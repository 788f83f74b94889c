// render/decide.h: a pixel's decision: a band against the root field.
// From the discs of every object along a ray (ObjectRoots), which root the
// pixel shows and whether that is proven (PixelStatus), with the band,
// clipping sphere and mirror predicates of pixel_decision.h. Internal header.
#pragma once

#include <cstdint>
#include <vector>

#include "argand/render.h"
#include "../pixel_decision.h"
#include "solve.h"
#include "vec3.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// Per-disc decisions of the current ray.
struct DiscInfo {
    int object;
    int index;               // into the object's res.discs
    double lo, hi;           // modulus bounds
    bool real, at_origin, live, eligible;
    Verdict band, clip;
};

struct HitInfo {
    bool hit = false;
    int object = -1;
    RootDisc disc{};
    double modulus = kInf;
    int eligible = 0;
    std::uint8_t status = kCertified;
    std::uint8_t level = kLevelFirst;
};

/// Approximate band test of a disc's centre (for the picture of an
/// undecided pixel only; proves nothing).
bool centre_in_band(const RootDisc& d, double sigma, double delta, bool complex_space);

/// The decisions of one band (the plan's sigma and delta) for the rays a
/// Tracer traces: the fast path (decide_fast, decide_one) and the full one
/// (decide_full, which keeps every disc's verdicts for refine and record).
class Decider {
public:
    explicit Decider(const FramePlan& plan);

    /// The pixel's decision from the current discs (see PixelStatus): the
    /// fast path when it decides, else the full one.
    HitInfo decide(ObjectRoots* roots, std::vector<DiscInfo>& infos) {
        HitInfo h;
        if (!recording && !full_only_ && decide_fast(roots, h)) return h;
        return decide_full(roots, infos);
    }

    /// The fast path of decide, for the common pixel: every object's roots
    /// complete (status Ok, every disc verified) and the result certified.
    /// It makes decide_full's decisions with the same predicates
    /// (detail::classify_discs_*: the *_fast forms of pixel_decision.h, four
    /// discs per vector where AVX2 runs, which return exactly what
    /// decide_full's references return), in the same order over the discs,
    /// but keeps only the live discs (in a fixed array), decides realness
    /// only where the band verdict depends on it, and uses moduli and the
    /// sphere only for discs not proven out of the band (as decide_full).
    /// True, with h (default-constructed by the caller) exactly
    /// decide_full's result, when the pixel is
    /// certified; false (h unspecified) for any other outcome (a blocked
    /// choice, a cluster chosen, more live discs than the array holds, an
    /// incomplete or degenerate object), which decide_full then decides
    /// (and fills `infos` for refine / record). (chosen_ is left alone: only
    /// record reads it, and record's pixels take the full path.)
    bool decide_fast(const ObjectRoots* roots, HitInfo& h) const;

    /// decide_fast for a scene of one object: the same decisions from the
    /// discs' verdicts and choice (classify_discs_*, finish_choice).
    bool decide_one(const ObjectRoots* roots, HitInfo& h) const {
        int best = -1, eligible = 0;
        if (!decide_one_verdict(roots, best, eligible)) return false;
        h.eligible = eligible;
        h.status = kCertified;
        if (best >= 0) set_hit(roots, 0, best, h);
        return true;
    }

    /// decide_one's decision alone: true where it certifies the pixel, with
    /// `best` the disc it shows (-1: a proven miss) and `eligible` its
    /// eligible count; nothing of the hit is made (a band counted, not
    /// written, needs no more).
    bool decide_one_verdict(const ObjectRoots* roots, int& best, int& eligible) const {
        const ObjectRoots& r = roots[0];
        best = -1;
        eligible = 0;
        if (r.status != Status::Ok || !r.complete) return false;  // (degenerate or incomplete)
        if (r.outside_sphere) return true;  // (no disc: a proven miss)
        const RootDisc* discs = r.res.discs;
        detail::DiscVerdicts v;
        classify_(discs, r.res.n_discs, classify_plans_[0], r.ray, v, r.res.memo);
        if (v.best < 0) return v.live == 0;  // (a live disc blocks the miss)
        if (discs[v.best].count > 1) return false;  // a cluster chosen
        if (v.blockers != 0 && !twins(r.res.memo, discs, r.res.n_discs, v.best, v.blockers)) return false;
        best = v.best;
        eligible = v.count;
        return true;
    }

    /// Whether decide_one_keyed decides the roots `r` of a sample: four
    /// discs of the batch (with their ClassifyMemo), classified by the form
    /// that keeps ClassifyMemo::band, and none of the band-independent
    /// reasons decide_one_verdict returns before classifying.
    bool keyable(const ObjectRoots& r) const {
        return r.res.memo != nullptr && r.res.n_discs == 4 && classify_ == detail::classify_discs_avx2 &&
               r.status == Status::Ok && r.complete && !r.outside_sphere;
    }
    /// The band and sphere constants of object 0 (detail::band_keys_four's plans).
    const detail::ClassifyPlan* object_plan() const { return &classify_plans_[0]; }

    /// decide_one_verdict for a band counted, not written (Tracer::
    /// decide_counted) of roots that are keyable, `key` their discs' band
    /// verdicts under this band (detail::band_keys_four): true where it
    /// decides, with `hit` (best >= 0). Where the sample's memo holds the
    /// answer of another band with the same verdicts (ClassifyMemo::band),
    /// that answer: past those verdicts decide_one_verdict reads only the
    /// discs, the ray and the memo, so it is the one it would make.
    /// `shared`: whether the answer is every band's with these verdicts (not
    /// where a disc needed the reference's band test, which reads the band
    /// itself).
    bool decide_one_keyed(const ObjectRoots* roots, std::uint16_t key, bool& hit, bool& shared) const {
        detail::ClassifyMemo* memo = roots[0].res.memo;
        if ((memo->groups & detail::ClassifyMemo::kBandHeld) && memo->band.decision >= 0 && memo->band_key == key) {
            hit = memo->band.decision == 2;
            shared = true;
            return memo->band.decision != 0;
        }
        int best, eligible;
        const bool decided = decide_one_verdict(roots, best, eligible);
        hit = best >= 0;
        // (classify_four holds kBandHeld after its call only for this
        // band's verdicts, and only where no disc took the reference's test.)
        shared = (memo->groups & detail::ClassifyMemo::kBandHeld) != 0;
        if (shared) memo->band.decision = static_cast<std::int8_t>(decided ? (hit ? 2 : 1) : 0);
        return decided;
    }

    /// blockers_are_twins, through the sample's memo where it has one: the
    /// bands of a tile share it, and ask it mostly of the same best disc
    /// and blockers (a conjugate pair, in every band that holds them both).
    static bool twins(detail::ClassifyMemo* memo, const RootDisc* discs, int n, int best, std::uint64_t blockers) {
        if (memo == nullptr) return blockers_are_twins(discs, n, best, blockers);
        if ((memo->groups & detail::ClassifyMemo::kTwinsHeld) && memo->twin_best == best &&
            memo->twin_blockers == blockers)
            return memo->twins;
        memo->twins = blockers_are_twins(discs, n, best, blockers);
        memo->twin_best = best;
        memo->twin_blockers = blockers;
        memo->groups |= detail::ClassifyMemo::kTwinsHeld;
        return memo->twins;
    }

    /// h shows disc `index` of object `object` (decide_fast and decide_full).
    static void set_hit(const ObjectRoots* roots, int object, int index, HitInfo& h) {
        h.hit = true;
        h.object = object;
        h.disc = roots[object].res.discs[index];
        // hypot(x, +-0) is |x| (C99 F.9.4.3); NaN keeps the call.
        h.modulus = h.disc.im == 0.0 && !std::isnan(h.disc.re) ? std::fabs(h.disc.re) : std::hypot(h.disc.re, h.disc.im);
    }

    /// The full decision, every disc's verdicts in `infos`.
    HitInfo decide_full(ObjectRoots* roots, std::vector<DiscInfo>& infos);

    /// Whether object `obj`'s band is the positive real axis (sigma = delta
    /// = 0, or a real object): a certified hit of it is then a root proven
    /// real (band_verdict says Yes on the axis only for a disc proven real).
    bool real_axis(int obj) const { return classify_plans_[obj].band.axis; }

    /// DecideMode::Full: decide_full for every pixel (the reference).
    bool full_only() const { return full_only_; }
    /// The infos entry decide_full chose (-1: none), for record.
    int chosen() const { return chosen_; }

    bool recording = false;  // keep every disc's decisions (explain_pixel)

private:
    /// Each disc of `blockers` holds exactly the conjugate of best's root
    /// (decide_full's proof for a disc not beyond best).
    __attribute__((noinline)) static bool blockers_are_twins(const RootDisc* discs, int n, int best,
                                                             std::uint64_t blockers);

    const FramePlan& plan_;
    int chosen_ = -1;
    bool full_only_ = false;  // DecideMode::Full: decide_full for every pixel (the reference)
    std::vector<detail::ClassifyPlan> classify_plans_;  // per object: band and sphere constants of decide_fast
    detail::ClassifyDiscs classify_ = nullptr;  // decide_fast's verdicts (DecideMode::FastScalar: the scalar form)
};

}  // namespace argand::detail

#pragma GCC visibility pop
