// roots_batch.h: find_roots for many polynomials of one degree at once.
//
// find_roots_rows() answers each row exactly as find_roots() would promise
// (the same contract, row by row; not necessarily the same discs): rows of
// degree 1 to kBatchMaxDegree go through a lane-parallel kernel (16
// polynomials per block, structure of arrays, vectorised for the widest
// instruction set the CPU has: AVX-512, AVX2, or the x86-64 baseline), which
// finds the approximations (closed-form starts for degree <= 4, circle
// starts above, Aberth-Ehrlich sweeps) and proves Smith's discs with the
// rounding bounds of smith_radii_fast, lane by lane. A lane is kept only when
// every one of its discs is proven to hold exactly one root and the mapping
// back from scaled coordinates is exact; every other row (clusters, multiple
// roots, exact zero roots, roots at infinity, subnormal or extreme
// coefficients, unconverged lanes, and every row of method "paper") is
// solved by find_roots with its scaling and escalation ladder.
#pragma once

#include <cstdint>

#include "argand/roots.h"

namespace argand {

/// Largest degree with a batched kernel (rows of higher degree use find_roots):
/// every surface degree (render.h's kMaxSurfaceDegree).
constexpr int kBatchKernelMaxDegree = 12;

/// Instruction set of the batched kernel. Auto: the widest this CPU runs.
/// Scalar: no batched kernel, find_roots row by row (the reference).
enum class BatchIsa : int { Auto = -1, Scalar = 0, Generic = 1, Avx2 = 2, Avx512 = 3 };

/// "scalar", "sse2" (the x86-64 baseline, or the compiler's default
/// elsewhere), "avx2", "avx512".
const char* batch_isa_name(BatchIsa isa);
/// Parses batch_isa_name's names and "auto"; false for anything else.
bool batch_isa_from_name(const char* name, BatchIsa& out);
/// The widest instruction set this CPU runs (what Auto means).
BatchIsa batch_isa_best();
/// True iff this CPU runs isa.
bool batch_isa_supported(BatchIsa isa);

/// What happened to the rows of one call.
struct BatchCounters {
    std::int64_t rows = 0;      // rows answered
    std::int64_t lanes = 0;     // rows that entered the batched kernel
    std::int64_t kept = 0;      // ... and were answered by it
    std::int64_t scalar = 0;    // rows answered by find_roots
    std::int64_t sweeps = 0;    // Aberth sweeps, summed over blocks
    std::int64_t blocks = 0;    // kernel blocks run
};

/// Solves rows polynomials of n_coeffs coefficients each (row-major, lowest
/// degree first) with `method`; out[r] receives row r's result. Stops at the
/// first row whose status is not Ok: returns that status and sets *bad_row
/// (rows after it are not answered). isa must be supported (Auto always is).
///
/// radius (optional, the same shape as coeffs): coefficient radii, as
/// find_roots' coeff_radius row by row: each row's discs then hold for every
/// real polynomial within those radii of it (Smith's family term in the
/// lanes too). A row with an invalid radius gets Status::NonFinite.
///
/// start_re, start_im (optional, rows x (n_coeffs - 1), row-major): starting
/// approximations per row for the lanes of degree 5 to 12 (the circle
/// otherwise; a row with a non-finite start takes the circle). Only speed
/// depends on them: rows the lanes do not prove are solved by find_roots
/// without them, and what is proven is the same contract.
Status find_roots_rows(const double* coeffs, std::int64_t rows, int n_coeffs, Method method, RootsResult* out,
                       std::int64_t* bad_row, BatchIsa isa = BatchIsa::Auto, BatchCounters* counters = nullptr,
                       const double* radius = nullptr, const double* start_re = nullptr,
                       const double* start_im = nullptr);

/// Row-major outputs of find_roots_rows_into for rows polynomials of
/// degree n: entry i of row r at [r * n + i] (the centre as a (re, im) pair
/// at center[2 (r n + i)], the layout of numpy's complex128), per-row
/// values at [r]. Entries past a row's discs are padding: NaN centre and
/// radius, count 0, verified and real false.
struct RowsOut {
    double* center = nullptr;
    double* radius = nullptr;
    std::int64_t* count = nullptr;
    bool* verified = nullptr;
    bool* real = nullptr;
    bool* wants_exact = nullptr;
    std::int32_t* n_infinite = nullptr;
    std::int32_t* escalation = nullptr;
};

/// find_roots_rows (no starts) writing each answered row straight into
/// `out` (no RootsResult per row): the same admission, kernel and scalar
/// fallback, so the same answers to the bit. Rows go to the kernel block by
/// block of kBatchLanes in place (row r in lane r mod 16 of block r / 16,
/// rows not admitted leave their lane inactive; a lane's answer depends on
/// its own row only). Stops at the first row whose status is not Ok:
/// returns that status and sets *bad_row (rows after it are not answered;
/// that row's entries are not written).
Status find_roots_rows_into(const double* coeffs, std::int64_t rows, int n_coeffs, Method method,
                            const RowsOut& out, std::int64_t* bad_row, BatchIsa isa = BatchIsa::Auto,
                            BatchCounters* counters = nullptr, const double* radius = nullptr);

/// Rows in structure-of-arrays form for find_roots_soa: coefficient k of row
/// j at coeffs[k * stride + j] (k = 0..n_coeffs-1, j = 0..rows-1), its
/// radius at radius[k * stride + j] (optional, as find_roots_rows' radius),
/// starting approximation i at start_re/start_im[i * start_stride + j]
/// (optional, both or neither, as find_roots_rows'; start_stride 0 means
/// stride), and skip[j] != 0 (optional) for a row to leave alone (out[j],
/// status[j] untouched).
struct SoaRows {
    const double* coeffs = nullptr;
    const double* radius = nullptr;
    const double* start_re = nullptr;
    const double* start_im = nullptr;
    const std::uint8_t* skip = nullptr;
    std::int64_t rows = 0;
    std::int64_t stride = 0;
    std::int64_t start_stride = 0;
    int n_coeffs = 0;
    // Optional (degree 5 to 12, verified methods): a row whose lane
    // converged and whose Smith discs are proven but not pairwise disjoint
    // is not sent to find_roots; out[j] gets those discs merged into
    // proven cluster discs (enclose_and_merge: each holds exactly its count
    // of roots of every member of the row's family; status Ok), and
    // provisional[j] = 1 with the lane's approximations at lane_re[j * (n_coeffs
    // - 1) + i], lane_im[...] (i < n_coeffs - 1): the caller may keep them,
    // or call find_roots_lane_seeded(row, lane_re, lane_im) for what
    // find_roots_soa would have answered without these arrays. Every other
    // row: provisional[j] = 0.
    std::uint8_t* provisional = nullptr;
    double* lane_re = nullptr;
    double* lane_im = nullptr;
};

/// find_roots_rows for rows in structure-of-arrays form, without stopping:
/// every row j not skipped gets out[j] and status[j] exactly as
/// find_roots_rows would answer it (the same admission to the lanes, the
/// same kernel, the same find_roots call for the rows the lanes do not
/// keep), and a row whose status is not Ok (its find_roots answer left in
/// out[j]) does not stop the others. Rows go to the kernel block by block
/// of kBatch lanes in place (row j in lane j mod 16 of block j / 16; rows
/// not admitted leave their lane inactive): a lane's answer depends on its
/// own row only, so the answers are find_roots_rows' to the bit. Counters
/// as find_roots_rows' (rows counts the rows answered).
void find_roots_soa(const SoaRows& rows, Method method, RootsResult* out, Status* status,
                    BatchIsa isa = BatchIsa::Auto, BatchCounters* counters = nullptr);

}  // namespace argand
