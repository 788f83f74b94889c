// render/solve.h: the roots of a ray: the discs the decisions read
// (RootsView, ObjectRoots), the neighbour seeds, and the primary rays'
// roots solved ahead in batches (PrimaryBatch). Tracer::solve, the scalar
// path, is in solve.cpp. Internal header.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "argand/render.h"
#include "argand/roots_batch.h"
#include "../pixel_decision.h"
#include "../ray_polynomial.h"
#include "vec3.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// The discs the decisions read (ObjectRoots::res), with RootsResult's
/// field names: discs[i], n_discs, n_infinite, wants_exact, escalation.
/// It points either at the tracer's own RootsResult (the scalar path, and a
/// batched sample whose discs refine changes) or straight at PrimaryBatch's
/// storage of the sample's RootsResult (no copy per sample), which stays
/// unchanged until the batch's next solve, after the sample's decisions.
struct RootsView {
    const RootDisc* discs = nullptr;
    std::int32_t n_discs = 0;
    std::int32_t n_infinite = 0;
    bool wants_exact = false;
    std::int32_t escalation = 0;
    // The band-independent verdicts of these discs on this ray
    // (detail::ClassifyMemo), where the bands of a tile share them: set by
    // PrimaryBatch::fill for the batch's discs, null for any other.
    ClassifyMemo* memo = nullptr;
    void bind(const RootsResult& r) {
        memo = nullptr;
        discs = r.discs;
        n_discs = r.n_discs;
        n_infinite = r.n_infinite;
        wants_exact = r.wants_exact;
        escalation = r.escalation;
    }
};

/// What the ladder computed for one primary sample of a batch beyond the
/// batch's own discs, kept for the tile's other bands of that sample: the
/// ladder's questions do not depend on the band (the ray is the same), only
/// which of them a band asks does. Every entry is the answer of a pure
/// function to the exact input kept with it, compared bit for bit: an
/// object's merged discs settled (PrimaryBatch::settle: find_roots from the
/// lane's approximations, a function of the cell and object alone), an
/// object's double-double ray polynomial (primary_ray_polynomial_dd of the
/// sample's direction), a cluster's polynomial re-isolated (isolate_dd on
/// the discs it started from) and a disc shrunk (refine_disc_dd on that
/// disc). So a band that asks a question another band asked takes the same
/// bits it would compute, and a band alone computes everything itself.
/// Bounded: past kEntries of a kind, answers are computed, not kept.
struct LadderMemo {
    static constexpr std::size_t kEntries = 32;
    struct Settled {
        int obj;
        Status status;
        RootsResult res;
    };
    struct Dd {
        int obj;
        RayCoefficients<DoubleDouble> p;
    };
    struct Isolated {
        int obj;
        bool done;
        std::uint8_t level;  // (kLevelRebased or kLevelDoubleDouble: which re-isolated)
        RootsResult in, out;
    };
    struct Shrunk {
        int obj;
        bool real, changed;
        RootDisc in, out;
    };
    std::vector<Settled> settled;
    std::vector<Dd> dd;
    std::vector<Isolated> isolated;
    std::vector<Shrunk> shrunk;

    void clear() {
        settled.clear();
        dd.clear();
        isolated.clear();
        shrunk.clear();
    }

    static bool same(double a, double b) {
        std::uint64_t x, y;
        std::memcpy(&x, &a, sizeof x);
        std::memcpy(&y, &b, sizeof y);
        return x == y;
    }
    static bool same(const RootDisc& a, const RootDisc& b) {
        return same(a.re, b.re) && same(a.im, b.im) && same(a.radius, b.radius) && a.count == b.count &&
               a.verified == b.verified && a.real == b.real;
    }
    static bool same(const RootsResult& a, const RootsResult& b) {
        if (a.n_discs != b.n_discs || a.n_infinite != b.n_infinite || a.wants_exact != b.wants_exact ||
            a.escalation != b.escalation)
            return false;
        for (int i = 0; i < a.n_discs; ++i)
            if (!same(a.discs[i], b.discs[i])) return false;
        return true;
    }
    static void copy(const RootsResult& from, RootsResult& to) {
        to.n_discs = from.n_discs;
        to.n_infinite = from.n_infinite;
        to.wants_exact = from.wants_exact;
        to.escalation = from.escalation;
        std::copy(from.discs, from.discs + from.n_discs, to.discs);
    }
};

