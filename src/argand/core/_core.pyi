"""Type stubs for the private compiled module argand.core._core."""

from collections.abc import Callable, Iterable, MutableSequence, Sequence
from typing import Any, ClassVar, Literal, NotRequired, TypedDict, overload

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
MAX_SAMPLES: int
EXACT_BITS_LIMIT: int
EXACT_PIXELS_PER_BLOCK: int
EXACT_DEFAULT_BITS: int
BAND_RULE: str
INTERLEAVED_CHANNELS: tuple[str, ...]
AOVS: tuple[tuple[str, str], ...]
STATUS_NAMES: dict[int, str]
LADDER_LEVEL_NAMES: dict[int, str]
#: Bounds of the typed scene's number fields, by "Struct.field": (lo, hi,
#: lo_open, hi_open); the setters check them and argand.scene.model reads them.
FIELD_LIMITS: dict[str, tuple[float, float, bool, bool]]

Vec3 = tuple[float, float, float]
_Numbers = Sequence[float] | npt.NDArray[np.float64]
Term = tuple[int, int, int, float]

# The typed scene (render.h's structs). Every field is checked when set (in
# the keyword constructor too): a wrong type is a TypeError and a wrong value
# a ValueError, each naming the field ("CameraSpec.up[2] must be finite").
# A constructor's omitted fields keep render.h's default member initialisers.
class Material:
    FIELDS: ClassVar[tuple[str, ...]]
    def __init__(
        self,
        *,
        color: _Numbers = ...,
        diffuse: float = ...,
        specular: float = ...,
        shininess: float = ...,
        reflectivity: float = ...,
        transparency: float = ...,
        ior: float = ...,
    ) -> None: ...
    @property
    def color(self) -> Vec3: ...
    @color.setter
    def color(self, value: _Numbers) -> None: ...
    diffuse: float
    specular: float
    shininess: float
    reflectivity: float
    transparency: float
    ior: float

class SurfaceSpec:
    FIELDS: ClassVar[tuple[str, ...]]
    def __init__(
        self,
        *,
        terms: Sequence[Term] = ...,
        degree: int = ...,
        complex_space: bool = ...,
        clip_radius: float = ...,
        material: Material = ...,
        linear: _Numbers = ...,
        translate: _Numbers = ...,
    ) -> None: ...
    @property
    def terms(self) -> tuple[Term, ...]: ...
    @terms.setter
    def terms(self, value: Sequence[Term]) -> None: ...
    degree: int
    complex_space: bool
    clip_radius: float
    material: Material
    @property
    def linear(self) -> tuple[float, ...]: ...
    @linear.setter
    def linear(self, value: _Numbers) -> None: ...
    @property
    def translate(self) -> Vec3: ...
    @translate.setter
    def translate(self, value: _Numbers) -> None: ...

class Light:
    FIELDS: ClassVar[tuple[str, ...]]
    def __init__(
        self, *, vector: _Numbers = ..., directional: bool = ..., color: _Numbers = ..., intensity: float = ...
    ) -> None: ...
    @property
    def vector(self) -> Vec3: ...
    @vector.setter
    def vector(self, value: _Numbers) -> None: ...
    directional: bool
    @property
    def color(self) -> Vec3: ...
    @color.setter
    def color(self, value: _Numbers) -> None: ...
    intensity: float

class CameraSpec:
    FIELDS: ClassVar[tuple[str, ...]]
    def __init__(
        self, *, position: _Numbers = ..., look_at: _Numbers = ..., up: _Numbers = ..., fov_degrees: float = ...
    ) -> None: ...
    @property
    def position(self) -> Vec3: ...
    @position.setter
    def position(self, value: _Numbers) -> None: ...
    @property
    def look_at(self) -> Vec3: ...
    @look_at.setter
    def look_at(self, value: _Numbers) -> None: ...
    @property
    def up(self) -> Vec3: ...
    @up.setter
    def up(self, value: _Numbers) -> None: ...
    fov_degrees: float

class SurfaceSpecList(MutableSequence[SurfaceSpec]):
    def __init__(self, items: Iterable[SurfaceSpec] = ...) -> None: ...

class LightList(MutableSequence[Light]):
    def __init__(self, items: Iterable[Light] = ...) -> None: ...

class SceneSpec:
    FIELDS: ClassVar[tuple[str, ...]]
    def __init__(
        self,
        *,
        objects: Iterable[SurfaceSpec] = ...,
        lights: Iterable[Light] = ...,
        background: _Numbers = ...,
        camera: CameraSpec = ...,
    ) -> None: ...
    @property
    def objects(self) -> SurfaceSpecList: ...
    @objects.setter
    def objects(self, value: Iterable[SurfaceSpec]) -> None: ...
    @property
    def lights(self) -> LightList: ...
    @lights.setter
    def lights(self, value: Iterable[Light]) -> None: ...
    @property
    def background(self) -> Vec3: ...
    @background.setter
    def background(self, value: _Numbers) -> None: ...
    camera: CameraSpec

