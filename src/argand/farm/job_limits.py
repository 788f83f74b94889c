"""The farm's hard limits: bounds no setting can raise, so that every request
is bounded before any work is done for it (the settings' limits, lower,
are in argand.farm.settings; docs/farm.md lists both)."""

from __future__ import annotations

from argand.render.frames import MAX_FRAME_SIDE, MAX_OBJECTS

#: A frame's side in pixels (the renderer's, defined in C++).
MAX_SIDE = MAX_FRAME_SIDE
#: Frames in one job (a list of deltas or a sweep's count).
MAX_FRAMES = 10_000
#: A page number of GET /api/jobs (its offset stays far inside a 64-bit integer).
MAX_PAGE = 1_000_000
#: Most objects in one scene (the renderer's, defined in C++).
MAX_SCENE_OBJECTS = MAX_OBJECTS
