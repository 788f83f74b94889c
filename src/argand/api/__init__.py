"""argand.api: the FastAPI job service (the render farm's front door)."""
