"""The primary ray of a pixel, exactly as the renderer casts it.

``primary_ray(scene, width, height, x, y) -> (origin, direction)`` returns
the two triples of doubles the renderer uses for pixel ``(x, y)`` of a
``width`` x ``height`` frame: the camera's eye and the unit direction through
the pixel's centre (column ``x`` from the left, row ``y`` from the top), in
world space. They come from the same C++ code that renders the frame
(``_core.primary_ray`` on the frame's plan), so they are the renderer's
doubles to the last bit, not a re-derivation.

This is a stable, public interface: it lets anyone check a pixel from the
outside. Take the doubles at their exact values, substitute the ray into the
surface, ``p(t) = F(linear (origin - translate) + t linear direction)`` for
each object, and every claim a certified pixel makes (hit or miss, which root)
is a statement about the roots of that exact polynomial
(``tests/helpers/pixel_truth.py`` is such a checker). The ray does not depend on
sigma, delta or the root method.

With several samples per pixel (``samples``, a square side x side), sample
``sample`` sits at the centre of stratum (sample % side, sample // side) of
the pixel: the samples of a width x height frame are exactly the pixel
centres of the (side width) x (side height) frame, to the bit.
"""

from __future__ import annotations

import operator
from typing import Any

from argand.core import _core

Vector3 = tuple[float, float, float]


def _integer(value: Any, name: str) -> int:
    try:
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer, got {value!r}") from None


def _pixel_index(value: Any, name: str, size: int) -> int:
    i = _integer(value, name)
    if not 0 <= i < size:
        raise ValueError(f"{name} = {i} is outside the frame: allowed 0 <= {name} <= {size - 1}")
    return i


def primary_ray(scene: Any, width: int, height: int, x: int, y: int, samples: int = 1,
                sample: int = 0) -> tuple[Vector3, Vector3]:
    """(origin, direction) of pixel (x, y) in a width x height frame (of
    sample ``sample`` when a pixel has ``samples`` samples).

    ``scene`` is an :class:`argand.scene.Scene` or an already converted core
    scene, as for :func:`argand.render.render_tile`. ``origin`` is the camera's
    eye and ``direction`` the unit vector (to rounding) through the pixel's
    centre (or the sample's), both world-space doubles exactly as the renderer
    uses them. Raises ValueError for a pixel or sample outside the frame or an
    invalid scene.
    """
    from argand.render.convert import to_core_scene
    from argand.render.frames import FrameParams, plan

    params = FrameParams(width=_integer(width, "width"), height=_integer(height, "height"),
                         samples=_integer(samples, "samples"))
    x = _pixel_index(x, "x (the pixel's column)", params.width)
    y = _pixel_index(y, "y (the pixel's row)", params.height)
    sample = _pixel_index(sample, "sample (the sample's index in the pixel)", params.samples)
    frame_plan = plan(to_core_scene(scene), params)
    origin, direction = _core.primary_ray(frame_plan, x, y, sample)
    return (
        (float(origin[0]), float(origin[1]), float(origin[2])),
        (float(direction[0]), float(direction[1]), float(direction[2])),
    )
