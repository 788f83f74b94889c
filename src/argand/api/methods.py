"""The methods a path of the API allows, from its OpenAPI document: the
Allow header of a 405 (Starlette's names only the methods of the first
route that matches the path)."""

from __future__ import annotations

import re

from fastapi import FastAPI


def allowed_methods(app: FastAPI, path: str) -> set[str]:
    """The methods the OpenAPI document gives ``path`` (HEAD wherever GET)."""
    methods: set[str] = set()
    for template, operations in app.openapi().get("paths", {}).items():
        pattern = "".join("[^/]+" if part.startswith("{") else re.escape(part)
                          for part in re.split(r"(\{[^}]+\})", template))
        if re.fullmatch(pattern, path):
            methods |= {m.upper() for m in operations}
    return methods | ({"HEAD"} if "GET" in methods else set())
