// render/solve.cpp: the roots of a tile's rays: the primary rays' batches
// (PrimaryBatch: ray polynomials, batched roots, the root field's tape)
// and the scalar path's find_roots (Tracer::solve).
#include "solve.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "../root_kernels.h"
#include "../roots_real.h"
#include "tracer.h"

namespace argand::detail {

void PrimaryBatch::solve(const double* dx, const double* dy, const double* dz, int cells, int first) {
    if (share_ladder_)
        for (int c = 0; c < cells; ++c) ladder_[c].clear();
    const int n_obj = static_cast<int>(objects_.size());
    for (int obj = 0; obj < n_obj; ++obj) {
        Object& o = objects_[obj];
        if (!o.batched) continue;
        const int n = plan_.scene.objects[obj].degree;
        prepare(obj, dx, dy, dz, cells);
        // The real path first (use_real_path): the cells it proves are not
        // solved by the batch, and take its discs once the batch is done.
        std::uint8_t skip_real[kCells];
        RootDisc real_discs[kCells][kBatchKernelMaxDegree];
        int real_n[kCells];
        const std::uint8_t* skip = o.skip;
        if (o.real) {
            for (int c = 0; c < cells; ++c) {
                o.real_done[c] = !o.skip[c] && solve_real(obj, c, real_discs[c], real_n[c]) ? 1 : 0;
                skip_real[c] = o.skip[c] | o.real_done[c];
                real_cells += o.real_done[c];
            }
            skip = skip_real;
        }
        // The seeds are the above arrays themselves (structure of
        // arrays along the tile's row of samples; a NaN in root 0 marks
        // a cell without seeds, which find_roots_soa starts on the
        // circle as before).
        SoaRows rows;
        rows.coeffs = &o.run.c[0][0];
        rows.radius = &o.run.r[0][0];
        rows.start_re = o.seeded ? o.above_re.data() + first : nullptr;
        rows.start_im = o.seeded ? o.above_im.data() + first : nullptr;
        rows.start_stride = row_cells_;
        rows.skip = skip;
        rows.rows = cells;
        rows.stride = kCells;
        rows.n_coeffs = n + 1;
        rows.provisional = o.provisional;
        rows.lane_re = o.lane_re;
        rows.lane_im = o.lane_im;
        find_roots_soa(rows, plan_.params.method, o.res, o.status, isa_);
        if (o.real)
            for (int c = 0; c < cells; ++c) {
                if (!o.real_done[c]) continue;
                RootsResult& res = o.res[c];
                res.n_discs = real_n[c];
                res.n_infinite = 0;
                res.wants_exact = false;
                res.escalation = 0;
                std::copy(real_discs[c], real_discs[c] + real_n[c], res.discs);
                o.status[c] = Status::Ok;
                o.provisional[c] = 0;
            }
        // What fill's ObjectRoots::complete was (status Ok, every disc
        // verified), once per cell here.
        for (int c = 0; c < cells; ++c) {
            bool complete = !o.skip[c] && o.status[c] == Status::Ok;
            if (complete) {
                const RootDisc* dd = o.res[c].discs;
                const int nd = o.res[c].n_discs;
                int i = 0;
                for (; i + 4 <= nd; i += 4)
                    complete &= dd[i].verified & dd[i + 1].verified & dd[i + 2].verified & dd[i + 3].verified;
                for (; i < nd; ++i) complete &= dd[i].verified;
            }
            o.complete[c] = complete ? 1 : 0;
            // A one-root disc that no other disc's mirror image can meet
            // holds a real root (real_by_mirror: the discs hold every root,
            // and its root's conjugate is a root, so in it): flagged real
            // here, once for every band, instead of by each band's
            // classify (band_fast_verified gives the same verdict either
            // way, and the vector classify keeps the disc instead of
            // sending it to the scalar reference).
            if (complete) detail::flag_real_by_mirror(o.res[c].discs, o.res[c].n_discs);
        }
        if (!o.seeded) continue;
        // These samples' roots seed the samples below them (as the
        // scalar path's seeds: every root, with multiplicity; NaN in
        // root 0 where there are not n).
        const std::size_t w = static_cast<std::size_t>(row_cells_);
        for (int c = 0; c < cells; ++c) {
            const std::size_t a = static_cast<std::size_t>(first + c);
            int m = 0;
            if (!o.skip[c] && o.provisional[c]) {
                // (The lane's own approximations: n distinct ones, where
                // its merged discs would repeat a cluster's centre.)
                for (; m < n; ++m) {
                    o.above_re[m * w + a] = o.lane_re[c * n + m];
                    o.above_im[m * w + a] = o.lane_im[c * n + m];
                }
            } else if (!o.skip[c] && o.status[c] == Status::Ok && o.res[c].n_infinite == 0) {
                const RootsResult& res = o.res[c];
                for (int i = 0; i < res.n_discs && m < n; ++i)
                    for (int k = 0; k < std::max(1, static_cast<int>(res.discs[i].count)) && m < n; ++k) {
                        o.above_re[m * w + a] = res.discs[i].re;
                        o.above_im[m * w + a] = res.discs[i].im;
                        ++m;
                    }
            }
            if (m != n) o.above_re[a] = kNaN;
        }
    }
}

void PrimaryBatch::record(std::vector<std::uint8_t>& tape, int cells) const {
    // The entries' size first, then one resize and plain stores (growing
    // the tape eight bytes at a time cost a 512² frame some 0.03 s).
    std::size_t bytes = 0;
    for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
        const Object& o = objects_[obj];
        if (!o.batched) continue;
        const std::size_t n = static_cast<std::size_t>(plan_.scene.objects[obj].degree);
        for (int c = 0; c < cells; ++c)
            if (!o.skip[c])
                bytes += 5 + 26 * static_cast<std::size_t>(o.res[c].n_discs) + (o.provisional[c] ? 16 * n : 0);
    }
    std::size_t at = tape.size();
    tape.resize(at + bytes);
    std::uint8_t* out = tape.data();
    auto put8 = [&](double v) {
        std::memcpy(out + at, &v, 8);
        at += 8;
    };
    for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
        const Object& o = objects_[obj];
        if (!o.batched) continue;
        const int n = plan_.scene.objects[obj].degree;
        for (int c = 0; c < cells; ++c) {
            if (o.skip[c]) continue;
            const RootsResult& res = o.res[c];
            out[at] = static_cast<std::uint8_t>(o.status[c]);
            out[at + 1] = static_cast<std::uint8_t>((o.provisional[c] ? 1 : 0) | (res.wants_exact ? 2 : 0));
            out[at + 2] = static_cast<std::uint8_t>(res.n_discs);
            out[at + 3] = static_cast<std::uint8_t>(res.n_infinite);
            out[at + 4] = static_cast<std::uint8_t>(res.escalation);
            at += 5;
            for (int i = 0; i < res.n_discs; ++i) {
                const RootDisc& d = res.discs[i];
                put8(d.re);
                put8(d.im);
                put8(d.radius);
                out[at] = static_cast<std::uint8_t>(d.count);
                out[at + 1] = static_cast<std::uint8_t>((d.verified ? 1 : 0) | (d.real ? 2 : 0));
                at += 2;
            }
            if (o.provisional[c])
                for (int m = 0; m < n; ++m) {
                    put8(o.lane_re[c * n + m]);
                    put8(o.lane_im[c * n + m]);
                }
        }
    }
}

