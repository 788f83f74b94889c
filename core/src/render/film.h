// render/film.h: where a tile's pixels go: the samples of a pixel folded
// into its AOVs (PixelAccumulator, the one writer of a pixel), a tile's
// own arrays (allocate) and the per-thread staging tile copied into a
// frame's rows (TileStaging). Internal header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>

#include "argand/render.h"
#include "sample.h"
#include "vec3.h"

#pragma GCC visibility push(hidden)  // internal: binds within the library, as the file-local code did

namespace argand::detail {

/// A pixel's samples, folded in as they are traced (TileAOVs says what
/// each AOV of a sampled pixel is).
struct PixelAccumulator {
    double rgb[3] = {0, 0, 0};
    int hits = 0, certified = 0, seen = 0;
    std::uint8_t status = kCertified, level = kLevelFirst;
    bool shown_hit = false;
    HitInfo shown;   // the shown sample: the hitting sample of least |t|, else the first

    // (Not inlined: with trace_sample inlined into render_tile, GCC 12 -O2
    // compiled add()'s rgb[a] += s.rgb[a] for a = 0, 1 as one cvtpd2ps
    // for the store of s.rgb and an addpd of the unrounded doubles, i.e.
    // it dropped the float rounding of the sample's colour: the 4-sample
    // frames' rgba moved in the last bit. Reading s.rgb here, behind a
    // call, keeps the rounding.)
    [[gnu::noinline]] void add(const SampleResult& s) {
        for (int a = 0; a < 3; ++a) rgb[a] += s.rgb[a];
        hits += s.hit.hit;
        certified += s.hit.status == kCertified;
        status = std::max(status, s.hit.status);
        level = std::max(level, s.hit.level);
        if (seen == 0 || (s.hit.hit && (!shown_hit || s.hit.modulus < shown.modulus))) {
            shown = s.hit;
            shown_hit = s.hit.hit;
        }
        ++seen;
    }

    void write(TileView& out, std::size_t i) const {
        const double n = seen;
        const float rgb_mean[3] = {static_cast<float>(rgb[0] / n), static_cast<float>(rgb[1] / n),
                                   static_cast<float>(rgb[2] / n)};
        write_pixel(out, i, rgb_mean, static_cast<float>(hits / n), status, level, static_cast<float>(certified / n),
                    shown, shown_hit);
    }

    /// Writes pixel i (y * out.stride + x) of the tile's AOVs (the one
    /// place that does).
    /// A view without planes (rgba null: TileView's figures only) gets the
    /// pixel's figures and nothing else.
    static void write_pixel(TileView& out, std::size_t i, const float* rgb, float alpha, std::uint8_t status,
                            std::uint8_t level, float certified_share, const HitInfo& shown, bool shown_hit) {
        if (level > kLevelFirst) ++out.escalations;
        ++out.by_status[status & 3];
        ++out.by_level[level & 7];
        out.hits += alpha > 0.0f;
        if (out.rgba == nullptr) return;
        for (int a = 0; a < 3; ++a) out.rgba[4 * i + a] = rgb[a];
        out.rgba[4 * i + 3] = alpha;
        out.status[i] = status;
        out.escalation[i] = level;
        out.certified_share[i] = certified_share;
        out.count[i] = shown.eligible;
        if (!shown_hit) {  // a miss (the planes come unset: every AOV is written here)
            out.modulus[i] = std::numeric_limits<float>::infinity();
            out.argument[i] = 0.0f;
            out.re[i] = 0.0f;
            out.im[i] = 0.0f;
            return;
        }
        out.modulus[i] = static_cast<float>(shown.modulus);
        out.argument[i] = static_cast<float>(argument_of(shown.disc.im, shown.disc.re));
        out.re[i] = static_cast<float>(shown.disc.re);
        out.im[i] = static_cast<float>(shown.disc.im);
    }

    /// A pixel of one sample, written as add() then write() would (the
    /// same values to the bit: a mean of one is the value), without the
    /// accumulator's copies.
    static void write_single(TileView& out, std::size_t i, const SampleResult& s) {
        const bool certified = s.hit.status == kCertified;
        write_pixel(out, i, s.rgb, s.hit.hit ? 1.0f : 0.0f, s.hit.status, s.hit.level, certified ? 1.0f : 0.0f,
                    s.hit, s.hit.hit);
    }
};

/// Sizes the tile's AOVs and returns the view of them render_tile writes
/// through. Their values are not set here: render_tile writes every pixel
/// through write_pixel, which writes every AOV (a miss included), so one
/// fill pass of nine (resize: a zeroing memset on fresh vectors) is all the
/// setup costs.
TileView allocate(TileAOVs& out, int w, int h);

/// A tile's AOVs in arrays of its own (render_tile's staging area when it
/// writes into a larger frame), one per thread, reused from tile to tile:
/// view() is a TileView of w x h pixels over them (allocate's); flush
/// copies its rows into another view's and adds its figures to that view's.
class TileStaging {
public:
    TileView& view(int w, int h) {
        view_ = allocate(aovs_, w, h);
        return view_;
    }

    /// Copies the staged tile into out (rows out.stride apart) and adds its
    /// figures.
    void flush(TileView& out) const;

private:
    /// memcpy, with the 16-byte-aligned middle of dst written by streaming
    /// stores: the frame's lines are not read first (nor kept in the
    /// caches), as a plain store to a line not cached would.
    static void stream_copy(void* dst_v, const void* src_v, std::size_t bytes);

    TileAOVs aovs_;
    TileView view_;
};

}  // namespace argand::detail

#pragma GCC visibility pop
