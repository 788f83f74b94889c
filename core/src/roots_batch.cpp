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

inline std::uint64_t bits_of(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
}
inline double from_bits(std::uint64_t b) {
    double v;
    std::memcpy(&v, &b, sizeof v);
    return v;
}
inline int biased_exponent(double v) { return static_cast<int>((bits_of(v) >> 52) & 0x7ff); }

/// v 2^k when that is exact because v and the result are both normal (or v
/// is zero); false otherwise (out untouched).
inline bool scale_normal(double v, int k, double& out) {
    if (v == 0.0) {
        out = v;
        return true;
    }
    const int b = biased_exponent(v);
    if (b == 0 || b == 0x7ff || b + k < 1 || b + k > 0x7fe) return false;
    out = from_bits(bits_of(v) + (static_cast<std::uint64_t>(static_cast<std::int64_t>(k)) << 52));
    return true;
}

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

/// A row admitted to a lane: its index, and the root scaling t = 2^e u.
struct Lane {
    std::int64_t row;
    int e;
};

/// Admits row c (degree n): finite coefficients that are normal or zero,
/// c_0 and c_n nonzero, and the scaling of scale_polynomial (roots to modulus
/// ~1 by 2^e, largest coefficient to [1, 2)) exact with every scaled
/// coefficient normal. Writes the scaled coefficients into lane l.
bool admit(const double* c, int n, BatchBlock& b, int l, int& e_out) {
    if (c[0] == 0.0 || c[n] == 0.0) return false;
    for (int k = 0; k <= n; ++k) {
        const int be = biased_exponent(c[k]);
        if (be == 0x7ff || (be == 0 && c[k] != 0.0)) return false;
    }
    const int lo_exp = biased_exponent(c[0]) - 1023;
    const int hi_exp = biased_exponent(c[n]) - 1023;
    // round((lo_exp - hi_exp) / n), halves away from zero (as lround), in integers.
    const int diff = lo_exp - hi_exp;
    const int e = diff >= 0 ? (2 * diff + n) / (2 * n) : -((-2 * diff + n) / (2 * n));
    int top = -100000;
    for (int k = 0; k <= n; ++k)
        if (c[k] != 0.0) top = std::max(top, biased_exponent(c[k]) - 1023 + e * k);
    const int f = -top;
    for (int k = 0; k <= n; ++k)
        if (!scale_normal(c[k], e * k + f, b.c[k][l])) return false;
    e_out = e;
    return true;
}

/// Writes lane l of a solved block as row result `res` (coordinates t = 2^e
/// u). Verified lanes: true iff every centre and radius maps back exactly
/// (then every claim carries over unchanged). Unverified lanes: always.
bool write_lane(const BatchBlock& b, int l, int e, bool verify, RootsResult& res) {
    const int n = b.n;
    for (int i = 0; i < n; ++i) {
        RootDisc& d = res.discs[i];
        if (verify) {
            if (!scale_normal(b.xr[i][l], e, d.re) || !scale_normal(b.xi[i][l], e, d.im) ||
                !scale_normal(b.r[i][l], e, d.radius))
                return false;
            d.verified = true;
            d.real = b.xi[i][l] == 0.0;
        } else {
            // (Nothing is claimed: any rounding will do; exact where possible.)
            if (!scale_normal(b.xr[i][l], e, d.re)) d.re = std::ldexp(b.xr[i][l], e);
            if (!scale_normal(b.xi[i][l], e, d.im)) d.im = std::ldexp(b.xi[i][l], e);
            if (!scale_normal(b.r[i][l], e, d.radius)) d.radius = std::ldexp(b.r[i][l], e);
            if (!std::isfinite(d.radius)) d.radius = std::numeric_limits<double>::infinity();
            d.verified = false;
            d.real = false;
        }
        d.count = 1;
    }
    res.n_discs = n;
    res.n_infinite = 0;
    res.wants_exact = false;
    res.escalation = 0;
    return true;
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
                       std::int64_t* bad_row, BatchIsa isa, BatchCounters* counters) {
    BatchCounters local;
    BatchCounters& cnt = counters ? *counters : local;
    if (isa == BatchIsa::Auto) isa = batch_isa_best();
    const int n = n_coeffs - 1;
    Kernel kernel = batch_isa_supported(isa) ? kernel_for(isa) : nullptr;
    if (method == Method::Paper || n < 1 || n > kBatchMaxDegree || !fp_environment_default()) kernel = nullptr;
    const bool verify = method != Method::Unverified;

    BatchBlock block;
    Lane lanes[kBatchLanes];
    int used = 0;
    if (kernel != nullptr) {
        block.n = n;
        // smith_radii_fast's slack: n 2^max(8n - 1070, -1014).
        block.slack = n * std::ldexp(1.0, std::max(8 * n - 1070, -1014));
        for (int i = 0; i < n; ++i) {
            const double angle = 2.0 * 3.14159265358979323846 * i / n + 0.4;
            block.circle_re[i] = std::cos(angle);
            block.circle_im[i] = std::sin(angle);
        }
    }
    // Solves the lanes gathered so far; rows whose lane is not kept go to find_roots.
    auto flush = [&]() {
        if (used == 0) return;
        for (int l = 0; l < kBatchLanes; ++l) {
            block.active[l] = l < used ? 1.0 : 0.0;
            if (l >= used)  // padding: a copy of lane 0 (finite, inactive)
                for (int k = 0; k <= n; ++k) block.c[k][l] = block.c[k][0];
        }
        cnt.sweeps += kernel(block, verify);
        ++cnt.blocks;
        cnt.lanes += used;
        for (int l = 0; l < used; ++l) {
            RootsResult& res = out[lanes[l].row];
            const bool good = block.ok[l] != 0.0 && (verify || block.converged[l] != 0.0) &&
                              write_lane(block, l, lanes[l].e, verify, res);
            if (good) {
                ++cnt.kept;
            } else {
                find_roots(coeffs + lanes[l].row * n_coeffs, n_coeffs, method, res);  // finite, c_n != 0: Ok
                ++cnt.scalar;
            }
        }
        used = 0;
    };

    for (std::int64_t r = 0; r < rows; ++r) {
        const double* c = coeffs + r * n_coeffs;
        int e = 0;
        if (kernel != nullptr && admit(c, n, block, used, e)) {
            lanes[used++] = Lane{r, e};
            ++cnt.rows;
            if (used == kBatchLanes) flush();
            continue;
        }
        const Status s = find_roots(c, n_coeffs, method, out[r]);
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

}  // namespace argand
