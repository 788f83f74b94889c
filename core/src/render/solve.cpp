// render/solve.cpp: the roots of a tile's rays: the primary rays' batches
// (PrimaryBatch: ray polynomials, batched roots, the root field's tape)
// and the scalar path's find_roots (Tracer::solve).
#include "solve.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "../root_kernels.h"
#include "tracer.h"

namespace argand::detail {

void PrimaryBatch::solve(const double* dx, const double* dy, const double* dz, int cells, int first) {
    const int n_obj = static_cast<int>(objects_.size());
    for (int obj = 0; obj < n_obj; ++obj) {
        Object& o = objects_[obj];
        if (!o.batched) continue;
        const int n = plan_.scene.objects[obj].degree;
        prepare(obj, dx, dy, dz, cells);
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
        rows.skip = o.skip;
        rows.rows = cells;
        rows.stride = kCells;
        rows.n_coeffs = n + 1;
        rows.provisional = o.provisional;
        rows.lane_re = o.lane_re;
        rows.lane_im = o.lane_im;
        find_roots_soa(rows, plan_.params.method, o.res, o.status, isa_);
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
    for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
        const Object& o = objects_[obj];
        if (!o.batched) continue;
        const int n = plan_.scene.objects[obj].degree;
        for (int c = 0; c < cells; ++c) {
            if (o.skip[c]) continue;
            const RootsResult& res = o.res[c];
            const std::uint8_t head[5] = {static_cast<std::uint8_t>(o.status[c]),
                                          static_cast<std::uint8_t>((o.provisional[c] ? 1 : 0) |
                                                                    (res.wants_exact ? 2 : 0)),
                                          static_cast<std::uint8_t>(res.n_discs),
                                          static_cast<std::uint8_t>(res.n_infinite),
                                          static_cast<std::uint8_t>(res.escalation)};
            tape.insert(tape.end(), head, head + 5);
            for (int i = 0; i < res.n_discs; ++i) {
                const RootDisc& d = res.discs[i];
                put(tape, d.re);
                put(tape, d.im);
                put(tape, d.radius);
                tape.push_back(static_cast<std::uint8_t>(d.count));
                tape.push_back(static_cast<std::uint8_t>((d.verified ? 1 : 0) | (d.real ? 2 : 0)));
            }
            if (o.provisional[c])
                for (int m = 0; m < n; ++m) {
                    put(tape, o.lane_re[c * n + m]);
                    put(tape, o.lane_im[c * n + m]);
                }
        }
    }
}

void PrimaryBatch::replay(const double* dx, const double* dy, const double* dz, int cells, const std::uint8_t* tape,
                          std::size_t size, std::size_t& at) {
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
    r.status = o.status[c];
    r.complete = o.complete[c] != 0;
    r.provisional = o.provisional[c] != 0;
    r.settled = false;
}

void PrimaryBatch::settle(int obj, int c, ObjectRoots& r) const {
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
    for (int c = 0; c < cells; ++c) o.skip[c] = o.run.finite[c] == 0 || o.outside[c] != 0;
}

void PrimaryBatch::put(std::vector<std::uint8_t>& tape, double v) {
    std::uint8_t b[8];
    std::memcpy(b, &v, 8);
    tape.insert(tape.end(), b, b + 8);
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
}

}  // namespace argand::detail
