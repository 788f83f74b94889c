// render/render_tile.cpp: render_tile and render_tile_bands: a tile's
// samples, row of samples by row of samples, their primary roots solved in
// batches once for every band, then each band's decisions, ladder and
// shading (tracer.h), each pixel's samples folded into its AOVs (film.h).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "argand/render.h"
#include "../ray_polynomial.h"
#include "film.h"
#include "sample.h"
#include "solve.h"
#include "tracer.h"

namespace argand {
namespace {

using namespace detail;

TileRect clamp_rect(const FramePlan& plan, const TileRect& rect_in) {
    const FrameParams& fp = plan.params;
    return TileRect{std::max(0, rect_in.x0), std::max(0, rect_in.y0), std::min(fp.width, rect_in.x1),
                    std::min(fp.height, rect_in.y1)};
}

}  // namespace

void render_tile(const FramePlan& plan, const TileRect& rect_in, TileAOVs& out, const ExactSolver* exact) {
    const TileRect r = clamp_rect(plan, rect_in);
    TileView v = allocate(out, std::max(0, r.x1 - r.x0), std::max(0, r.y1 - r.y0));
    render_tile(plan, r, v, exact);
    out.escalations = v.escalations;
    out.root_calls = v.root_calls;
}

namespace {
void render_tile_view(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact);
}  // namespace

void render_tile(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact) {
    const TileRect r = clamp_rect(plan, rect_in);
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    if (out.stride <= w || h <= 1) {
        render_tile_view(plan, r, out, exact);
        return;
    }
    // Rows of out a frame's row apart: render into the thread's staging
    // tile and copy it over once done. (Written pixel by pixel at such
    // strides, the frame's cache lines were fetched while the tile was
    // traced, and the loads of the next run of samples waited behind those
    // pending stores: a 64x64 tile of a 1024x1024 frame took some 12% longer
    // than the same tile traced into arrays of its own.)
    static thread_local TileStaging staging;
    TileView& v = staging.view(w, h);
    render_tile_view(plan, r, v, exact);
    staging.flush(out);
    out.width = w;
    out.height = h;
}

namespace {
/// What one band of a tile keeps while the tile is traced: the band's plan,
/// its tracer (ladder, scratch, counters), its neighbour seeds, its row of
/// pixel accumulators and where its pixels go.
struct BandTrace {
    BandTrace(const FramePlan& plan, const ExactSolver* exact, TileView& out, int w)
        : plan(plan), tracer(plan, exact, plan.params.engine.cull), seeds(plan.scene.objects.size()),
          row(static_cast<std::size_t>(w)), out(out) {}
    const FramePlan& plan;
    Tracer tracer;
    std::vector<Seeds> seeds;
    std::vector<PixelAccumulator> row;
    TileView& out;
};

/// The colour the last band gave a sample's certified hit, and the root it
/// shaded (shade reads the hit's object, disc centre and modulus).
struct ShadeMemo {
    bool valid = false;
    int object = -1;
    double re = 0, im = 0, modulus = 0;
    float rgb[3] = {0, 0, 0};
    bool same(const HitInfo& h) const {
        return h.object == object && std::memcmp(&h.disc.re, &re, sizeof re) == 0 &&
               std::memcmp(&h.disc.im, &im, sizeof im) == 0 && std::memcmp(&h.modulus, &modulus, sizeof modulus) == 0;
    }
    void keep(const HitInfo& h, const float* colour) {
        valid = true;
        object = h.object;
        re = h.disc.re;
        im = h.disc.im;
        modulus = h.modulus;
        for (int a = 0; a < 3; ++a) rgb[a] = colour[a];
    }
};

/// A root field's header: its format, the rays it belongs to
/// (rays_fingerprint) and the tile (clamped) it holds.
void field_header(const FramePlan& plan, const TileRect& r, std::vector<std::uint8_t>& out) {
    const char magic[8] = {'A', 'R', 'G', 'F', 'I', 'E', 'L', '1'};
    out.insert(out.end(), magic, magic + 8);
    const std::uint64_t f = rays_fingerprint(plan);
    const std::int32_t rect[4] = {r.x0, r.y0, r.x1, r.y1};
    unsigned char b[8 + sizeof rect];
    std::memcpy(b, &f, 8);
    std::memcpy(b + 8, rect, sizeof rect);
    out.insert(out.end(), b, b + sizeof b);
}

void reset_figures(TileView& out, int w, int h) {
    out.width = w;
    out.height = h;
    out.escalations = 0;
    out.root_calls = 0;
    out.hits = 0;
    std::fill(std::begin(out.by_status), std::end(out.by_status), 0);
    std::fill(std::begin(out.by_level), std::end(out.by_level), 0);
}

/// The bands counted, not written, of a one-object scene the batch solves,
/// one sample per pixel, no bounce (Tracer::decide_counted), in the order
/// of the tile's bands: each sample is decided for all of them before the
/// bands' loop (decide_counted_run; the answers read only the sample's
/// roots and its memos, so their order changes none), and a band's loop
/// then takes only the samples they left undecided, in its own order.
struct CountedBands {
    /// `active`: the tile's samples take this path (else no band is counted here).
    CountedBands(std::vector<std::unique_ptr<BandTrace>>& bands, bool active) {
        for (std::size_t b = 0; b < bands.size() && active; ++b)
            if (bands[b]->out.rgba == nullptr) {
                of.push_back(static_cast<int>(b));
                trace.push_back(bands[b].get());
                plans.push_back(bands[b]->tracer.counted_plan());
            }
        keys.resize(of.size());
        decided.resize(of.size());
        counts.resize(of.size());
    }
    /// What write_single adds to a band's figures for the certified samples
    /// intersect_batched gives, counted here and added once (flush).
    struct Counts {
        std::uint64_t decided = 0, tier = 0, hits = 0, calls = 0;
    };
    std::vector<int> of;  // the counted bands' indices among the tile's
    std::vector<BandTrace*> trace;
    std::vector<const detail::ClassifyPlan*> plans;  // (band_keys_four's)
    std::vector<std::uint16_t> keys;
    std::vector<std::uint64_t> decided;  // per counted band: bit c, sample c of the run decided
    std::vector<Counts> counts;

