"""A frame's size when a run gives none (a job over HTTP and `argand render`
alike), apart from argand.frames.frame_set so that the CLI states it in its
help without importing numpy and the renderer."""

DEFAULT_WIDTH = DEFAULT_HEIGHT = 512
