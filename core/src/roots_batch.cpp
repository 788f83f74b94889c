// roots_batch.cpp: find_roots_rows, the driver of the batched root kernels
// (runtime dispatch, admission of rows to lanes, exact scaling, exact
// mapping back, and the scalar fallback). See argand/roots_batch.h.
#include "argand/roots_batch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "roots_batch_block.h"

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
        Circles() {
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
    // smith_radii_lanes_reference's slack: n 2^max(8n - 1070, -1014).
    block.slack = n * std::ldexp(1.0, std::max(8 * n - 1070, -1014));
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

void find_roots_soa(const SoaRows& in, Method method, RootsResult* out, Status* status, BatchIsa isa,
                    BatchCounters* counters) {
    BatchCounters local;
    BatchCounters& cnt = counters ? *counters : local;
    const int nc = in.n_coeffs, n = nc - 1;
    const std::int64_t stride = in.stride;
    const std::int64_t start_stride = in.start_stride != 0 ? in.start_stride : in.stride;
    const Kernel kernel = select_kernel(isa, method, n);
    const bool verify = method != Method::Unverified;
    const bool has_radius = in.radius != nullptr;
    // A row the lanes do not answer: find_roots on a gathered copy of it.
    auto scalar = [&](std::int64_t j) {
        double c[kMaxDegree + 1], r[kMaxDegree + 1];
        for (int k = 0; k < nc; ++k) {
            c[k] = in.coeffs[k * stride + j];
            if (has_radius) r[k] = in.radius[k * stride + j];
        }
        status[j] = find_roots(c, nc, method, out[j], nullptr, nullptr, has_radius ? r : nullptr);
        ++cnt.rows;
        ++cnt.scalar;
    };
    if (kernel == nullptr || nc > kMaxDegree + 1) {
        for (std::int64_t j = 0; j < in.rows; ++j)
            if (in.skip == nullptr || in.skip[j] == 0) scalar(j);
        return;
    }
    BatchBlock block;
    init_block(block, n, has_radius, in.start_re != nullptr && in.start_im != nullptr);
    for (std::int64_t j0 = 0; j0 < in.rows; j0 += kBatchLanes) {
        const int m = static_cast<int>(std::min<std::int64_t>(kBatchLanes, in.rows - j0));
        // Admission, lane by lane (find_roots_rows' admit): not skipped,
        // c_0 and c_n nonzero, every coefficient finite, every radius
        // finite and >= 0 (NaN fails every comparison). The rows go into
        // the block as they are (lanes past the last row hold 1.0: finite,
        // never admitted); the tests are loops over all 16 lanes.
        for (int k = 0; k <= n; ++k) {
            std::memcpy(block.c[k], in.coeffs + k * stride + j0, sizeof(double) * m);
            for (int l = m; l < kBatchLanes; ++l) block.c[k][l] = 1.0;
        }
        if (has_radius)
            for (int k = 0; k <= n; ++k) {
                std::memcpy(block.rad[k], in.radius + k * stride + j0, sizeof(double) * m);
                for (int l = m; l < kBatchLanes; ++l) block.rad[k][l] = 0.0;
            }
        // z[l] = sum_k 0 c_k (+ sum_k 0 rad_k) is 0 iff every one is finite
        // (0 inf and 0 NaN are NaN, and NaN stays); low[l] = min_k rad_k
        // (a NaN radius already makes z NaN).
        double z[kBatchLanes], low[kBatchLanes];
        for (int l = 0; l < kBatchLanes; ++l) {
            z[l] = 0.0;
            low[l] = 0.0;
        }
        for (int k = 0; k <= n; ++k)
            for (int l = 0; l < kBatchLanes; ++l) z[l] += 0.0 * block.c[k][l];
        if (has_radius)
            for (int k = 0; k <= n; ++k)
                for (int l = 0; l < kBatchLanes; ++l) {
                    const double v = block.rad[k][l];
                    z[l] += 0.0 * v;
                    low[l] = v < low[l] ? v : low[l];
                }
        bool admitted[kBatchLanes];
        for (int l = 0; l < kBatchLanes; ++l)
            admitted[l] = l < m && (in.skip == nullptr || in.skip[j0 + l] == 0) && z[l] == 0.0 && low[l] >= 0.0 &&
                          block.c[0][l] != 0.0 && block.c[n][l] != 0.0;
        int first = -1, used = 0;
        for (int l = 0; l < kBatchLanes; ++l) {
            if (admitted[l]) {
                if (first < 0) first = l;
                ++used;
            } else if (l < m && (in.skip == nullptr || in.skip[j0 + l] == 0)) {
                scalar(j0 + l);
            }
        }
        if (used == 0) continue;
        // Lanes without an admitted row: a copy of the first admitted lane
        // (finite), inactive.
        for (int l = 0; l < kBatchLanes; ++l) {
            block.active[l] = admitted[l] ? 1.0 : 0.0;
            if (admitted[l]) continue;
            for (int k = 0; k <= n; ++k) {
                block.c[k][l] = block.c[k][first];
                block.rad[k][l] = block.rad[k][first];
            }
            block.start_ok[l] = 0.0;
        }
        if (block.has_start != 0)
            for (int l = 0; l < kBatchLanes; ++l) {
                if (!admitted[l]) continue;
                bool finite = true;
                for (int i = 0; i < n; ++i) {
                    const double re = in.start_re[i * start_stride + j0 + l], im = in.start_im[i * start_stride + j0 + l];
                    finite = finite && std::isfinite(re) && std::isfinite(im);
                    block.start_re[i][l] = finite ? re : 0.0;
                    block.start_im[i][l] = finite ? im : 0.0;
                }
                block.start_ok[l] = finite ? 1.0 : 0.0;
            }
        cnt.sweeps += kernel(block, verify);
        ++cnt.blocks;
        cnt.lanes += used;
        cnt.rows += used;
        for (int l = 0; l < kBatchLanes; ++l) {
            if (!admitted[l]) continue;
            const std::int64_t j = j0 + l;
            if (block.ok[l] != 0.0 && (verify || block.converged[l] != 0.0)) {
                write_lane(block, l, verify, out[j]);
                status[j] = Status::Ok;
                ++cnt.kept;
            } else {
                --cnt.rows;  // (scalar() counts it)
                scalar(j);   // all finite: Ok
            }
        }
    }
}

}  // namespace argand
