// bind_roots.cpp: find_roots / find_roots_batch bindings.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <complex>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "argand/roots.h"
#include "argand/roots_batch.h"

namespace py = pybind11;
using argand::Method;
using argand::RootsResult;
using argand::Status;

namespace {

Method parse_method(const std::string& name) {
    Method m;
    if (!argand::method_from_name(name.c_str(), m))
        throw py::value_error("unknown method '" + name + "': expected one of auto, paper, smith, unverified");
    return m;
}

void raise_status(Status s, py::ssize_t row) {
    std::string where = row >= 0 ? " (row " + std::to_string(row) + ")" : "";
    switch (s) {
        case Status::Ok: return;
        case Status::NonFinite: throw py::value_error("coefficients must be finite numbers; got NaN or infinity" + where);
        case Status::ZeroPolynomial: throw py::value_error("the zero polynomial has every point as a root" + where);
        case Status::TooLarge:
            throw py::value_error("degree above the supported maximum of " + std::to_string(argand::kMaxDegree) + where);
    }
}

using F64 = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Output buffers of find_roots_batch, recycled: one allocation holds all
// eight result arrays (views with a capsule as their base), and when the
// last of them dies the buffer goes back to a small pool instead of the
// system. A fresh allocation of the ~2.7 MB a batch of 20000 quartics
// returns is mmapped and page-faulted on first touch, which cost about as
// much as solving the batch; a recycled one is already mapped. At most
// kPoolBuffers buffers, kPoolBytes in all, are kept.
constexpr std::size_t kPoolHeader = 64, kPoolBuffers = 4, kPoolBytes = std::size_t{64} << 20;
struct BufferPool {
    std::mutex mutex;
    std::vector<unsigned char*> free;  // raw blocks, capacity in their header
    std::size_t held = 0;
};
BufferPool& buffer_pool() {
    static BufferPool* pool = new BufferPool;  // (never destroyed: capsules may die at exit)
    return *pool;
}
void* buffer_acquire(std::size_t bytes) {
    bytes = (bytes + 63) / 64 * 64;
    BufferPool& pool = buffer_pool();
    {
        std::lock_guard<std::mutex> lock(pool.mutex);
        for (std::size_t i = 0; i < pool.free.size(); ++i) {
            std::size_t cap;
            std::memcpy(&cap, pool.free[i], sizeof cap);
            if (cap >= bytes && cap <= 2 * bytes + 65536) {
                unsigned char* raw = pool.free[i];
                pool.free.erase(pool.free.begin() + static_cast<std::ptrdiff_t>(i));
                pool.held -= cap;
                return raw + kPoolHeader;
            }
        }
    }
    auto* raw = static_cast<unsigned char*>(std::aligned_alloc(64, kPoolHeader + bytes));
    if (raw == nullptr) throw std::bad_alloc();
    std::memcpy(raw, &bytes, sizeof bytes);
    return raw + kPoolHeader;
}
void buffer_release(void* data) {
    unsigned char* raw = static_cast<unsigned char*>(data) - kPoolHeader;
    std::size_t cap;
    std::memcpy(&cap, raw, sizeof cap);
    BufferPool& pool = buffer_pool();
    {
        std::lock_guard<std::mutex> lock(pool.mutex);
        if (pool.free.size() < kPoolBuffers && pool.held + cap <= kPoolBytes) {
            pool.free.push_back(raw);
            pool.held += cap;
            return;
        }
    }
    std::free(raw);
}

// One polynomial: returns (center, radius, count, verified, real, n_infinite,
// wants_exact, escalation) with arrays of length n_discs.
py::tuple find_roots_py(F64 coeffs, const std::string& method, py::object initial, py::object coeff_radius) {
    if (coeffs.ndim() != 1) throw py::value_error("coeffs must be a 1-D sequence of numbers, lowest degree first");
    const Method m = parse_method(method);
    const py::ssize_t n_coeffs = coeffs.shape(0);
    if (n_coeffs < 1) throw py::value_error("coeffs must not be empty");
    std::vector<double> ire, iim;
    if (!initial.is_none()) {
        auto arr = py::array_t<std::complex<double>, py::array::c_style | py::array::forcecast>::ensure(initial);
        if (!arr || arr.ndim() != 1 || arr.shape(0) < n_coeffs - 1)
            throw py::value_error("initial must be a 1-D complex array with one entry per root (degree)");
        for (py::ssize_t i = 0; i < arr.shape(0); ++i) {
            ire.push_back(arr.at(i).real());
            iim.push_back(arr.at(i).imag());
        }
    }
    std::vector<double> rad;
    if (!coeff_radius.is_none()) {
        auto arr = F64::ensure(coeff_radius);
        if (!arr || arr.ndim() != 1 || arr.shape(0) != n_coeffs)
            throw py::value_error("radius must be a 1-D sequence with one radius per coefficient");
        rad.assign(arr.data(), arr.data() + n_coeffs);
        for (double r : rad)
            if (!(r >= 0.0) || !std::isfinite(r))
                throw py::value_error("every coefficient radius must be a finite number >= 0");
    }
    RootsResult res;
    Status s;
    {
        py::gil_scoped_release release;
        s = argand::find_roots(coeffs.data(), static_cast<int>(n_coeffs), m, res,
                               ire.empty() ? nullptr : ire.data(), iim.empty() ? nullptr : iim.data(),
                               rad.empty() ? nullptr : rad.data());
    }
    raise_status(s, -1);
    const py::ssize_t k = res.n_discs;
    py::array_t<std::complex<double>> center(k);
    py::array_t<double> radius(k);
    py::array_t<std::int64_t> count(k);
    py::array_t<bool> verified(k), real(k);
    for (py::ssize_t i = 0; i < k; ++i) {
        const auto& d = res.discs[i];
        center.mutable_at(i) = {d.re, d.im};
        radius.mutable_at(i) = d.radius;
        count.mutable_at(i) = d.count;
        verified.mutable_at(i) = d.verified;
        real.mutable_at(i) = d.real;
    }
    return py::make_tuple(center, radius, count, verified, real, res.n_infinite, res.wants_exact, res.escalation);
}

// A batch: matrix (N, n+1) -> arrays (N, n), unused entries with count 0.
// kernel: "auto" (the widest batched kernel this CPU runs), "scalar"
// (find_roots row by row, the reference), or an instruction set by name.
py::dict find_roots_batch_py(F64 matrix, const std::string& method, const std::string& kernel, py::object coeff_radius) {
    if (matrix.ndim() != 2) throw py::value_error("matrix must be 2-D: one polynomial per row, lowest degree first");
    F64 rad_arr;
    if (!coeff_radius.is_none()) {
        rad_arr = F64::ensure(coeff_radius);
        if (!rad_arr || rad_arr.ndim() != 2 || rad_arr.shape(0) != matrix.shape(0) || rad_arr.shape(1) != matrix.shape(1))
            throw py::value_error("radius must have the matrix's shape: one radius per coefficient");
        const double* rp = rad_arr.data();
        for (py::ssize_t i = 0; i < rad_arr.size(); ++i)
            if (!(rp[i] >= 0.0) || !std::isfinite(rp[i]))
                throw py::value_error("every coefficient radius must be a finite number >= 0 (row " +
                                      std::to_string(i / std::max<py::ssize_t>(1, rad_arr.shape(1))) + ")");
    }
    const double* rad_data = coeff_radius.is_none() ? nullptr : rad_arr.data();
    const Method m = parse_method(method);
    argand::BatchIsa isa;
    if (!argand::batch_isa_from_name(kernel.c_str(), isa))
        throw py::value_error("unknown kernel '" + kernel + "': expected one of auto, scalar, sse2, avx2, avx512");
    if (!argand::batch_isa_supported(isa))
        throw py::value_error("kernel '" + kernel + "' is not supported by this CPU (best: " +
                              argand::batch_isa_name(argand::BatchIsa::Auto) + ")");
    const py::ssize_t rows = matrix.shape(0), cols = matrix.shape(1);
    if (cols < 1) throw py::value_error("matrix rows must not be empty");
    if (cols - 1 > argand::kMaxDegree)
        throw py::value_error("degree above the supported maximum of " + std::to_string(argand::kMaxDegree));
    const py::ssize_t n = cols - 1;
    // The eight arrays in one recycled buffer (see buffer_acquire).
    const std::size_t entries = static_cast<std::size_t>(rows) * static_cast<std::size_t>(n);
    const std::size_t nrows = static_cast<std::size_t>(rows);
    auto align = [](std::size_t b) { return (b + 63) / 64 * 64; };
    const std::size_t off_radius = align(entries * 16), off_count = off_radius + align(entries * 8),
                      off_verified = off_count + align(entries * 8), off_real = off_verified + align(entries),
                      off_wants = off_real + align(entries), off_ninf = off_wants + align(nrows),
                      off_esc = off_ninf + align(nrows * 4), total = off_esc + align(nrows * 4);
    auto* buf = static_cast<unsigned char*>(buffer_acquire(total));
    py::capsule owner(buf, [](void* p) { buffer_release(p); });
    py::array_t<std::complex<double>> center({rows, n}, reinterpret_cast<std::complex<double>*>(buf), owner);
    py::array_t<double> radius({rows, n}, reinterpret_cast<double*>(buf + off_radius), owner);
    py::array_t<std::int64_t> count({rows, n}, reinterpret_cast<std::int64_t*>(buf + off_count), owner);
    py::array_t<bool> verified({rows, n}, reinterpret_cast<bool*>(buf + off_verified), owner);
    py::array_t<bool> real({rows, n}, reinterpret_cast<bool*>(buf + off_real), owner);
    py::array_t<bool> wants_exact({rows}, reinterpret_cast<bool*>(buf + off_wants), owner);
    py::array_t<std::int32_t> n_infinite({rows}, reinterpret_cast<std::int32_t*>(buf + off_ninf), owner);
    py::array_t<std::int32_t> escalation({rows}, reinterpret_cast<std::int32_t*>(buf + off_esc), owner);
    argand::RowsOut sink;
    static_assert(sizeof(std::complex<double>) == 2 * sizeof(double), "complex128 is two doubles");
    sink.center = reinterpret_cast<double*>(center.mutable_data());
    sink.radius = radius.mutable_data();
    sink.count = count.mutable_data();
    sink.verified = verified.mutable_data();
    sink.real = real.mutable_data();
    sink.wants_exact = wants_exact.mutable_data();
    sink.n_infinite = n_infinite.mutable_data();
    sink.escalation = escalation.mutable_data();
    const double* data = matrix.data();
    std::int64_t bad_row = -1;
    Status bad = Status::Ok;
    argand::BatchCounters counters;
    {
        py::gil_scoped_release release;
        // Every answered row is written straight into the arrays (no
        // RootsResult per row, no second pass).
        bad = argand::find_roots_rows_into(data, rows, static_cast<int>(cols), m, sink, &bad_row, isa, &counters,
                                           rad_data);
    }
    raise_status(bad, static_cast<py::ssize_t>(bad_row));
    py::dict out;
    out["center"] = center;
    out["radius"] = radius;
    out["count"] = count;
    out["verified"] = verified;
    out["real"] = real;
    out["wants_exact"] = wants_exact;
    out["n_infinite"] = n_infinite;
    out["escalation"] = escalation;
    // The batched kernel runs for methods other than paper, degrees 1 to
    // kBatchKernelMaxDegree; otherwise every row took the scalar path.
    const bool batched = isa != argand::BatchIsa::Scalar && m != Method::Paper && n >= 1 &&
                         n <= argand::kBatchKernelMaxDegree;
    out["kernel"] = std::string(batched ? argand::batch_isa_name(isa) : "scalar");
    out["lanes"] = counters.lanes;
    out["lanes_kept"] = counters.kept;
    out["scalar_rows"] = counters.scalar;
    return out;
}

}  // namespace

void init_roots(py::module_& m) {
    m.attr("MAX_DEGREE") = argand::kMaxDegree;
    m.def("find_roots", &find_roots_py, py::arg("coeffs"), py::arg("method") = "auto",
          py::arg("initial") = py::none(), py::arg("radius") = py::none(),
          "Raw root finder for one polynomial (see argand.core.find_roots).");
    m.def("find_roots_batch", &find_roots_batch_py, py::arg("matrix"), py::arg("method") = "auto",
          py::arg("kernel") = "auto", py::arg("radius") = py::none(),
          "Raw batch root finder, GIL released (see argand.core.find_roots_batch).");
    m.def("batch_kernel", [] { return std::string(argand::batch_isa_name(argand::BatchIsa::Auto)); },
          "Instruction set of the batched root kernel this CPU runs: avx512, avx2 or sse2.");
    m.attr("BATCH_MAX_DEGREE") = argand::kBatchKernelMaxDegree;
}
