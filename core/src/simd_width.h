// simd_width.h: how many doubles one native vector register holds in the
// instruction set this translation unit is compiled for (internal; read by
// the kernels compiled once per instruction set: ray_run_kernel.h and
// roots_batch_kernel.h). AVX-512: 8; AVX and AVX2: 4; otherwise (SSE2, the
// generic build): 2. (The avx2 files are built with -mavx2, which defines
// __AVX__ too.)
#ifndef ARGAND_SIMD_WIDTH_H
#define ARGAND_SIMD_WIDTH_H

namespace argand::detail {

#if defined(__AVX512F__)
constexpr int kSimdDoubles = 8;
#elif defined(__AVX__)
constexpr int kSimdDoubles = 4;
#else
constexpr int kSimdDoubles = 2;
#endif

}  // namespace argand::detail

#endif