class FramePlan:
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def samples(self) -> int: ...
    @property
    def engine(self) -> dict[str, Any]: ...

class PolynomialExplanation(TypedDict):
    object: int
    coeffs: list[float]
    radius: list[float]
    roots_status: int
    seeded: bool
    root_escalation: int
    complete: bool

class DiscExplanation(TypedDict):
    object: int
    center: complex
    radius: float
    count: int
    verified: bool
    real: bool
    modulus: tuple[float, float]
    at_origin: bool
    in_band: str
    inside_clip: str
    live: bool
    eligible: bool

class PixelExplanation(TypedDict):
    origin: list[float]
    direction: list[float]
    polynomials: list[PolynomialExplanation]
    discs: list[DiscExplanation]
    chosen: int
    hit: bool
    status: int
    escalation: int
    reason: str
    exact_ran: bool
    root: complex
    exact: NotRequired[dict[str, Any]]  # the exact tier's answer and steps, when it ran

def band_rule_holds(sigma: float, delta: float) -> bool: ...
def sample_side(samples: int) -> int: ...
def plan_frame(
    scene: SceneSpec,
    sigma: float,
    delta: float,
    width: int,
    height: int,
    method: str = "auto",
    max_depth: int = 3,
    hue_by_argument: bool = False,
    seed_from_neighbour: bool = True,
    exact_pixels_per_block: int = ...,
    exact_max_bits: int = ...,
    samples: int = 1,
    kernel: str = "auto",
    cull: bool = True,
    decide: str = "fast",
    shade: str = "fast",
) -> FramePlan: ...

#: The exact tier's hook: (frame, query) -> answer (argand.render.exact.decide_pixel).
ExactSolver = Callable[[dict[str, Any], dict[str, Any]], dict[str, Any]]

def render_tile(
    plan: FramePlan, x0: int, y0: int, x1: int, y1: int, exact: ExactSolver | None = None
) -> dict[str, Any]: ...
def render_tile_frame(
    plan: FramePlan,
    x0: int,
    y0: int,
    x1: int,
    y1: int,
    rgba: npt.NDArray[np.float32],
    Z: npt.NDArray[np.float32],
    arg: npt.NDArray[np.float32],
    re: npt.NDArray[np.float32],
    im: npt.NDArray[np.float32],
    count: npt.NDArray[np.int32],
    status: npt.NDArray[np.uint8],
    escalation: npt.NDArray[np.uint8],
    certified_share: npt.NDArray[np.float32],
    exact: ExactSolver | None = None,
) -> tuple[int, int, tuple[int, int, int, int], int, tuple[int, int, int, int, int, int, int, int]]: ...
#: A band's figures from render_tile_bands: escalations, root calls, pixels
#: per status 0..3, pixels that hit, pixels per ladder level 0..7.
BandFigures = tuple[int, int, tuple[int, int, int, int], int, tuple[int, int, int, int, int, int, int, int]]

def render_tile_bands(
    plans: Sequence[FramePlan],
    x0: int,
    y0: int,
    x1: int,
    y1: int,
    outs: list[tuple[npt.NDArray[Any], ...]],
    ox: int = -1,
    oy: int = -1,
    exact: ExactSolver | None = None,
    *,
    record: bool = False,
    field: bytes | None = None,
) -> list[BandFigures] | tuple[list[BandFigures], bytes]: ...
def rays_fingerprint(plan: FramePlan) -> int: ...
def render_tile_into(
    plan: FramePlan,
    x0: int,
    y0: int,
    x1: int,
    y1: int,
    out: npt.NDArray[np.float32],
    ox: int = 0,
    oy: int = 0,
    exact: ExactSolver | None = None,
) -> tuple[int, int, tuple[int, int, int, int], int]: ...
@overload
def ray_polynomial(
    plan: FramePlan, object: int, origin: _Numbers, direction: _Numbers, with_radius: Literal[False] = False
) -> npt.NDArray[np.float64]: ...
@overload
def ray_polynomial(
    plan: FramePlan, object: int, origin: _Numbers, direction: _Numbers, with_radius: Literal[True]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def rebased_ray_polynomial(
    plan: FramePlan, object: int, direction: _Numbers, t0: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def primary_ray(plan: FramePlan, x: int, y: int, sample: int = 0) -> tuple[list[float], list[float]]: ...
def explain_pixel(
    plan: FramePlan,
    x: int,
    y: int,
    row_start: int,
    sample: int = 0,
    exact: ExactSolver | None = None,
    column_start: int = 0,
) -> PixelExplanation: ...
def render_kernel(plan: FramePlan) -> str: ...
