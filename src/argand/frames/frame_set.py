"""A job's frames as (σ, δ) pairs: a δ sweep at one σ, a σ sweep at one δ
(a "rotating band"), a grid sigmas x deltas, or the atlas, a triangular grid
over the whole space the paper says is enough (section 3: "it is only
necessary to sample the complex space determined by σ ≥ 0 and σ + δ ≤ π").

One definition for `argand render` and the farm: both build their frames
with :meth:`FrameSet.from_axes`, so the same request gives the same pairs, in
the same order, and the same refusals. Frames are ordered by row (σ) then
column (δ), so a single-σ sweep keeps the order it always had.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from argand.core import _core
from argand.frames.angles import parse_angle, parse_sweep
from argand.render.arguments import argument_histogram
from argand.render.frames import BAND_RULE, delta_sweep

# A frame's size when a run gives none, a job over HTTP and `argand render`
# alike: defined apart, so the CLI's help states it without importing this.
from argand.frames.defaults import DEFAULT_HEIGHT, DEFAULT_WIDTH

#: How many offending pairs a refusal quotes (the count says how many more).
QUOTED_PAIRS = 5


class BandRuleError(ValueError):
    """Pairs outside σ ≥ 0, δ ≥ 0, σ + δ ≤ π; the message quotes the rule and names them."""


@dataclass(frozen=True)
class FramePoint:
    """One frame's place: its row (σ index) and column (δ index) in the
    grid, and the exact values rendered."""

    sigma_index: int
    delta_index: int
    sigma: float
    delta: float


#: One axis of a run as it is given: None (not given), one value (a number
#: or angle text such as "pi/9"), a list of values, or a sweep of COUNT
#: values from START to STOP inclusive: a mapping {start, stop, count} or the
#: text "START:STOP:COUNT".
Axis = Any


@dataclass(frozen=True)
class FrameSet:
    """The σ axis (rows), the δ axis (columns) and the frames, in frame
    order. A full grid holds every (row, column); the atlas only the
    triangle σ + δ ≤ π (where a diagonal δ may sit an ulp or two below its
    column's value, see atlas_grid). Built from a run's axes by
    :meth:`from_axes`."""

    sigmas: tuple[float, ...]
    deltas: tuple[float, ...]
    points: tuple[FramePoint, ...]

    def __len__(self) -> int:
        return len(self.points)

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.sigmas), len(self.deltas)

    @property
    def is_grid(self) -> bool:
        """More than one σ and more than one δ: an atlas image is worth making."""
        return len(self.sigmas) > 1 and len(self.deltas) > 1

    @property
    def positions(self) -> list[tuple[int, int]]:
        return [(p.sigma_index, p.delta_index) for p in self.points]

    @staticmethod
    def check_one_way(sigma: Axis = None, sigmas: Axis = None, delta: Axis = None, deltas: Axis = None,
                      atlas: int | None = None) -> None:
        """Raises ValueError unless each axis is given one way: sigma (one
        value) or sigmas, delta (one value) or deltas, or atlas alone."""
        given = [name for name, v in (("sigma", sigma), ("sigmas", sigmas), ("delta", delta), ("deltas", deltas))
                 if v is not None]
        if atlas is not None and given:
            raise ValueError(f"atlas lays out its own sigmas and deltas: give it without {' and '.join(given)}")
        if sigma is not None and sigmas is not None:
            raise ValueError("give sigma (one value) or sigmas, not both")
        if delta is not None and deltas is not None:
            raise ValueError("give delta (one value) or deltas, not both")

    @classmethod
    def from_axes(cls, sigma: Axis = None, sigmas: Axis = None, delta: Axis = None, deltas: Axis = None,
                  atlas: int | None = None, max_frames: int | None = None,
                  atlas_cuts: Sequence[float] | None = None) -> "FrameSet":
        """The frames a run asks for, the CLI's and the API's alike: the grid
        σ values x δ values (each axis 0 when not given), or with ``atlas``
        the triangular grid of that many steps (atlas_grid; over
        ``atlas_cuts`` when given, e.g. atlas_cuts() where the roots are). Raises
        ValueError naming the axis for an axis given two ways or unreadable,
        for more than ``max_frames`` frames (counted before anything is
        expanded), and BandRuleError naming the pairs that break the band rule."""
        cls.check_one_way(sigma, sigmas, delta, deltas, atlas)
        if atlas is not None:
            _check_frames(atlas_frames(atlas) if _is_count(atlas) else 0, max_frames)
            return atlas_grid(atlas, atlas_cuts)
        if atlas_cuts is not None:
            raise ValueError("atlas cuts need an atlas")
        row = _axis("sigmas", sigmas) if sigmas is not None else _axis("sigma", 0.0 if sigma is None else sigma, True)
        column = _axis("deltas", deltas) if deltas is not None else _axis("delta", 0.0 if delta is None else delta, True)
        _check_frames(_count(row) * _count(column), max_frames)
        return frame_grid(_values(row), _values(column))

    @classmethod
    def from_points(cls, points: Sequence[FramePoint]) -> "FrameSet":
        """The grid of frames stored with their places: each axis value is
        that of the first frame at its row or column (an atlas's diagonal
        frames may sit an ulp below their column's value)."""
        sigmas: dict[int, float] = {}
        deltas: dict[int, float] = {}
        for p in points:
            sigmas.setdefault(p.sigma_index, p.sigma)
            deltas.setdefault(p.delta_index, p.delta)
        return cls(tuple(sigmas[k] for k in sorted(sigmas)), tuple(deltas[k] for k in sorted(deltas)), tuple(points))


def band_rule_violations(pairs: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """The pairs that break the band rule (decided exactly, in C++)."""
    return [(s, d) for s, d in pairs if not _core.band_rule_holds(float(s), float(d))]


def _pi_fraction(value: float) -> tuple[int, int] | None:
    """(num, den) with value = num π / den (den ≤ 48, lowest terms) to 1e-9; None if it is none."""
    if value == 0:
        return 0, 1
    for den in range(1, 49):
        num = round(value * den / math.pi)
        if num and abs(value - num * math.pi / den) <= 1e-9 * max(1.0, abs(value)):
            g = math.gcd(num, den)
            return num // g, den // g
    return None


def angle_text(value: float) -> str:
    """An angle as a person writes it: a π fraction when it is one ("π/2",
    "2π/3"), else six significant digits ("0.1", "2")."""
    return format_angle(value) if _pi_fraction(value) is not None else f"{value:.6g}"


def _pair_text(sigma: float, delta: float) -> str:
    """A pair that breaks the band rule, its angles as written; when the π
    fractions it reads as keep the rule, it says that rounding broke it."""
    text = f"(σ = {angle_text(sigma)}, δ = {angle_text(delta)})"
    fs, fd = _pi_fraction(sigma), _pi_fraction(delta)
    if fs and fd and fs[0] >= 0 and fd[0] >= 0 and fs[0] * fd[1] + fd[0] * fs[1] <= fs[1] * fd[1]:
        text += f" [σ + δ rounds above π in double precision: {sigma!r} + {delta!r}]"
    return text


def check_band_rule(pairs: Sequence[tuple[float, float]]) -> None:
    """Raises BandRuleError quoting BAND_RULE and the first QUOTED_PAIRS
    offending pairs (with how many more there are)."""
    bad = band_rule_violations(pairs)
    if not bad:
        return
    named = ", ".join(_pair_text(s, d) for s, d in bad[:QUOTED_PAIRS])
    more = f" and {len(bad) - QUOTED_PAIRS} more" if len(bad) > QUOTED_PAIRS else ""
    which = "the frame breaks" if len(pairs) == 1 else \
        f"{len(bad)} of the {len(pairs)} frames {'breaks' if len(bad) == 1 else 'break'}"
    raise BandRuleError(f"{which} the band rule ({BAND_RULE}): {named}{more}; "
                        "an atlas covers the whole space within the rule")


def _is_count(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _axis(name: str, axis: Axis, one: bool = False) -> list[float] | tuple[float, float, int]:
    """An axis read: its values, or a sweep (start, stop, count) not yet
    expanded. ``one``: a single value only (sigma, delta). ValueError names the axis."""
    try:
        if one or not isinstance(axis, (str, list, tuple, Mapping)):
            return [parse_angle(axis)]
        if isinstance(axis, str):
            return parse_sweep(axis) if ":" in axis else [parse_angle(axis)]
        if isinstance(axis, Mapping):
            if set(axis) != {"start", "stop", "count"}:
                raise ValueError(f"a sweep is {{start, stop, count}}, got the keys {sorted(map(str, axis))}")
            count = axis["count"]
            if not _is_count(count) or count < 1:
                raise ValueError(f"a sweep's count must be a whole number >= 1, got {count!r}")
            return parse_angle(axis["start"]), parse_angle(axis["stop"]), count
        if not axis:
            raise ValueError("no values: give at least one")
        return [parse_angle(v) for v in axis]
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def _count(axis: list[float] | tuple[float, float, int]) -> int:
    return axis[2] if isinstance(axis, tuple) else len(axis)


def _values(axis: list[float] | tuple[float, float, int]) -> list[float]:
    """An axis's values: a sweep's as delta_sweep sweeps it."""
    return delta_sweep(*axis) if isinstance(axis, tuple) else axis


def _check_frames(n: int, max_frames: int | None) -> None:
    if max_frames is not None and n > max_frames:
        raise ValueError(f"{n} frames exceed the limit of {max_frames}")


def frame_grid(sigmas: Sequence[float], deltas: Sequence[float]) -> FrameSet:
    """Every pair of ``sigmas`` x ``deltas``, row (σ) by row; BandRuleError
    if any pair breaks the band rule, ValueError for an empty axis or a
    value that is not finite."""
    sigmas, deltas = [float(s) for s in sigmas], [float(d) for d in deltas]
    if not sigmas or not deltas:
        raise ValueError("a job needs at least one sigma and one delta")
    if not all(math.isfinite(v) for v in sigmas + deltas):
        raise ValueError("every sigma and delta must be a finite number")
    points = tuple(FramePoint(i, j, s, d) for i, s in enumerate(sigmas) for j, d in enumerate(deltas))
    check_band_rule([(p.sigma, p.delta) for p in points])
    return FrameSet(tuple(sigmas), tuple(deltas), points)


def atlas_frames(steps: int) -> int:
    """Frames in the atlas of ``steps`` (without building it)."""
    return steps * (steps + 1) // 2


def atlas_grid(steps: int, cuts: Sequence[float] | None = None) -> FrameSet:
    """The whole space σ ≥ 0, σ + δ ≤ π on a triangular grid of ``steps``
    rows and columns over the cuts c_0 = 0 < c_1 < ... < c_steps = π: row i
    starts its bands at σ = c_i, column j ends them j + 1 cuts later, so
    frame (i, j) is the band [c_i, c_{i+j+1}] (δ = c_{i+j+1} - c_i), row i
    holds steps - i frames and the last of each row ends at π. ``cuts``
    None: the uniform atlas, c_k = k π / steps (linspace), whose δ is the
    same along a column, h = π / steps, 2h, ..., π; other cuts (atlas_cuts:
    where the roots are) give each frame its own δ, and the δ axis holds the
    first row's (from_points' rule).

    δ = 0 is left out: a band of width 0 holds a root only if its argument is
    exactly σ, so for σ > 0 that column would be empty, and σ = 0, δ = 0 (the
    real surface) is what `--delta 0` renders. Where a diagonal pair's
    rounded sum exceeds π its δ is lowered by the fewest ulps that satisfy
    the band rule."""
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise ValueError(f"an atlas needs a whole number of steps >= 1, got {steps!r}")
    if cuts is None:
        line = [float(v) for v in np.linspace(0.0, math.pi, steps + 1)]
        width = line[1:]  # (the uniform atlas's δ: the cut itself, as it always was)
    else:
        line = _check_cuts(cuts, steps)
        width = None
    sigmas = tuple(line[:-1])
    points = []
    for i, s in enumerate(sigmas):
        for j in range(steps - i):
            d = width[j] if width is not None else line[i + j + 1] - s
            while not _core.band_rule_holds(s, d):  # the diagonal, rounded above pi: an ulp at a time
                d = math.nextafter(d, 0.0)
            points.append(FramePoint(i, j, s, d))
    deltas = tuple(width) if width is not None else tuple(p.delta for p in points[:steps])
    return FrameSet(sigmas, deltas, tuple(points))


def _check_cuts(cuts: Sequence[float], steps: int) -> list[float]:
    line = [float(c) for c in cuts]
    if len(line) != steps + 1 or line[0] != 0.0 or line[-1] != math.pi:
        raise ValueError(f"an atlas of {steps} steps needs {steps + 1} cuts from 0 to pi, got {len(line)}")
    if not all(a < b for a, b in zip(line, line[1:])):
        raise ValueError("an atlas's cuts must increase strictly")
    return line


#: The share of an atlas's cuts placed by the roots' arguments (the rest are
#: spread evenly, so every part of [0, π] keeps some cuts and the cuts stay
#: apart even where all roots share one argument, e.g. 0 on the real surface).
ROOT_SHARE = 0.75


def atlas_cuts(edges: Sequence[float], counts: Sequence[float], steps: int, root_share: float = ROOT_SHARE,
               at_zero: float = 0, at_pi: float = 0) -> list[float]:
    """Cuts 0 = c_0 < ... < c_steps = π for atlas_grid laid out where the
    roots are: c_k is where the mixed distribution
    M(θ) = (1 - root_share) θ / π + root_share R(θ) reaches k / steps, R the
    roots' share with argument below θ (the histogram ``counts`` over the
    bins ``edges`` of [0, π], argand.render.arguments, linear within a bin).
    So an arc of [0, π] holding a share f of the roots gets about
    steps (root_share f + (1 - root_share) w / π) cuts, w its width, and
    bands change where pictures change. Roots whose argument is exactly 0
    or exactly π (``at_zero``, ``at_pi``: counted in the first and last bin;
    the real roots) are left out: every atlas cuts there already, and
    spreading them over their bin would put cuts where no picture changes.
    No other roots: the uniform cuts."""
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise ValueError(f"an atlas needs a whole number of steps >= 1, got {steps!r}")
    if not 0.0 <= root_share < 1.0:
        raise ValueError(f"root_share must lie in [0, 1), got {root_share!r}")
    e = np.asarray(edges, float)
    c = np.asarray(counts, float)
    if e.ndim != 1 or c.shape != (len(e) - 1,) or len(c) == 0 or np.any(c < 0) or np.any(np.diff(e) <= 0):
        raise ValueError("atlas_cuts needs a histogram: counts >= 0 over increasing edges")
    c = c.copy()
    c[0] = max(0.0, c[0] - float(at_zero))
    c[-1] = max(0.0, c[-1] - float(at_pi))
    total = float(c.sum())
    roots = np.concatenate([[0.0], np.cumsum(c) / total]) if total > 0 else e / math.pi * 0.0
    share = root_share if total > 0 else 0.0
    mixed = (1.0 - share) * (e - e[0]) / (e[-1] - e[0]) + share * roots
    line = [float(v) for v in np.interp(np.arange(steps + 1) / steps, mixed, e)]
    line[0], line[-1] = 0.0, math.pi
    for k in range(1, steps):  # (strictly increasing: interp of a strictly increasing M)
        line[k] = min(max(line[k], math.nextafter(line[k - 1], math.inf)), math.pi)
    return _check_cuts(line, steps)


def root_atlas_cuts(core_scene: Any, width: int, height: int, steps: int) -> list[float]:
    """atlas_cuts for a scene's frame: where the roots of an evenly spread
    grid of its pixels' primary rays are (argand.render.arguments)."""
    h = argument_histogram(core_scene, width, height)
    return atlas_cuts(h["edges"], h["counts"], steps, at_zero=h["at_zero"], at_pi=h["at_pi"])


def format_angle(value: float) -> str:
    """An angle for a label: a multiple of π/36 or π/N (N ≤ 48) written as
    such ("0", "π/4", "2π/3"), anything else to three decimals."""
    fraction = _pi_fraction(value)
    if fraction is None:
        return f"{value:.3f}"
    num, den = fraction
    if num == 0:
        return "0"
    top = "π" if num == 1 else "-π" if num == -1 else f"{num}π"
    return top if den == 1 else f"{top}/{den}"
