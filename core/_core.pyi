"""Type stubs for the private compiled module argand.core._core."""

from typing import Any

import numpy as np
import numpy.typing as npt

MAX_DEGREE: int

def find_roots(
    coeffs: npt.NDArray[np.float64],
    method: str = "auto",
    initial: npt.NDArray[np.complex128] | None = None,
    radius: npt.NDArray[np.float64] | None = None,
) -> tuple[
    npt.NDArray[np.complex128],
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    npt.NDArray[np.bool_],
    npt.NDArray[np.bool_],
    int,
    bool,
    int,
]: ...
def find_roots_batch(matrix: npt.NDArray[np.float64], method: str = "auto") -> dict[str, Any]: ...
