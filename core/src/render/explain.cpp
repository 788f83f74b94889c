// render/explain.cpp: explain_pixel: one pixel's decisions, from the very
// code path render_tile runs, and Tracer::record, which writes them.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "argand/render.h"
#include "camera.h"
#include "sample.h"
#include "solve.h"
#include "tracer.h"

namespace argand {
namespace detail {

void Tracer::record(const ObjectRoots* roots, const std::vector<DiscInfo>& infos, const HitInfo& h, PixelExplanation* t) const {
    const int n_obj = static_cast<int>(plan_.scene.objects.size());
    t->polynomials.clear();
    t->discs.clear();
    for (int obj = 0; obj < n_obj; ++obj) {
        const ObjectRoots& r = roots[obj];
        ExplainedPolynomial p;
        p.object = obj;
        p.coeffs.assign(r.poly.c, r.poly.c + plan_.scene.objects[obj].degree + 1);
        p.radius.assign(r.poly.r, r.poly.r + plan_.scene.objects[obj].degree + 1);
        p.roots_status = static_cast<int>(r.status);
        p.seeded = r.seeded;
        p.root_escalation = r.res.escalation;
        p.complete = r.complete && !r.outside_sphere;  // (no disc covers its roots: none was sought)
        p.outside_sphere = r.outside_sphere;
        p.provisional = r.provisional;
        p.settled = r.settled;
        t->polynomials.push_back(std::move(p));
    }
    for (const DiscInfo& i : infos) {
        ExplainedDisc e;
        e.object = i.object;
        e.disc = roots[i.object].res.discs[i.index];
        e.modulus_lo = i.lo;
        e.modulus_hi = i.hi;
        e.real = i.real;
        e.at_origin = i.at_origin;
        e.band = static_cast<std::uint8_t>(i.band);
        // (The sphere is not evaluated for a disc proven out of the band.)
        e.clip = i.band == Verdict::No ? 3 : static_cast<std::uint8_t>(i.clip);
        e.live = i.live;
        e.eligible = i.eligible;
        t->discs.push_back(e);
    }
    t->chosen = decider_.chosen();
    t->hit = h.hit;
    t->status = h.status;
    t->level = h.level;
}

}  // namespace detail

namespace {

using namespace detail;

const char* status_reason(std::uint8_t status) {
    switch (status) {
        case kCertified: return "every decision proven";
        case kCluster: return "a deciding disc holds several roots (or the ray lies in the surface)";
        case kUnverified: return "a root of the ray polynomial is not enclosed (or a coefficient overflowed)";
        default: return "a band edge, the clipping sphere or another root's modulus lies within a deciding disc";
    }
}

}  // namespace

PixelExplanation explain_pixel(const FramePlan& plan, int x, int y, int row_start, int sample,
                               const ExactSolver* exact, int column_start) {
    const FrameParams& fp = plan.params;
    if (x < 0 || x >= fp.width || y < 0 || y >= fp.height)
        throw std::invalid_argument("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is not inside the " +
                                    std::to_string(fp.width) + "x" + std::to_string(fp.height) + " frame");
    if (row_start < 0 || row_start > x) throw std::invalid_argument("row_start must be in 0..x");
    if (column_start < 0 || column_start > y) throw std::invalid_argument("column_start must be in 0..y");
    if (sample < 0 || sample >= fp.samples)
        throw std::invalid_argument("sample must be in 0.." + std::to_string(fp.samples - 1));
    // Replay the tile's row of samples from its first sample, or from the
    // first of the pixel's seed block (the neighbour seeds render_tile
    // would have), then trace the sample.
    const int side = sample_side(fp.samples);
    const int sx_cell = side * x + sample % side, sy_cell = side * y + sample / side;
    const int first_cell = std::max(side * row_start, sx_cell - sx_cell % kSeedBlock);
    const int first_row = std::max(side * column_start, sy_cell - sy_cell % kSeedBlock);
    const bool cull = plan.params.engine.cull;
    Tracer tracer(plan, exact, cull);
    tracer.explaining_ = true;
    PrimaryBatch batch(plan, resolved_kernel(plan.params.engine), cull);
    // (The frame's own path: a lone band's tile takes the real path where
    // render_tile does.)
    if (plan.params.engine.real) batch.use_real_path(plan.params.sigma == 0.0 && plan.params.delta == 0.0);
    std::vector<Seeds> seeds(plan.scene.objects.size());
    PixelExplanation e;
    // A batched object's discs depend on its own ray and its seeds, the
    // roots of the samples above it in the tile (not on the other lanes):
    // replay that column from the tile's first row with batches of one,
    // then the row for the scalar objects' neighbour seeds.
    batch.begin_tile(1);
    double dir[3];
    if (batch.any())
        for (int sy = first_row; sy < sy_cell; ++sy) {
            sample_direction(plan, sx_cell, sy, side, dir);
            batch.solve(dir, dir + 1, dir + 2, 1, 0);
        }
    for (int c = first_cell; c <= sx_cell; ++c) {
        const BatchedCell pre{&batch, 0};
        const bool batched = batch.any() && c == sx_cell;
        if (batched) {
            sample_direction(plan, c, sy_cell, side, dir);
            batch.solve(dir, dir + 1, dir + 2, 1, 0);
        }
        trace_sample(plan, tracer, c, sy_cell, side, seeds.data(), c == sx_cell ? &e : nullptr,
                     batched ? &pre : nullptr);
    }
    e.reason = e.exact_ran && !e.exact.reason.empty() ? e.exact.reason : status_reason(e.status);
    return e;
}

}  // namespace argand
