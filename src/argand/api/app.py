"""The FastAPI application: render jobs over HTTP (OpenAPI at /docs), the
front end at /, Prometheus metrics at /metrics."""

from __future__ import annotations

import importlib.util
import time
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import Depends, FastAPI, Request
from fastapi.exception_handlers import http_exception_handler, request_validation_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import FileResponse, JSONResponse, PlainTextResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Histogram, generate_latest

from argand.api.auth import check_access, needs_token
from argand.api.connections import connection_options
from argand.api.methods import allowed_methods
from argand.api.outages import add_outage_answers
from argand.api.request_limits import BodyLimit
from argand.api.routes import bands, frames, jobs, service
from argand.farm.control import NoSuchJob
from argand.farm.metrics import FarmCollector
from argand.farm.outbox import Drainer
from argand.farm.settings import Settings

WEB = Path(__file__).resolve().parent.parent / "web"
#: Swagger UI's own files, from the swagger-ui-py package (nothing from a CDN).
SWAGGER_UI = Path(importlib.util.find_spec("swagger_ui").submodule_search_locations[0]) / "static"
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

    @app.get("/metrics", tags=["service"], response_class=PlainTextResponse)
    def metrics() -> Response:
        return Response(generate_latest(registry), media_type=CONTENT_TYPE_LATEST)


def _add_api_page(app: FastAPI) -> None:
    """/docs: Swagger UI served from this app's own files, so it works offline."""
    app.mount("/docs-assets", StaticFiles(directory=SWAGGER_UI), name="docs-assets")

    @app.get("/docs", include_in_schema=False)
    def docs():
        return get_swagger_ui_html(openapi_url=app.openapi_url, title=f"{app.title}: API",
                                   swagger_js_url="/docs-assets/swagger-ui-bundle.js",
                                   swagger_css_url="/docs-assets/swagger-ui.css", swagger_favicon_url="/favicon.ico",
                                   swagger_ui_parameters={"validatorUrl": None})  # no badge from swagger.io


def _add_front_end(app: FastAPI) -> None:
    index = WEB / "index.html"
    if WEB.is_dir():
        app.mount("/static", StaticFiles(directory=WEB), name="static")

    @app.get("/favicon.ico", include_in_schema=False)
    def favicon():
        return FileResponse(WEB / "favicon.ico", media_type="image/x-icon")

    @app.get("/", include_in_schema=False)
    def root():
        if index.exists():
            return FileResponse(index)
        return JSONResponse({"service": "argand", "docs": "/docs", "jobs": "/api/jobs"})


_MESSAGE = {"type": "object", "properties": {"detail": {"type": "string"}}, "required": ["detail"]}


def _answer(description: str) -> dict:
    return {"description": description, "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Message"}}}}


def _document_errors(app: FastAPI, settings: Settings) -> None:
    """The OpenAPI document says every answer the service gives: a 422 is
    FastAPI's list of field errors or one message (a refused job, a scene
    that does not parse, a limit); a path with a job or preset may be a 404;
    a body may be a 413; with a token, the state-changing operations are
    secured (bearer) and may be a 401."""
    generate = app.openapi

    def openapi() -> dict:
        if app.openapi_schema is not None:
            return app.openapi_schema
        schema = generate()
        components = schema.setdefault("components", {})
        components.setdefault("schemas", {})["Message"] = _MESSAGE
        error = components["schemas"].get("HTTPValidationError")
        if error is not None:
            listed = {k: v for k, v in error["properties"]["detail"].items() if k != "title"}
            error["properties"]["detail"] = {"anyOf": [{"type": "string"}, listed], "title": "Detail"}
        secured = settings.token() is not None
        if secured:
            components["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer",
                                                        "description": "The farm's API token (ARGAND_API_TOKEN)"}}
        for path, operations in schema.get("paths", {}).items():
            for method, op in operations.items():
                answers = op.setdefault("responses", {})
                if "{" in path:
                    answers.setdefault("404", _answer("No such job, preset or file (yet)"))
                if "requestBody" in op:
                    answers.setdefault("400", _answer("The body is not JSON"))
                    answers.setdefault("413", _answer("The body is above max_body_bytes"))
                if secured and needs_token(settings, method.upper(), path):
                    op["security"] = [{"bearer": []}]
                    answers.setdefault("401", _answer("No token, or a wrong one"))
        app.openapi_schema = schema
        return schema

    app.openapi = openapi


def uvicorn_options(settings: Settings) -> dict:
    """How uvicorn serves the app: X-Forwarded-* believed only from the
    proxies the settings name (uvicorn's own default trusts 127.0.0.1, and
    with it any local client's header); header, keep-alive and connection
    bounds (argand.api.connections)."""
    trusted = settings.forwarded_allow_ips
    return {"host": settings.host, "port": settings.port, "log_level": "warning",
            "proxy_headers": trusted is not None, "forwarded_allow_ips": trusted or "", **connection_options()}


def _answer_unparsable_bodies(app: FastAPI) -> None:
    """A body that is not JSON is a 400 (a client's mistake in the request
    itself); a JSON body that does not fit the route stays a 422."""

    @app.exception_handler(RequestValidationError)
    async def invalid(request: Request, exc: RequestValidationError):
        broken = [e for e in exc.errors() if e.get("type") == "json_invalid"]
        if broken:
            where = broken[0].get("ctx", {}).get("error", "")
            return JSONResponse({"detail": f"the request body is not valid JSON ({where})"}, status_code=400)
        return await request_validation_exception_handler(request, exc)


def _answer_wrong_methods(app: FastAPI) -> None:
    """A 405's Allow lists every method the path has (Starlette names only
    those of the first route that matches the path)."""

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        if exc.status_code != 405:
            return await http_exception_handler(request, exc)
        # The document's methods for the path; Starlette's (those of the first
        # route matching the path, which may be the hidden catch-all POST of a
        # job's sub-paths) only for a path the document does not have.
        allowed = allowed_methods(request.app, request.url.path) or \
            {m.strip() for m in (exc.headers or {}).get("Allow", "").split(",") if m.strip()}
        allow = ", ".join(sorted(allowed))
        return JSONResponse({"detail": f"{request.method} is not allowed here; allowed: {allow}"}, status_code=405,
                            headers={"Allow": allow})


def create_app(settings: Settings) -> FastAPI:
    @asynccontextmanager
    async def lifespan(app: FastAPI):
        # The outbox's sender: requests write messages as rows and wake it, so
        # none waits on the broker (argand.farm.outbox).
        drainer = app.state.drainer = Drainer(settings)
        drainer.start()
        try:
            yield
        finally:
            drainer.stop.set()
            drainer.wake.set()
            drainer.join(5)

    app = FastAPI(title="Argand", description="Render jobs of algebraic surfaces in complex space.",
                  dependencies=[Depends(check_access)], lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.settings = settings
    for module in (jobs, frames, bands, service):
        app.include_router(module.router)

    @app.exception_handler(ValueError)
    async def _value_error(_request: Request, exc: ValueError):
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    @app.exception_handler(NoSuchJob)
    async def _no_such_job(_request: Request, exc: NoSuchJob):
        return JSONResponse(status_code=404, content={"detail": str(exc)})

    _add_metrics(app, settings)
    _add_front_end(app)
    _add_api_page(app)
    _document_errors(app, settings)
    add_outage_answers(app)
    _answer_unparsable_bodies(app)
    _answer_wrong_methods(app)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    return app
