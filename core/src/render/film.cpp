// render/film.cpp: a tile's arrays and the staging tile's copy into a
// frame (film.h).
#include "film.h"

#include <algorithm>
#include <cstring>
#include <iterator>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace argand::detail {

TileView allocate(TileAOVs& out, int w, int h) {
    out.width = w;
    out.height = h;
    const std::size_t np = static_cast<std::size_t>(w) * h;
    out.rgba.resize(4 * np);
    out.modulus.resize(np);
    out.argument.resize(np);
    out.re.resize(np);
    out.im.resize(np);
    out.count.resize(np);
    out.status.resize(np);
    out.escalation.resize(np);
    out.certified_share.resize(np);
    out.escalations = 0;
    out.root_calls = 0;
    TileView v;
    v.stride = w;
    v.rgba = out.rgba.data();
    v.modulus = out.modulus.data();
    v.argument = out.argument.data();
    v.re = out.re.data();
    v.im = out.im.data();
    v.count = out.count.data();
    v.status = out.status.data();
    v.escalation = out.escalation.data();
    v.certified_share = out.certified_share.data();
    return v;
}

void TileStaging::flush(TileView& out) const {
    const std::size_t w = static_cast<std::size_t>(view_.width), stride = static_cast<std::size_t>(out.stride);
    for (int y = 0; y < view_.height; ++y) {
        const std::size_t from = static_cast<std::size_t>(y) * w, to = static_cast<std::size_t>(y) * stride;
        auto copy = [&](auto* dst, const auto* src, std::size_t k) {
            stream_copy(dst + k * to, src + k * from, sizeof(*src) * k * w);
        };
        copy(out.rgba, view_.rgba, 4);
        copy(out.modulus, view_.modulus, 1);
        copy(out.argument, view_.argument, 1);
        copy(out.re, view_.re, 1);
        copy(out.im, view_.im, 1);
        copy(out.count, view_.count, 1);
        copy(out.status, view_.status, 1);
        copy(out.escalation, view_.escalation, 1);
        copy(out.certified_share, view_.certified_share, 1);
    }
#if defined(__SSE2__)
    _mm_sfence();  // (the streaming stores ordered before anything after)
#endif
    out.escalations = view_.escalations;
    out.root_calls = view_.root_calls;
    out.hits = view_.hits;
    std::copy(std::begin(view_.by_status), std::end(view_.by_status), std::begin(out.by_status));
    std::copy(std::begin(view_.by_level), std::end(view_.by_level), std::begin(out.by_level));
}

void TileStaging::stream_copy(void* dst_v, const void* src_v, std::size_t bytes) {
    auto* dst = static_cast<unsigned char*>(dst_v);
    const auto* src = static_cast<const unsigned char*>(src_v);
#if defined(__SSE2__)
    const std::size_t head = std::min(bytes, (16 - reinterpret_cast<std::uintptr_t>(dst) % 16) % 16);
    std::memcpy(dst, src, head);
    std::size_t i = head;
    for (; i + 16 <= bytes; i += 16)
        _mm_stream_si128(reinterpret_cast<__m128i*>(dst + i),
                         _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i)));
    std::memcpy(dst + i, src + i, bytes - i);
#else
    std::memcpy(dst, src, bytes);
#endif
}

}  // namespace argand::detail
