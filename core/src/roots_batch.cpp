// roots_batch.cpp: find_roots_rows, the driver of the batched root kernels
// (runtime dispatch, admission of rows to lanes, exact scaling, exact
// mapping back, and the scalar fallback). See argand/roots_batch.h.
#include "argand/roots_batch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <cstring>
#include <limits>

#include "roots_batch_block.h"
#include "root_kernels.h"

#if defined(__x86_64__) || defined(_M_X64)
#define ARGAND_BATCH_X86 1
#include <xmmintrin.h>
#endif

namespace argand {
static_assert(kBatchKernelMaxDegree == kBatchMaxDegree, "roots_batch.h and roots_batch_block.h disagree");
namespace {

/// The kernels' rounding argument needs IEEE-754 round-to-nearest with
/// gradual underflow: no flush-to-zero, no denormals-are-zero. (On x86 the
/// vector units obey MXCSR; anything else set there sends every row to the
/// scalar path, which is the reference.)
bool fp_environment_default() {
#ifdef ARGAND_BATCH_X86
    const unsigned csr = _mm_getcsr();
    return (csr & 0x8040u) == 0 && (csr & 0x6000u) == 0;  // FTZ, DAZ; rounding control
#else
    return true;
#endif
}

using Kernel = int (*)(BatchBlock&, bool);

Kernel kernel_for(BatchIsa isa) {
    switch (isa) {
        case BatchIsa::Generic: return &batch_generic::solve_block;
#ifdef ARGAND_BATCH_X86
        case BatchIsa::Avx2: return &batch_avx2::solve_block;
        case BatchIsa::Avx512: return &batch_avx512::solve_block;
#endif
        default: return nullptr;
    }
}

using Admit = int (*)(BatchBlock&);

/// The admission test of the kernel that select_kernel picks for isa.
Admit admit_for(BatchIsa isa) {
    if (isa == BatchIsa::Auto) isa = batch_isa_best();
    switch (isa) {
#ifdef ARGAND_BATCH_X86
        case BatchIsa::Avx2: return &batch_avx2::admit_block;
        case BatchIsa::Avx512: return &batch_avx512::admit_block;
#endif
        default: return &batch_generic::admit_block;
    }
}

/// Admits row c (degree n) to lane l: finite coefficients with c_0 and c_n
/// nonzero (no exact zero roots, no roots at infinity). The kernel scales
/// the lane and sends it back when that is not exact.
inline bool admit(const double* c, const double* rad, int n, BatchBlock& b, int l) {
    if (c[0] == 0.0 || c[n] == 0.0) return false;
    bool finite = true;
    for (int k = 0; k <= n; ++k) {
        finite = finite && std::fabs(c[k]) <= std::numeric_limits<double>::max();
        b.c[k][l] = c[k];
    }
    if (rad != nullptr)
        for (int k = 0; k <= n; ++k) {
            // (find_roots refuses NaN, negative or infinite radii: NonFinite.)
            finite = finite && rad[k] >= 0.0 && rad[k] <= std::numeric_limits<double>::max();
            b.rad[k][l] = rad[k];
        }
    return finite;
}

/// Writes lane l of a solved block (ok: proven or estimated, mapped back
/// exactly by the kernel) as a row result.
void write_lane(const BatchBlock& b, int l, bool verify, RootsResult& res) {
    const int n = b.n;
    for (int i = 0; i < n; ++i) {
        RootDisc& d = res.discs[i];
        d.re = b.xr[i][l];
        d.im = b.xi[i][l];
        d.radius = b.r[i][l];
        d.count = 1;
        d.verified = verify;
        d.real = verify && b.xi[i][l] == 0.0;
    }
    res.n_discs = n;
    res.n_infinite = 0;
    res.wants_exact = false;
    res.escalation = 0;
}

/// The per-call part of a block: degree, flags, zero radii, the slack and
/// the circle starts.
void init_block(BatchBlock& block, int n, bool has_radius, bool has_start) {
    // The circle starts of every degree, computed once.
    struct Circles {
        double re[kBatchMaxDegree + 1][kBatchMaxDegree], im[kBatchMaxDegree + 1][kBatchMaxDegree];
        double slack[kBatchMaxDegree + 1];
        Circles() {
            // smith_radii_lanes_reference's slack: n 2^max(8n - 1070, -1014).
            for (int d = 0; d <= kBatchMaxDegree; ++d) slack[d] = d * std::ldexp(1.0, std::max(8 * d - 1070, -1014));
            for (int d = 1; d <= kBatchMaxDegree; ++d)
                for (int i = 0; i < d; ++i) {
                    const double angle = 2.0 * 3.14159265358979323846 * i / d + 0.4;
                    re[d][i] = std::cos(angle);
                    im[d][i] = std::sin(angle);
                }
        }
    };
    static const Circles circles;
    block.n = n;
    block.has_radius = has_radius ? 1 : 0;
    block.has_start = has_start && n >= 5 ? 1 : 0;
    if (!has_radius)  // (with radii, every lane's are written before each block)
        for (int k = 0; k <= n; ++k)
            for (int l = 0; l < kBatchLanes; ++l) block.rad[k][l] = 0.0;
    block.slack = circles.slack[n];
    for (int i = 0; i < n; ++i) {
        block.circle_re[i] = circles.re[n][i];
        block.circle_im[i] = circles.im[n][i];
    }
}

Kernel select_kernel(BatchIsa isa, Method method, int n) {
    if (isa == BatchIsa::Auto) isa = batch_isa_best();
    Kernel kernel = batch_isa_supported(isa) ? kernel_for(isa) : nullptr;
    if (method == Method::Paper || n < 1 || n > kBatchMaxDegree || !fp_environment_default()) kernel = nullptr;
    return kernel;
}

}  // namespace

const char* batch_isa_name(BatchIsa isa) {
    switch (isa) {
        case BatchIsa::Auto: return batch_isa_name(batch_isa_best());
        case BatchIsa::Scalar: return "scalar";
        case BatchIsa::Generic: return "sse2";
        case BatchIsa::Avx2: return "avx2";
        case BatchIsa::Avx512: return "avx512";
    }
    return "scalar";
}

bool batch_isa_from_name(const char* name, BatchIsa& out) {
    static const struct { const char* name; BatchIsa isa; } table[] = {
        {"auto", BatchIsa::Auto}, {"scalar", BatchIsa::Scalar}, {"sse2", BatchIsa::Generic},
        {"avx2", BatchIsa::Avx2}, {"avx512", BatchIsa::Avx512}};
    for (const auto& entry : table)
        if (std::strcmp(name, entry.name) == 0) {
            out = entry.isa;
            return true;
        }
    return false;
}

bool batch_isa_supported(BatchIsa isa) {
    switch (isa) {
        case BatchIsa::Auto:
        case BatchIsa::Scalar:
        case BatchIsa::Generic: return true;
#ifdef ARGAND_BATCH_X86
        case BatchIsa::Avx2: return __builtin_cpu_supports("avx2");
        case BatchIsa::Avx512:
            return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                   __builtin_cpu_supports("avx512vl");
#endif
        default: return false;
    }
}

BatchIsa batch_isa_best() {
    static const BatchIsa best = [] {
        if (batch_isa_supported(BatchIsa::Avx512)) return BatchIsa::Avx512;
        if (batch_isa_supported(BatchIsa::Avx2)) return BatchIsa::Avx2;
        return BatchIsa::Generic;
    }();
    return best;
}

Status find_roots_rows(const double* coeffs, std::int64_t rows, int n_coeffs, Method method, RootsResult* out,
                       std::int64_t* bad_row, BatchIsa isa, BatchCounters* counters, const double* radius,
                       const double* start_re, const double* start_im) {
    BatchCounters local;
    BatchCounters& cnt = counters ? *counters : local;
    const int n = n_coeffs - 1;
    const Kernel kernel = select_kernel(isa, method, n);
    const bool verify = method != Method::Unverified;

    BatchBlock block;
    std::int64_t lanes[kBatchLanes];
    int used = 0;
    if (kernel != nullptr) init_block(block, n, radius != nullptr, start_re != nullptr && start_im != nullptr);
    // Solves the lanes gathered so far; rows whose lane is not kept go to find_roots.
    auto flush = [&]() {
        if (used == 0) return;
        for (int l = 0; l < kBatchLanes; ++l) {
            block.active[l] = l < used ? 1.0 : 0.0;
            if (l >= used) {  // padding: a copy of lane 0 (finite, inactive)
                for (int k = 0; k <= n; ++k) {
                    block.c[k][l] = block.c[k][0];
                    block.rad[k][l] = block.rad[k][0];
                }
                block.start_ok[l] = 0.0;
            }
        }
        cnt.sweeps += kernel(block, verify);
        ++cnt.blocks;
        cnt.lanes += used;
        for (int l = 0; l < used; ++l) {
            RootsResult& res = out[lanes[l]];
            if (block.ok[l] != 0.0 && (verify || block.converged[l] != 0.0)) {
                write_lane(block, l, verify, res);
                ++cnt.kept;
            } else if (n >= 5 && block.active[l] != 0.0 && block.converged[l] != 0.0) {
                // (As the block driver: the lane's approximations seed
                // find_roots; see find_roots_lane_seeded.)
                double sr[kBatchMaxDegree], si[kBatchMaxDegree];
                for (int i = 0; i < n; ++i) {
                    sr[i] = block.xr[i][l];
                    si[i] = block.xi[i][l];
                }
                detail::find_roots_lane_seeded(coeffs + lanes[l] * n_coeffs, n_coeffs, method, res, sr, si,
                                               radius != nullptr ? radius + lanes[l] * n_coeffs : nullptr);
                ++cnt.scalar;
            } else {
                find_roots(coeffs + lanes[l] * n_coeffs, n_coeffs, method, res, nullptr, nullptr,
                           radius != nullptr ? radius + lanes[l] * n_coeffs : nullptr);  // all finite: Ok
                ++cnt.scalar;
            }
        }
        used = 0;
    };

    for (std::int64_t r = 0; r < rows; ++r) {
        const double* c = coeffs + r * n_coeffs;
        const double* rad = radius != nullptr ? radius + r * n_coeffs : nullptr;
        if (kernel != nullptr && admit(c, rad, n, block, used)) {
            if (block.has_start != 0) {
                bool finite = true;
                for (int i = 0; i < n; ++i) {
                    const double re = start_re[r * n + i], im = start_im[r * n + i];
                    finite = finite && std::isfinite(re) && std::isfinite(im);
                    block.start_re[i][used] = finite ? re : 0.0;
                    block.start_im[i][used] = finite ? im : 0.0;
                }
                block.start_ok[used] = finite ? 1.0 : 0.0;
            }
            lanes[used++] = r;
            ++cnt.rows;
            if (used == kBatchLanes) flush();
            continue;
        }
        const Status s = find_roots(c, n_coeffs, method, out[r], nullptr, nullptr, rad);
        if (s != Status::Ok) {
            if (kernel != nullptr) flush();
            if (bad_row) *bad_row = r;
            return s;
        }
        ++cnt.rows;
        ++cnt.scalar;
    }
    if (kernel != nullptr) flush();
    if (bad_row) *bad_row = -1;
    return Status::Ok;
}

namespace {

/// Writes lane l of a solved block (ok: proven or estimated, mapped back
/// exactly by the kernel) as a row result: write_lane's fields, each disc's
/// count, verified, real and padding as one 8-byte store.
/// xi == 0.0 (either zero) as an integer test (no flags, no branch).
inline bool is_zero(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    return (bits << 1) == 0;
}

inline void write_lane_fast(const BatchBlock& b, int n, int l, bool verify, RootsResult& res) {
    static_assert(sizeof(RootDisc) == 32 && offsetof(RootDisc, count) == 24 && offsetof(RootDisc, verified) == 28 &&
                      offsetof(RootDisc, real) == 29,
                  "RootDisc's layout");
    const std::uint64_t tail = 1u | (verify ? (std::uint64_t{1} << 32) : 0u);
#pragma GCC unroll 8
    for (int i = 0; i < n; ++i) {
        RootDisc& d = res.discs[i];
        const double xi = b.xi[i][l];
        d.re = b.xr[i][l];
        d.im = xi;
        d.radius = b.r[i][l];
        const std::uint64_t real = static_cast<std::uint64_t>(verify & is_zero(xi)) << 40;
        const std::uint64_t t = tail | real;
        std::memcpy(reinterpret_cast<unsigned char*>(&d) + 24, &t, sizeof t);
    }
    res.n_discs = n;
    res.n_infinite = 0;
    res.wants_exact = false;
    res.escalation = 0;
}

/// Where a driver's rows come from: SoaRows' fields. RowMajor: coefficient
/// k of row j at coeffs[j * n_coeffs + k] (find_roots_rows' layout; no
/// starts, no skips, stride unused); otherwise SoaRows' layout.
using Source = SoaRows;

/// Sink of find_roots_soa: RootsResult and Status per row.
struct SoaSink {
    RootsResult* out;
    Status* status;
    std::uint8_t* provisional;  // (SoaRows::provisional, nullable)
    static constexpr bool kStops = false;
    template <int N>
    void lane(const BatchBlock& b, int l, std::int64_t j, bool verify) {
        write_lane_fast(b, N, l, verify, out[j]);
        status[j] = Status::Ok;
        if (provisional) provisional[j] = 0;
    }
    /// Every lane of the block kept, rows j0..j0 + kBatchLanes - 1.
    template <int N>
    void whole(const BatchBlock& b, std::int64_t j0, bool verify) {
        for (int l = 0; l < kBatchLanes; ++l) {
            lane<N>(b, l, j0 + l, verify);
            if (provisional) provisional[j0 + l] = 0;
        }
    }
    /// Lane l (Smith's discs proven, not disjoint) into row j: its discs
    /// merged into proven clusters, and its approximations kept.
    template <int N>
    void merged(const BatchBlock& b, int l, std::int64_t j, const SoaRows& in) {
        detail::MemberDisc members[N];
        for (int i = 0; i < N; ++i) {
            members[i] = {b.xr[i][l], b.xi[i][l], b.r[i][l], 1};
            in.lane_re[j * N + i] = b.xr[i][l];
            in.lane_im[j * N + i] = b.xi[i][l];
        }
        RootsResult& res = out[j];
        res.n_discs = detail::enclose_and_merge(members, N, /*real_axis_centers=*/true, res.discs);
        res.n_infinite = 0;
        res.wants_exact = false;
        res.escalation = 0;
        status[j] = Status::Ok;
        in.provisional[j] = 1;
    }
    Status scalar(std::int64_t j, const double* c, int nc, Method method, const double* r, const double* seed_re,
                  const double* seed_im) {
        if (provisional) provisional[j] = 0;
        return status[j] = seed_re != nullptr
                               ? detail::find_roots_lane_seeded(c, nc, method, out[j], seed_re, seed_im, r)
                               : find_roots(c, nc, method, out[j], nullptr, nullptr, r);
    }
};

/// Sink of find_roots_rows_into: straight into the row-major arrays.
struct RowsSink {
    const RowsOut& out;
    int n;  // entries per row
    RootsResult tmp;
    static constexpr bool kStops = true;
    RowsSink(const RowsOut& o, int entries) : out(o), n(entries) {}
    template <int N>
    void lane(const BatchBlock& b, int l, std::int64_t j, bool verify) {
        const std::int64_t base = j * N;
        double* center = out.center + 2 * base;
        double* radius = out.radius + base;
        std::int64_t* count = out.count + base;
        bool* verified = out.verified + base;
        bool* real = out.real + base;
#pragma GCC unroll 8
        for (int i = 0; i < N; ++i) {
            const double xi = b.xi[i][l];
            center[2 * i] = b.xr[i][l];
            center[2 * i + 1] = xi;
            radius[i] = b.r[i][l];
            count[i] = 1;
            verified[i] = verify;
            real[i] = verify & is_zero(xi);
        }
        out.wants_exact[j] = false;
        out.n_infinite[j] = 0;
        out.escalation[j] = 0;
    }
    /// Every lane of the block kept, rows j0..j0 + kBatchLanes - 1 (one
    /// contiguous stretch of every array).
    template <int N>
    void whole(const BatchBlock& b, std::int64_t j0, bool verify) {
        const std::int64_t base = j0 * N;
        double* center = out.center + 2 * base;
        double* radius = out.radius + base;
        bool* real = out.real + base;
        // (Count 1 everywhere: copied from a block of ones, not stored one by one.)
        static const struct Ones {
            std::int64_t v[kBatchLanes * kBatchMaxDegree];
            Ones() { for (auto& x : v) x = 1; }
        } ones;
        std::memcpy(out.count + base, ones.v, sizeof(std::int64_t) * kBatchLanes * N);
        std::memset(out.verified + base, verify ? 1 : 0, kBatchLanes * N);
        for (int l = 0; l < kBatchLanes; ++l) {
#pragma GCC unroll 8
            for (int i = 0; i < N; ++i) {
                const double xi = b.xi[i][l];
                center[2 * (l * N + i)] = b.xr[i][l];
                center[2 * (l * N + i) + 1] = xi;
                radius[l * N + i] = b.r[i][l];
                real[l * N + i] = verify & is_zero(xi);
            }
        }
        std::memset(out.wants_exact + j0, 0, kBatchLanes);
        std::memset(out.n_infinite + j0, 0, sizeof(std::int32_t) * kBatchLanes);
        std::memset(out.escalation + j0, 0, sizeof(std::int32_t) * kBatchLanes);
    }
    Status scalar(std::int64_t j, const double* c, int nc, Method method, const double* r, const double* seed_re,
                  const double* seed_im) {
        const Status s = seed_re != nullptr
                             ? detail::find_roots_lane_seeded(c, nc, method, tmp, seed_re, seed_im, r)
                             : find_roots(c, nc, method, tmp, nullptr, nullptr, r);
        if (s == Status::Ok) put(j, tmp);
        return s;
    }
    void put(std::int64_t j, const RootsResult& res) {
        const std::int64_t base = j * n;
        const double nan = std::numeric_limits<double>::quiet_NaN();
        for (int i = 0; i < n; ++i) {
            if (i < res.n_discs) {
                const RootDisc& d = res.discs[i];
                out.center[2 * (base + i)] = d.re;
                out.center[2 * (base + i) + 1] = d.im;
                out.radius[base + i] = d.radius;
                out.count[base + i] = d.count;
                out.verified[base + i] = d.verified;
                out.real[base + i] = d.real;
            } else {
                out.center[2 * (base + i)] = nan;
                out.center[2 * (base + i) + 1] = nan;
                out.radius[base + i] = nan;
                out.count[base + i] = 0;
                out.verified[base + i] = false;
                out.real[base + i] = false;
            }
        }
        out.wants_exact[j] = res.wants_exact;
        out.n_infinite[j] = res.n_infinite;
        out.escalation[j] = res.escalation;
    }
};

/// The block driver of find_roots_soa and find_roots_rows_into: rows go to
/// the kernel block by block of kBatchLanes in place (row j in lane j mod 16
/// of block j / 16); rows not admitted leave their lane inactive and are
/// solved by find_roots, as are admitted rows whose lane is not kept.
/// Returns the first row whose status is not Ok when the sink stops there
/// (-1 otherwise), with its status in *bad.
/// The blocks of degree N (see drive).
template <bool RowMajor, int N, class Sink, class Scalar>
std::int64_t blocks(const Source& in, Method method, Sink& sink, Status* bad, BatchIsa isa, BatchCounters& cnt,
                    Kernel kernel, Scalar& scalar) {
    constexpr int n = N;
    const std::int64_t stride = in.stride;
    const std::int64_t start_stride = in.start_stride != 0 ? in.start_stride : in.stride;
    const bool verify = method != Method::Unverified;
    const bool has_radius = in.radius != nullptr;
    const Admit admit = admit_for(isa);
    BatchBlock block;
    init_block(block, n, has_radius, in.start_re != nullptr && in.start_im != nullptr);
    for (std::int64_t j0 = 0; j0 < in.rows; j0 += kBatchLanes) {
        const int m = static_cast<int>(std::min<std::int64_t>(kBatchLanes, in.rows - j0));
        // The rows go into the block as they are (lanes past the last row
        // hold 1.0: finite, never admitted); admission (find_roots_rows'
        // admit: not skipped, c_0 and c_n nonzero, every coefficient
        // finite, every radius finite and >= 0) is the kernel's
        // admit_block, vectorised over the block.
        if constexpr (RowMajor) {
            for (int l = 0; l < m; ++l) {
                const double* c = in.coeffs + (j0 + l) * (n + 1);
#pragma GCC unroll 9
                for (int k = 0; k <= n; ++k) block.c[k][l] = c[k];
            }
            if (has_radius)
                for (int l = 0; l < m; ++l) {
                    const double* r = in.radius + (j0 + l) * (n + 1);
#pragma GCC unroll 9
                    for (int k = 0; k <= n; ++k) block.rad[k][l] = r[k];
                }
        } else {
#pragma GCC unroll 9
            for (int k = 0; k <= n; ++k) std::memcpy(block.c[k], in.coeffs + k * stride + j0, sizeof(double) * m);
            if (has_radius)
#pragma GCC unroll 9
                for (int k = 0; k <= n; ++k)
                    std::memcpy(block.rad[k], in.radius + k * stride + j0, sizeof(double) * m);
        }
        if (m < kBatchLanes)
            for (int k = 0; k <= n; ++k)
                for (int l = m; l < kBatchLanes; ++l) {
                    block.c[k][l] = 1.0;
                    block.rad[k][l] = 0.0;
                }
        if (in.skip == nullptr)
            for (int l = 0; l < kBatchLanes; ++l) block.active[l] = l < m ? 1.0 : 0.0;
        else
            for (int l = 0; l < kBatchLanes; ++l) block.active[l] = (l < m) & (in.skip[j0 + (l < m ? l : 0)] == 0) ? 1.0 : 0.0;
        int used = admit(block), first = -1;
        double admitted[kBatchLanes];
        std::memcpy(admitted, block.active, sizeof admitted);
        if (used < kBatchLanes)
            for (int l = kBatchLanes - 1; l >= 0; --l) first = admitted[l] != 0.0 ? l : first;
        else
            first = 0;
        // Rows not admitted (and not skipped): find_roots. A sink that
        // stops at a bad row still gets the admitted rows before it.
        int stop = -1;
        if (used < m)
            for (int l = 0; l < m; ++l) {
                if (admitted[l] != 0.0 || (in.skip != nullptr && in.skip[j0 + l] != 0)) continue;
                const Status s = scalar(j0 + l);
                if (Sink::kStops && s != Status::Ok) {
                    --cnt.rows;
                    --cnt.scalar;
                    *bad = s;
                    stop = l;
                    break;
                }
            }
        if (Sink::kStops && stop >= 0) {
            used = 0;
            for (int l = 0; l < kBatchLanes; ++l) {
                admitted[l] = l < stop ? admitted[l] : 0.0;
                used += admitted[l] != 0.0;
            }
            if (used == 0) return j0 + stop;
        }
        if (used == 0) continue;
        std::memcpy(block.active, admitted, sizeof admitted);  // (as the stop left them)
        // Lanes without an admitted row: a copy of the first admitted lane
        // (finite), inactive.
        if (used < kBatchLanes)
            for (int l = 0; l < kBatchLanes; ++l) {
                if (admitted[l] != 0.0) continue;
                for (int k = 0; k <= n; ++k) {
                    block.c[k][l] = block.c[k][first];
                    block.rad[k][l] = block.rad[k][first];
                }
                block.start_ok[l] = 0.0;
            }
        if constexpr (!RowMajor && N >= 5) {
            if (block.has_start != 0)
                for (int l = 0; l < m; ++l) {
                    if (admitted[l] == 0.0) continue;
                    bool finite = true;
                    for (int i = 0; i < n; ++i) {
                        const double re = in.start_re[i * start_stride + j0 + l];
                        const double im = in.start_im[i * start_stride + j0 + l];
                        finite = finite && std::isfinite(re) && std::isfinite(im);
                        block.start_re[i][l] = finite ? re : 0.0;
                        block.start_im[i][l] = finite ? im : 0.0;
                    }
                    block.start_ok[l] = finite ? 1.0 : 0.0;
                }
        }
        cnt.sweeps += kernel(block, verify);
        ++cnt.blocks;
        cnt.lanes += used;
        if (used == kBatchLanes) {
            // Every lane admitted (the common block): kept lanes go out in
            // one pass when the kernel kept them all.
            // (ok and converged hold 0.0 or 1.0: an OR of bits is 0 iff all are 1.0.)
            std::uint64_t off = 0;
            for (int l = 0; l < kBatchLanes; ++l) {
                std::uint64_t ok;
                std::memcpy(&ok, &block.ok[l], sizeof ok);
                off |= ok ^ 0x3ff0000000000000ULL;
            }
            if (!verify)
                for (int l = 0; l < kBatchLanes; ++l) {
                    std::uint64_t conv;
                    std::memcpy(&conv, &block.converged[l], sizeof conv);
                    off |= conv ^ 0x3ff0000000000000ULL;
                }
            if (off == 0) {
                sink.template whole<N>(block, j0, verify);
                cnt.rows += kBatchLanes;
                cnt.kept += kBatchLanes;
                if (Sink::kStops && stop >= 0) return j0 + stop;
                continue;
            }
        }
        for (int l = 0; l < m; ++l) {
            if (admitted[l] == 0.0) continue;
            const std::int64_t j = j0 + l;
            if (block.ok[l] != 0.0 && (verify || block.converged[l] != 0.0)) {
                sink.template lane<N>(block, l, j, verify);
                ++cnt.rows;
                ++cnt.kept;
            } else if (N >= 5 && block.active[l] != 0.0 && block.converged[l] != 0.0) {
                if constexpr (!RowMajor) {
                    if (in.provisional != nullptr && verify && block.discs_ok[l] != 0.0) {
                        // The lane's own discs, merged (see SoaRows::provisional).
                        sink.template merged<N>(block, l, j, in);
                        ++cnt.rows;
                        continue;
                    }
                }
                // The lane scaled exactly and Aberth stopped every root, but
                // Smith's discs were not proven disjoint (a cluster):
                // find_roots starts from the lane's approximations (mapped
                // back to the input's coordinates by the kernel) and keeps
                // them only where that ends in double (see
                // find_roots_lane_seeded). Seeds are approximations only:
                // what is proven does not depend on them. (Degrees 5 to 8:
                // below, find_roots starts from the closed forms, cheaply.)
                double sr[kBatchMaxDegree], si[kBatchMaxDegree];
                for (int i = 0; i < n; ++i) {
                    sr[i] = block.xr[i][l];
                    si[i] = block.xi[i][l];
                }
                scalar(j, sr, si);  // all finite: Ok
            } else {
                scalar(j);  // all finite: Ok
            }
        }
        if (Sink::kStops && stop >= 0) return j0 + stop;
    }
    return -1;
}

/// The block driver of find_roots_soa and find_roots_rows_into: rows go to
/// the kernel block by block of kBatchLanes in place (row j in lane j mod 16
/// of block j / 16); rows not admitted leave their lane inactive and are
/// solved by find_roots, as are admitted rows whose lane is not kept.
/// Returns the first row whose status is not Ok when the sink stops there
/// (-1 otherwise), with its status in *bad.
template <bool RowMajor, class Sink>
std::int64_t drive(const Source& in, Method method, Sink& sink, Status* bad, BatchIsa isa, BatchCounters& cnt) {
    const int nc = in.n_coeffs, n = nc - 1;
    const std::int64_t stride = in.stride;
    const Kernel kernel = select_kernel(isa, method, n);
    const bool has_radius = in.radius != nullptr;
    // A row the lanes do not answer: find_roots on it (a gathered copy of
    // it in structure-of-arrays form).
    auto scalar = [&](std::int64_t j, const double* seed_re = nullptr, const double* seed_im = nullptr) -> Status {
        ++cnt.rows;
        ++cnt.scalar;
        if constexpr (RowMajor) {
            return sink.scalar(j, in.coeffs + j * nc, nc, method, has_radius ? in.radius + j * nc : nullptr, seed_re,
                               seed_im);
        } else {
            double c[kMaxDegree + 1], r[kMaxDegree + 1];
            for (int k = 0; k < nc; ++k) {
                c[k] = in.coeffs[k * stride + j];
                if (has_radius) r[k] = in.radius[k * stride + j];
            }
            return sink.scalar(j, c, nc, method, has_radius ? r : nullptr, seed_re, seed_im);
        }
    };
    if (kernel == nullptr || nc > kMaxDegree + 1) {
        for (std::int64_t j = 0; j < in.rows; ++j)
            if (in.skip == nullptr || in.skip[j] == 0) {
                const Status s = scalar(j);
                if (Sink::kStops && s != Status::Ok) {
                    --cnt.rows;
                    --cnt.scalar;
                    *bad = s;
                    return j;
                }
            }
        return -1;
    }
    switch (n) {
        case 1: return blocks<RowMajor, 1>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 2: return blocks<RowMajor, 2>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 3: return blocks<RowMajor, 3>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 4: return blocks<RowMajor, 4>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 5: return blocks<RowMajor, 5>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 6: return blocks<RowMajor, 6>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 7: return blocks<RowMajor, 7>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 8: return blocks<RowMajor, 8>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 9: return blocks<RowMajor, 9>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 10: return blocks<RowMajor, 10>(in, method, sink, bad, isa, cnt, kernel, scalar);
        case 11: return blocks<RowMajor, 11>(in, method, sink, bad, isa, cnt, kernel, scalar);
        default: return blocks<RowMajor, 12>(in, method, sink, bad, isa, cnt, kernel, scalar);
    }
}

}  // namespace

void find_roots_soa(const SoaRows& in, Method method, RootsResult* out, Status* status, BatchIsa isa,
                    BatchCounters* counters) {
    BatchCounters local;
    SoaSink sink{out, status, in.provisional};
    Status bad = Status::Ok;
    drive<false>(in, method, sink, &bad, isa, counters ? *counters : local);
}

Status find_roots_rows_into(const double* coeffs, std::int64_t rows, int n_coeffs, Method method, const RowsOut& out,
                            std::int64_t* bad_row, BatchIsa isa, BatchCounters* counters, const double* radius) {
    BatchCounters local;
    Source src;
    src.coeffs = coeffs;
    src.radius = radius;
    src.rows = rows;
    src.n_coeffs = n_coeffs;
    RowsSink sink(out, n_coeffs - 1);
    Status bad = Status::Ok;
    const std::int64_t r = drive<true>(src, method, sink, &bad, isa, counters ? *counters : local);
    if (bad_row) *bad_row = r;
    return r < 0 ? Status::Ok : bad;
}

}  // namespace argand
