// ray_run_avx2.cpp: the lane loops of primary_ray_polynomial_run and
// sample_direction_run compiled for the avx2 instruction set (flags in
// core/CMakeLists.txt, as the root kernels'; chosen at run time by
// ray_polynomial.cpp).
#define ARGAND_RAY_NS ray_avx2
#include "ray_run_kernel.h"