void PrimaryBatch::replay(const double* dx, const double* dy, const double* dz, int cells, const std::uint8_t* tape,
                          std::size_t size, std::size_t& at) {
    if (share_ladder_)
        for (int c = 0; c < cells; ++c) ladder_[c].clear();
    for (std::size_t k = 0; k < objects_.size(); ++k) {
        const int obj = static_cast<int>(k);
        Object& o = objects_[obj];
        if (!o.batched) continue;
        const int n = plan_.scene.objects[obj].degree;
        prepare(obj, dx, dy, dz, cells);
        for (int c = 0; c < cells; ++c) {
            o.provisional[c] = 0;
            o.complete[c] = 0;
            if (o.skip[c]) continue;
            need(size, at, 5);
            const std::uint8_t* h = tape + at;
            at += 5;
            const int n_discs = h[2], n_inf = h[3];
            if (h[0] > static_cast<int>(Status::TooLarge) || (h[1] & ~3) != 0 || n_discs > n || n_inf > n)
                throw std::invalid_argument("root field: a damaged entry");
            RootsResult& res = o.res[c];
            o.status[c] = static_cast<Status>(h[0]);
            o.provisional[c] = (h[1] & 1) ? 1 : 0;
            res.wants_exact = (h[1] & 2) != 0;
            res.n_discs = n_discs;
            res.n_infinite = n_inf;
            res.escalation = h[4];
            bool complete = o.status[c] == Status::Ok;
            for (int i = 0; i < n_discs; ++i) {
                need(size, at, 26);
                RootDisc& d = res.discs[i];
                std::memcpy(&d.re, tape + at, 8);
                std::memcpy(&d.im, tape + at + 8, 8);
                std::memcpy(&d.radius, tape + at + 16, 8);
                d.count = tape[at + 24];
                if ((tape[at + 25] & ~3) != 0 || d.count < 0 || d.count > n)
                    throw std::invalid_argument("root field: a damaged disc");
                d.verified = (tape[at + 25] & 1) != 0;
                d.real = (tape[at + 25] & 2) != 0;
                at += 26;
                complete = complete && d.verified;
            }
            o.complete[c] = complete ? 1 : 0;
            if (o.provisional[c]) {
                need(size, at, static_cast<std::size_t>(16) * n);
                for (int m = 0; m < n; ++m) {
                    std::memcpy(&o.lane_re[c * n + m], tape + at, 8);
                    std::memcpy(&o.lane_im[c * n + m], tape + at + 8, 8);
                    at += 16;
                }
            }
        }
    }
}

