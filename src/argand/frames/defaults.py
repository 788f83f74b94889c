"""A frame's size when a run gives none (a job over HTTP and `argand render`
alike), and the most frames one run may ask for, apart from
argand.frames.frame_set so that the CLI states them without importing numpy,
the renderer or the farm."""

DEFAULT_WIDTH = DEFAULT_HEIGHT = 512

#: Frames in one run: a job (a list of deltas or a sweep's count; the farm's
#: max_frames may be lower) or an `argand render`, counted before anything
#: is expanded.
MAX_FRAMES = 10_000
