"""Type stubs for the private compiled module argand.core._core."""

from typing import Any

import numpy as np
import numpy.typing as npt

MAX_DEGREE: int
BATCH_MAX_DEGREE: int

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
def find_roots_batch(
    matrix: npt.NDArray[np.float64], method: str = "auto", kernel: str = "auto",
    radius: npt.NDArray[np.float64] | None = None,
) -> dict[str, Any]: ...
def batch_kernel() -> str: ...

# Rendering (bind_render.cpp).
MAX_OBJECTS: int
MAX_SURFACE_DEGREE: int
MAX_FRAME_SIDE: int
BAND_RULE: str
INTERLEAVED_CHANNELS: tuple[str, ...]

class FramePlan:
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...

def band_rule_holds(sigma: float, delta: float) -> bool: ...
def plan_frame(
    scene: dict[str, Any],
    sigma: float,
    delta: float,
    width: int,
    height: int,
    method: str = "auto",
    max_depth: int = 3,
    hue_by_argument: bool = False,
    seed_from_neighbour: bool = True,
) -> FramePlan: ...
def render_tile(plan: FramePlan, x0: int, y0: int, x1: int, y1: int) -> dict[str, Any]: ...
def render_tile_into(
    plan: FramePlan, x0: int, y0: int, x1: int, y1: int, out: npt.NDArray[np.float32], ox: int = 0, oy: int = 0
) -> tuple[int, int, tuple[int, int, int, int], int]: ...
def ray_polynomial(
    plan: FramePlan, object: int, origin: Any, direction: Any, with_radius: bool = False
) -> Any: ...
def primary_ray(plan: FramePlan, x: int, y: int) -> tuple[list[float], list[float]]: ...
def explain_pixel(plan: FramePlan, x: int, y: int, row_start: int) -> dict[str, Any]: ...
