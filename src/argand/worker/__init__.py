"""argand.worker: Celery workers that render tiles and assemble frames."""
