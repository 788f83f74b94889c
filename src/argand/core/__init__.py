"""argand.core: all complex roots of a real polynomial, with proven enclosures.

The compiled module ``argand.core._core`` does the work; this package gives it
a typed, documented interface. See :func:`find_roots` for the contract.
"""

from argand.core.roots import (
    BATCH_MAX_DEGREE,
    KERNELS,
    METHODS,
    BatchRoots,
    Roots,
    find_roots,
    batch_kernel,
    find_roots_batch,
)

__all__ = ["BATCH_MAX_DEGREE", "KERNELS", "METHODS", "batch_kernel", "BatchRoots", "Roots", "find_roots", "find_roots_batch"]
