"""The farm's hard limits: bounds no setting can raise, so that every request
is bounded before any work is done for it (the settings' limits, lower,
are in argand.farm.settings; docs/farm.md lists both)."""

from __future__ import annotations

# A frame's side in pixels and the objects in one scene: the renderer's
# limits (defined in C++), named here as there.
from argand.render.frames import MAX_FRAME_SIDE, MAX_OBJECTS

#: Frames in one job (a list of deltas or a sweep's count): `argand render`'s limit too.
from argand.frames.defaults import MAX_FRAMES
#: A page number of GET /api/jobs (its offset stays far inside a 64-bit integer).
MAX_PAGE = 1_000_000

__all__ = ["MAX_FRAMES", "MAX_FRAME_SIDE", "MAX_OBJECTS", "MAX_PAGE"]
