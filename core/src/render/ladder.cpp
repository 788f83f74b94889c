// render/ladder.cpp: a ray's roots and the escalation ladder (LadderLevel):
// while the pixel's decision is not proven, a cluster re-isolated from the
// ray polynomial about it (rebase) or with double-double ray coefficients,
// which also shrink the deciding discs (refine), the batch's merged discs
// settled, a retry without neighbour seeds, then (a primary ray, within the
// tile's budget) the exact tier: an ExactSolver given by the caller decides
// the pixel on the exact rational ray polynomial.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "../refine_dd.h"
#include "../root_kernels.h"
#include "tracer.h"

namespace argand::detail {

Tracer::Tracer(const FramePlan& plan, const ExactSolver* exact, bool cull)
    : plan_(plan), exact_(exact), cull_(cull), decider_(plan) {
    const int levels = plan.params.max_depth + 2;
    scratch_.resize(static_cast<std::size_t>(levels) * plan.scene.objects.size());
    infos_.resize(static_cast<std::size_t>(levels));
    for (const SurfaceSpec& s : plan.scene.objects)
        seed_objects_ = seed_objects_ || (s.degree > 4 && plan.params.seed_from_neighbour);
}

HitInfo Tracer::intersect(const double* o, const double* d, bool primary, Seeds* seeds, int depth, PixelExplanation* trace,
                          const BatchedCell* pre, bool filled) {
    const int n_obj = static_cast<int>(plan_.scene.objects.size());
    const int slot = std::min(depth, plan_.params.max_depth + 1);
    ObjectRoots* roots = scratch_.data() + static_cast<std::size_t>(slot) * n_obj;
    std::vector<DiscInfo>& infos = infos_[slot];
    bool any_seeded = false;
    std::uint8_t level = kLevelFirst;
    decider_.recording = trace != nullptr;
    for (int obj = 0; obj < n_obj; ++obj) {
        const SurfaceSpec& s = plan_.scene.objects[obj];
        ObjectRoots& r = roots[obj];
        if (primary && pre != nullptr && pre->batch->batched(obj)) {
            if (!filled) pre->batch->fill(obj, pre->cell, r, trace != nullptr);
            if (!r.outside_sphere) ++root_calls;
            r.have_dd = false;
            if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
            continue;
        }
        if (primary) detail::primary_ray_polynomial(s, plan_.objects[obj], d, r.poly, r.ray);
        else detail::general_ray_polynomial(s, o, d, r.poly, r.ray);
        r.origin_is_plan = primary;
        r.have_dd = false;
        if (cull_ && s.clip_radius > 0.0 && detail::ray_misses_sphere(r.ray, s.clip_radius)) {
            r.set_outside_sphere();  // (not solved: no root call)
            continue;
        }
        const bool use_seed = seeds && seeds[obj].valid && plan_.params.seed_from_neighbour && s.degree > 4;
        solve(r, s.degree, use_seed ? seeds + obj : nullptr);
        any_seeded = any_seeded || r.seeded;
        if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
    }
    HitInfo h = filled ? decider_.decide_full(roots, infos) : decider_.decide(roots, infos);
    if (h.status != kCertified && primary && pre != nullptr) {
        // Discs a lane merged into clusters did not prove the pixel. Such a
        // cluster is nearly always a near-double root where the ray passes
        // near a node of the surface, which no solve in double of the eye's
        // polynomial splits (on Endrass's octic, solving the row again in
        // double decided 45 of 4,093 such pixels, at a fifth of the frame's
        // time; the polynomial about the cluster, in double, decides all but
        // a few, double-double the rest): the ladder's re-isolation first
        // (refine: the cluster re-isolated from the merged discs). Where it
        // does not decide, the rows solved as find_roots_soa would without
        // merging (settle), decided again, and the ladder goes on as for
        // any pixel.
        bool provisional = false;
        for (int obj = 0; obj < n_obj; ++obj) provisional = provisional || roots[obj].provisional;
        if (provisional) {
            const std::uint8_t reached = refine(roots, infos, pre->batch->ladder_memo(pre->cell));
            if (reached != kLevelFirst) {
                level = std::max(level, reached);
                h = decider_.decide(roots, infos);
            }
        }
        if (h.status != kCertified) {
            bool settled = false;
            for (int obj = 0; obj < n_obj; ++obj) {
                ObjectRoots& r = roots[obj];
                if (!r.provisional) continue;
                pre->batch->settle(obj, pre->cell, r);
                settled = true;
                if (r.res.escalation > 0) level = std::max<std::uint8_t>(level, kLevelRootTier);
            }
            if (settled) h = decider_.decide(roots, infos);
        }
    }
    if (h.status != kCertified && any_seeded) {
        level = kLevelUnseeded;
        for (int obj = 0; obj < n_obj; ++obj)
            if (roots[obj].seeded) solve(roots[obj], plan_.scene.objects[obj].degree, nullptr);
        h = decider_.decide(roots, infos);
    }
    if (h.status != kCertified && primary) {
        const std::uint8_t reached = refine(roots, infos, pre != nullptr ? pre->batch->ladder_memo(pre->cell) : nullptr);
        if (reached != kLevelFirst) {
            level = std::max(level, reached);
            h = decider_.decide(roots, infos);
        }
    }
    const bool exact_tier = h.status != kCertified && primary && exact_ && *exact_ &&
                            plan_.params.exact_pixels_per_block > 0 && plan_.params.method != Method::Unverified &&
                            (trace != nullptr || !explaining_);
    bool exact_ran = false;
    if (exact_tier) {
        // Level 5: the exact tier, within the block's budget (--explain
        // runs it for its pixel whatever the budget).
        auto used = std::find_if(exact_used_.rbegin(), exact_used_.rend(),
                                 [&](const auto& b) { return b.first == exact_block_; });
        if (used == exact_used_.rend()) {
            exact_used_.emplace_back(exact_block_, 0);
            used = exact_used_.rbegin();
        }
        if (trace == nullptr && used->second >= plan_.params.exact_pixels_per_block) {
            level = kLevelExactOverCap;
        } else {
            ++used->second;
            ExactQuery q{pixel_x_, pixel_y_, Ray{}, trace != nullptr};
            for (int a = 0; a < 3; ++a) {
                q.ray.origin[a] = o[a];
                q.ray.direction[a] = d[a];
            }
            // (The answer, strings and all, exists only here: not
            // made and destroyed for every ray.)
            ExactAnswer answer = (*exact_)(plan_, q);
            exact_ran = true;
            level = answer.multiple ? kLevelExactMultiple : kLevelExact;
            h.status = answer.status;
            if (answer.decided) {
                h.hit = answer.hit;
                h.eligible = answer.eligible;
                if (answer.hit) {
                    h.object = answer.object;
                    h.disc = RootDisc{answer.re, answer.im, 0.0, 1, true, answer.im == 0.0};
                    h.modulus = answer.modulus;
                } else {
                    h.object = -1;
                    h.modulus = kInf;
                }
            }
            if (trace) trace->exact = std::move(answer);
        }
    }
    if (h.hit) {
        const int object = h.object, n = plan_.scene.objects[object].degree;
        const ObjectRoots& r = roots[object];
        const bool from_batch = primary && pre != nullptr && pre->batch->batched(object);
        show_root(
            h,
            [&](double* c, double* rad) {
                if (from_batch) {
                    pre->batch->coefficients(object, pre->cell, c, rad);
                } else {
                    std::copy(r.poly.c, r.poly.c + n + 1, c);
                    std::copy(r.poly.r, r.poly.r + n + 1, rad);
                }
            },
            n, proven_real_hit(h), primary ? d : nullptr);
    }
    upper_half(h);
    h.level = level;
    if (seeds && seed_objects_) {
        // Only for the objects whose seeds a later sample may read: the
        // scalar path's (intersect's use_seed: degree > 4 and
        // seed_from_neighbour), and not those this batch solves (the
        // batch's lanes take their seeds from its own arrays; a tile
        // with a batch gives every primary sample its BatchedCell).
        // Any other object's Seeds stay as they were, never read.
        for (int obj = 0; obj < n_obj; ++obj) {
            const int n = plan_.scene.objects[obj].degree;
            if (n <= 4 || !plan_.params.seed_from_neighbour) continue;
            if (primary && pre != nullptr && pre->batch->batched(obj)) continue;
            const ObjectRoots& r = roots[obj];
            int m = 0;
            for (int i = 0; i < r.res.n_discs && m < n; ++i)
                for (int c = 0; c < std::max(1, static_cast<int>(r.res.discs[i].count)) && m < n; ++c) {
                    seeds[obj].re[m] = r.res.discs[i].re;
                    seeds[obj].im[m] = r.res.discs[i].im;
                    ++m;
                }
            seeds[obj].valid = r.status == Status::Ok && m == n && r.res.n_infinite == 0;
        }
    }
    if (trace) {
        record(roots, infos, h, trace);
        trace->exact_ran = exact_ran;
        if (!exact_ran) trace->exact = ExactAnswer{};
        if (exact_ran && trace->exact.decided) trace->chosen = -1;  // the root is the exact tier's
        trace->root_re = h.disc.re;
        trace->root_im = h.disc.im;
    }
    return h;
}

bool Tracer::rebase(int obj, RootsResult& own) const {
    const SurfaceSpec& s = plan_.scene.objects[obj];
    const int n = s.degree;
    // (Not for a polynomial with roots at infinity or an exact root at 0:
    // the decider reads those from the discs as find_roots gives them.)
    if (own.n_infinite != 0 || own.n_discs < 1) return false;
    // t0: the real part of the cluster of least |centre|, from the discs
    // alone (not from the band that asks: every band of a sample gets the
    // same answer, LadderMemo or not).
    double t0 = NAN, least = INFINITY;
    for (int i = 0; i < own.n_discs; ++i) {
        const RootDisc& d = own.discs[i];
        if (d.re == 0.0 && d.im == 0.0 && d.radius == 0.0) return false;
        const double m = std::fabs(d.re) + std::fabs(d.im);
        if (d.count > 1 && m < least) {
            least = m;
            t0 = d.re;
        }
    }
    if (!std::isfinite(t0)) return false;
    RayCoefficients<double> q;
    detail::rebased_ray_polynomial(s, plan_.objects[obj], current_direction_, t0, q);
    if (!q.finite || !(add_down(std::fabs(q.c[n]), -q.r[n]) > 0.0)) return false;
    // Seeds (speed only): the current discs about t0, a cluster's count
    // spread on its circle.
    double seed_re[kMaxDegree], seed_im[kMaxDegree];
    int m = 0;
    for (int i = 0; i < own.n_discs && m < n; ++i) {
        const RootDisc& d = own.discs[i];
        for (int k = 0; k < d.count && m < n; ++k) {
            const double a = 2.0 * 3.14159265358979323846 * k / d.count + 0.4;
            const double rho = d.count > 1 ? 0.5 * d.radius : 0.0;
            seed_re[m] = d.re - t0 + rho * std::cos(a);
            seed_im[m++] = d.im + rho * std::sin(a);
        }
    }
    RootsResult out;
    const bool seeded = m == n;
    if (find_roots(q.c, n + 1, plan_.params.method, out, seeded ? seed_re : nullptr, seeded ? seed_im : nullptr, q.r) !=
            Status::Ok ||
        out.n_infinite != 0 || out.n_discs != n)
        return false;
    // The roots t = t0 + s: each centre rounded, its rounding error (TwoSum,
    // exact) added to the radius; a disc's imaginary part and its proof of
    // a real root stay (t0 is real).
    for (int i = 0; i < n; ++i) {
        RootDisc& d = out.discs[i];
        if (!d.verified || d.count != 1) return false;
        const double re = t0 + d.re;
        const double err = add_error(t0, d.re, re);
        d.re = re;
        d.radius = add_up0(d.radius, err);
        if (!std::isfinite(d.re) || !std::isfinite(d.radius)) return false;
    }
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const RootDisc &a = out.discs[i], &b = out.discs[j];
            if (!(dist_down(a.re, a.im, b.re, b.im) > add_up(a.radius, b.radius))) return false;
        }
    flag_real_by_mirror(out.discs, n);
    own.n_discs = n;
    for (int i = 0; i < n; ++i) own.discs[i] = out.discs[i];
    own.wants_exact = false;
    own.escalation = std::max(own.escalation, out.escalation);
    return true;
}

