// render/decide.cpp: a pixel's decision from its ray's discs (decide.h).
#include "decide.h"

#include <cmath>

namespace argand::detail {

bool centre_in_band(const RootDisc& d, double sigma, double delta, bool complex_space) {
    if (!complex_space) return std::fabs(d.im) <= 1e-9 * std::fabs(d.re) && d.re > 0.0;
    const double theta = std::fabs(std::atan2(d.im, d.re));
    return theta >= sigma && theta <= sigma + delta;
}

Decider::Decider(const FramePlan& plan) : plan_(plan) {
    const DecideMode mode = plan.params.engine.decide;
    full_only_ = mode == DecideMode::Full;
    classify_ = detail::classify_discs_best(mode == DecideMode::FastScalar);
    for (const SurfaceSpec& s : plan.scene.objects)
        classify_plans_.push_back(detail::classify_plan(plan, s.complex_space, s.clip_radius));
}

bool Decider::decide_fast(const ObjectRoots* roots, HitInfo& h) const {
    struct Live {
        double lo, hi;
        int object, index;
    };
    const int n_obj = static_cast<int>(plan_.scene.objects.size());
    if (n_obj == 1) return decide_one(roots, h);
    detail::DiscVerdicts v;
    constexpr int kLive = 2 * kMaxDegree;
    Live live[kLive];
    int n_live = 0, eligible = 0, best = -1;
    for (int obj = 0; obj < n_obj; ++obj) {
        const ObjectRoots& r = roots[obj];
        if (r.status != Status::Ok || !r.complete) return false;  // (degenerate or incomplete)
        // decide_full's verdicts: band (with proven_real, every disc
        // verified), then (not proven out of the band) moduli and sphere.
        classify_(r.res.discs, r.res.n_discs, classify_plans_[obj], r.ray, v, r.res.memo);
        for (std::uint64_t m = v.live; m != 0; m &= m - 1) {
            const int i = __builtin_ctzll(m);
            if (n_live == kLive) return false;
            live[n_live] = Live{v.lo[i], v.hi[i], obj, i};
            if ((v.eligible >> i) & 1) {
                eligible += r.res.discs[i].count;
                if (best < 0 || v.hi[i] < live[best].hi) best = n_live;
            }
            ++n_live;
        }
    }
    // decide_full's proof of the choice; any blocking disc: not certified.
    if (best < 0) {
        if (n_live > 0) return false;
    } else {
        const Live& b = live[best];
        const ObjectRoots& rb = roots[b.object];
        if (rb.res.discs[b.index].count > 1) return false;  // a cluster chosen
        for (int i = 0; i < n_live; ++i) {
            if (i == best) continue;
            const Live& j = live[i];
            if (b.hi < j.lo) continue;
            if (j.object == b.object && detail::is_mirror_twin_fast(rb.res.discs, rb.res.n_discs, b.index, j.index))
                continue;
            return false;
        }
    }
    // (h is decide's default HitInfo: no hit, certified, level first.)
    h.eligible = eligible;
    h.status = kCertified;
    if (best >= 0) set_hit(roots, live[best].object, live[best].index, h);
    return true;
}

bool Decider::blockers_are_twins(const RootDisc* discs, int n, int best,
                                                                            std::uint64_t blockers) {
    for (; blockers != 0; blockers &= blockers - 1)
        if (!detail::is_mirror_twin_fast(discs, n, best, __builtin_ctzll(blockers))) return false;
    return true;
}

HitInfo Decider::decide_full(ObjectRoots* roots, std::vector<DiscInfo>& infos) {
    const FrameParams& fp = plan_.params;
    const int n_obj = static_cast<int>(plan_.scene.objects.size());
    infos.clear();
    bool incomplete = false, degenerate = false;
    for (int obj = 0; obj < n_obj; ++obj) {
        const ObjectRoots& r = roots[obj];
        const SurfaceSpec& s = plan_.scene.objects[obj];
        if (r.status == Status::ZeroPolynomial) {  // the ray lies in the surface
            degenerate = true;
            continue;
        }
        if (!r.complete) incomplete = true;
        if (r.status != Status::Ok) continue;
        for (int i = 0; i < r.res.n_discs; ++i) {
            const RootDisc& disc = r.res.discs[i];
            if (disc.count <= 0) continue;
            DiscInfo info{};
            info.object = obj;
            info.index = i;
            if (!disc.verified) {
                detail::modulus_bounds(disc, info.lo, info.hi);
                // Not enclosed: may be anywhere.
                info.band = info.clip = Verdict::Unknown;
                info.live = true;
                infos.push_back(info);
                continue;
            }
            // The exact root t = 0 (an exactly zero constant term): the
            // camera on the surface. Not a root the pixel shows.
            info.at_origin = disc.re == 0.0 && disc.im == 0.0 && disc.radius == 0.0;
            info.real = detail::proven_real(r.res.discs, r.res.n_discs, i, r.complete);
            info.band = detail::band_membership(disc, info.real, plan_, s.complex_space);
            // (Moduli and the sphere only matter for a root that may be in
            // the band.)
            if (info.band != Verdict::No) {
                detail::modulus_bounds(disc, info.lo, info.hi);
            }
            info.clip = s.clip_radius <= 0.0 || info.band == Verdict::No
                            ? Verdict::Yes
                            : detail::inside_clip(r.ray, info.lo, info.hi, s.clip_radius);
            info.live = !info.at_origin && info.clip != Verdict::No && info.band != Verdict::No;
            info.eligible = info.live && info.clip == Verdict::Yes && info.band == Verdict::Yes;
            // (A disc proven out plays no further part; kept only for
            // --explain.)
            if (info.live || recording) infos.push_back(info);
        }
    }
    HitInfo h;
    int best = -1;
    for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
        if (!infos[i].eligible) continue;
        h.eligible += roots[infos[i].object].res.discs[infos[i].index].count;
        if (best < 0 || infos[i].hi < infos[best].hi) best = i;
    }
    // Proof of the choice: every other live disc lies beyond the chosen
    // one, or holds exactly its conjugate.
    bool blocked = false, cluster_blocks = false;
    for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
        const DiscInfo& j = infos[i];
        if (!j.live || i == best) continue;
        if (best >= 0) {
            const DiscInfo& b = infos[best];
            if (b.hi < j.lo) continue;
            const ObjectRoots& r = roots[j.object];
            if (j.object == b.object &&
                detail::is_mirror_twin(r.res.discs[b.index], r.res.discs[j.index], r.res.discs, r.res.n_discs, r.complete))
                continue;
        }
        blocked = true;
        if (roots[j.object].res.discs[j.index].count > 1) cluster_blocks = true;
    }
    const bool best_cluster = best >= 0 && roots[infos[best].object].res.discs[infos[best].index].count > 1;
    if (degenerate) h.status = kCluster;
    else if (incomplete) h.status = kUnverified;
    else if (blocked) h.status = cluster_blocks ? kCluster : kUndecided;
    else if (best_cluster) h.status = kCluster;
    else h.status = kCertified;
    chosen_ = -1;
    if (!blocked && !incomplete && !degenerate) {
        chosen_ = best;
    } else {
        // Not proven: show the likeliest root (smallest centre modulus
        // among live discs whose centre looks eligible).
        double best_mod = kInf;
        for (int i = 0; i < static_cast<int>(infos.size()); ++i) {
            const DiscInfo& j = infos[i];
            if (!j.live) continue;
            const RootDisc& disc = roots[j.object].res.discs[j.index];
            const SurfaceSpec& s = plan_.scene.objects[j.object];
            if (j.band == Verdict::Unknown && !centre_in_band(disc, fp.sigma, fp.delta, s.complex_space)) continue;
            if (j.clip == Verdict::Unknown && s.clip_radius > 0.0) {
                const double m = std::hypot(disc.re, disc.im);
                double p = 0.0;
                for (int a = 0; a < 3; ++a) {
                    const double v = roots[j.object].ray.origin[a].mid + m * roots[j.object].ray.direction[a].mid;
                    p += v * v;
                }
                if (p > s.clip_radius * s.clip_radius) continue;
            }
            const double m = std::hypot(disc.re, disc.im);
            if (m < best_mod) {
                best_mod = m;
                chosen_ = i;
            }
        }
    }
    if (chosen_ >= 0) set_hit(roots, infos[chosen_].object, infos[chosen_].index, h);
    return h;
}

}  // namespace argand::detail