void PrimaryBatch::fill(int obj, int c, ObjectRoots& r, bool all) const {
    const Object& o = objects_[obj];
    const detail::PrimaryRun& p = o.run;
    if (all) {
        const int n = p.n;
        r.poly.n = n;
        r.poly.finite = p.finite[c] != 0;
        for (int k = 0; k <= n; ++k) {
            r.poly.c[k] = p.c[k][c];
            r.poly.r[k] = p.r[k][c];
        }
    }
    if (all || o.clipped) {
        if (!r.origin_is_plan) {
            const FramePlan::ObjectPlan& op = plan_.objects[obj];
            for (int a = 0; a < 3; ++a) r.ray.origin[a] = op.origin[a];
            r.origin_is_plan = true;
        }
        r.ray.direction[0] = Ball(p.dir[0][c], p.dir_rad[0][c]);
        r.ray.direction[1] = Ball(p.dir[1][c], p.dir_rad[1][c]);
        r.ray.direction[2] = Ball(p.dir[2][c], p.dir_rad[2][c]);
    }
    r.seeded = false;
    if (o.outside[c]) {
        r.set_outside_sphere();
        return;
    }
    if (o.skip[c]) {
        r.set_non_finite();
        return;
    }
    r.outside_sphere = false;
    r.res.bind(o.res[c]);
    r.res.memo = &o.memo[c];
    r.status = o.status[c];
    r.complete = o.complete[c] != 0;
    r.provisional = o.provisional[c] != 0;
    r.settled = false;
}

void PrimaryBatch::settle(int obj, int c, ObjectRoots& r) const {
    LadderMemo* memo = ladder_memo(c);
    const LadderMemo::Settled* known = nullptr;
    if (memo)
        for (const LadderMemo::Settled& e : memo->settled)
            if (e.obj == obj) known = &e;
    if (known != nullptr) {  // (another band of this sample settled it: the same answer)
        r.status = known->status;
        LadderMemo::copy(known->res, r.own);
    } else {
        const Object& o = objects_[obj];
        const detail::PrimaryRun& p = o.run;
        const int n = p.n;
        double coeffs[kMaxDegree + 1], radius[kMaxDegree + 1];
        for (int k = 0; k <= n; ++k) {
            coeffs[k] = p.c[k][c];
            radius[k] = p.r[k][c];
        }
        r.status = detail::find_roots_lane_seeded(coeffs, n + 1, plan_.params.method, r.own, o.lane_re + c * n,
                                                  o.lane_im + c * n, radius);
        if (memo && memo->settled.size() < LadderMemo::kEntries) {
            memo->settled.emplace_back();
            memo->settled.back().obj = obj;
            memo->settled.back().status = r.status;
            LadderMemo::copy(r.own, memo->settled.back().res);
        }
    }
    r.res.bind(r.own);
    r.complete = r.status == Status::Ok;
    for (int i = 0; i < r.res.n_discs && r.complete; ++i) r.complete = r.res.discs[i].verified;
    r.provisional = false;
    r.settled = true;
}

