"""The FastAPI application: render jobs over HTTP (OpenAPI at /docs), the
front end at /, Prometheus metrics at /metrics."""

from __future__ import annotations

import time
from pathlib import Path

from fastapi import Depends, FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Histogram, generate_latest

from argand.api.auth import check_access
from argand.api.limits import BodyLimit
from argand.api.routers import frames, jobs, service
from argand.farm.control import NoSuchJob
from argand.farm.metrics import FarmCollector
from argand.farm.settings import Settings

WEB = Path(__file__).resolve().parent.parent / "web"
LATENCY_BUCKETS = (0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10)


def _add_metrics(app: FastAPI, settings: Settings) -> None:
    """/metrics: the farm's (from the database) and this API's request latency."""
    registry = CollectorRegistry()
    registry.register(FarmCollector(settings))
    latency = Histogram("argand_request_seconds", "HTTP request latency by route", ["method", "route"],
                        buckets=LATENCY_BUCKETS, registry=registry)

    @app.middleware("http")
    async def _time_request(request: Request, call_next):
        start = time.perf_counter()
        response = await call_next(request)
        route = request.scope.get("route")
        latency.labels(request.method, getattr(route, "path", "unmatched")).observe(time.perf_counter() - start)
        return response

    @app.get("/metrics", tags=["service"])
    def metrics() -> Response:
        return Response(generate_latest(registry), media_type=CONTENT_TYPE_LATEST)


def _add_front_end(app: FastAPI) -> None:
    index = WEB / "index.html"
    if WEB.is_dir():
        app.mount("/static", StaticFiles(directory=WEB), name="static")

    @app.get("/", include_in_schema=False)
    def root():
        if index.exists():
            return FileResponse(index)
        return JSONResponse({"service": "argand", "docs": "/docs", "jobs": "/api/jobs"})


def create_app(settings: Settings) -> FastAPI:
    app = FastAPI(title="Argand", description="Render jobs of algebraic surfaces in complex space.",
                  dependencies=[Depends(check_access)])
    app.state.settings = settings
    for module in (jobs, frames, service):
        app.include_router(module.router)

    @app.exception_handler(ValueError)
    async def _value_error(_request: Request, exc: ValueError):
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    @app.exception_handler(NoSuchJob)
    async def _no_such_job(_request: Request, exc: NoSuchJob):
        return JSONResponse(status_code=404, content={"detail": str(exc)})

    _add_metrics(app, settings)
    _add_front_end(app)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    return app