/// One object's roots along the current ray.
///
/// For an object solved in a batch (PrimaryBatch::fill), res views the
/// batch's RootsResult, and poly and ray are copied only where something
/// reads them: poly for record (explain_pixel), ray where the object has a
/// clipping sphere (the only decisions that read it) or for record. A
/// batched object is never solved again by solve() (seeded is false), so
/// its poly is not needed there.
struct ObjectRoots {
    // (User-provided: a Tracer's slots are not zeroed first, some 2 KB of
    // discs and coefficients each; every field is written before it is
    // read, as for RootsResult.)
    ObjectRoots() {}
    RayCoefficients<double> poly;
    ObjectRay ray;
    RootsView res;      // what the decisions read
    RootsResult own;    // the discs of solve(), and refine's copy (writable())
    Status status = Status::Ok;
    bool seeded = false;
    bool complete = false;   // status Ok, finite, every disc verified
    bool outside_sphere = false;  // set_outside_sphere: not solved, a proven miss
    // The batch's lane merged its discs into clusters instead of solving
    // the row again (SoaRows::provisional): proven discs, which
    // PrimaryBatch::settle replaces with find_roots' answer from the lane's
    // approximations where a decision needs more than they prove.
    bool provisional = false;
    bool settled = false;  // (its merged discs did not decide: solved again, for --explain)
    bool have_dd = false;
    // ray.origin holds the object's plan origin (a primary ray's, as fill
    // and primary_ray_polynomial write it): fill need not copy it again.
    bool origin_is_plan = false;
    RayCoefficients<DoubleDouble> poly_dd;

    /// The discs as a RootsResult refine may change: own, holding a copy
    /// of the batch's discs first if res views the batch's (copy on write;
    /// the same fields fill used to copy). res views own afterwards; call
    /// res.bind(own) again after changing own's header.
    RootsResult& writable() {
        if (res.discs != own.discs) {
            own.n_discs = res.n_discs;
            own.n_infinite = res.n_infinite;
            own.wants_exact = res.wants_exact;
            own.escalation = res.escalation;
            std::copy(res.discs, res.discs + res.n_discs, own.discs);
            res.bind(own);
        }
        return own;
    }

    /// The ray provably misses the object's clipping sphere
    /// (detail::ray_misses_sphere): no root can be the pixel's, so nothing
    /// is solved, and the object holds no disc and blocks nothing (status
    /// Ok, complete: the decisions then see a proven miss, as they would
    /// with every disc's inside_clip No). Every header field is defined, as
    /// in set_non_finite.
    void set_outside_sphere() {
        set_empty(Status::Ok);
        complete = true;
        outside_sphere = true;
    }

    /// A ray polynomial whose coefficients are not all finite: nothing is
    /// solved or claimed. Every header field is defined (no discs, no
    /// roots at infinity, no root tier, not seeded), so nothing of the
    /// slot's previous sample (its escalation, say, which sets the pixel's
    /// ladder level) is read for this one.
    void set_non_finite() { set_empty(Status::NonFinite); }

private:
    /// No discs, no roots at infinity, no root tier, not seeded, not
    /// complete, with status s.
    void set_empty(Status s) {
        status = s;
        seeded = false;
        complete = false;
        outside_sphere = false;
        provisional = false;
        settled = false;
        own.n_discs = 0;
        own.n_infinite = 0;
        own.wants_exact = false;
        own.escalation = 0;
        res.bind(own);
    }
};

struct Seeds {
    // Per object, the previous pixel's roots (in t).
    double re[kMaxDegree], im[kMaxDegree];
    bool valid = false;
};

/// The root kernel an engine option names, Auto resolved to the widest this
/// CPU runs (plan_frame has refused the ones it does not run).
inline BatchIsa resolved_kernel(const EngineOptions& engine) {
    return engine.kernel == BatchIsa::Auto ? batch_isa_best() : engine.kernel;
}

/// The primary rays' root discs of a run of samples (consecutive cells of
/// one row of samples), solved ahead of their decisions: per object, the
/// samples' ray polynomials (with their coefficient radii) go into
/// find_roots_rows as one structure-of-arrays batch. Each row's discs carry
/// find_roots' contract for the family within the radii (the lanes prove
/// them with Smith's family term; rows the lanes drop are solved by
/// find_roots exactly as the scalar path solves them, without seeds), so
/// the decisions that follow, per sample, are proven as before. Objects of
/// degree above kBatchKernelMaxDegree, method "paper" and the scalar kernel
/// keep the sample-by-sample path (with neighbour seeds).
///
/// Seeds (degree 5 to 12, seed_from_neighbour): a lane starts from the roots
/// of the sample above it (the same cell of the previous row of samples of
/// the tile), the nearest neighbour that is already solved when a row is
/// batched; the first row of a tile starts on the circle. Seeds never change
/// what is proven, only how many Aberth sweeps a block needs.
class PrimaryBatch {
public:
    static constexpr int kCells = 32;  // samples per batch (two blocks of 16 lanes)

