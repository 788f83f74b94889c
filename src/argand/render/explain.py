"""One pixel, explained: the ray, its polynomial with coefficient radii, the
root discs, every decision and the status, from the very code path that
render_tile runs (``_core.explain_pixel``), so that anyone can check a pixel
independently (e.g. with python-flint on the exact ray polynomial).

The ray's origin and direction are the exact doubles the renderer uses;
``float.hex`` prints them without loss. When the pixel reaches the exact
tier (ladder level 5), its steps are printed too: the exact polynomial's
squarefree factors, the root balls at each precision with their decisions,
and its conclusion (the tier runs for the explained pixel whatever its
block's budget).
"""

from __future__ import annotations

from typing import Any

from argand.core import _core
from argand.render.exact import decide_pixel
from argand.render.frames import (
    DOUBLE_DOUBLE_LEVEL,
    LADDER_LEVEL_NAMES,
    REBASED_LEVEL,
    STATUS_NAMES,
    FrameParams,
    plan,
)


def explain_pixel(scene: Any, params: FrameParams, x: int, y: int, tile: int = 64, sample: int = 0) -> dict:
    """The decisions render_tile makes for pixel (x, y) of the frame
    ``params`` when tiles are ``tile`` pixels wide (a tile's rows replay the
    neighbour seeds from its first column, and the batched kernel's seeds
    from its first row, as render_tile does). With
    ``params.samples`` > 1: for sample ``sample`` of the pixel (its status
    is one of those whose worst is the pixel's)."""
    from argand.render.convert import to_core_scene

    if tile < 1:
        raise ValueError("tile size must be >= 1")
    if not (0 <= x < params.width and 0 <= y < params.height):
        raise ValueError(f"pixel ({x}, {y}) is not inside the {params.width}x{params.height} frame")
    if not 0 <= sample < params.samples:
        raise ValueError(f"sample {sample} is not one of the pixel's {params.samples} samples (0..{params.samples - 1})")
    frame_plan = plan(to_core_scene(scene), params)
    return _core.explain_pixel(frame_plan, int(x), int(y), int(x) // tile * tile, int(sample), exact=decide_pixel,
                               column_start=int(y) // tile * tile)


def format_explanation(e: dict) -> list[str]:
    """Human-readable lines (exact doubles in hex next to their decimal)."""

    def vec(v: list[float]) -> str:
        return "(" + ", ".join(f"{c!r} [{float(c).hex()}]" for c in v) + ")"

    lines = [f"ray origin    {vec(e['origin'])}", f"ray direction {vec(e['direction'])}"]
    for p in e["polynomials"]:
        lines.append(
            f"object {p['object']}: p(t) = sum c_k t^k, |exact p_k - c_k| <= r_k "
            f"(roots status {p['roots_status']}, seeded {p['seeded']}, root tier {p['root_escalation']}, "
            f"all discs verified {p['complete']})"
        )
        for k, (c, r) in enumerate(zip(p["coeffs"], p["radius"])):
            lines.append(f"  c_{k} = {c!r} [{float(c).hex()}]  r_{k} = {r:.3e}")
        if p.get("provisional") and e.get("escalation", 0) == REBASED_LEVEL:
            lines.append("  discs: the batch lane's own Smith discs, merged where they overlap (each cluster holds "
                         "exactly its count of roots); they did not decide the pixel alone, so the ladder's "
                         "rebased level re-isolated the clusters in double from the ray polynomial expanded about "
                         "them, and the row was not solved again")
        elif p.get("provisional") and e.get("escalation", 0) >= DOUBLE_DOUBLE_LEVEL:
            lines.append("  discs: the batch lane's own Smith discs, merged where they overlap (each cluster holds "
                         "exactly its count of roots); they did not decide the pixel alone, so the ladder "
                         "re-isolated the clusters from them (the rebased ray polynomial in double, else "
                         "double-double coefficients), and the row was not solved again")
        elif p.get("provisional"):
            lines.append("  discs: the batch lane's own Smith discs, merged where they overlap (each cluster holds "
                         "exactly its count of roots); they decided the pixel, so the row was not solved again")
        if p.get("settled"):
            lines.append("  discs: the batch lane's merged discs did not decide the pixel, nor did the ladder's "
                         "re-isolation from them (the rebased ray polynomial, double-double), so the row was "
                         "solved again from the lane's approximations (find_roots)")
        if p.get("outside_sphere"):
            lines.append("  not solved: the ray provably misses the object's clipping sphere "
                         "(|o + s d| > radius for every s >= 0), so none of its roots can be shown")
    lines.append("discs (in band / inside clip: yes, no, unknown):")
    for i, d in enumerate(e["discs"]):
        z = d["center"]
        mark = "  <- chosen" if i == e["chosen"] and e["chosen"] >= 0 else ""
        lines.append(
            f"  [{i}] object {d['object']} centre {z.real!r} {'-' if z.imag < 0 else '+'} {abs(z.imag)!r}i radius {d['radius']:.3e} count {d['count']} "
            f"verified {d['verified']} real {d['real']} |t| in [{d['modulus'][0]!r}, {d['modulus'][1]!r}] "
            f"band {d['in_band']} clip {d['inside_clip']} at t=0 {d['at_origin']} live {d['live']} "
            f"eligible {d['eligible']}{mark}"
        )
    if e.get("exact_ran"):
        x = e["exact"]
        lines.append("exact tier (the exact rational ray polynomial, python-flint/arb):")
        lines += [f"  {step}" for step in x["steps"]]
        if x["decided"] and x["hit"]:
            z = x["root"]
            lines.append(f"  the pixel's root: object {x['object']}, t = {z.real!r} {'-' if z.imag < 0 else '+'} "
                         f"{abs(z.imag)!r}i (nearest doubles), eligible roots {x['eligible']}")
    lines.append(
        f"status {e['status']} ({STATUS_NAMES[e['status']]}): {e['reason']}; "
        f"{'hit' if e['hit'] else 'miss'}; ladder level {e['escalation']} ({LADDER_LEVEL_NAMES[e['escalation']]})"
    )
    return lines
