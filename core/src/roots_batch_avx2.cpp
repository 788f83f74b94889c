// roots_batch_avx2.cpp: the batched root kernel compiled for the avx2
// instruction set (flags in core/CMakeLists.txt; chosen at run time by
// roots_batch.cpp). All code lives in namespace argand::batch_avx2.
#define ARGAND_BATCH_NS batch_avx2
#include "roots_batch_kernel.h"