    PrimaryBatch(const FramePlan& plan, BatchIsa isa, bool cull) : plan_(plan), isa_(isa), cull_(cull) {
        static_assert(kCells == detail::kRunCells && kBatchKernelMaxDegree <= detail::kRunMaxDegree,
                      "PrimaryBatch's runs are primary_ray_polynomial_run's");
        static_assert(ClassifyMemo::kDiscs == kBatchKernelMaxDegree,
                      "a batched cell's memo holds a verdict for each of its discs");
        const int n_obj = static_cast<int>(plan.scene.objects.size());
        objects_.resize(static_cast<std::size_t>(n_obj));
        for (int obj = 0; obj < n_obj; ++obj) {
            const int n = plan.scene.objects[obj].degree;
            Object& o = objects_[obj];
            o.batched = isa != BatchIsa::Scalar && plan.params.method != Method::Paper && n <= kBatchKernelMaxDegree;
            any_ = any_ || o.batched;
            if (!o.batched) continue;
            o.seeded = plan.params.seed_from_neighbour && n > 4;
            o.clipped = plan.scene.objects[obj].clip_radius > 0.0;
        }
    }

    /// Starts a tile whose rows of samples are `cells` wide: no seeds yet.
    void begin_tile(int cells) {
        row_cells_ = cells;
        for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
            Object& o = objects_[obj];
            if (!o.seeded) continue;
            const int n = plan_.scene.objects[obj].degree;
            o.above_re.assign(static_cast<std::size_t>(cells) * n, kNaN);
            o.above_im.assign(static_cast<std::size_t>(cells) * n, kNaN);
        }
    }

    /// The real-root path (roots_real.h) for the objects that need only
    /// real roots: every object when `real_bands` (every band traced is
    /// sigma = delta = 0), else the objects with space: real. Only an object
    /// solved in batches, with a clipping sphere and degree <= 12 takes it;
    /// a cell the real path does not prove is solved by the batch as
    /// before. Not with a root field (record, replay): a field holds every
    /// root, for any band.
    void use_real_path(bool real_bands) {
        for (std::size_t obj = 0; obj < objects_.size(); ++obj) {
            Object& o = objects_[obj];
            const SurfaceSpec& s = plan_.scene.objects[obj];
            o.real = o.batched && o.clipped && s.degree <= 12 && (real_bands || !s.complex_space);
        }
    }

    /// Cells the real path proved, over this batch's solves.
    std::int64_t real_cells = 0;

    /// True when some object is solved in batches.
    bool any() const { return any_; }
    bool batched(int obj) const { return objects_[obj].batched; }
    BatchIsa isa() const { return isa_; }

    /// Solves the primary rays along the unit world directions (dx[c],
    /// dy[c], dz[c]) of cells 0..cells-1 (cells <= kCells), which are cells
    /// first..first+cells-1 of the tile's row of samples (begin_tile's
    /// count). Per object, the cells' ray polynomials are computed lane by
    /// lane (primary_ray_polynomial_run: primary_ray_polynomial's bits) in
    /// structure-of-arrays form and go as they are into find_roots_soa
    /// (find_roots_rows' answers, row by row; a cell whose coefficients
    /// overflowed is skipped: nothing claimed, as solve() does; a row whose
    /// status is not Ok, the ray in the surface, keeps that status).
    void solve(const double* dx, const double* dy, const double* dz, int cells, int first);

    /// solve's answers for its last cells (0..cells-1), appended to a root
    /// field's tape: per batched object and cell that was solved (not
    /// skipped: skip is recomputed on replay from the same polynomials),
    /// status, flags, the discs' header and discs, and for a provisional
    /// cell the lane's approximations settle starts from.
    void record(std::vector<std::uint8_t>& tape, int cells) const;

    /// solve without solving: the cells' ray polynomials, clip tests and
    /// skips as solve computes them (the same bits), their answers read from
    /// a root field's tape at `at` (record's layout), which `at` then
    /// passes. What fill and settle read afterwards is what they read after
    /// the solve that recorded the tape, so every decision is that solve's.
    /// Throws std::invalid_argument where the tape does not hold what the
    /// cells need (a tape of other rays, cut short or damaged).
    void replay(const double* dx, const double* dy, const double* dz, int cells, const std::uint8_t* tape,
                std::size_t size, std::size_t& at);

    /// Cell c's roots for object obj (batched(obj)), in the tracer's form:
    /// what primary_ray_polynomial and find_roots_rows gave before, read
    /// from the run's structure of arrays (coefficients and radii up to the
    /// degree, the discs that exist).
    /// `all`: also the polynomial and the ray whatever the object (record
    /// reads them); otherwise the ray only for an object with a clipping
    /// sphere and the polynomial not at all (see ObjectRoots). r.res views
    /// the batch's RootsResult of the cell (valid until the next solve).
    void fill(int obj, int c, ObjectRoots& r, bool all) const;

    /// Cell c's ray polynomial coefficients for object obj (batched(obj)),
    /// c[0..degree]: the doubles its discs were proven for.
    void coefficients(int obj, int c, double* out, double* radii) const {
        const detail::PrimaryRun& p = objects_[obj].run;
        for (int k = 0; k <= p.n; ++k) {
            out[k] = p.c[k][c];
            radii[k] = p.r[k][c];
        }
    }

    /// Cell c's LadderMemo, shared by the bands of the tile (share_ladder),
    /// emptied as the cells take new rays (solve, replay); null when the
    /// tile has one band (no other band could reuse an answer).
    LadderMemo* ladder_memo(int c) const { return share_ladder_ ? &ladder_[c] : nullptr; }
    void share_ladder(bool on) { share_ladder_ = on; }

    /// Replaces the provisional (merged) discs of cell c of object obj in
    /// r with find_roots' answer from the lane's approximations: what
    /// find_roots_soa answers without SoaRows::provisional, to the bit.
    void settle(int obj, int c, ObjectRoots& r) const;

