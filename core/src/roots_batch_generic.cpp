// roots_batch_generic.cpp: the batched root kernel compiled for the generic
// instruction set (flags in core/CMakeLists.txt; chosen at run time by
// roots_batch.cpp). All code lives in namespace argand::batch_generic.
#define ARGAND_BATCH_NS batch_generic
#include "roots_batch_kernel.h"
