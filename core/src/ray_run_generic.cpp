// ray_run_generic.cpp: the lane loops of primary_ray_polynomial_run and
// sample_direction_run compiled for the generic instruction set (flags in
// core/CMakeLists.txt, as the root kernels'; chosen at run time by
// ray_polynomial.cpp).
#define ARGAND_RAY_NS ray_generic
#include "ray_run_kernel.h"
