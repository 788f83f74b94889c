// roots_batch_avx512.cpp: the batched root kernel compiled for the avx512
// instruction set (flags in core/CMakeLists.txt; chosen at run time by
// roots_batch.cpp). All code lives in namespace argand::batch_avx512.
#define ARGAND_BATCH_NS batch_avx512
#include "roots_batch_kernel.h"
