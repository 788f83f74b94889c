// fuzz_input.h: turns the fuzzer's bytes into typed values, deterministically.
// Every read succeeds: past the end of the data it returns zeros, so a short
// input is still a valid (small) case.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace argand_fuzz {

class FuzzInput {
public:
    FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

    std::size_t remaining() const { return size_ - pos_; }

    std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }

    /// An integer in [lo, hi] (hi - lo < 65536).
    int in_range(int lo, int hi) {
        const unsigned span = static_cast<unsigned>(hi - lo) + 1u;
        const unsigned raw = span > 256u ? (static_cast<unsigned>(byte()) << 8) | byte() : byte();
        return lo + static_cast<int>(raw % span);
    }

    /// Any bit pattern: NaN, infinities, subnormals and signed zeros included.
    double raw_double() {
        std::uint64_t bits = 0;
        for (int i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(byte()) << (8 * i);
        double v;
        std::memcpy(&v, &bits, sizeof v);
        return v;
    }

    /// A double that people write more often: a small integer times a power
    /// of two anywhere in the double range (exact zeros, multiple roots and
    /// huge or subnormal scales are all reachable), or raw bits (1 in 8).
    double structured_double() {
        const std::uint8_t kind = byte();
        if ((kind & 7) == 0) return raw_double();
        const int mantissa = static_cast<std::int8_t>(byte());
        int exponent = 0;
        switch ((kind >> 3) & 3) {
            case 0: exponent = 0; break;                              // integers
            case 1: exponent = in_range(-8, 8); break;                // dyadic
            case 2: exponent = in_range(-60, 60); break;              // wide
            default: exponent = in_range(-1100, 1100); break;         // extreme
        }
        return ldexp_int(mantissa, exponent);
    }

private:
    static double ldexp_int(int mantissa, int exponent) {
        double v = static_cast<double>(mantissa);
        // Scale one step at a time so that no intermediate overflows early.
        while (exponent > 0) { v *= 2.0; --exponent; }
        while (exponent < 0) { v *= 0.5; ++exponent; }
        return v;
    }

    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

}  // namespace argand_fuzz
