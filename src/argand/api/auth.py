"""Access: every state-changing request (POST, PUT, PATCH, DELETE) carries
``Authorization: Bearer <token>`` when the farm has a token (settings
ARGAND_API_TOKEN or ARGAND_API_TOKEN_FILE). The token is compared in
constant time and never logged. A header, not a cookie: a cross-site form
or fetch cannot send it, so the browser front end is CSRF-safe. Reads stay
open (the front end's images and event stream are plain GETs), unless
ARGAND_TOKEN_FOR_READS is set: then every route needs the token but the
health checks, the front end's files and the API's documentation (a
browser's <img> and EventSource cannot send a header, so the web front end
is then for viewing the docs only; API clients send the header)."""

from __future__ import annotations

import hmac

from fastapi import HTTPException, Request

from argand.api.deps import get_settings

CHANGES_STATE = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: Open even with token_for_reads: probes, the front end's files and icon, the docs
#: (Swagger UI's own files are under /docs-assets, a mount outside these checks).
OPEN_PATHS = frozenset({"/", "/healthz", "/readyz", "/docs", "/openapi.json", "/favicon.ico"})


def needs_token(settings, method: str, path: str) -> bool:
    if method in CHANGES_STATE:
        return True
    return settings.token_for_reads and path not in OPEN_PATHS and not path.startswith("/static/")


def check_access(request: Request) -> None:
    """The app's one dependency (the OpenAPI document marks the state-changing
    operations as secured when a token is set: argand.api.app)."""
    settings = get_settings(request)
    if not needs_token(settings, request.method, request.url.path):
        return
    token = settings.token()
    if token is None:
        return
    scheme, _, given = request.headers.get("authorization", "").partition(" ")
    if scheme.lower() != "bearer":
        given = ""
    given = given.strip()
    if not hmac.compare_digest(given.encode(), token.encode()):
        raise HTTPException(401, detail="this farm needs its API token: send Authorization: Bearer <token>"
                            if not given else "the API token is wrong", headers={"WWW-Authenticate": "Bearer"})