private:
    /// The cells' ray polynomials of object obj (structure of arrays), its
    /// clip test and which cells are not solved (coefficients not finite,
    /// or the ray provably misses the clipping sphere).
    void prepare(int obj, const double* dx, const double* dy, const double* dz, int cells);

    /// The real path for cell c of object obj (o.real, not skipped): every
    /// real root of the ray polynomial's family in a segment that holds the
    /// ray's part inside the clipping sphere, as verified real discs of one
    /// root each (ascending, disjoint), into discs[0..n_discs). The omitted
    /// roots are proven not to matter: non-real ones lie outside the band
    /// (the positive real axis), real ones outside the segment outside the
    /// sphere. False (discs unspecified) where it proves less: the batch
    /// solves the cell.
    bool solve_real(int obj, int c, RootDisc* discs, int& n_discs) const;

    static void need(std::size_t size, std::size_t at, std::size_t bytes);

    struct Object {
        // (User-provided: objects_ is not zeroed first, some 70 KB per
        // object per tile; res, status and complete are written by solve
        // before fill reads them, run by primary_ray_polynomial_run.)
        Object() {}
        bool batched = false;
        bool seeded = false;   // lanes start from the roots of the sample above
        detail::PrimaryRun run;  // the cells' ray polynomials (structure of arrays)
        std::uint8_t skip[kCells] = {};  // cell not solved: coefficients not finite, or outside
        std::uint8_t outside[kCells] = {};  // the cell's ray provably misses the clipping sphere
        // Seeds: root i of the sample above cell c of the tile's row of
        // samples at [i * row_cells_ + c] (NaN at i = 0: none).
        std::vector<double> above_re, above_im;
        RootsResult res[kCells];
        Status status[kCells];
        std::uint8_t complete[kCells];  // solved, status Ok, every disc verified
        std::uint8_t provisional[kCells];  // SoaRows::provisional (its lane's merged discs)
        double lane_re[kCells * kBatchKernelMaxDegree], lane_im[kCells * kBatchKernelMaxDegree];  // (cell c's at c * n)
        bool clipped = false;  // a clipping sphere: the decisions read the ray
        bool real = false;     // the real-root path first (use_real_path)
        std::uint8_t real_done[kCells] = {};  // the cell's roots are the real path's
        // Each cell's band-independent verdicts (RootsView::memo), cleared
        // by prepare as the cells take new rays.
        mutable ClassifyMemo memo[kCells];
    };
    const FramePlan& plan_;
    BatchIsa isa_;
    bool cull_;  // rays that provably miss the clipping sphere are not solved
    bool any_ = false;
    bool share_ladder_ = false;
    mutable LadderMemo ladder_[kCells];
    int row_cells_ = 0;
    std::vector<Object> objects_;
};

/// A sample's place in a solved PrimaryBatch.
struct BatchedCell {
    const PrimaryBatch* batch;
    int cell;
};

}  // namespace argand::detail

#pragma GCC visibility pop
