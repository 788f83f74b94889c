"""The engine's modes (root kernel, culling, real-root path, decision path,
shading path) as
one checked value carried with a frame's parameters, and the one place
where they are read from the environment.

Every combination gives the same decisions (the status and hit of every
pixel; tests/render/test_kernel.py, test_decide.py, test_cull.py and
test_shade.py and test_real_path.py hold them to it); the alternatives to the defaults are the
references those tests and the benchmarks compare against. The library
never reads the environment itself: the CLI and the worker call
:func:`engine_options_from_environment` once and pass the result down,
and each EXR records the options its frame was rendered with.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, fields
from typing import Mapping

#: Root kernels of the primary rays: auto (the widest batched kernel this
#: CPU runs), the batched kernels by instruction set, or scalar (find_roots
#: sample by sample with the neighbour seeds: the reference).
KERNELS = ("auto", "scalar", "sse2", "avx2", "avx512")
#: fast: the quick predicates (decide_fast) with the widest classifier;
#: fast-scalar: the same predicates in scalar code; full: decide_full for
#: every pixel (the reference).
DECIDE_MODES = ("fast", "fast-scalar", "full")
#: fast: the tabled gradient and fast paths; reference: the plain per-pixel
#: code (std::pow, std::exp, std::atan2 always). Same bits.
SHADE_MODES = ("fast", "reference")

#: The environment variables the CLI and the worker read, and the field each sets.
ENVIRONMENT = {"ARGAND_KERNEL": "kernel", "ARGAND_CULL": "cull", "ARGAND_DECIDE": "decide", "ARGAND_SHADE": "shade",
               "ARGAND_REAL": "real"}
#: The fields given as on | off in the environment.
SWITCHES = ("cull", "real")


@dataclass(frozen=True)
class EngineOptions:
    """How the engine computes a frame. Raises ValueError naming the field
    and the allowed values for anything else. Whether this CPU runs the
    kernel is checked when a frame is planned (plan_frame)."""

    kernel: str = "auto"
    cull: bool = True
    decide: str = "fast"
    shade: str = "fast"
    #: Objects that need only real roots (every object at sigma = delta = 0,
    #: an object with space: real always) isolate just the real roots inside
    #: their clipping sphere where that proves the pixel; False (the
    #: default): every complex root, always. Off by default while it is
    #: slower than the batched complex kernel (docs/performance.md).
    real: bool = False

    def __post_init__(self) -> None:
        for field, allowed in (("kernel", KERNELS), ("decide", DECIDE_MODES), ("shade", SHADE_MODES)):
            value = getattr(self, field)
            if value not in allowed:
                raise ValueError(f"engine option {field}={value!r}: use one of {', '.join(allowed)}")
        for field in SWITCHES:
            if not isinstance(getattr(self, field), bool):
                raise ValueError(f"engine option {field}={getattr(self, field)!r}: use True or False")

    def stored(self) -> dict:
        """The options as a JSON object (a job's row keeps them)."""
        return asdict(self)

    @classmethod
    def from_stored(cls, value: Mapping[str, object] | None) -> "EngineOptions":
        """EngineOptions from stored(); None (a job stored before jobs kept
        their options) is the defaults. ValueError for anything else."""
        if value is None:
            return cls()
        unknown = set(value) - {f.name for f in fields(cls)}
        if unknown:
            raise ValueError(f"engine options: unknown field(s) {', '.join(sorted(unknown))}")
        return cls(**value)

    def metadata(self) -> dict[str, str]:
        """The options as a frame's metadata (EXR attributes argand:engine:*)."""
        return {f"argand:engine:{k}": str(v).lower() if isinstance(v, bool) else v for k, v in asdict(self).items()}


def engine_options_from_environment(environ: Mapping[str, str] | None = None) -> EngineOptions:
    """EngineOptions from ARGAND_KERNEL, ARGAND_CULL and ARGAND_REAL (on |
    off), ARGAND_DECIDE and ARGAND_SHADE; an unset or empty variable keeps the
    default. Raises ValueError naming the variable for a bad value, so a
    mistake stops the CLI or the worker at start, not a job mid-way."""
    env = os.environ if environ is None else environ
    values: dict[str, object] = {}
    for name, field in ENVIRONMENT.items():
        raw = env.get(name, "")
        if raw == "":
            continue
        if field in SWITCHES:
            if raw not in ("on", "off"):
                raise ValueError(f"{name}={raw}: use on or off")
            values[field] = raw == "on"
        else:
            values[field] = raw
    try:
        return EngineOptions(**values)
    except ValueError as exc:
        field = str(exc).split("=")[0].removeprefix("engine option ")
        name = next(n for n, f in ENVIRONMENT.items() if f == field)
        raise ValueError(f"{name}={values[field]}: {str(exc).split(': ', 1)[1]}") from None


def engine_environment(options: EngineOptions) -> dict[str, str]:
    """The variables that give a child process (a worker started by `argand
    serve`) these options: engine_options_from_environment's inverse."""
    return {"ARGAND_KERNEL": options.kernel, "ARGAND_CULL": "on" if options.cull else "off",
            "ARGAND_DECIDE": options.decide, "ARGAND_SHADE": options.shade,
            "ARGAND_REAL": "on" if options.real else "off"}
