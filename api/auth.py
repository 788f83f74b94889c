"""Access: every state-changing request (POST, PUT, PATCH, DELETE) carries
``Authorization: Bearer <token>`` when the farm has a token (settings
ARGAND_API_TOKEN or ARGAND_API_TOKEN_FILE). The token is compared in
constant time and never logged. A header, not a cookie: a cross-site form
or fetch cannot send it, so the browser front end is CSRF-safe. Reads stay
open (the front end's images and event stream are plain GETs)."""

from __future__ import annotations

import hmac

from fastapi import HTTPException, Request

from argand.api.deps import get_settings

CHANGES_STATE = frozenset({"POST", "PUT", "PATCH", "DELETE"})


def check_access(request: Request) -> None:
    """The app's one dependency (the OpenAPI document marks the state-changing
    operations as secured when a token is set: argand.api.app)."""
    if request.method not in CHANGES_STATE:
        return
    token = get_settings(request).token()
    if token is None:
        return
    scheme, _, given = request.headers.get("authorization", "").partition(" ")
    if scheme.lower() != "bearer":
        given = ""
    given = given.strip()
    if not hmac.compare_digest(given.encode(), token.encode()):
        raise HTTPException(401, detail="this farm needs its API token: send Authorization: Bearer <token>"
                            if not given else "the API token is wrong", headers={"WWW-Authenticate": "Bearer"})
