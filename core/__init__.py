"""argand.core: all complex roots of a real polynomial, with proven enclosures.

The compiled module ``argand.core._core`` does the work; this package gives it
a typed, documented interface. See :func:`find_roots` for the contract.
"""

from argand.core.roots import (
    METHODS,
    BatchRoots,
    Roots,
    find_roots,
    find_roots_batch,
)

__all__ = ["METHODS", "BatchRoots", "Roots", "find_roots", "find_roots_batch"]