void PrimaryBatch::prepare(int obj, const double* dx, const double* dy, const double* dz, int cells) {
    Object& o = objects_[obj];
    const SurfaceSpec& s = plan_.scene.objects[obj];
    detail::primary_ray_polynomial_run(s, plan_.objects[obj], dx, dy, dz, cells, o.run, isa_);
    // A cell whose ray provably misses the clipping sphere is not
    // solved either (intersect's test, on the same balls).
    if (o.clipped && cull_) {
        detail::ObjectRay ray;
        for (int a = 0; a < 3; ++a) ray.origin[a] = plan_.objects[obj].origin[a];
        for (int c = 0; c < cells; ++c) {
            for (int a = 0; a < 3; ++a) ray.direction[a] = Ball(o.run.dir[a][c], o.run.dir_rad[a][c]);
            o.outside[c] = detail::ray_misses_sphere(ray, s.clip_radius) ? 1 : 0;
        }
    }
    for (int c = 0; c < cells; ++c) {
        o.skip[c] = o.run.finite[c] == 0 || o.outside[c] != 0;
        o.memo[c].groups = 0;
    }
}

bool PrimaryBatch::solve_real(int obj, int c, RootDisc* discs, int& n_discs) const {
    const Object& o = objects_[obj];
    const detail::PrimaryRun& p = o.run;
    const int n = p.n;
    const double radius = plan_.scene.objects[obj].clip_radius;
    detail::ObjectRay ray;
    for (int a = 0; a < 3; ++a) {
        ray.origin[a] = plan_.objects[obj].origin[a];
        ray.direction[a] = Ball(p.dir[a][c], p.dir_rad[a][c]);
    }
    // The segment: for any o', d' in the ray's balls, |o' + t d'| <= R
    // needs |o'| - R <= t |d'| <= |o'| + R, so t lies in [(|o| - so - R) /
    // (|d| + sd), (|o| + so + R) / (|d| - sd)] (so, sd: the sums of the
    // balls' radii, bounding the 2-norm of the offsets). Each bound is
    // computed in double and widened by 2^-24 relative, which covers its
    // few roundings (relative error below 16u) once |o| - so - R exceeds
    // 2^-16 (|o| + R): a smaller gap (the eye on or inside the sphere)
    // is left to the batch.
    double oo = 0.0, dd = 0.0, so = 0.0, sd = 0.0;
    for (int a = 0; a < 3; ++a) {
        oo += ray.origin[a].mid * ray.origin[a].mid;
        dd += ray.direction[a].mid * ray.direction[a].mid;
        so += ray.origin[a].rad;
        sd += ray.direction[a].rad;
    }
    const double no = std::sqrt(oo), nd = std::sqrt(dd);
    const double gap = no - so - radius;
    if (!(gap > 0x1p-16 * (no + radius)) || !(nd - sd > 0.5 * nd)) return false;
    double t_in = gap / (nd + sd) * (1.0 - 0x1p-24);
    double t_out = (no + so + radius) / (nd - sd) * (1.0 + 0x1p-24);
    if (!(t_in > 0.0) || !std::isfinite(t_out)) return false;
    // Narrower: the chord. With b = o.d / |d|^2 and X = R^2 - (|o|^2 -
    // (o.d)^2 / |d|^2) the sphere's points on the centre ray are t = -b +-
    // sqrt(X) / |d|. The computed X errs by at most 16u (|o|^2 + R^2) (a few
    // roundings of terms of that size, |o.d|^2 / |d|^2 <= |o|^2), and the
    // balls move it by at most 4 (|o| + R)(so + t_out sd) for t <= t_out;
    // |sqrt(x) - sqrt(y)| <= sqrt(|x - y|) bounds the half chord's error
    // whatever X is (a grazing ray included), and the same sum bounds the
    // centre's. The chord widened by four times that, intersected with the
    // segment above, still holds every point inside the sphere.
    {
        double od = 0.0;
        for (int a = 0; a < 3; ++a) od += ray.origin[a].mid * ray.direction[a].mid;
        const double x = radius * radius - (oo - od * od / dd);
        const double err = 16.0 * kUnitRoundoff * (oo + radius * radius) + 4.0 * (no + radius) * (so + t_out * sd);
        const double margin = 4.0 * (std::sqrt(err) + std::fabs(od / dd) * 0x1p-40) / (nd - sd) + 0x1p-30 * t_out;
        const double half = std::sqrt(std::max(x, 0.0)) / nd, mid = -od / dd;
        if (std::isfinite(margin) && std::isfinite(half) && std::isfinite(mid)) {
            t_in = std::max(t_in, (mid - half) - margin);
            t_out = std::min(t_out, (mid + half) + margin);
        }
        if (!(t_out > t_in)) return false;
    }
    const double w = (t_out - t_in) * (1.0 + 0x1p-40);
    double coeffs[kBatchKernelMaxDegree + 1], radii[kBatchKernelMaxDegree + 1];
    for (int k = 0; k <= n; ++k) {
        coeffs[k] = p.c[k][c];
        radii[k] = p.r[k][c];
    }
    detail::RealIsolation iso;
    if (!detail::real_roots_in(coeffs, radii, n, t_in, w, iso) || iso.n > kBatchKernelMaxDegree) return false;
    // Each root's disc: its interval, narrowed where the clipping sphere's
    // verdict needs it, and always for the first root kept (the one the
    // pixel shows: its value goes to the AOVs). The verdicts are the
    // decisions' own (modulus_fast, clip_fast: modulus_bounds' and
    // inside_clip's answers).
    // A first root kept that Newton's iteration does not pin down (a root
    // nearly double: a grazing ray) is left to the batch, whose ladder and
    // polish give its value: the real path writes no rougher value.
    bool first_kept = false;
    const detail::ClipSums sums = detail::clip_sums(ray);
    for (int i = 0; i < iso.n; ++i) {
        double lo = iso.lo[i], hi = iso.hi[i], value = NAN;
        Verdict v = Verdict::Unknown;
        bool tight = false;
        for (int pass = 0; pass < 2; ++pass) {
            RootDisc& d = discs[i];
            // (Centred on Newton's settled iterate where there is one: the
            // root of the centres' polynomial, which the pixel shows.)
            d.re = tight && value >= lo && value <= hi ? value : 0.5 * lo + 0.5 * hi;
            d.im = 0.0;
            d.radius = next_up(std::max(d.re - lo, hi - d.re) * (1.0 + 4.0 * kUnitRoundoff));
            d.count = 1;
            d.verified = true;
            d.real = true;
            double mlo, mhi;
            detail::modulus_fast(d, mlo, mhi);
            // (A wide disc the quick test leaves open is narrowed first.)
            v = pass == 0 ? detail::clip_quick(ray, sums, mlo, mhi, radius)
                          : detail::clip_fast(ray, sums, mlo, mhi, radius);
            const bool wants_value = v == Verdict::Yes && !first_kept;
            if ((v != Verdict::Unknown && !wants_value) || pass == 1) break;
            if (!detail::narrow_real_root(coeffs, radii, n, lo, hi, &tight, iso.guess[i], &value)) break;
        }
        if (v == Verdict::Unknown || (v == Verdict::Yes && !first_kept && !tight)) return false;
        first_kept = first_kept || v == Verdict::Yes;
    }
    n_discs = iso.n;
    return true;
}

void PrimaryBatch::need(std::size_t size, std::size_t at, std::size_t bytes) {
    if (at > size || size - at < bytes) throw std::invalid_argument("root field: the tape ends early");
}

void Tracer::solve(ObjectRoots& r, int degree, const Seeds* seed) {
    ++root_calls;
    r.outside_sphere = false;
    r.provisional = r.settled = false;
    if (!r.poly.finite) {
        r.set_non_finite();  // (not seeded: no seed was used, so no retry without)
        return;
    }
    r.seeded = seed != nullptr;
    r.status = find_roots(r.poly.c, degree + 1, plan_.params.method, r.own, seed ? seed->re : nullptr,
                          seed ? seed->im : nullptr, r.poly.r);
    r.res.bind(r.own);
    r.complete = r.status == Status::Ok;
    for (int i = 0; i < r.res.n_discs && r.complete; ++i) r.complete = r.res.discs[i].verified;
    // As PrimaryBatch::solve (find_roots snaps only approximations within
    // 64 ulps of the axis; the band verdicts are the same either way). (r.res
    // views r.own's discs.)
    if (r.complete) flag_real_by_mirror(r.own.discs, r.own.n_discs);
}

}  // namespace argand::detail