std::uint8_t Tracer::refine(ObjectRoots* roots, const std::vector<DiscInfo>& infos, LadderMemo* memo) {
    bool rebased = false, by_dd = false;
    auto ensure_dd = [&](int obj) {
        ObjectRoots& r = roots[obj];
        if (r.have_dd) return;
        r.have_dd = true;
        if (memo)
            for (const LadderMemo::Dd& e : memo->dd)
                if (e.obj == obj) {
                    r.poly_dd = e.p;
                    return;
                }
        detail::primary_ray_polynomial_dd(plan_.scene.objects[obj], plan_.objects[obj], current_direction_, r.poly_dd);
        if (memo && memo->dd.size() < LadderMemo::kEntries) memo->dd.push_back({obj, r.poly_dd});
    };
    // rebase about a cluster's centre, else isolate_dd, on r's discs;
    // or the answer a band of this sample got for the same discs. Returns
    // whether the discs were re-isolated; `how` the level that did it.
    auto isolate = [&](int obj, ObjectRoots& r, std::uint8_t& how) {
        RootsResult& own = r.writable();
        if (memo)
            for (const LadderMemo::Isolated& e : memo->isolated)
                if (e.obj == obj && LadderMemo::same(e.in, own)) {
                    LadderMemo::copy(e.out, own);
                    how = e.level;
                    return e.done;
                }
        LadderMemo::Isolated* kept = nullptr;
        if (memo && memo->isolated.size() < LadderMemo::kEntries) {
            memo->isolated.emplace_back();
            kept = &memo->isolated.back();
            kept->obj = obj;
            LadderMemo::copy(own, kept->in);
        }
        bool done = rebase(obj, own);
        how = kLevelRebased;
        if (!done) {
            ensure_dd(obj);
            done = detail::isolate_dd(r.poly_dd, own);
            how = kLevelDoubleDouble;
        }
        if (kept) {
            kept->done = done;
            kept->level = how;
            LadderMemo::copy(own, kept->out);
        }
        return done;
    };
    // refine_disc_dd on disc, likewise.
    auto shrink = [&](int obj, bool real, RootDisc& disc) {
        if (memo)
            for (const LadderMemo::Shrunk& e : memo->shrunk)
                if (e.obj == obj && e.real == real && LadderMemo::same(e.in, disc)) {
                    disc = e.out;
                    return e.changed;
                }
        const RootDisc in = disc;
        const bool done = detail::refine_disc_dd(roots[obj].poly_dd, real, disc);
        if (memo && memo->shrunk.size() < LadderMemo::kEntries) memo->shrunk.push_back({obj, real, done, in, disc});
        return done;
    };
    const int n_obj = static_cast<int>(plan_.scene.objects.size());
    std::vector<bool> isolated(n_obj, false);
    for (const DiscInfo& info : infos) {
        ObjectRoots& r = roots[info.object];
        if (!info.live || isolated[info.object] || !r.complete) continue;
        if (r.res.discs[info.index].count < 2) continue;
        std::uint8_t how = kLevelFirst;
        const bool done = isolate(info.object, r, how);
        r.res.bind(r.own);  // (its header may have changed)
        if (done) {
            isolated[info.object] = true;
            rebased = rebased || how == kLevelRebased;
            by_dd = by_dd || how == kLevelDoubleDouble;
        }
    }
    for (const DiscInfo& info : infos) {
        if (!info.live || info.at_origin || isolated[info.object]) continue;
        ObjectRoots& r = roots[info.object];
        if (!r.complete || r.res.discs[info.index].count != 1) continue;
        ensure_dd(info.object);
        RootDisc& disc = r.writable().discs[info.index];
        const bool real_before = info.real;
        if (shrink(info.object, real_before, disc)) {
            // A proven real root stays real: its disc is now centred on
            // the axis (Newton on the real line) and symmetric.
            if (real_before) disc.real = true;
            by_dd = true;
        }
    }
    return by_dd ? kLevelDoubleDouble : rebased ? kLevelRebased : kLevelFirst;
}

}  // namespace argand::detail