    /// Adds the counts to the bands' figures (before their root calls are read).
    void flush() {
        static_assert(kLevelRootTier > kLevelFirst, "a root-tier level counts as an escalation");
        for (std::size_t k = 0; k < of.size(); ++k) {
            const Counts& n = counts[k];
            TileView& out = trace[k]->out;
            out.escalations += static_cast<std::int64_t>(n.tier);
            out.by_status[kCertified & 3] += static_cast<std::int64_t>(n.decided);
            out.by_level[kLevelFirst & 7] += static_cast<std::int64_t>(n.decided - n.tier);
            out.by_level[kLevelRootTier & 7] += static_cast<std::int64_t>(n.tier);
            out.hits += static_cast<std::int64_t>(n.hits);
            trace[k]->tracer.root_calls += static_cast<std::int64_t>(n.calls);
            counts[k] = Counts{};
        }
    }
};

/// The counted bands' decisions of a run of `cells` samples: each sample's
/// roots filled once (`shared`), then decided for every counted band, in
/// order, and bit c of cb.decided[k] set where band k decides. Four discs
/// are read once for all the bands' verdicts (band_keys_four); a band whose
/// verdicts are the band before's takes its answer, and one whose verdicts
/// the sample's memo holds takes that (Decider::decide_one_keyed): past
/// those verdicts a decision reads only the discs, the ray and the memo
/// (unless a disc needed the reference's band test: then no band shares it).
void decide_counted_run(PrimaryBatch& batch, int cells, std::vector<ObjectRoots>& shared, CountedBands& cb) {
    const int n = static_cast<int>(cb.of.size());
    std::fill(cb.decided.begin(), cb.decided.end(), 0);
    for (int c = 0; c < cells; ++c) {
        ObjectRoots& r = shared[c];
        batch.fill(0, c, r, false);
        r.have_dd = false;
        const bool keyed = cb.trace[0]->tracer.counted_keyable(r);
        if (keyed) detail::band_keys_four(r.res.discs, cb.plans.data(), n, cb.keys.data());
        const bool tier = Tracer::counted_level(r) != kLevelFirst;
        const bool call = !r.outside_sphere;
        const std::uint16_t* keys = cb.keys.data();
        std::uint64_t* decided = cb.decided.data();
        CountedBands::Counts* counts = cb.counts.data();
        const std::uint64_t bit = std::uint64_t{1} << c;
        int last_key = -1;  // (the band before's verdicts where its answer is theirs, and that answer)
        bool ok = false, hit = false;
        for (int k = 0; k < n; ++k) {
            if (!keyed || keys[k] != last_key) {
                Tracer& t = cb.trace[k]->tracer;
                bool shared = false;
                ok = keyed ? t.decide_counted_keyed(r, keys[k], hit, shared) : t.decide_counted(r, hit);
                last_key = shared ? keys[k] : -1;
            }
            if (!ok) continue;
            decided[k] |= bit;
            CountedBands::Counts& m = counts[k];
            ++m.decided;
            m.tier += tier;
            m.hits += hit;
            m.calls += call;
        }
    }
}

/// Traces the tile r of every band of `plans` (same rays: same_rays) into
/// `outs`. The primary rays' batched roots do not depend on the band
/// (PrimaryBatch::solve reads the scene, the camera, the method and the
/// seeds of its own earlier solves, never sigma or delta): each run of
/// samples is solved once, then every band decides, climbs its own ladder
/// and shades from those discs with its own tracer and seeds, in the order
/// a tile of that band alone is traced. So each band's pixels are the bits
/// render_tile gives for its plan alone, by construction.
void render_tile_views(const std::vector<const FramePlan*>& plans, const TileRect& r,
                       const std::vector<TileView*>& outs, const ExactSolver* exact, RootField* record,
                       const RootField* replay) {
    const FramePlan& plan = *plans[0];
    const FrameParams& fp = plan.params;
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    const int side = sample_side(fp.samples);
    if (side == 0) throw std::invalid_argument("samples must be a square from 1 to " + std::to_string(kMaxSamples));
    std::vector<std::unique_ptr<BandTrace>> bands;
    bands.reserve(plans.size());
    for (std::size_t b = 0; b < plans.size(); ++b) {
        reset_figures(*outs[b], w, h);
        bands.push_back(std::make_unique<BandTrace>(*plans[b], exact, *outs[b], w));
    }
    PrimaryBatch batch(plan, resolved_kernel(plan.params.engine), plan.params.engine.cull);
    batch.share_ladder(bands.size() > 1);  // (the ladder's answers, for the other bands of a sample)
    batch.begin_tile(side * w);
    // The real-root path (EngineOptions::real), for the objects every band
    // here shows only real roots of; not while a root field is kept.
    if (plan.params.engine.real && !record && !replay) {
        bool real_bands = true;
        for (const FramePlan* p : plans) real_bands = real_bands && p->params.sigma == 0.0 && p->params.delta == 0.0;
        batch.use_real_path(real_bands);
    }
    // The root field: recorded as the batch solves, or replayed instead of
    // solving (its header names the rays and the tile it holds).
    std::size_t at = 0;
    if (record) field_header(plan, r, record->bytes);
    if (replay) {
        std::vector<std::uint8_t> want;
        field_header(plan, r, want);
        if (replay->bytes.size() < want.size() || std::memcmp(replay->bytes.data(), want.data(), want.size()) != 0)
            throw std::invalid_argument("root field: it holds another tile, scene, camera or set of parameters");
        at = want.size();
    }
    // Every object solved in the batch: a certified sample may take
    // Tracer::intersect_batched (intersect's result, the ladder unneeded).
    bool all_batched = batch.any();
    for (std::size_t obj = 0; obj < plan.scene.objects.size(); ++obj)
        all_batched = all_batched && batch.batched(static_cast<int>(obj));
    alignas(64) double dx[PrimaryBatch::kCells], dy[PrimaryBatch::kCells], dz[PrimaryBatch::kCells];
    // Per object: whether shading its root at depth 0 traces further rays
    // (shade's `bounces`), whose decisions would depend on the band.
    std::vector<char> bounces;
    for (const SurfaceSpec& s : plan.scene.objects)
        bounces.push_back(!s.complex_space && 0 < fp.max_depth &&
                          (s.material.reflectivity > 0 || s.material.transparency > 0));
    const bool any_bounce = std::find(bounces.begin(), bounces.end(), 1) != bounces.end();
    ShadeMemo memo[PrimaryBatch::kCells];
    PolishMemo polished[PrimaryBatch::kCells];
    // Bands counted, not written, of a one-object scene the batch solves,
    // one sample per pixel, no bounce: their decisions read the sample's
    // roots filled once (Tracer::decide_counted), not once per band.
    const bool counted_path = all_batched && plan.scene.objects.size() == 1 && side == 1 && !any_bounce;
    int counted_bands = 0;
    for (const auto& band : bands) counted_bands += band->out.rgba == nullptr;
    std::vector<ObjectRoots> shared(counted_path && counted_bands > 0 ? PrimaryBatch::kCells : 0);
    static_assert(PrimaryBatch::kCells <= 64, "a counted band's decided samples: one bit per cell");
    CountedBands counted(bands, !shared.empty());
    std::vector<int> counted_slot(bands.size(), -1);  // band -> its index in `counted`
    for (std::size_t k = 0; k < counted.of.size(); ++k) counted_slot[counted.of[k]] = static_cast<int>(k);
    const bool share_colours = bands.size() > 1;  // (a lone frame has no other band to share with)
    detail::SampleRowInput row_in;
    for (int a = 0; a < 3; ++a) {
        row_in.forward[a] = plan.forward[a];
        row_in.right[a] = plan.right[a];
        row_in.up[a] = plan.up[a];
    }
    // sample_direction's quantities, computed as there.
    row_in.tan_half_fov = plan.tan_half_fov;
    row_in.aspect = static_cast<double>(fp.width) / fp.height;
    row_in.cols = static_cast<double>(side) * fp.width;
    const double rows_total = static_cast<double>(side) * fp.height;
    // The samples are traced in the order of the (side W) x (side H) frame's
    // pixels: row of samples by row of samples, left to right, the
    // neighbour seeds flowing along each row of samples. With a batched
    // kernel, each run of PrimaryBatch::kCells samples of a row of samples
    // has its primary roots solved together first.
    // Seeds flow within blocks of kSeedBlock x kSeedBlock samples aligned
    // on the frame's grid of samples (FrameParams::seed_from_neighbour):
    // the batch's seeds from above restart at each block's first row of
    // samples, the scalar path's from the left at each block's first column.
    for (int y = r.y0; y < r.y1; ++y) {
        if (side > 1)
            for (auto& band : bands) std::fill(band->row.begin(), band->row.end(), PixelAccumulator{});
        for (int j = 0; j < side; ++j) {
            for (auto& band : bands)
                for (Seeds& s : band->seeds) s.valid = false;
            const int c0 = side * r.x0, c1 = side * r.x1, sy = side * y + j;
            if (sy != side * r.y0 && sy % kSeedBlock == 0 && batch.any()) batch.begin_tile(side * w);
            for (int b0 = c0; b0 < c1; b0 += PrimaryBatch::kCells) {
                const int cells = std::min(PrimaryBatch::kCells, c1 - b0);
                if (batch.any()) {
                    row_in.sy = (1.0 - 2.0 * (sy + 0.5) / rows_total) * plan.tan_half_fov;
                    detail::sample_direction_run(row_in, b0, cells, dx, dy, dz, batch.isa());
                    if (replay) {
                        batch.replay(dx, dy, dz, cells, replay->bytes.data(), replay->bytes.size(), at);
                    } else {
                        batch.solve(dx, dy, dz, cells, b0 - c0);
                        if (record) batch.record(record->bytes, cells);
                    }
                }
                for (int c = 0; c < cells; ++c) memo[c].valid = polished[c].valid = false;
                if (!counted.of.empty()) decide_counted_run(batch, cells, shared, counted);
                for (std::size_t b = 0; b < bands.size(); ++b) {
                    auto& band = bands[b];
                    Tracer& tracer = band->tracer;
                    const std::size_t stride = static_cast<std::size_t>(band->out.stride);
                    // A band counted, not written (TileView without planes),
                    // whose hits bounce no ray: its certified hits need no
                    // value and no colour (shade then reads nothing the
                    // figures count: no ray, no root call), so neither is made.
                    const bool values = band->out.rgba != nullptr || any_bounce;
                    const std::uint64_t done = counted_slot[b] >= 0 ? counted.decided[counted_slot[b]] : 0;
                    if (cells == 64 ? done == ~std::uint64_t{0} : done == (std::uint64_t{1} << cells) - 1) {
                        // (Every sample decided: only the seeds' restarts of
                        // the loop below, which no sample here reads.)
                        for (int c = 0; c < cells; ++c)
                            if ((b0 + c) % kSeedBlock == 0) {
                                for (Seeds& s : band->seeds) s.valid = false;
                                break;
                            }
                        continue;
                    }
                    for (int c = 0; c < cells; ++c) {
                        const BatchedCell pre{&batch, c};
                        const int sx = b0 + c;
                        if (sx % kSeedBlock == 0)
                            for (Seeds& s : band->seeds) s.valid = false;
                        if (done >> c & 1) continue;  // (decided and counted by decide_counted_run)
                        // (The run's directions are sample_direction's, to the bit.)
                        const double dir[3] = {dx[c], dy[c], dz[c]};
                        SampleResult sample;
                        bool filled = false;
                        if (all_batched && tracer.intersect_batched(pre, sample.hit, filled, values, dir,
                                                                  share_colours ? &polished[c] : nullptr)) {
                            // trace_sample's shading of the certified hit (the
                            // ray's origin is the eye's doubles). Shading a
                            // root that bounces no ray reads only the root,
                            // the ray and what the bands share: a band that
                            // chose the root an earlier band of this sample
                            // chose takes that band's colour, the same bits.
                            ShadeMemo& m = memo[c];
                            if (!values) {
                                for (float& v : sample.rgb) v = 0.0f;
                            } else if (share_colours && sample.hit.hit && m.valid && m.same(sample.hit)) {
                                for (int a = 0; a < 3; ++a) sample.rgb[a] = m.rgb[a];
                            } else {
                                double rgb[3];
                                if (sample.hit.hit) tracer.shade(plan.eye, dir, sample.hit, 0, rgb);
                                else for (int a = 0; a < 3; ++a) rgb[a] = plan.scene.background[a];
                                for (int a = 0; a < 3; ++a) sample.rgb[a] = static_cast<float>(rgb[a]);
                                if (share_colours && sample.hit.hit && !bounces[sample.hit.object])
                                    m.keep(sample.hit, sample.rgb);
                            }
                        } else {
                            sample = trace_sample(band->plan, tracer, sx, sy, side, band->seeds.data(), nullptr,
                                                  batch.any() ? &pre : nullptr, batch.any() ? dir : nullptr, filled);
                        }
                        // One sample per pixel: straight to the AOVs (the same
                        // bits as add() then write(), without the copies).
                        if (side == 1)
                            PixelAccumulator::write_single(band->out, static_cast<std::size_t>(y - r.y0) * stride + (sx - r.x0),
                                                           sample);
                        else band->row[sx / side - r.x0].add(sample);
                    }
                }
            }
        }
        if (side > 1)
            for (auto& band : bands) {
                const std::size_t stride = static_cast<std::size_t>(band->out.stride);
                for (int x = 0; x < w; ++x) band->row[x].write(band->out, static_cast<std::size_t>(y - r.y0) * stride + x);
            }
    }
    counted.flush();
    for (auto& band : bands) band->out.root_calls = band->tracer.root_calls;
    if (replay && at != replay->bytes.size())
        throw std::invalid_argument("root field: it holds more than the tile's samples");
}

void render_tile_view(const FramePlan& plan, const TileRect& rect_in, TileView& out, const ExactSolver* exact) {
    render_tile_views({&plan}, clamp_rect(plan, rect_in), {&out}, exact, nullptr, nullptr);
}
}  // namespace

void render_tile_bands(const std::vector<const FramePlan*>& plans, const TileRect& rect_in,
                       const std::vector<TileView*>& outs, const ExactSolver* exact, RootField* record,
                       const RootField* replay) {
    if (record && replay) throw std::invalid_argument("render_tile_bands: record a root field or replay one, not both");
    if (record) record->bytes.clear();
    if (plans.empty() || plans.size() != outs.size())
        throw std::invalid_argument("render_tile_bands needs one output per plan, and at least one plan");
    for (std::size_t b = 1; b < plans.size(); ++b)
        if (!same_rays(*plans[0], *plans[b]))
            throw std::invalid_argument("render_tile_bands: plan " + std::to_string(b) +
                                        " does not share plan 0's scene, camera and parameters (only sigma and delta "
                                        "may differ)");
    const TileRect r = clamp_rect(*plans[0], rect_in);
    const int w = std::max(0, r.x1 - r.x0), h = std::max(0, r.y1 - r.y0);
    // Bands whose rows lie a frame's row apart are traced into staging
    // tiles of their own and copied over once done (see render_tile).
    static thread_local std::vector<std::unique_ptr<TileStaging>> staging;
    std::vector<TileView*> views(outs.size());
    std::vector<int> staged(outs.size(), -1);
    int used = 0;
    for (std::size_t b = 0; b < outs.size(); ++b) {
        if (outs[b]->stride <= w || h <= 1) {
            views[b] = outs[b];
            continue;
        }
        if (static_cast<int>(staging.size()) <= used) staging.push_back(std::make_unique<TileStaging>());
        staged[b] = used;
        views[b] = &staging[used++]->view(w, h);
    }
    render_tile_views(plans, r, views, exact, record, replay);
    for (std::size_t b = 0; b < outs.size(); ++b) {
        if (staged[b] < 0) continue;
        staging[staged[b]]->flush(*outs[b]);
        outs[b]->width = w;
        outs[b]->height = h;
    }
}

}  // namespace argand
